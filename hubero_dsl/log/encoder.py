"""The writing side of a run log: turns updates from the run into MCAP records in a file.

`RunLog` (writer.py) captures what happened at each tick as an `Update` (task events and, at
sample times, a `FrameState`) and hands it to a `LogEncoder`, in this process or in a writer
process of its own. Everything static is prepared beforehand as a `LogSetup` (reading the map
and the scenario, which may fail with a LogError before anything is written). The encoder owns
the file: it writes the header, schemas, channels, provenance and attachments at once, every
update as it comes, and on `finish` the result, the summary, then renames the temporary file
to the final name. Same setup and updates, same bytes, wherever it runs.

The records go to a `MessageSink` (`sinks.py`): the file's `McapContainer`, and when the run is
watched live the `LiveServer` as well (or alone, when no file is written).
"""

from __future__ import annotations

import contextlib
import os
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, BinaryIO

import numpy as np

from hubero_dsl.log import schemas as s
from hubero_dsl.log.container import McapContainer
from hubero_dsl.log.crowds import (
    CrowdChannels,
    CrowdEncoder,
    crowd_poses_topic,
    crowd_state_topic,
    members_of_crowds,
)
from hubero_dsl.log.frames import FrameEncoder, FrameState
from hubero_dsl.log.scene import TIME_MARK, SceneBuilder
from hubero_dsl.log.sinks import Fanout, MessageSink
from hubero_dsl.sim.status import TaskStatus

if TYPE_CHECKING:
    from hubero_dsl.diagnostics import Span
    from hubero_dsl.sim.status import TaskEvent
    from hubero_dsl.world.shapes import Shape


@dataclass
class LogSetup:
    """What a log needs that does not change during the run."""

    final: Path | None  # None: no file (the run is only watched live)
    temp: Path | None
    library: str
    compression: str
    chunk_size: int
    dt_ns: int
    humans: list[str]
    radius: list[float]
    shapes: list[Shape]
    crowds: list[tuple[str, list[int]]]  # crowds and flows: name, their members' rows
    robots: list[str]
    robot_radius: list[float]
    robot_controllers: list[str]
    source_path: str                            # the scenario as the log names it
    source_lines: list[str]
    metadata: dict[str, str]
    attachments: list[tuple[str, str, bytes]]  # name, media type, data
    grid: bytes                                 # the /map message
    start_message: str


@dataclass
class Update:
    """What happened since the last update: task events (with the task's description) and,
    at sample times, the frame."""

    events: list[tuple[TaskEvent, str]]
    frame: FrameState | None


class LogEncoder:
    """Writes one log from a setup and a sequence of updates: into the file `stream`, to
    `live`, or both."""

    def __init__(self, setup: LogSetup, stream: BinaryIO | None, *, background: bool = True,
                 live: MessageSink | None = None) -> None:
        self._setup = setup
        self._stream = stream
        sinks: list[MessageSink] = []
        if stream is not None:
            sinks.append(McapContainer(stream, library=setup.library,
                                       compression=setup.compression,
                                       chunk_size=setup.chunk_size, background=background))
        if live is not None:
            sinks.append(live)
        if not sinks:
            raise ValueError("a log needs a file or a live server to write to")
        self._out: MessageSink = sinks[0] if len(sinks) == 1 else Fanout(sinks)
        # the humans with topics of their own: everyone not in a crowd or flow
        self._named = np.flatnonzero(~members_of_crowds(len(setup.humans), setup.crowds))
        named = self._named.tolist()
        self._scene = SceneBuilder([setup.humans[i] for i in named],
                                   [setup.radius[i] for i in named],
                                   [setup.shapes[i] for i in named], setup.robots,
                                   setup.robot_radius)
        self._frames = 0
        self._define_channels()
        self._out.add_metadata(s.METADATA_NAME, setup.metadata)
        for name, media_type, data in setup.attachments:
            self._out.add_attachment(name, media_type, data)
        self._out.add_message(self._channel[s.MAP_TOPIC], 0, setup.grid)
        self._log(s.LOG_INFO, setup.start_message, None, 0)

    def _define_channels(self) -> None:
        setup = self._setup
        names = {*s.TOPIC_SCHEMAS.values(), s.POSE_IN_FRAME, s.HUMAN_STATE}
        if setup.crowds:  # logs without crowds keep the schemas they always had
            names |= {s.POSES_IN_FRAME, s.CROWD_STATE}
        schema_id = {name: self._out.add_schema(name, s.schema_bytes(name))
                     for name in sorted(names)}
        self._channel = {topic: self._out.add_channels([topic], schema_id[name])[0]
                         for topic, name in s.TOPIC_SCHEMAS.items()}
        humans = [setup.humans[i] for i in self._named.tolist()]
        poses = self._out.add_channels([s.human_pose_topic(n) for n in humans],
                                       schema_id[s.POSE_IN_FRAME])
        states = self._out.add_channels([s.human_state_topic(n) for n in humans],
                                        schema_id[s.HUMAN_STATE])
        self._frame = FrameEncoder(humans, setup.robots, poses, states, setup.dt_ns)
        self._crowds = [CrowdEncoder(CrowdChannels(
            name, np.array(rows, dtype=np.intp), [setup.humans[i] for i in rows],
            *self._out.add_channels([crowd_poses_topic(name)], schema_id[s.POSES_IN_FRAME]),
            *self._out.add_channels([crowd_state_topic(name)], schema_id[s.CROWD_STATE])),
            setup.dt_ns) for name, rows in setup.crowds]
        self._crowd_of = {member: crowd for crowd in self._crowds
                          for member in crowd.crowd.members}
        self._robot_states: list[int] = []
        self._robot_status = [s.IDLE] * len(self._setup.robots)
        if self._setup.robots:  # logs without robots keep the schemas they always had
            robot_schema = self._out.add_schema(s.ROBOT_STATE, s.schema_bytes(s.ROBOT_STATE))
            self._robot_states = self._out.add_channels(
                [s.robot_state_topic(n) for n in self._setup.robots], robot_schema)

    # ---- updates ----------------------------------------------------------------------------

    def write(self, update: Update) -> None:
        for event, description in update.events:
            self._write_event(event, description)
        if update.frame is not None:
            self._write_frame(update.frame)

    def _write_event(self, event: TaskEvent, description: str) -> None:
        ns = event.tick * self._setup.dt_ns
        span = event.span
        self._out.add_message(self._channel[s.TASKS_TOPIC], ns, s.dumps({
            "timestamp": s.timestamp(ns), "tick": event.tick, "task_id": event.task_id,
            "human": event.human, "kind": event.kind, "status": event.status.value,
            "reason": event.reason, "file": self._setup.source_path if span else "",
            "line": span.line if span else 0, "column": span.column if span else 0,
            "end_line": span.end_line if span else 0,
            "end_column": span.end_column if span else 0,
            "source_line": self._source_line(span)}).encode())
        crowd = self._crowd_of.get(event.human)
        (crowd or self._frame).record_event(event, description)
        if event.status is TaskStatus.ABORTED:
            self._log(s.LOG_WARNING, f"{event.human} {event.kind} aborted: {event.reason}",
                      span, ns)

    def _source_line(self, span: Span | None) -> str:
        lines = self._setup.source_lines
        if span is None or not 0 < span.line <= len(lines):
            return ""
        return lines[span.line - 1].strip()

    def _write_frame(self, frame: FrameState) -> None:
        ns = frame.tick * self._setup.dt_ns
        ts = s.timestamp_json(ns)
        named = frame.select(self._named)
        scene = self._scene.snapshot(named, self._frame.status)
        if scene is not None:
            self._out.add_message(self._channel[s.SCENE_TOPIC], ns,
                                  scene.replace(TIME_MARK, ts).encode())
        tf, blocks = self._frame.encode(named, self._frames)
        self._out.add_message(self._channel[s.TF_TOPIC], ns, tf)
        for block in blocks:
            self._out.add_block(block.data, block.channels, block.offsets, ns)
        for crowd in self._crowds:
            poses, state = crowd.encode(frame)
            self._out.add_message(crowd.crowd.poses, ns, poses)
            self._out.add_message(crowd.crowd.state, ns, state)
        self._write_robots(frame, ns)
        self._frames += 1

    def _write_robots(self, frame: FrameState, ns: int) -> None:
        setup = self._setup
        for i, channel in enumerate(self._robot_states):
            status, task = frame.robot_task[i]
            if status:  # a robot without a task shows its last task's status
                self._robot_status[i] = status
            x, y = frame.robot_position[i]
            vx, vy = frame.robot_velocity[i]
            self._out.add_message(channel, ns, s.dumps({
                "timestamp": s.timestamp(ns), "position": {"x": s.number(x), "y": s.number(y)},
                "velocity": {"x": s.number(vx), "y": s.number(vy)},
                "heading": s.number(frame.robot_heading[i]),
                "controller": setup.robot_controllers[i], "status": self._robot_status[i],
                "task": task}).encode())

    def _log(self, level: int, message: str, span: Span | None, ns: int) -> None:
        self._out.add_message(self._channel[s.LOG_TOPIC], ns, s.dumps({
            "timestamp": s.timestamp(ns), "level": level, "message": message,
            "name": "hubero", "file": self._setup.source_path,
            "line": span.line if span else 0}).encode())

    # ---- the end ----------------------------------------------------------------------------

    def finish(self, result: dict[str, Any] | None, end_tick: int) -> None:
        """Write the result (if any) and the summary, then give the file its final name."""
        if result is not None:
            self._write_result(result, end_tick * self._setup.dt_ns)
        self._out.finish()
        if self._stream is None:
            return
        assert self._setup.temp is not None and self._setup.final is not None
        self._stream.flush()
        os.fsync(self._stream.fileno())
        self._stream.close()
        os.replace(self._setup.temp, self._setup.final)

    def _write_result(self, result: dict[str, Any], ns: int) -> None:
        reason = f": {result['reason']}" if result["reason"] else ""
        self._log(s.LOG_INFO if result["succeeded"] else s.LOG_ERROR,
                  f"run {result['state']}{reason}", None, ns)
        for expectation in result["expectations"]:
            verdict = "holds" if expectation["held"] else "fails"
            decided = expectation["decided_at"]
            when = f" (decided at {decided:g} s)" if decided is not None else ""
            self._log(s.LOG_INFO if expectation["held"] else s.LOG_ERROR,
                      f"expectation {verdict}: {expectation['text']}{when}",
                      expectation["span"], ns)
        expectations = [{key: value for key, value in expectation.items() if key != "span"}
                        for expectation in result["expectations"]]
        self._out.add_metadata(s.RESULT_METADATA_NAME, {
            "state": result["state"], "reason": result["reason"], "time": result["time"],
            "ticks": result["ticks"], "succeeded": "true" if result["succeeded"] else "false",
            "expectations": s.dumps(expectations), "humans": s.dumps(result["humans"]),
            **({"robots": s.dumps(result["robots"])} if result["robots"] else {})})

    def discard(self) -> None:
        """Stop and delete the temporary file (the run failed or was interrupted)."""
        self._out.abandon()
        discard_file(self._stream, self._setup.temp)


def discard_file(stream: BinaryIO | None, temp: Path | None) -> None:
    if stream is not None:
        with contextlib.suppress(OSError, ValueError):
            stream.close()
    if temp is not None:
        with contextlib.suppress(OSError):
            temp.unlink()
