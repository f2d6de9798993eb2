"""A frame of a run: captured from the engine, then encoded as `/tf`, poses and states.

`capture(engine)` copies what a frame needs out of the engine into a `FrameState` (plain arrays
and lists, cheap to pickle), so that encoding can happen elsewhere (another process) while the
simulation goes on. Paths are sent only for the humans whose path changed since the last
capture.

Encoding: the per-tick messages are most of a log (two per human per frame), so they are not
built as dicts, nor even one by one. The pose records of a frame, its state records and the
transforms of `/tf` are each a `rows.RowTemplate`: one row per human, MCAP record header
included, with the numbers at fixed columns in fixed-width text (`digits`: metres and m/s with
4 decimals, quaternions with 8, headings with 4; JSON allows the padding spaces). A frame writes
each column of numbers once, formatted for the whole crowd by table lookups, and the message
indexes follow from the rows' common length. Keys are in sorted order, as `schemas.dumps` writes
them. The text that changes rarely (a human's behaviour state, posture, task and status) is part
of the state row's literal text, rewritten only where it changed.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt
from mcap.opcode import Opcode

from hubero_dsl.log import schemas as s
from hubero_dsl.log.container import MESSAGE_FIELDS, RECORD_PREFIX
from hubero_dsl.log.digits import METRES, RADIANS, UNIT
from hubero_dsl.log.rows import RowTemplate, SlotValue, Stamp
from hubero_dsl.sim.status import TaskStatus

if TYPE_CHECKING:
    from hubero_dsl.sim.engine import Engine
    from hubero_dsl.sim.status import TaskEvent

FloatArray = npt.NDArray[np.float64]
ByteArray = npt.NDArray[np.uint8]

TIMESTAMP = b'{"nsec":%9d,"sec":%10d}'  # fixed width, so records keep their length
TIME = Stamp(len(TIMESTAMP % (0, 0)))
# An MCAP message record (layout in `container`): opcode, record length, channel; then the
# message fields (sequence, log and publish time: the same for a whole frame), then the JSON.
RECORD_LENGTH = Stamp(8)
RECORD_FIELDS = Stamp(MESSAGE_FIELDS.size)
RECORD_START = bytes([Opcode.MESSAGE])

# The literal pieces between the slots of each kind of row (the slots are listed beside them).
POSE_SLOTS = (RECORD_LENGTH, RECORD_FIELDS, UNIT, UNIT, METRES, METRES, TIME)
POSE_PIECES = (b'{"frame_id":"map","pose":{"orientation":{"w":', b',"x":0,"y":0,"z":',
               b'},"position":{"x":', b',"y":', b',"z":0}},"timestamp":', b"}")
TRANSFORM_SLOTS = (UNIT, UNIT, TIME, METRES, METRES)
STATE_SLOTS = (RECORD_LENGTH, RECORD_FIELDS, RADIANS, METRES, METRES, TIME, METRES, METRES)


def yaw_text(heading: FloatArray) -> tuple[ByteArray, ByteArray]:
    """The w and z components of each heading's rotation about z, as quaternion text."""
    half = heading / 2.0
    w, z = np.split(UNIT.text(np.concatenate([np.cos(half), np.sin(half)])), 2)
    return w, z


def frame_timestamp(ns: int) -> bytes:
    return TIMESTAMP % (ns % 1_000_000_000, ns // 1_000_000_000)


def _record_start(channel: int) -> list[bytes]:
    """The pieces before and after a record's length: opcode, then the channel id."""
    return [RECORD_START, struct.pack("<H", channel)]


def _transform_pieces(first: bool, frame: str) -> list[bytes]:
    return [(b" " if first else b",") + b'{"child_frame_id":' + _ascii(s.dumps(frame))
            + b',"parent_frame_id":"map","rotation":{"w":', b',"x":0,"y":0,"z":',
            b'},"timestamp":', b',"translation":{"x":', b',"y":', b',"z":0}}']


def _state_pieces(channel: int, fsm: str, posture: str, status: str, task: str) -> list[bytes]:
    return [*_record_start(channel), b'{"fsm_state":' + _ascii(s.dumps(fsm)) + b',"heading":',
            b',"position":{"x":', b',"y":',
            b'},"posture":"' + posture.encode() + b'","status":"' + status.encode()
            + b'","task":' + _ascii(task) + b',"timestamp":',
            b',"velocity":{"x":', b',"y":', b"}}"]


def _ascii(text: str) -> bytes:
    return text.encode("ascii")  # schemas.dumps escapes everything else


@dataclass(frozen=True)
class RecordBlock:
    """Message records of one frame, ready to go into a chunk as they are."""

    data: memoryview                 # valid until the next frame is encoded
    channels: npt.NDArray[np.uint16]
    offsets: npt.NDArray[np.uint64]  # of each record in `data`


class _Records:
    """The records of one topic per human for a frame: a row template with MCAP headers."""

    def __init__(self, template: RowTemplate, channels: list[int]) -> None:
        self.template = template
        self.channels = np.array(channels, dtype=np.uint16)

    def fill(self, numbers: list[SlotValue], sequence: int, ns: int) -> RecordBlock:
        """The records of every human."""
        length = struct.pack("<Q", self.template.row_length - RECORD_PREFIX)
        rows = self.template.fill([length, MESSAGE_FIELDS.pack(sequence, ns, ns), *numbers])
        channels = self.channels
        offsets = np.arange(len(channels), dtype=np.uint64) * np.uint64(rows.shape[1])
        return RecordBlock(rows.reshape(-1).data, channels, offsets)


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
    present: npt.NDArray[np.bool_] | None  # who is in the scene; None: everyone (no flows)
    robot_position: FloatArray    # (R, 2)
    robot_heading: FloatArray     # (R,)
    robot_velocity: FloatArray    # (R, 2)
    robot_task: list[tuple[str, str]]  # (status, description) of each robot's task now

    def select(self, rows: npt.NDArray[np.intp]) -> FrameState:
        """The frame of the humans at `rows` only (those with topics of their own), robots
        included. They are never members of a flow, so they are always present."""
        if len(rows) == len(self.heading) and self.present is None:
            return self
        where = {int(row): i for i, row in enumerate(rows.tolist())}
        return FrameState(
            tick=self.tick, position=self.position[rows], velocity=self.velocity[rows],
            heading=self.heading[rows], posture=self.posture[rows], goal=self.goal[rows],
            fsm=[self.fsm[row] for row in rows.tolist()], cursor=self.cursor[rows],
            end=self.end[rows],
            paths={where[row]: path for row, path in self.paths.items() if row in where},
            removed=self.removed, present=None, robot_position=self.robot_position,
            robot_heading=self.robot_heading, robot_velocity=self.robot_velocity,
            robot_task=self.robot_task)


class Capturer:
    """Copies frames out of an engine, remembering whose path it has already sent."""

    def __init__(self, count: int, drawn: npt.NDArray[np.bool_] | None = None) -> None:
        self._cursor = np.full(count, -1, dtype=np.intp)
        self._end = np.full(count, -1, dtype=np.intp)
        # whose paths the scene draws (crowd members' are not): only theirs are copied
        self._drawn = np.ones(count, dtype=bool) if drawn is None else drawn

    def capture(self, engine: Engine) -> FrameState:
        humans, paths, robots = engine.humans, engine.paths, engine.robots
        changed = np.flatnonzero(((paths.cursor != self._cursor) | (paths.end != self._end))
                                 & self._drawn)
        self._cursor, self._end = paths.cursor.copy(), paths.end.copy()
        return FrameState(
            tick=engine.tick, position=np.nan_to_num(humans.position),
            velocity=np.nan_to_num(humans.velocity), heading=np.nan_to_num(humans.heading),
            posture=humans.posture.copy(), goal=humans.goal.copy(),
            fsm=engine.fsm_states(),
            cursor=self._cursor, end=self._end,
            paths={i: paths.waypoints(i).copy() for i in changed.tolist()},
            removed=tuple(sorted(engine.removed)),
            present=None if humans.present is None else humans.present.copy(),
            robot_position=robots.position.copy(), robot_heading=robots.heading.copy(),
            robot_velocity=robots.velocity.copy(),
            robot_task=[(t.handle.status.value, t.handle.description) if t is not None
                        else ("", "") for t in robots.tasks])


class TaskTracker:
    """Each human's current task (as JSON) and status, followed from the task events."""

    def __init__(self, humans: list[str]) -> None:
        self.index = {name: i for i, name in enumerate(humans)}
        count = len(humans)
        self.status: npt.NDArray[np.int8] = np.zeros(count, dtype=np.int8)
        self.task = ["null"] * count
        self.task_id = np.zeros(count, dtype=np.int64)
        self.changed: set[int] = set(range(count))  # whose task or status changed

    def record_event(self, event: TaskEvent, description: str) -> None:
        index = self.index.get(event.human)
        if index is None:
            return
        if event.status is TaskStatus.ACTIVE:
            self.task_id[index] = event.task_id
            self.task[index] = s.dumps({"id": event.task_id, "kind": event.kind,
                                        "description": description,
                                        "line": event.span.line if event.span else 0})
        elif self.task_id[index] == event.task_id:
            self.task_id[index] = 0
            self.task[index] = "null"
        elif event.status.is_final:
            return  # an earlier task ending late must not hide the current one's status
        self.status[index] = s.STATUS_CODE[event.status.value]
        self.changed.add(index)


class FrameEncoder:
    """Encodes frames of every human and robot; keeps the humans' task state between frames."""

    def __init__(self, humans: list[str], robots: list[str], pose_channels: list[int],
                 state_channels: list[int], dt_ns: int) -> None:
        self.names = humans
        self.dt_ns = dt_ns
        self.tasks = TaskTracker(humans)
        count = len(humans)
        frames = [s.human_frame(n) for n in humans] + [s.robot_frame(n) for n in robots]
        self._transforms = RowTemplate(TRANSFORM_SLOTS, [
            _transform_pieces(row == 0, frame) for row, frame in enumerate(frames)])
        self._poses = _Records(RowTemplate(POSE_SLOTS, [
            [*_record_start(channel), *POSE_PIECES] for channel in pose_channels]),
            pose_channels)
        self._states = _Records(RowTemplate(STATE_SLOTS, [
            _state_pieces(channel, "idle", s.POSTURE_NAMES[0], s.STATUS_NAMES[0], "null")
            for channel in state_channels]), state_channels)
        self._state_channels = state_channels
        self._fsm: list[str] = []
        self._posture = np.full(count, -1, dtype=np.int8)
        self._status = np.full(count, -1, dtype=np.int8)

    # ---- tasks ------------------------------------------------------------------------------

    @property
    def status(self) -> npt.NDArray[np.int8]:
        return self.tasks.status

    def record_event(self, event: TaskEvent, description: str) -> None:
        """Follow each human's current task and status (the /state and the scene show them)."""
        self.tasks.record_event(event, description)

    # ---- messages ---------------------------------------------------------------------------

    def encode(self, frame: FrameState, sequence: int) -> tuple[bytes, list[RecordBlock]]:
        """/tf (the frame of every human and robot in the map frame) and the records of
        /humans/NAME/pose and /humans/NAME/state; each number is formatted once."""
        ns = frame.tick * self.dt_ns
        stamp = frame_timestamp(ns)
        humans, robots = len(frame.heading), len(frame.robot_heading)
        if not humans + robots:  # everyone is in a crowd or flow
            return b'{"transforms":[]}', []
        # one call per format: humans' and robots' numbers side by side, each column a slice
        w, z = yaw_text(np.concatenate([frame.heading, frame.robot_heading]))
        metres = METRES.text(np.concatenate([frame.position.T.ravel(),
                                             frame.robot_position.T.ravel(),
                                             frame.velocity.T.ravel()]))
        x, y = metres[:humans], metres[humans:2 * humans]
        robot_x, robot_y = np.split(metres[2 * humans:2 * (humans + robots)], 2)
        vx, vy = np.split(metres[2 * (humans + robots):], 2)
        transforms = self._transforms.fill([w, z, stamp, np.concatenate([x, robot_x]),
                                            np.concatenate([y, robot_y])])
        tf = b'{"transforms":[' + transforms.tobytes() + b"]}"
        if not humans:
            return tf, []
        self._refresh_state_rows(frame)
        poses = self._poses.fill([w[:humans], z[:humans], x, y, stamp], sequence, ns)
        states = self._states.fill([frame.heading, x, y, stamp, vx, vy], sequence, ns)
        return tf, [poses, states]

    def _refresh_state_rows(self, frame: FrameState) -> None:
        changed = self.tasks.changed
        if frame.fsm != self._fsm:
            old = self._fsm or [""] * len(frame.fsm)
            changed.update(i for i, (a, b) in enumerate(zip(frame.fsm, old, strict=True))
                           if a != b)
        changed.update(np.flatnonzero((frame.posture != self._posture)
                                      | (self.status != self._status)).tolist())
        if not changed:
            return
        self._states.template.set_rows({i: _state_pieces(
            self._state_channels[i], frame.fsm[i], s.POSTURE_NAMES[frame.posture[i]],
            s.STATUS_NAMES[self.status[i]], self.tasks.task[i]) for i in sorted(changed)})
        self._fsm, self._posture, self._status = frame.fsm, frame.posture, self.status.copy()
        self.tasks.changed = set()
