"""A frame of a run: captured from the engine, then encoded as `/tf`, poses and states.

`capture(engine)` copies what a frame needs out of the engine into a `FrameState` (plain arrays
and lists, cheap to pickle), so that encoding can happen elsewhere (another process) while the
simulation goes on. Paths are sent only for the humans whose path changed since the last
capture.

Encoding: the per-tick messages are most of a log (two per human per frame), so they are not
built as dicts, nor even one by one. Their numbers have fixed widths (`%12.4f` for metres,
m/s and radians, `%9.6f` for quaternions, the timestamp's fields padded; JSON allows the
spaces), so every record of a human has a length known in advance. A frame's pose records, and
its state records, are then one bytes template each, MCAP record headers included, filled by one
`%` operation; the message indexes come from offsets computed with the template. Keys are in
sorted order, as `schemas.dumps` writes them. The text that changes rarely (a human's behaviour
state, posture, task and status) is baked into the state template, rebuilt only where it
changed. Values beyond +-999999.9999 (a human 1000 km away) are clipped to keep the widths.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from hubero_dsl.log import schemas as s
from hubero_dsl.sim.status import TaskStatus

if TYPE_CHECKING:
    from hubero_dsl.sim.engine import Engine
    from hubero_dsl.sim.status import TaskEvent

FloatArray = npt.NDArray[np.float64]

LIMIT = 999_999.9999  # the largest magnitude a %12.4f field holds
TIME = b"@ts@"  # where the frame's timestamp goes: templates are kept split there
TIMESTAMP = b'{"nsec":%9d,"sec":%10d}'  # fixed width, so records keep their length
POSE = (b'{"frame_id":"map","pose":{"orientation":{"w":%9.6f,"x":0,"y":0,"z":%9.6f},'
        b'"position":{"x":%12.4f,"y":%12.4f,"z":0}},"timestamp":' + TIME + b"}")
TRANSFORM = (b'{"child_frame_id":%s,"parent_frame_id":"map","rotation":'
             b'{"w":%9.6f,"x":0,"y":0,"z":%9.6f},"timestamp":' + TIME + b","
             b'"translation":{"x":%12.4f,"y":%12.4f,"z":0}}')
# A state is HEAD heading, position TAIL vx, vy END; HEAD and TAIL hold the rarely changing text.
STATE_HEAD = b'{"fsm_state":%s,"heading":'
STATE_MIDDLE = b'%12.4f,"position":{"x":%12.4f,"y":%12.4f},'
STATE_TAIL = b'"posture":"%s","status":"%s","task":%s,"timestamp":' + TIME + b',"velocity":{"x":'
STATE_END = b'%12.4f,"y":%12.4f}}'
# An MCAP message record: opcode 5, record length, channel; then sequence, log and publish time
# (the same for a whole frame: one %s); then the JSON.
RECORD_START = struct.Struct("<BQH")
FRAME_FIELDS = struct.Struct("<IQQ")
RECORD_OVERHEAD = RECORD_START.size + FRAME_FIELDS.size


def frame_timestamp(ns: int) -> bytes:
    return TIMESTAMP % (ns % 1_000_000_000, ns // 1_000_000_000)


@dataclass(frozen=True)
class RecordBlock:
    """Message records of one frame, ready to go into a chunk as they are."""

    data: bytes
    channels: npt.NDArray[np.uint16]
    offsets: npt.NDArray[np.uint64]  # of each record in `data`


class _Records:
    """One template for the records of a row of channels; rows' payload templates may change."""

    def __init__(self, channels: list[int], numbers_per_record: int) -> None:
        self.channels = np.array(channels, dtype=np.uint16)
        self._numbers = numbers_per_record
        self._parts: list[bytes] = [b""] * len(channels)
        self._lengths = np.zeros(len(channels), dtype=np.uint64)
        self._template: list[bytes] = []
        self._offsets = np.zeros(len(channels), dtype=np.uint64)

    def set_payload(self, row: int, payload: bytes) -> None:
        """The JSON template of row's records (with TIME and `numbers_per_record` fields)."""
        filled = payload.replace(TIME, frame_timestamp(0)) % ((0.0,) * self._numbers)
        start = RECORD_START.pack(5, RECORD_OVERHEAD - 9 + len(filled), self.channels[row])
        self._parts[row] = start.replace(b"%", b"%%") + b"%s" + payload
        self._lengths[row] = RECORD_OVERHEAD + len(filled)
        self._template = []

    def fill(self, numbers: npt.NDArray[np.float64], sequence: int, ns: int) -> RecordBlock:
        if not self._template:
            self._template = b"".join(self._parts).split(TIME)
            self._offsets = np.concatenate([[0], np.cumsum(self._lengths)[:-1]]).astype(
                np.uint64)
        values = np.empty((len(self.channels), self._numbers + 1), dtype=object)
        values[:, 0] = FRAME_FIELDS.pack(sequence, ns, ns)
        values[:, 1:] = numbers
        data = frame_timestamp(ns).join(self._template) % tuple(values.ravel().tolist())
        return RecordBlock(data, self.channels, self._offsets)


@dataclass
class FrameState:
    """Everything a frame shows, copied out of the engine at one tick."""

    tick: int
    position: FloatArray          # (N, 2)
    velocity: FloatArray          # (N, 2)
    heading: FloatArray           # (N,)
    posture: npt.NDArray[np.int8]
    goal: FloatArray              # (N, 2), nan when none
    fsm: list[str]                # behaviour state per human ("idle" without a task)
    cursor: npt.NDArray[np.intp]  # path pool rows: a change means a new or advanced path
    end: npt.NDArray[np.intp]
    paths: dict[int, FloatArray]  # remaining waypoints of the humans whose path changed
    removed: tuple[str, ...]
    robot_position: FloatArray    # (R, 2)
    robot_heading: FloatArray     # (R,)


class Capturer:
    """Copies frames out of an engine, remembering whose path it has already sent."""

    def __init__(self, count: int) -> None:
        self._cursor = np.full(count, -1, dtype=np.intp)
        self._end = np.full(count, -1, dtype=np.intp)

    def capture(self, engine: Engine) -> FrameState:
        humans, paths, robots = engine.humans, engine.paths, engine.robots
        changed = np.flatnonzero((paths.cursor != self._cursor) | (paths.end != self._end))
        self._cursor, self._end = paths.cursor.copy(), paths.end.copy()
        return FrameState(
            tick=engine.tick, position=np.nan_to_num(humans.position),
            velocity=np.nan_to_num(humans.velocity), heading=np.nan_to_num(humans.heading),
            posture=humans.posture.copy(), goal=humans.goal.copy(),
            fsm=[b.state if b is not None else "idle" for b in engine.behaviour],
            cursor=self._cursor, end=self._end,
            paths={i: paths.waypoints(i).copy() for i in changed.tolist()},
            removed=tuple(sorted(engine.removed)),
            robot_position=robots.position.copy(), robot_heading=robots.heading.copy())


def _clip(values: FloatArray) -> FloatArray:
    return np.clip(values, -LIMIT, LIMIT)


def _literal(text: str) -> bytes:
    """JSON text (ASCII) put into a %-template as it is."""
    return text.replace("%", "%%").encode("ascii")


class FrameEncoder:
    """Encodes frames of every human and robot; keeps the humans' task state between frames."""

    def __init__(self, humans: list[str], robots: list[str], pose_channels: list[int],
                 state_channels: list[int], dt_ns: int) -> None:
        self.names = humans
        self.dt_ns = dt_ns
        self._index = {name: i for i, name in enumerate(humans)}
        count = len(humans)
        self.status: npt.NDArray[np.int8] = np.zeros(count, dtype=np.int8)
        self._task = ["null"] * count
        self._task_id = [0] * count
        frames = [s.human_frame(n) for n in humans] + [s.robot_frame(n) for n in robots]
        self._tf_template = (b'{"transforms":[' + b",".join(
            TRANSFORM.replace(b"%s", _literal(s.dumps(frame)), 1) for frame in frames)
                             + b"]}").split(TIME)
        self._poses = _Records(pose_channels, 4)
        for row in range(count):
            self._poses.set_payload(row, POSE)
        self._states = _Records(state_channels, 5)
        self._fsm: list[str] = []
        self._posture = np.full(count, -1, dtype=np.int8)
        self._status = np.full(count, -1, dtype=np.int8)
        self._task_changed: set[int] = set(range(count))

    # ---- tasks ------------------------------------------------------------------------------

    def record_event(self, event: TaskEvent, description: str) -> None:
        """Follow each human's current task and status (the /state and the scene show them)."""
        index = self._index.get(event.human)
        if index is None:
            return
        if event.status is TaskStatus.ACTIVE:
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
        self._task_changed.add(index)

    # ---- messages ---------------------------------------------------------------------------

    def transforms(self, frame: FrameState) -> bytes:
        """/tf: the frame of every human and robot in the map frame."""
        half = np.concatenate([frame.heading, frame.robot_heading]) / 2.0
        xy = _clip(np.concatenate([frame.position, frame.robot_position]))
        numbers = np.column_stack([np.cos(half), np.sin(half), xy])
        ts = frame_timestamp(frame.tick * self.dt_ns)
        return ts.join(self._tf_template) % tuple(numbers.ravel().tolist())

    def poses(self, frame: FrameState, sequence: int) -> RecordBlock:
        """The records of /humans/NAME/pose for every human."""
        half = frame.heading / 2.0
        numbers = np.column_stack([np.cos(half), np.sin(half), _clip(frame.position)])
        return self._poses.fill(numbers, sequence, frame.tick * self.dt_ns)

    def states(self, frame: FrameState, sequence: int) -> RecordBlock:
        """The records of /humans/NAME/state for every human."""
        self._refresh_state_template(frame)
        numbers = _clip(np.column_stack([frame.heading, frame.position, frame.velocity]))
        return self._states.fill(numbers, sequence, frame.tick * self.dt_ns)

    def _refresh_state_template(self, frame: FrameState) -> None:
        changed = self._task_changed
        if frame.fsm != self._fsm:
            old = self._fsm or [""] * len(frame.fsm)
            changed.update(i for i, (a, b) in enumerate(zip(frame.fsm, old, strict=True))
                           if a != b)
        changed.update(np.flatnonzero((frame.posture != self._posture)
                                      | (self.status != self._status)).tolist())
        if not changed:
            return
        for i in changed:
            self._states.set_payload(i, (
                STATE_HEAD % _literal(s.dumps(frame.fsm[i])) + STATE_MIDDLE
                + STATE_TAIL % (s.POSTURE_NAMES[frame.posture[i]].encode(),
                                s.STATUS_NAMES[self.status[i]].encode(),
                                _literal(self._task[i]))
                + STATE_END))
        self._fsm, self._posture, self._status = frame.fsm, frame.posture, self.status.copy()
        self._task_changed = set()
