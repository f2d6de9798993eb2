"""One run of a sweep, as a worker executes it: compile, simulate, log, measure, report.

`execute_run(task) -> RunRecord` is the function every executor calls (inline, in a worker
process, on a Dask worker). It never raises for a run that goes wrong: a failed or timed-out
scenario, an exception in the simulation, a log that cannot be written, metrics that cannot be
computed all come back as a record with a status and a reason, so one bad run never stops the
sweep. The task carries the scenario's text and absolute path, and the worker compiles it
once per process (a small cache keyed by path and text).

Worker processes of the process executor call `install_worker_signals` first: Ctrl-C is the
parent's to handle (it stops the workers), and SIGTERM, which the parent sends to stop them,
ends a run through the log writer's clean-up so no temporary file is left behind.
"""

from __future__ import annotations

import _thread
import contextlib
import os
import signal
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

from hubero_dsl.errors import HuberoError, Stopped

if TYPE_CHECKING:
    from hubero_dsl.log.reader import LoggedRun
    from hubero_dsl.model.program import Program
    from hubero_dsl.sim.loop import RunResult

EXIT_TERMINATED = 128 + signal.SIGTERM
PARENT_POLL = 0.5  # s between a worker's checks that the sweep's process is still there
_CACHE_SIZE = 4  # compiled programs kept per process (a sweep needs one)


class RunMetricsLike(Protocol):
    """What a metrics function returns (`hubero_dsl.analysis.metrics.RunMetrics`)."""

    def to_dict(self) -> dict[str, Any]: ...

    def flat(self) -> dict[str, Any]: ...


MetricsFunction = Callable[["LoggedRun"], RunMetricsLike]


def standard_metrics(run: LoggedRun) -> RunMetricsLike:
    """The metrics of `hubero_dsl.analysis.metrics` (imported in the worker, when needed)."""
    from hubero_dsl.analysis.metrics import compute_metrics

    return compute_metrics(run)


@dataclass(frozen=True, slots=True)
class RunTask:
    """What a worker needs for one run: plain data that pickles cheaply."""

    scenario_path: str   # absolute
    source: str          # the text the client planned with
    variant: str | None
    seed: int
    log_path: str        # absolute
    log: str             # relative to the output folder, for the record
    log_rate: float
    metrics: MetricsFunction | None
    # robots handed to classes of the caller's own (picklable by reference: MODULE:CLASS)
    controllers: tuple[tuple[str, type], ...] = ()


@dataclass(frozen=True, slots=True)
class RunRecord:
    """How one run ended. Holds no wall-clock time: records do not depend on the executor."""

    variant: str | None
    seed: int
    status: str                       # completed | failed | timed_out | error
    reason: str
    duration: float | None            # simulated seconds; None when the run did not happen
    succeeded: bool                   # completed and every expectation holds
    failed_expectations: tuple[str, ...]
    metrics: dict[str, Any] | None    # RunMetrics.to_dict()
    flat_metrics: dict[str, Any] | None  # RunMetrics.flat(), for the CSV
    log: str | None                   # relative to the output folder


def error_record(variant: str | None, seed: int, reason: str) -> RunRecord:
    """A run that could not be carried out (or whose outcome could not be read)."""
    return RunRecord(variant, seed, "error", reason, None, False, (), None, None, None)


def execute_run(task: RunTask) -> RunRecord:
    """Run one variant with one seed into its log; every failure becomes the record's reason."""
    try:
        with _running(task.log_path):
            return _execute(task)
    except WorkerTerminated:
        # The log writer has dropped its temporary file on the way out; leave at once, as the
        # parent asked, without returning to the pool's loop.
        os._exit(EXIT_TERMINATED)


def _execute(task: RunTask) -> RunRecord:
    try:
        program = compiled(task.scenario_path, task.source)
        result = _simulate(program, task)
    except HuberoError as exc:
        return error_record(task.variant, task.seed, str(exc))
    except Exception as exc:  # a bug or an environment problem: record it, keep sweeping
        return error_record(task.variant, task.seed, f"{type(exc).__name__}: {exc}")
    duration = round(result.time, 9)
    failed = tuple(e.text for e in result.expectations if not e.held)
    state, reason = result.state.value, result.reason
    metrics: dict[str, Any] | None = None
    flat: dict[str, Any] | None = None
    if task.metrics is not None:
        try:
            metrics, flat = _measure(task)
        except Exception as exc:  # the run is logged, but the sweep's table would lie
            state = "error"
            reason = f"computing the metrics failed: {type(exc).__name__}: {exc}"
    succeeded = state == "completed" and result.succeeded
    return RunRecord(task.variant, task.seed, state, reason, duration, succeeded, failed,
                     metrics, flat, task.log)


def _simulate(program: Program, task: RunTask) -> RunResult:
    from hubero_dsl.simulate import simulate

    # Encode in this process: a sweep's parallelism is across runs, and Dask's daemonic worker
    # processes may not start a writer process of their own.
    return simulate(program, variant=task.variant, seed=task.seed, log=Path(task.log_path),
                    log_rate=task.log_rate, writer_process=False,
                    controllers=dict(task.controllers) or None)


def _measure(task: RunTask) -> tuple[dict[str, Any], dict[str, Any]]:
    from hubero_dsl.log.reader import load_run

    assert task.metrics is not None
    measured = task.metrics(load_run(task.log_path))
    return measured.to_dict(), measured.flat()


# ---- the compiled program, once per process ----------------------------------------------------

_programs: dict[tuple[str, str], Program] = {}
_programs_lock = threading.Lock()  # Dask may run several tasks in threads of one process


def compiled(path: str, source: str) -> Program:
    """The program of this text at this path, compiled at most once per process."""
    from hubero_dsl.pipeline import compile_source

    key = (path, source)
    with _programs_lock:
        program = _programs.get(key)
        if program is None:
            program = compile_source(source, path)
            if len(_programs) >= _CACHE_SIZE:
                _programs.pop(next(iter(_programs)))
            _programs[key] = program
        return program


# ---- signals in worker processes ---------------------------------------------------------------


class WorkerTerminated(Stopped):
    """Raised in a worker process's run by SIGTERM: the sweep was stopped."""


_state: dict[str, Any] = {"log": None}  # the log of the run under way; None between runs


def install_worker_signals(parent: int | None = None) -> None:
    """For worker processes: ignore Ctrl-C, let SIGTERM end a run cleanly, and end with the
    sweep's process `parent` however it ends (even SIGKILL, which it cannot pass on)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, _on_terminate)
    if parent is not None:
        threading.Thread(target=_watch, args=(parent,), daemon=True,
                         name="hubero-parent-watch").start()


def _watch(parent: int) -> None:
    """Poll the parent; when it is gone, end the run as SIGTERM would (its log discarded)."""
    while _alive(parent):
        time.sleep(PARENT_POLL)
    _thread.interrupt_main(signal.SIGTERM)
    time.sleep(5.0)  # the run's clean-up has had its chance
    _drop_own_temporary_log()  # the stop was lost (raised where it could not be) or is slow
    os._exit(EXIT_TERMINATED)


def _drop_own_temporary_log() -> None:
    """Remove the temporary log this process was writing, if it is still there."""
    from hubero_dsl.log.writer import temporary_logs

    log = _state["log"]
    if not isinstance(log, str):
        return
    mine = f".{os.getpid()}."
    for temp in temporary_logs(Path(log)):
        if mine in temp.name:
            with contextlib.suppress(OSError):
                temp.unlink()


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _on_terminate(signum: int, frame: Any) -> None:
    if _state["log"] is not None:
        raise WorkerTerminated
    os._exit(EXIT_TERMINATED)  # idle between runs: nothing to clean up


@contextlib.contextmanager
def _running(log: str) -> Iterator[None]:
    _state["log"] = log
    try:
        yield
    finally:
        _state["log"] = None
