"""`RunLog`: records a run as an MCAP file that Foxglove replays and `load_run` reads back.

    with RunLog("run.mcap", sim, rate_hz=10) as log:
        result = run_program(sim, [log.observe])
        log.close(result)

The log is written to a temporary file beside the final one (`.NAME.PID.N.part`) and renamed
over it only by `close()`: a run that fails, is interrupted or is killed never leaves a partial
file under the final name (a killed run leaves its `.part` file). Leaving the `with` block
through an exception deletes the temporary file.

What is written (topics and schemas in `schemas.py`, the scene in `scene.py`): at the start the
provenance metadata, the scenario source and its map (YAML and image) as attachments, `/map`
and a first frame; a frame (`/tf`, `/humans/NAME/pose`, `/humans/NAME/state`, and `/scene`
when it changed) each time the simulation clock passes a multiple of 1/rate_hz, plus one at the
last tick; every task status change on `/tasks` as it happens; scenario events on `/log`; at
the end how the run ended (`hubero.result` metadata). Log and publish times are simulation time.
"""

from __future__ import annotations

import contextlib
import hashlib
import itertools
import math
import os
from pathlib import Path
from types import TracebackType
from typing import TYPE_CHECKING, Any, BinaryIO

import numpy as np
import yaml

from hubero_dsl import __version__
from hubero_dsl.errors import LogError
from hubero_dsl.log import schemas as s
from hubero_dsl.log.container import McapContainer
from hubero_dsl.log.frames import FrameEncoder
from hubero_dsl.log.scene import TIME_MARK, SceneBuilder
from hubero_dsl.sim.status import TaskStatus
from hubero_dsl.world.shapes import Circle, Ellipse, Rectangle

if TYPE_CHECKING:
    from hubero_dsl.diagnostics import Span
    from hubero_dsl.sim.run import RunResult
    from hubero_dsl.sim.simulation import Simulation
    from hubero_dsl.sim.status import TaskEvent

SAMPLE_EPSILON = 1e-9  # tick * dt * rate lands a hair below an integer for some dt and rates
MEDIA_TYPES = {".yaml": "application/yaml", ".yml": "application/yaml", ".hub": "text/plain",
               ".pgm": "image/x-portable-graymap", ".png": "image/png", ".bmp": "image/bmp",
               ".jpg": "image/jpeg", ".jpeg": "image/jpeg", ".tif": "image/tiff",
               ".tiff": "image/tiff", ".gif": "image/gif", ".ppm": "image/x-portable-pixmap"}

class RunLog:
    """An MCAP log of one run; a context manager whose `observe` is a run observer."""

    def __init__(self, path: str | Path, sim: Simulation, *, rate_hz: float = 10.0,
                 compression: str = "zstd", chunk_size: int = 1 << 20) -> None:
        if not (isinstance(rate_hz, int | float) and math.isfinite(rate_hz) and rate_hz > 0):
            raise LogError(f"the log rate must be a number of hertz above 0, got {rate_hz!r}")
        self.path = Path(path)
        self.rate_hz = float(rate_hz)
        self._sim = sim
        self._compression = compression
        self._chunk_size = chunk_size
        self._file: BinaryIO | None = None
        self._temp: Path | None = None
        self._mcap: McapContainer | None = None
        self._closed = False
        engine = sim.engine
        self._dt_ns = s.nanoseconds(engine.dt)
        self._names = list(engine.humans.names)
        self._frame = FrameEncoder(self._names, list(engine.robots.names))
        self._source_lines = sim.program.source.text.splitlines()
        self._events_written = 0
        self._last_sample = -1
        self._last_frame_tick = -1
        self._frames = 0
        self._scene = SceneBuilder(engine)

    # ---- the context manager ----------------------------------------------------------------

    def __enter__(self) -> RunLog:
        self.open()
        return self

    def __exit__(self, kind: type[BaseException] | None, error: BaseException | None,
                 trace: TracebackType | None) -> None:
        if kind is None and not self._closed and self._mcap is not None:
            self.close()
        else:
            self._discard()

    # ---- the observer API -------------------------------------------------------------------

    def open(self) -> None:
        """Create the temporary file and write the header, provenance, map and first frame."""
        if self._file is not None:
            raise LogError(f"log {self.path} is already open")
        fd, self._temp = _create_temp(self.path)
        self._file = os.fdopen(fd, "wb", buffering=1 << 20)
        try:
            self._start()
        except BaseException:
            self._discard()
            raise

    def _start(self) -> None:
        assert self._file is not None
        with self._writing():
            self._mcap = McapContainer(self._file, library=f"hubero {__version__}",
                                       compression=self._compression,
                                       chunk_size=self._chunk_size, background=True)
            self._define_channels()
            self._write_provenance()
            self._mcap.add_message(self._channel[s.MAP_TOPIC], 0,
                                   s.dumps(s.grid_message(self._sim.program.grid)).encode())
            self._log(s.LOG_INFO, self._start_message(), None)
            self.observe(self._sim)

    def observe(self, sim: Simulation) -> None:
        """Record what happened since the last call; a frame when a sample time was passed."""
        with self._writing():
            engine = sim.engine
            self._write_events(engine.events)
            sample = math.floor(engine.tick * engine.dt * self.rate_hz + SAMPLE_EPSILON)
            if sample > self._last_sample:
                self._last_sample = sample
                self._write_frame(sim)

    def close(self, result: RunResult | None = None) -> Path:
        """Write the last events, frame and the result, then move the file to its final name."""
        if self._closed:
            return self.path
        if self._mcap is None or self._file is None or self._temp is None:
            raise LogError(f"log {self.path} was never opened")
        try:
            with self._writing():
                engine = self._sim.engine
                self._write_events(engine.events)
                if engine.tick != self._last_frame_tick:
                    self._write_frame(self._sim)
                if result is not None:
                    self._write_result(result)
                self._mcap.finish()
                self._file.flush()
                os.fsync(self._file.fileno())
                self._file.close()
                os.replace(self._temp, self.path)
        except BaseException:
            self._discard()
            raise
        self._closed = True
        return self.path

    @property
    def frames(self) -> int:
        """How many frames have been written so far."""
        return self._frames

    # ---- writing ----------------------------------------------------------------------------

    def _writing(self) -> _WriteGuard:
        return _WriteGuard(self.path)

    def _define_channels(self) -> None:
        assert self._mcap is not None
        names = sorted({*s.TOPIC_SCHEMAS.values(), s.POSE_IN_FRAME, s.HUMAN_STATE})
        schema_id = {name: self._mcap.add_schema(name, s.schema_bytes(name)) for name in names}
        self._channel = {topic: self._mcap.add_channel(topic, schema_id[name])
                         for topic, name in s.TOPIC_SCHEMAS.items()}
        self._pose_channels = [self._mcap.add_channel(s.human_pose_topic(n),
                                                      schema_id[s.POSE_IN_FRAME])
                               for n in self._names]
        self._state_channels = [self._mcap.add_channel(s.human_state_topic(n),
                                                       schema_id[s.HUMAN_STATE])
                                for n in self._names]
        self._frame_channels = np.array(self._pose_channels + self._state_channels,
                                        dtype=np.uint16)

    def _write_provenance(self) -> None:
        assert self._mcap is not None
        program, sim = self._sim.program, self._sim
        source_name = Path(program.source.path).name or "scenario.hub"
        source = program.source.text.encode("utf-8")
        map_yaml, image_path, image = _read_map_files(program.map_path)
        attachments = {"source": f"source/{source_name}",
                       "map": f"map/{program.map_path.name}",
                       "map_image": f"map/{image_path.name}"}
        metadata = {
            "format": s.FORMAT, "format_version": str(s.FORMAT_VERSION),
            "hubero_version": __version__, "title": program.title,
            "source_path": program.source.path,
            "source_sha256": hashlib.sha256(source).hexdigest(),
            "map_path": str(program.map_path),
            "map_sha256": hashlib.sha256(map_yaml).hexdigest(),
            "map_image_sha256": hashlib.sha256(image).hexdigest(),
            "seed": str(sim.seed), "variant": sim.variant or "",
            "variants": s.dumps(list(program.variants)),
            "params": s.dumps(_params_json(sim.params)),
            "step": repr(sim.engine.dt), "time_limit": repr(program.time_limit),
            "on_failure": program.on_failure, "log_rate_hz": repr(self.rate_hz),
            "humans": s.dumps(self._names),
            "robots": s.dumps(list(sim.engine.robots.names)),
            "attachments": s.dumps(attachments),
        }
        self._mcap.add_metadata(s.METADATA_NAME, metadata)
        self._mcap.add_attachment(attachments["source"], "text/plain", source)
        self._mcap.add_attachment(attachments["map"], "application/yaml", map_yaml)
        self._mcap.add_attachment(attachments["map_image"],
                                  MEDIA_TYPES.get(image_path.suffix.lower(),
                                                  "application/octet-stream"), image)

    def _write_frame(self, sim: Simulation) -> None:
        assert self._mcap is not None
        engine = sim.engine
        ns = engine.tick * self._dt_ns
        ts = s.timestamp_json(ns)
        self._write_scene(engine, ns)
        encoder = self._frame
        self._mcap.add_message(self._channel[s.TF_TOPIC], ns, encoder.transforms(engine, ts))
        self._mcap.add_messages(self._frame_channels, ns,
                                encoder.poses(engine, ts) + encoder.states(engine, ts),
                                self._frames)
        self._frames += 1
        self._last_frame_tick = engine.tick

    def _write_scene(self, engine: Any, ns: int) -> None:
        assert self._mcap is not None
        scene = self._scene.snapshot(engine, self._frame.status)
        if scene is not None:
            payload = scene.replace(TIME_MARK, s.timestamp_json(ns))
            self._mcap.add_message(self._channel[s.SCENE_TOPIC], ns, payload.encode())

    def _write_events(self, events: list[TaskEvent]) -> None:
        assert self._mcap is not None
        engine = self._sim.engine
        for event in events[self._events_written:]:
            ns = event.tick * self._dt_ns
            self._mcap.add_message(self._channel[s.TASKS_TOPIC], ns,
                                   s.dumps(self._task_event(event, ns)).encode())
            self._frame.record_event(engine, event)
            if event.status is TaskStatus.ABORTED:
                self._log(s.LOG_WARNING, f"{event.human} {event.kind} aborted: {event.reason}",
                          event.span, ns)
        self._events_written = len(events)

    def _task_event(self, event: TaskEvent, ns: int) -> dict[str, Any]:
        span = event.span
        return {"timestamp": s.timestamp(ns), "tick": event.tick, "task_id": event.task_id,
                "human": event.human, "kind": event.kind, "status": event.status.value,
                "reason": event.reason, "file": span.file if span else "",
                "line": span.line if span else 0, "column": span.column if span else 0,
                "end_line": span.end_line if span else 0,
                "end_column": span.end_column if span else 0,
                "source_line": self._source_line(span)}

    def _source_line(self, span: Span | None) -> str:
        if span is None or not 0 < span.line <= len(self._source_lines):
            return ""
        return self._source_lines[span.line - 1].strip()

    def _log(self, level: int, message: str, span: Span | None, ns: int = 0) -> None:
        assert self._mcap is not None
        self._mcap.add_message(self._channel[s.LOG_TOPIC], ns, s.dumps({
            "timestamp": s.timestamp(ns), "level": level, "message": message,
            "name": "hubero", "file": span.file if span else self._sim.program.source.path,
            "line": span.line if span else 0}).encode())

    def _start_message(self) -> str:
        sim = self._sim
        variant = f"variant '{sim.variant}'" if sim.variant else "no variant"
        return (f"run of '{sim.program.title}' started: {variant}, seed {sim.seed}, "
                f"{len(self._names)} humans, {sim.engine.robots.count} robots")

    def _write_result(self, result: RunResult) -> None:
        assert self._mcap is not None
        ns = self._sim.engine.tick * self._dt_ns
        level = s.LOG_INFO if result.succeeded else s.LOG_ERROR
        reason = f": {result.reason}" if result.reason else ""
        self._log(level, f"run {result.state.value}{reason}", None, ns)
        expectations = []
        for expectation in result.expectations:
            verdict = "holds" if expectation.held else "fails"
            decided = expectation.decided_at
            when = f" (decided at {decided:g} s)" if decided is not None else ""
            self._log(s.LOG_INFO if expectation.held else s.LOG_ERROR,
                      f"expectation {verdict}: {expectation.text}{when}",
                      expectation.decl.span, ns)
            expectations.append({"text": expectation.text, "held": bool(expectation.held),
                                 "decided_at": None if decided is None else s.number(decided),
                                 "line": expectation.decl.span.line})
        self._mcap.add_metadata(s.RESULT_METADATA_NAME, {
            "state": result.state.value, "reason": result.reason,
            "time": repr(result.time), "ticks": str(result.ticks),
            "succeeded": "true" if result.succeeded else "false",
            "expectations": s.dumps(expectations),
            "humans": s.dumps([{"name": h.name, "tasks_done": h.tasks_done,
                                "tasks_total": h.tasks_total, "last_status": h.last_status,
                                "path_length": s.number(h.path_length),
                                "busy_time": s.number(h.busy_time)} for h in result.humans])})

    def _discard(self) -> None:
        """Drop the temporary file (after a failure or an interruption)."""
        if self._mcap is not None:
            self._mcap.abandon()
        if self._file is not None:
            with contextlib.suppress(OSError):
                self._file.close()
        if self._temp is not None and not self._closed:
            with contextlib.suppress(OSError):
                self._temp.unlink()
        self._closed = True


class _WriteGuard:
    """Turns OS errors while writing (full disk, vanished directory) into a LogError."""

    def __init__(self, path: Path) -> None:
        self.path = path

    def __enter__(self) -> None:
        return None

    def __exit__(self, kind: type[BaseException] | None, error: BaseException | None,
                 trace: TracebackType | None) -> None:
        if isinstance(error, OSError):
            raise LogError(f"cannot write log {self.path}: {_reason(error)}") from None


def _reason(error: OSError) -> str:
    import errno

    if error.errno == errno.ENOSPC:
        return "no space left on the device"
    return error.strerror or str(error)


def ensure_directory(folder: str | Path) -> Path:
    """Create the folder logs go into (`--out-dir`), parents included; LogError if it cannot."""
    folder = Path(folder)
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except FileExistsError:
        raise LogError(f"cannot write logs into {folder}: it is a file, not a directory") \
            from None
    except OSError as exc:
        raise LogError(f"cannot create log directory {folder}: {_reason(exc)}") from None
    return folder


def _create_temp(final: Path) -> tuple[int, Path]:
    """A new file beside `final`, opened for writing, honouring the umask."""
    parent = final.parent
    if final.is_dir():
        raise LogError(f"cannot write log {final}: it is a directory")
    if not parent.is_dir():
        problem = "is not a directory" if parent.exists() else "does not exist"
        raise LogError(f"cannot write log {final}: {parent} {problem}")
    for attempt in itertools.count():
        temp = parent / f".{final.name}.{os.getpid()}.{attempt}.part"
        try:
            return os.open(temp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666), temp
        except FileExistsError:
            continue
        except OSError as exc:
            raise LogError(f"cannot write log {final}: {_reason(exc)}") from None
    raise AssertionError("unreachable")


def _read_map_files(yaml_path: Path) -> tuple[bytes, Path, bytes]:
    """The map's YAML bytes, its image's path and bytes, to attach them to the log."""
    try:
        text = yaml_path.read_bytes()
        image_name = yaml.safe_load(text)["image"]
        image_path = Path(image_name)
        if not image_path.is_absolute():
            image_path = yaml_path.parent / image_path
        return text, image_path, image_path.read_bytes()
    except (OSError, yaml.YAMLError, KeyError, TypeError) as exc:
        raise LogError(f"cannot attach map {yaml_path} to the log: {exc}") from None


def _params_json(params: dict[str, dict[str, Any]]) -> dict[str, dict[str, Any]]:
    """Every human's resolved parameters as JSON values (shapes as objects)."""
    def value(v: Any) -> Any:
        if isinstance(v, Circle | Ellipse | Rectangle):
            return s.shape_json(v)
        if isinstance(v, bool | int | float | str):
            return v
        return str(v)

    return {human: {key: value(v) for key, v in values.items()}
            for human, values in params.items()}
