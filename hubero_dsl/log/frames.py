"""The per-tick messages of a frame: `/tf`, `/humans/NAME/pose` and `/humans/NAME/state`.

These are most of a log's messages (two per human per frame), so they are not built as dicts:
each kind has a template with its keys in sorted order, exactly what `schemas.dumps` would write,
and one `%` operation per frame fills every human's numbers at once ("\\n" separates messages;
compact JSON never contains one). Numbers are written `%.4f` (positions, velocities, headings)
or `%.6f` (quaternions). The text that changes rarely (a human's behaviour state, posture, task
and status) is baked into the state template, which is rebuilt only when some of it changed.

`FrameEncoder` also keeps each human's current task and status from the task events.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from hubero_dsl.log import schemas as s
from hubero_dsl.sim.status import TaskStatus

if TYPE_CHECKING:
    from hubero_dsl.sim.engine import Engine
    from hubero_dsl.sim.status import TaskEvent

TIME = "@ts@"  # replaced by the frame's timestamp (a template never contains '@' otherwise)
POSE = ('{"frame_id":"map","pose":{"orientation":{"w":%.6f,"x":0,"y":0,"z":%.6f},'
        '"position":{"x":%.4f,"y":%.4f,"z":0}},"timestamp":' + TIME + "}")
TRANSFORM = ('{"child_frame_id":%s,"parent_frame_id":"map","rotation":'
             '{"w":%.6f,"x":0,"y":0,"z":%.6f},"timestamp":' + TIME + ","
             '"translation":{"x":%.4f,"y":%.4f,"z":0}}')
# A state: HEAD heading POSITION TAIL vx VELOCITY_Y; HEAD and TAIL hold the rarely changing text.
STATE_HEAD = '{"fsm_state":%s,"heading":'
STATE_MIDDLE = '%.4f,"position":{"x":%.4f,"y":%.4f},'
STATE_TAIL = '"posture":"%s","status":"%s","task":%s,"timestamp":' + TIME + ',"velocity":{"x":'
STATE_END = '%.4f,"y":%.4f}}'


def _literal(text: str) -> str:
    """Text put into a %-template as it is."""
    return text.replace("%", "%%")


class FrameEncoder:
    """Encodes a frame of every human and robot; keeps the humans' task state between frames."""

    def __init__(self, humans: list[str], robots: list[str]) -> None:
        self.names = humans
        self._index = {name: i for i, name in enumerate(humans)}
        count = len(humans)
        self.status: npt.NDArray[np.int8] = np.zeros(count, dtype=np.int8)
        self._task = ["null"] * count
        self._task_id = [0] * count
        frames = [s.human_frame(n) for n in humans] + [s.robot_frame(n) for n in robots]
        self._tf_template = '{"transforms":[' + ",".join(
            TRANSFORM.replace("%s", _literal(s.dumps(frame)), 1) for frame in frames) + "]}"
        self._pose_template = "\n".join([POSE] * count)
        self._state_parts: list[str] = [""] * count
        self._state_template = ""
        self._state_key: list[tuple[str, int, int, str]] = []
        self._fsm_json: dict[str, str] = {}

    # ---- tasks ------------------------------------------------------------------------------

    def record_event(self, engine: Engine, event: TaskEvent) -> None:
        """Follow each human's current task and status (the /state and the scene show them)."""
        index = self._index.get(event.human)
        if index is None:
            return
        if event.status is TaskStatus.ACTIVE:
            handle = engine.handle[index]
            description = handle.description if handle is not None \
                and handle.task_id == event.task_id else ""
            self._task_id[index] = event.task_id
            self._task[index] = s.dumps({"id": event.task_id, "kind": event.kind,
                                         "description": description,
                                         "line": event.span.line if event.span else 0})
        elif self._task_id[index] == event.task_id:
            self._task_id[index] = 0
            self._task[index] = "null"
        elif event.status.is_final:
            return  # an earlier task ending late must not hide the current one's status
        self.status[index] = s.STATUS_CODE[event.status.value]

    # ---- messages ---------------------------------------------------------------------------

    def transforms(self, engine: Engine, ts: str) -> bytes:
        """/tf: the frame of every human and robot in the map frame."""
        humans, robots = engine.humans, engine.robots
        half = np.concatenate([np.nan_to_num(humans.heading), robots.heading]) / 2.0
        xy = np.concatenate([np.nan_to_num(humans.position), robots.position])
        numbers = np.column_stack([np.cos(half), np.sin(half), xy])
        return (self._tf_template.replace(TIME, ts) % tuple(numbers.ravel().tolist())).encode()

    def poses(self, engine: Engine, ts: str) -> list[bytes]:
        """/humans/NAME/pose for every human, in order."""
        if not self.names:
            return []
        humans = engine.humans
        half = np.nan_to_num(humans.heading) / 2.0
        numbers = np.column_stack([np.cos(half), np.sin(half), np.nan_to_num(humans.position)])
        text = self._pose_template.replace(TIME, ts) % tuple(numbers.ravel().tolist())
        return text.encode().split(b"\n")

    def states(self, engine: Engine, ts: str) -> list[bytes]:
        """/humans/NAME/state for every human, in order."""
        if not self.names:
            return []
        humans = engine.humans
        self._refresh_state_template(engine)
        numbers = np.column_stack([np.nan_to_num(humans.heading),
                                   np.nan_to_num(humans.position),
                                   np.nan_to_num(humans.velocity)])
        text = self._state_template.replace(TIME, ts) % tuple(numbers.ravel().tolist())
        return text.encode().split(b"\n")

    def _refresh_state_template(self, engine: Engine) -> None:
        fsm = [self._fsm(b.state) if b is not None else '"idle"' for b in engine.behaviour]
        keys = list(zip(fsm, engine.humans.posture.tolist(), self.status.tolist(), self._task,
                        strict=True))
        if keys == self._state_key:
            return
        old: list[tuple[str, int, int, str] | None] = list(self._state_key) or [None] * len(keys)
        for i, (key, before) in enumerate(zip(keys, old, strict=True)):
            if key != before:
                fsm_json, posture, status, task = key
                self._state_parts[i] = (
                    STATE_HEAD % _literal(fsm_json) + STATE_MIDDLE
                    + STATE_TAIL % (s.POSTURE_NAMES[posture], s.STATUS_NAMES[status],
                                    _literal(task)) + STATE_END)
        self._state_key = keys
        self._state_template = "\n".join(self._state_parts)

    def _fsm(self, state: str) -> str:
        text = self._fsm_json.get(state)
        if text is None:
            text = self._fsm_json[state] = s.dumps(state)
        return text
