"""The aggregate topics of crowds and flows: two messages per crowd per frame.

Per-person topics do not scale: at 1000 people they were most of a log (two messages, a
transform and a scene entity per person per frame) and as much work as the simulation. So the
members of a `crowd` or a `flow` are logged together, and only the humans written one by one
keep topics of their own:

- `/crowds/NAME/poses`, `foxglove.PosesInFrame` in `map`: one pose per member present, in
  member order; Foxglove's 3D panel draws each as an arrow (or axes), one colour per topic;
- `/crowds/NAME/state`, `hubero.CrowdState`: the names of the members present and, in the same
  order, their positions, velocities, headings, postures, statuses, behaviour states and
  current task ids, as parallel arrays (`x[i]` is the x of `names[i]`; Foxglove's Plot panel
  plots `/crowds/NAME/state.x[0]`).

People of a flow appear in both messages only while they are in the scene. Numbers are
formatted as whole columns of fixed-width text (`digits`), like the per-person rows, and the
padding is then dropped from the whole block at once.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from hubero_dsl.log import schemas as s
from hubero_dsl.log.digits import METRES, RADIANS, UNIT, FixedFormat
from hubero_dsl.log.frames import TaskTracker

if TYPE_CHECKING:
    from hubero_dsl.log.frames import FrameState
    from hubero_dsl.sim.status import TaskEvent

ByteArray = npt.NDArray[np.uint8]

# one member's pose in /crowds/NAME/poses: literal text and the formats of the numbers between
POSE_ROW: tuple[bytes | FixedFormat, ...] = (
    b'{"orientation":{"w":', UNIT, b',"x":0,"y":0,"z":', UNIT, b'},"position":{"x":', METRES,
    b',"y":', METRES, b',"z":0}},')
POSTURE_JSON = [s.dumps(name) for name in s.POSTURE_NAMES]
STATUS_JSON = [s.dumps(name) for name in s.STATUS_NAMES]


def crowd_poses_topic(name: str) -> str:
    return f"/crowds/{name}/poses"


def crowd_state_topic(name: str) -> str:
    return f"/crowds/{name}/state"


class ColumnRows:
    """Rows of the same literal text with numbers at fixed columns, any number of rows."""

    def __init__(self, parts: tuple[bytes | FixedFormat, ...]) -> None:
        text, self.columns = b"", []
        for part in parts:
            if isinstance(part, bytes):
                text += part
            else:
                self.columns.append((len(text), part.width))
                text += b" " * part.width
        self.template = np.frombuffer(text, dtype=np.uint8)

    def fill(self, numbers: list[ByteArray]) -> ByteArray:
        """The rows, one per value of the (equally long) formatted number columns."""
        rows = np.empty((len(numbers[0]), len(self.template)), dtype=np.uint8)
        rows[:] = self.template
        for (start, width), text in zip(self.columns, numbers, strict=True):
            rows[:, start:start + width] = text
        return rows


def json_numbers(text: ByteArray) -> bytes:
    """Formatted numbers (one per row) as a JSON array."""
    if not len(text):
        return b"[]"
    rows = np.empty((text.shape[0], text.shape[1] + 1), dtype=np.uint8)
    rows[:, :-1] = text
    rows[:, -1] = ord(",")
    return b"[" + _unpadded(rows)[:-1] + b"]"


def _unpadded(rows: ByteArray) -> bytes:
    """Rows of numbers and JSON keys without the numbers' padding: shorter to compress and
    read (the rows hold no other spaces)."""
    return rows.tobytes().replace(b" ", b"")


@dataclass(frozen=True)
class CrowdChannels:
    """A crowd or flow in the log: its name, its members' rows in the engine, its channels."""

    name: str
    rows: npt.NDArray[np.intp]
    members: list[str]
    poses: int
    state: int


class CrowdEncoder:
    """Encodes one crowd's two messages per frame; follows its members' tasks."""

    POSES = ColumnRows(POSE_ROW)

    def __init__(self, crowd: CrowdChannels, dt_ns: int) -> None:
        self.crowd = crowd
        self._dt_ns = dt_ns
        self.tasks = TaskTracker(crowd.members)
        self._present: npt.NDArray[np.bool_] | None = None
        self._names = b"[]"
        self._quoted: dict[str, str] = {}

    def record_event(self, event: TaskEvent, description: str) -> None:
        self.tasks.record_event(event, description)

    def encode(self, frame: FrameState) -> tuple[bytes, bytes]:
        """(/crowds/NAME/poses, /crowds/NAME/state) of the members present in `frame`."""
        rows = self.crowd.rows
        present = np.ones(len(rows), dtype=bool) if frame.present is None \
            else frame.present[rows]
        here = rows[present]
        stamp = s.timestamp_json(frame.tick * self._dt_ns).encode()
        heading = frame.heading[here]
        half = heading / 2.0
        w, z = np.split(UNIT.text(np.concatenate([np.cos(half), np.sin(half)])), 2)
        count = len(here)
        metres = METRES.text(np.concatenate([frame.position[here].T.ravel(),
                                             frame.velocity[here].T.ravel()]))
        x, y, vx, vy = (metres[i * count:(i + 1) * count] for i in range(4))
        poses = _unpadded(self.POSES.fill([w, z, x, y]))[:-1]
        poses_json = (b'{"frame_id":"map","poses":[' + poses + b'],"timestamp":' + stamp
                      + b"}")
        state_json = b"".join([
            b'{"fsm_state":[', self._strings([frame.fsm[row] for row in here.tolist()]),
            b'],"heading":', json_numbers(RADIANS.text(heading)),
            b',"names":', self._names_of(present),
            b',"posture":[', ",".join([POSTURE_JSON[p] for p in
                                        frame.posture[here].tolist()]).encode(),
            b'],"status":[', ",".join([STATUS_JSON[c] for c in
                                       self.tasks.status[present].tolist()]).encode(),
            b'],"task_id":[', ",".join(map(str, self.tasks.task_id[present].tolist())).encode(),
            b'],"timestamp":', stamp, b',"vx":', json_numbers(vx), b',"vy":', json_numbers(vy),
            b',"x":', json_numbers(x), b',"y":', json_numbers(y), b"}"])
        return poses_json, state_json

    def _names_of(self, present: npt.NDArray[np.bool_]) -> bytes:
        """The JSON array of the present members' names (rebuilt only when they change)."""
        if self._present is None or not np.array_equal(present, self._present):
            self._present = present.copy()
            members = self.crowd.members
            self._names = ("[" + self._strings_text([members[i] for i in
                                                      np.flatnonzero(present).tolist()])
                           + "]").encode()
        return self._names

    def _strings(self, values: list[str]) -> bytes:
        return self._strings_text(values).encode()

    def _strings_text(self, values: list[str]) -> str:
        quoted = self._quoted
        for value in set(values) - quoted.keys():
            quoted[value] = s.dumps(value)
        return ",".join([quoted[value] for value in values])
