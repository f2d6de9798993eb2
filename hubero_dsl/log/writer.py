"""`RunLog`: records a run as an MCAP file that Foxglove replays and `load_run` reads back.

    with RunLog("run.mcap", sim, rate_hz=10) as log:
        result = run_program(sim, [log.observe])
        log.close(result)

The log is written to a temporary file beside the final one (`.NAME.PID.N.part`) and renamed
over it only by `close()`: a run that fails, is interrupted or is killed never leaves a partial
file under the final name. Leaving the `with` block through an exception deletes the temporary
file (a killed run's writer process deletes it too; an in-process writer cannot).

What is written (topics and schemas in `schemas.py`, frames in `frames.py`, the scene in
`scene.py`): at the start the provenance metadata, the scenario source and its map (YAML and
image) as attachments, `/map` and a first frame (the state before the first step); a frame
(`/tf`, `/humans/NAME/pose`, `/humans/NAME/state`, `/crowds/NAME/poses` and `/state` (in
`crowds.py`), and `/scene` when it changed) each time the
simulation clock passes a multiple of 1/rate_hz, plus one at the last tick if that was not a
sample; every task status change on `/tasks` as it happens; scenario events on `/log`; at the
end how the run ended (`hubero.result` metadata). Log and publish times are simulation time.

Where the work happens: `observe` only copies what changed out of the engine (`Update`s). The
JSON and MCAP encoding (`encoder.py`) runs in a writer process forked at `open()` when the
platform can fork and no other thread runs, so that it overlaps with the simulation on another
core; otherwise, or with `writer_process=False`, in this process. Both write the same bytes.

With `live` (a `live.LiveServer`) the encoder hands every record to the server as well; it then
runs in this process, where the server is, and `path` may be None (watched, not written).
"""

from __future__ import annotations

import contextlib
import glob
import itertools
import math
import multiprocessing
import os
import signal
import sys
import threading
import weakref
from pathlib import Path
from types import TracebackType
from typing import TYPE_CHECKING, Any, Protocol

from hubero_dsl import __version__
from hubero_dsl.errors import LogError
from hubero_dsl.files import STOPS, check_output, stops_held
from hubero_dsl.log import schemas as s
from hubero_dsl.log.crowds import members_of_crowds
from hubero_dsl.log.encoder import LogEncoder, LogSetup, Update, discard_file
from hubero_dsl.log.frames import Capturer
from hubero_dsl.log.provenance import logged_source_path, provenance
from hubero_dsl.log.reader import refuse_unless_run_log
from hubero_dsl.log.sinks import MessageSink
from hubero_dsl.world.mapfile import map_files

if TYPE_CHECKING:
    from multiprocessing.connection import Connection

    from hubero_dsl.model.program import Program
    from hubero_dsl.sim.loop import HumanSummary, RunResult
    from hubero_dsl.sim.simulation import Simulation
    from hubero_dsl.sim.status import TaskEvent

SAMPLE_EPSILON = 1e-9  # tick * dt * rate lands a hair below an integer for some dt and rates
WRITER_JOIN_TIMEOUT = 30.0  # s to wait for the writer process to wind down after a failure


def check_log_path(path: Path, program: Program, advice: str = "name another log") -> None:
    """Refuse (InputError) to write a log of `program` at `path`: in a folder that does not
    exist, over a folder, a device, the scenario or its map, or over a file that is not a
    hubero run log (a run's log is written over, a user's file never)."""
    check_output(path, (Path(program.source.path), *map_files(program.map_path)),
                 lambda where, reason: f"cannot write log {where}: {reason}")
    refuse_unless_run_log(path, advice)


class RunLog:
    """An MCAP log of one run; a context manager whose `observe` is a run observer."""

    def __init__(self, path: str | Path | None, sim: Simulation, *, rate_hz: float = 10.0,
                 compression: str = "zstd", chunk_size: int = 4 << 20,
                 writer_process: bool | None = None, live: MessageSink | None = None) -> None:
        if not (isinstance(rate_hz, int | float) and math.isfinite(rate_hz) and rate_hz > 0):
            raise LogError(f"the log rate must be a number of hertz above 0, got {rate_hz!r}")
        if path is None and live is None:
            raise LogError("a log needs a file or a live server to write to")
        self.path = None if path is None else Path(path)
        self._live = live
        self.rate_hz = float(rate_hz)
        self._sim = sim
        self._compression = compression
        self._chunk_size = chunk_size
        self._writer_process = writer_process
        self._sink: _Sink | None = None
        self._closed = False
        self._crowds = _crowds(sim)
        count = sim.engine.humans.count
        self._capturer = Capturer(count, ~members_of_crowds(count, self._crowds))
        self._events_sent = 0
        self._last_sample = -1
        self._last_frame_tick = -1
        self._frames = 0

    # ---- the context manager ----------------------------------------------------------------

    def __enter__(self) -> RunLog:
        self.open()
        return self

    def __exit__(self, kind: type[BaseException] | None, error: BaseException | None,
                 trace: TracebackType | None) -> None:
        if kind is None and not self._closed and self._sink is not None:
            self.close()
        else:
            self._discard()

    # ---- the observer API -------------------------------------------------------------------

    def open(self) -> None:
        """Create the temporary file, start the writer, and record the first frame."""
        if self._sink is not None:
            raise LogError(f"log {self.path} is already open")
        program = self._sim.program
        fd, temp = None, None
        if self.path is not None:
            check_log_path(self.path, program)
        try:
            # Ctrl-C or SIGTERM between the file's creation and its name being known here
            # would leave it behind: held until then, raised inside the `try` that removes it
            with stops_held():
                if self.path is not None:
                    fd, temp = _create_temp(self.path)
            setup = self._setup(temp)
            # a live server publishes from this process, so the encoding stays here
            fork = can_fork() if self._writer_process is None else self._writer_process
            if fork and fd is not None and self._live is None:
                self._sink = _ProcessSink(setup, fd)
            else:
                self._sink = _LocalSink(setup, fd, self._live)
        except BaseException:
            if fd is not None:
                with contextlib.suppress(OSError):
                    os.close(fd)
            discard_file(None, temp)
            raise
        # a log never closed (a Gymnasium env left open, dropped, or the program ending) leaves
        # no temporary file behind it: removed when this object goes, or at exit
        self._unfinished = weakref.finalize(self, discard_file, None, temp)
        try:
            self.observe(self._sim)
        except BaseException:
            self._discard()
            raise

    def observe(self, sim: Simulation) -> None:
        """Record what happened since the last call; a frame when a sample time was passed."""
        assert self._sink is not None, "observe() before open()"
        engine = sim.engine
        sample = math.floor(engine.tick * engine.dt * self.rate_hz + SAMPLE_EPSILON)
        frame = None
        if sample > self._last_sample:
            self._last_sample = sample
            frame = self._capture(sim)
        events = self._new_events(sim)
        if events or frame is not None:
            self._sink.send(Update(events, frame))

    def close(self, result: RunResult | None = None) -> Path | None:
        """Record the last events and frame and the result; move the file to its final name."""
        if self._closed:
            return self.path
        if self._sink is None:
            raise LogError(f"log {self.path} was never opened")
        try:
            engine = self._sim.engine
            frame = self._capture(self._sim) if engine.tick != self._last_frame_tick else None
            self._sink.send(Update(self._new_events(self._sim), frame))
            self._sink.finish(_result_json(result) if result is not None else None,
                              engine.tick)
        except BaseException:
            self._discard()
            raise
        self._closed = True
        self._unfinished.detach()  # renamed into place: nothing to remove
        return self.path

    @property
    def frames(self) -> int:
        """How many frames have been recorded so far."""
        return self._frames

    # ---- capturing --------------------------------------------------------------------------

    def _capture(self, sim: Simulation) -> Any:
        self._frames += 1
        self._last_frame_tick = sim.engine.tick
        return self._capturer.capture(sim.engine)

    def _new_events(self, sim: Simulation) -> list[tuple[TaskEvent, str]]:
        """Task events since the last call, each with its task's description."""
        engine = sim.engine
        events = engine.events[self._events_sent:]
        self._events_sent += len(events)
        described = []
        for event in events:
            description = ""
            if event.human in engine.humans.names:
                handle = engine.handle[engine.index_of(event.human)]
                if handle is not None and handle.task_id == event.task_id:
                    description = handle.description
            elif event.human in engine.robots.names:
                current = engine.robots.current(event.human)
                if current is not None and current.handle.task_id == event.task_id:
                    description = current.handle.description
            described.append((event, description))
        return described

    def _setup(self, temp: Path | None) -> LogSetup:
        sim, program, engine = self._sim, self._sim.program, self._sim.engine
        humans, robots = engine.humans, engine.robots
        variant = f"variant '{sim.variant}'" if sim.variant else "no variant"
        metadata, attachments = provenance(sim, self.rate_hz)
        return LogSetup(
            final=self.path, temp=temp, library=f"hubero {__version__}",
            compression=self._compression, chunk_size=self._chunk_size,
            dt_ns=s.nanoseconds(engine.dt), humans=list(humans.names),
            radius=[float(r) for r in humans.radius], shapes=list(humans.shapes),
            crowds=self._crowds,
            robots=list(robots.names), robot_radius=[float(r) for r in robots.radius],
            robot_controllers=robots.controller_names(),
            source_path=logged_source_path(program),
            source_lines=program.source.text.splitlines(),
            metadata=metadata, attachments=attachments,
            grid=s.dumps(s.grid_message(program.grid)).encode(),
            start_message=(f"run of '{program.title}' started: {variant}, seed {sim.seed}, "
                           f"{_people(program, humans.count)}, {robots.count} robots"))

    def _discard(self) -> None:
        """Stop the writer and drop the temporary file (after a failure or an interruption)."""
        if self._sink is not None and not self._closed:
            self._sink.abort()
            self._unfinished.detach()
        self._closed = True


def _people(program: Program, count: int) -> str:
    """The humans at the start, and how many more the flows may bring: a flow's people are
    rows of the run from the start, as many as it may bring, and most never come."""
    brought = sum(len(flow.members) for flow in program.flows)
    if not brought:
        return f"{count} humans"
    *others, last = [flow.name for flow in program.flows]
    flows = f"flows {', '.join(others)} and {last}" if others else f"flow {last}"
    return f"{count - brought} humans and up to {brought} more from {flows}"


def _crowds(sim: Simulation) -> list[tuple[str, list[int]]]:
    """The crowds and flows of the run with their members' rows: they share topics."""
    row = {name: i for i, name in enumerate(sim.engine.humans.names)}
    return [(name, [row[member] for member in members])
            for name, (kind, members) in sim.program.people_sets().items()
            if kind in ("crowd", "flow")]


def can_fork() -> bool:
    """Whether a writer process can be forked safely: the platform forks, this process runs no
    other thread (a lock another thread holds would stay locked in the child) and is not a
    daemonic worker (which may have no children)."""
    return ("fork" in multiprocessing.get_all_start_methods() and threading.active_count() == 1
            and not multiprocessing.current_process().daemon)


# ---- where the encoding runs -------------------------------------------------------------------


class _Sink(Protocol):
    def send(self, update: Update) -> None: ...

    def finish(self, result: dict[str, Any] | None, end_tick: int) -> None: ...

    def abort(self) -> None: ...


class _LocalSink:
    """Encodes in this process (a thread compresses and writes chunks), into the file `fd`,
    to `live`, or both."""

    def __init__(self, setup: LogSetup, fd: int | None, live: MessageSink | None = None) -> None:
        self._path = setup.final
        stream = None if fd is None else os.fdopen(fd, "wb", buffering=1 << 20)
        try:
            with _WriteGuard(self._path):
                self._encoder = LogEncoder(setup, stream, live=live)
        except BaseException:
            discard_file(stream, setup.temp)
            raise

    def send(self, update: Update) -> None:
        with _WriteGuard(self._path):
            self._encoder.write(update)

    def finish(self, result: dict[str, Any] | None, end_tick: int) -> None:
        with _WriteGuard(self._path):
            self._encoder.finish(result, end_tick)

    def abort(self) -> None:
        self._encoder.discard()


class _ProcessSink:
    """Encodes in a forked writer process; updates go to it through a pipe.

    The writer ignores Ctrl-C (this process decides what an interruption means) and deletes
    the temporary file when the pipe closes without a `finish`: also when this process is
    killed. Its errors come back as messages and are raised here as LogErrors.
    """

    def __init__(self, setup: LogSetup, fd: int) -> None:
        self._temp = setup.temp
        context = multiprocessing.get_context("fork")
        self._conn, child = context.Pipe(duplex=True)
        for stream in (sys.stdout, sys.stderr):  # the child must not flush our buffers again
            with contextlib.suppress(OSError, ValueError, AttributeError):
                stream.flush()
        self._process = context.Process(target=_serve, args=(setup, fd, child, self._conn),
                                        name="hubero-log-writer", daemon=True)
        # Ctrl-C or SIGTERM during the fork would run this process's handler in the child's
        # start-up, before it ignores them, and print a traceback there: hold them until then
        with stops_held():
            self._process.start()
        child.close()
        os.close(fd)

    def send(self, update: Update) -> None:
        if self._conn.poll():
            self._raise_reply()
        try:
            self._conn.send(update)
        except (BrokenPipeError, ConnectionResetError, EOFError):
            self._raise_reply()

    def finish(self, result: dict[str, Any] | None, end_tick: int) -> None:
        try:
            self._conn.send(("finish", result, end_tick))
            reply = self._conn.recv()
        except (BrokenPipeError, ConnectionResetError, EOFError):
            reply = ("error", "the log writer stopped unexpectedly")
        self._conn.close()
        self._process.join(WRITER_JOIN_TIMEOUT)
        if reply[0] != "done":
            raise LogError(reply[1])

    def _raise_reply(self) -> None:
        try:
            reply = self._conn.recv()
        except (EOFError, OSError):
            reply = ("error", "the log writer stopped unexpectedly")
        raise LogError(reply[1])

    def abort(self) -> None:
        with contextlib.suppress(OSError):
            self._conn.close()
        self._process.join(WRITER_JOIN_TIMEOUT)
        if self._process.is_alive():
            self._process.kill()
            self._process.join()
        discard_file(None, self._temp)


def _serve(setup: LogSetup, fd: int, conn: Connection, parent_end: Connection) -> None:
    """The writer process: encode updates until `finish` (rename) or a closed pipe (delete).
    Ctrl-C and SIGTERM are the run's to handle (they reach the whole process group): the run
    then aborts the writer, or its pipe closes."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, STOPS)  # held since the fork; now ignored
    parent_end.close()  # else the pipe would never report the run's end, even if it is killed
    stream = os.fdopen(fd, "wb", buffering=1 << 20)
    encoder: LogEncoder | None = None
    failure: str | None = None
    try:
        encoder = LogEncoder(setup, stream)
    except (LogError, OSError) as exc:
        failure = _failure(setup.final, exc)
    while True:
        try:
            item = conn.recv()
        except (EOFError, OSError):
            break
        if failure is None and encoder is not None:
            try:
                if isinstance(item, Update):
                    encoder.write(item)
                    continue
                encoder.finish(item[1], item[2])
                conn.send(("done", ""))
                return
            except Exception as exc:  # reported to the run, which raises it as a LogError
                failure = _failure(setup.final, exc)
                conn.send(("error", failure))
        elif not isinstance(item, Update):
            conn.send(("error", failure or "the log writer failed"))
            break
    if encoder is not None:
        encoder.discard()
    else:
        discard_file(stream, setup.temp)


def _failure(final: Path | None, error: BaseException) -> str:
    if isinstance(error, LogError):
        return error.message
    if isinstance(error, OSError):
        return f"cannot write log {final}: {_reason(error)}"
    return f"the log writer failed: {type(error).__name__}: {error}"


def _result_json(result: RunResult) -> dict[str, Any]:
    """How the run ended, as plain values (the writer process gets a copy)."""
    return {
        "state": result.state.value, "reason": result.reason, "time": repr(result.time),
        "ticks": str(result.ticks), "succeeded": result.succeeded,
        "expectations": [
            {"text": e.text, "held": bool(e.held), "line": e.expectation.span.line,
             "decided_at": None if e.decided_at is None else s.number(e.decided_at),
             "span": e.expectation.span} for e in result.expectations],
        "humans": [_summary_json(h) for h in result.humans],
        "robots": [_summary_json(r) for r in result.robots]}


def _summary_json(actor: HumanSummary) -> dict[str, Any]:
    return {"name": actor.name, "tasks_done": actor.tasks_done,
            "tasks_total": actor.tasks_total, "last_status": actor.last_status,
            "path_length": s.number(actor.path_length), "busy_time": s.number(actor.busy_time)}


# ---- files -------------------------------------------------------------------------------------


class _WriteGuard:
    """Turns OS errors while writing (full disk, vanished directory) into a LogError."""

    def __init__(self, path: Path | None) -> None:
        self.path = path

    def __enter__(self) -> None:
        return None

    def __exit__(self, kind: type[BaseException] | None, error: BaseException | None,
                 trace: TracebackType | None) -> None:
        if isinstance(error, OSError) and self.path is not None:
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


def temporary_logs(final: Path) -> list[Path]:
    """The temporary files beside `final` that writers of it left (`_create_temp` names them):
    a log being written, or one a killed process never finished."""
    return sorted(final.parent.glob(f".{glob.escape(final.name)}.*.part"))


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
