"""Running a planned sweep on an executor: submit, collect, survive failures and Ctrl-C.

    with open_executor("process", jobs=2) as executor:
        outcome = run_sweep(plan, out_dir, executor, on_done=show_progress)
    write_index(out_dir, plan, outcome)

`run_sweep` keeps a bounded queue of runs submitted (twice the executor's slots, so a sweep of
100,000 runs is not 100,000 futures and an interruption has little to cancel) and collects
records as runs finish, in whatever order; the outcome lists them in the plan's order, so it
is the same whichever executor ran them. A run that fails, raises in the worker or loses its
worker process is recorded as such and the sweep goes on. On Ctrl-C the executor is stopped
and the outcome holds the runs that had finished (`complete=False`); logs of runs that did not
finish are removed (a Dask worker may still finish a run it had started, and write its log).
"""

from __future__ import annotations

import contextlib
import itertools
import os
import tempfile
from collections.abc import Callable, Iterator, Mapping, Sequence
from concurrent.futures import FIRST_COMPLETED, BrokenExecutor, Executor, Future, wait
from dataclasses import dataclass
from pathlib import Path

from hubero_dsl.errors import LogError, Terminated
from hubero_dsl.sweep.executors import deaf_to_interrupts, executor_slots, terminate
from hubero_dsl.sweep.plan import SweepPlan
from hubero_dsl.sweep.worker import (
    MetricsFunction,
    RunRecord,
    RunTask,
    error_record,
    execute_run,
    standard_metrics,
)

OnDone = Callable[[RunRecord], None]
FRUITLESS_POOLS = 3  # fresh pools in a row, none of whose runs began, before giving up
WORKERS_DIE = ("worker processes die as they start, pool after pool; a Python script that "
               "starts a sweep must do so under `if __name__ == \"__main__\":`")


@dataclass(frozen=True)
class SweepOutcome:
    records: tuple[RunRecord, ...]  # in the plan's order; only finished runs if interrupted
    complete: bool                  # False when the sweep was interrupted
    terminated: bool = False        # interrupted by SIGTERM, not Ctrl-C

    @property
    def succeeded(self) -> bool:
        """Every planned run finished, completed, and met its expectations."""
        return self.complete and all(record.succeeded for record in self.records)


def prepare_out_dir(plan: SweepPlan, out_dir: str | Path, earlier: Sequence[Path] = ()
                    ) -> Path:
    """Create the output folders, check they are writable, and remove the logs of an earlier
    sweep at this sweep's log paths (so a log the index names is always this sweep's) and
    `earlier`, the other logs its index named (so that none is left that no index names); a
    file at a log path that is not a log is the user's, and refused."""
    from hubero_dsl.log.reader import refuse_unless_run_log
    from hubero_dsl.log.writer import ensure_directory

    folder = ensure_directory(out_dir)
    try:
        with tempfile.TemporaryFile(dir=folder):
            pass
    except OSError as exc:
        raise LogError(f"cannot write into {folder}: {exc.strerror or exc}") from None
    for spec in plan.runs:
        log = folder / spec.log
        refuse_unless_run_log(log, "give another --out-dir")
    for log in earlier:  # first: a variant's folder left empty goes, then this sweep's come
        with contextlib.suppress(FileNotFoundError):
            log.unlink()
        with contextlib.suppress(OSError):  # not empty
            log.parent.rmdir()
    for spec in plan.runs:
        log = folder / spec.log
        if not log.parent.is_dir():
            ensure_directory(log.parent)
        if log.is_file() or log.is_symlink():
            with contextlib.suppress(FileNotFoundError):
                log.unlink()
    return folder


def build_tasks(plan: SweepPlan, out_dir: str | Path, *, log_rate: float = 10.0,
                metrics: MetricsFunction | None = standard_metrics,
                controllers: Mapping[str, type] | None = None) -> list[RunTask]:
    """One picklable task per planned run, with absolute paths (workers' folders differ)."""
    folder = os.path.abspath(out_dir)
    handed = tuple(sorted((controllers or {}).items()))
    return [RunTask(plan.scenario_path, plan.source, spec.variant, spec.seed,
                    os.path.join(folder, *spec.log.split("/")), spec.log, log_rate, metrics,
                    handed)
            for spec in plan.runs]


def run_sweep(plan: SweepPlan, out_dir: str | Path, executor: Executor, *,
              log_rate: float = 10.0, metrics: MetricsFunction | None = standard_metrics,
              on_done: OnDone | None = None, window: int | None = None,
              controllers: Mapping[str, type] | None = None) -> SweepOutcome:
    """Run every planned run on the executor; the records in plan order. `controllers` hands
    robots to the caller's own classes, as `hubero run --controller` does."""
    tasks: list[RunTask] = []
    records: dict[int, RunRecord] = {}
    pending: dict[Future[RunRecord], int] = {}

    def collect(index: int, record: RunRecord) -> None:
        records[index] = record
        if on_done is not None:
            on_done(record)

    try:  # from the start: stopped however early, the sweep still has an (empty) outcome
        tasks = build_tasks(plan, out_dir, log_rate=log_rate, metrics=metrics,
                            controllers=controllers)
        limit = window if window is not None else 2 * executor_slots(executor)
        queue: Iterator[tuple[int, RunTask]] = iter(enumerate(tasks))
        _submit(executor, queue, tasks, pending, collect, max(1, limit))
        fruitless = 0  # pools in a row that broke before any of their runs began
        while pending:
            finished, _ = wait(pending, return_when=FIRST_COMPLETED)
            broke = any(_broke_the_pool(future) for future in finished)
            if broke and fruitless >= FRUITLESS_POOLS:
                _give_up(pending, queue, tasks, collect)
                break
            if broke and _renew(executor):
                finished = set(wait(pending).done)  # every submitted run fails with the pool
                unstarted = {f: pending.pop(f) for f in finished
                             if _broke_the_pool(f) and not _started(tasks[pending[f]])}
                finished -= set(unstarted)  # they go again, first, in the fresh pool
                fruitless = fruitless + 1 if not finished else 0
                queue = itertools.chain(((i, tasks[i]) for i in sorted(unstarted.values())),
                                        queue)
            for future in sorted(finished, key=pending.__getitem__):
                index = pending.pop(future)
                collect(index, _record_of(future, tasks[index]))
            _submit(executor, queue, tasks, pending, collect, max(1, limit))
    except KeyboardInterrupt as stop:
        with deaf_to_interrupts():
            terminate(executor)
            _harvest(pending, records)
            _drop_unrecorded_logs(tasks, records)
        return SweepOutcome(tuple(records[i] for i in sorted(records)), complete=False,
                            terminated=isinstance(stop, Terminated))
    return SweepOutcome(tuple(records[i] for i in sorted(records)), complete=True)


def _give_up(pending: dict[Future[RunRecord], int], queue: Iterator[tuple[int, RunTask]],
             tasks: list[RunTask], collect: Callable[[int, RunRecord], None]) -> None:
    """Record every run left as failed: worker processes die as they start, pool after pool
    (a script that starts a sweep without `if __name__ == "__main__":` makes each worker
    start it again), so a fresh pool would die too."""
    wait(pending)
    left = sorted([*pending.values(), *(index for index, _ in queue)])
    pending.clear()
    for index in left:
        _remove_temporary_logs(tasks[index])
        collect(index, error_record(tasks[index].variant, tasks[index].seed, WORKERS_DIE))


def _submit(executor: Executor, queue: Iterator[tuple[int, RunTask]], tasks: list[RunTask],
            pending: dict[Future[RunRecord], int], collect: Callable[[int, RunRecord], None],
            limit: int) -> None:
    """Top the queue of submitted runs up to `limit` (a serial executor runs each here)."""
    while len(pending) < limit:
        item = next(queue, None)
        if item is None:
            return
        index, task = item
        try:
            future = executor.submit(execute_run, task)
        except Exception as exc:  # a broken pool refuses new work: record it, go on
            collect(index, error_record(task.variant, task.seed, _worker_failure(exc)))
            continue
        if future.done():
            collect(index, _record_of(future, task))
        else:
            pending[future] = index


def _broke_the_pool(future: Future[RunRecord]) -> bool:
    return not future.cancelled() and isinstance(future.exception(), BrokenExecutor)


def _renew(executor: Executor) -> bool:
    """A worker died: a process pool refuses all work after, so the runs not yet started go
    on in a fresh one (those in flight cannot be told from the one that died, and fail).
    False for an executor that cannot be renewed."""
    renew = getattr(executor, "renew", None)
    if renew is not None:
        renew()
    return renew is not None


def _started(task: RunTask) -> bool:
    """Whether a run had begun writing its log (its temporary file, or the log itself)."""
    from hubero_dsl.log.writer import temporary_logs

    return os.path.exists(task.log_path) or bool(temporary_logs(Path(task.log_path)))


def _record_of(future: Future[RunRecord], task: RunTask) -> RunRecord:
    """The worker's record, or an error record when the worker itself failed (its log's
    temporary file, which a killed worker leaves, removed)."""
    try:
        return future.result()
    except KeyboardInterrupt:
        raise
    except BaseException as exc:  # the worker died or exited, a pickling error, Dask lost it
        _remove_temporary_logs(task)
        return error_record(task.variant, task.seed, _worker_failure(exc))


def _remove_temporary_logs(task: RunTask) -> None:
    from hubero_dsl.log.writer import temporary_logs

    for temp in temporary_logs(Path(task.log_path)):
        with contextlib.suppress(OSError):
            temp.unlink()


def _worker_failure(exc: BaseException) -> str:
    return f"the worker failed: {type(exc).__name__}: {exc}".rstrip(": ")


def _harvest(pending: dict[Future[RunRecord], int], records: dict[int, RunRecord]) -> None:
    """Keep the runs that finished while the sweep was being stopped."""
    for future, index in pending.items():
        if future.done() and not future.cancelled() and future.exception() is None:
            records[index] = future.result()


def _drop_unrecorded_logs(tasks: list[RunTask], records: dict[int, RunRecord]) -> None:
    """A run stopped after its log was closed (while measuring it) has a log the index will
    not name, and a worker stopped before its clean-up ran (killed after the grace time, or
    stopped while it was opening its log) leaves a temporary file: remove both, so that the
    logs on disk are the index's. The workers are stopped by now, so none is still writing."""
    for index, task in enumerate(tasks):
        if index not in records:
            with contextlib.suppress(OSError):
                os.unlink(task.log_path)
            _remove_temporary_logs(task)
