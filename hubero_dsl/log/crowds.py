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

People of a flow appear in both messages only while they are in the scene. Every array is
written as a whole column of fixed-width text (numbers by `digits`, postures and statuses from
tables of padded JSON strings), like the per-person rows; JSON allows the padding.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from hubero_dsl.log import schemas as s
from hubero_dsl.log.digits import METRES, UNIT, FixedFormat
from hubero_dsl.log.frames import TaskTracker, yaw_text

if TYPE_CHECKING:
    from hubero_dsl.log.frames import FrameState
    from hubero_dsl.sim.status import TaskEvent

ByteArray = npt.NDArray[np.uint8]
FloatArray = npt.NDArray[np.float64]


def pose_row(metres: FixedFormat) -> tuple[bytes | FixedFormat, ...]:
    """One member's pose in /crowds/NAME/poses: literal text and the numbers' formats."""
    return (b'{"orientation":{"w":', UNIT, b',"x":0,"y":0,"z":', UNIT, b'},"position":{"x":',
            metres, b',"y":', metres, b',"z":0}},')


NARROW = FixedFormat(head_groups=1, decimals=4)  # |x| < 1000: metres, m/s and radians


def members_of_crowds(count: int, crowds: Sequence[tuple[str, Sequence[int]]]
                      ) -> npt.NDArray[np.bool_]:
    """Which of `count` humans belong to a crowd or flow (and so have no topics, frame or
    scene entity of their own)."""
    member = np.zeros(count, dtype=bool)
    for _, rows in crowds:
        member[list(rows)] = True
    return member


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


def json_array(text: ByteArray) -> bytes:
    """Fixed-width JSON values (one per row, padded with spaces) as a JSON array."""
    if not len(text):
        return b"[]"
    rows = np.empty((text.shape[0], text.shape[1] + 1), dtype=np.uint8)
    rows[:, :-1] = text
    rows[:, -1] = ord(",")
    return b"[" + rows.tobytes()[:-1] + b"]"


def _columns(values: list[FloatArray]) -> list[ByteArray]:
    """Columns of numbers as text in one call: the narrow format when every value fits it
    (every map up to a kilometre), else the wide one."""
    joined = np.concatenate(values)
    fits = not len(joined) or float(np.abs(joined).max()) < NARROW.limit
    text = (NARROW if fits else METRES).text(joined)
    return np.split(text, np.cumsum([len(v) for v in values])[:-1])


def _fixed_strings(names: tuple[str, ...]) -> ByteArray:
    """JSON strings padded to one width, one row each: row k is names[k]."""
    quoted = [s.dumps(name).encode() for name in names]
    width = max(map(len, quoted))
    return np.frombuffer(b"".join(q.ljust(width) for q in quoted),
                         dtype=np.uint8).reshape(len(names), width)


POSE_ROWS = {format.width: ColumnRows(pose_row(format)) for format in (NARROW, METRES)}
POSTURE_TEXT = _fixed_strings(s.POSTURE_NAMES)
STATUS_TEXT = _fixed_strings(s.STATUS_NAMES)


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
        if not here.size:  # a flow before its first arrival or after its last departure
            return self._nobody(stamp)
        heading = frame.heading[here]
        w, z = yaw_text(heading)
        x, y, vx, vy, heading_text = _columns(
            [frame.position[here, 0], frame.position[here, 1], frame.velocity[here, 0],
             frame.velocity[here, 1], heading])
        poses = POSE_ROWS[x.shape[1]].fill([w, z, x, y]).tobytes()[:-1]
        poses_json = (b'{"frame_id":"map","poses":[' + poses + b'],"timestamp":' + stamp
                      + b"}")
        state_json = b"".join([
            b'{"fsm_state":[', self._strings([frame.fsm[row] for row in here.tolist()]).encode(),
            b'],"heading":', json_array(heading_text),
            b',"names":', self._names_of(present),
            b',"posture":', json_array(POSTURE_TEXT[frame.posture[here]]),
            b',"status":', json_array(STATUS_TEXT[self.tasks.status[present]]),
            b',"task_id":[', ",".join(map(str, self.tasks.task_id[present].tolist())).encode(),
            b'],"timestamp":', stamp, b',"vx":', json_array(vx), b',"vy":', json_array(vy),
            b',"x":', json_array(x), b',"y":', json_array(y), b"}"])
        return poses_json, state_json

    @staticmethod
    def _nobody(stamp: bytes) -> tuple[bytes, bytes]:
        """The two messages of a frame without members: what `encode` writes for them, with
        none of its array work (a validation rebuild is hundreds of flows of one person)."""
        return (b'{"frame_id":"map","poses":[],"timestamp":' + stamp + b"}",
                b'{"fsm_state":[],"heading":[],"names":[],"posture":[],"status":[],'
                b'"task_id":[],"timestamp":' + stamp
                + b',"vx":[],"vy":[],"x":[],"y":[]}')

    def _names_of(self, present: npt.NDArray[np.bool_]) -> bytes:
        """The JSON array of the present members' names (rebuilt only when they change)."""
        if self._present is None or not np.array_equal(present, self._present):
            self._present = present.copy()
            members = self.crowd.members
            self._names = ("[" + self._strings([members[i] for i in
                                                 np.flatnonzero(present).tolist()])
                           + "]").encode()
        return self._names

    def _strings(self, values: list[str]) -> str:
        """The values as JSON strings, comma-separated (each encoded once per run)."""
        quoted = self._quoted
        for value in set(values) - quoted.keys():
            quoted[value] = s.dumps(value)
        return ",".join([quoted[value] for value in values])
