"""Where a sweep's runs execute: three `concurrent.futures.Executor`s behind one interface.

    with open_executor("process", jobs=4) as executor:      # or "serial", or "dask"
        future = executor.submit(execute_run, task)

- `SerialExecutor` runs each call inline when it is submitted: no processes, easy to debug.
- `ProcessExecutor` is a `ProcessPoolExecutor` (forkserver where the platform has it, else
  spawn: never fork, which copies the parent's threads and locks) whose workers leave Ctrl-C
  to the parent and stop cleanly on SIGTERM.
- `DaskExecutor` submits to a Dask distributed scheduler through `Client.get_executor()`;
  `distributed` is the optional extra `hubero[dask]` and is imported only here, only when asked.

Each has `slots` (how many runs it executes at once, to size the queue of submitted runs) and
`terminate()` (stop now: cancel what has not started, stop what is running where possible),
which the sweep calls when it is interrupted.
"""

from __future__ import annotations

import contextlib
import multiprocessing
import os
import signal
import threading
from collections.abc import Callable, Iterator
from concurrent.futures import Executor, Future, ProcessPoolExecutor
from typing import Any, Literal, ParamSpec, TypeVar

from hubero_dsl.errors import InputError, Terminated
from hubero_dsl.files import stops_held

ExecutorKind = Literal["serial", "process", "dask"]
EXECUTOR_KINDS: tuple[ExecutorKind, ...] = ("serial", "process", "dask")
DEFAULT_CONNECT_TIMEOUT = 5.0  # s before an unreachable Dask scheduler is reported
TERMINATE_TIMEOUT = 10.0  # s to wait for worker processes to end after SIGTERM
MAX_JOBS = 256  # worker processes at most: each holds a simulator (some 50-200 MB)

WORKER_MODULES = ("hubero_dsl.sweep.worker", "hubero_dsl.pipeline", "hubero_dsl.sim.loop",
                  "hubero_dsl.sim.simulation", "hubero_dsl.log.writer", "hubero_dsl.log.reader",
                  "hubero_dsl.analysis.metrics")

P = ParamSpec("P")
T = TypeVar("T")


def check_jobs(jobs: int | None) -> None:
    """Refuse (InputError) a `--jobs` that is no number of worker processes to start."""
    if jobs is not None and not 1 <= jobs <= MAX_JOBS:
        raise InputError(f"--jobs must be from 1 to {MAX_JOBS}, got {jobs}")


def available_cores() -> int:
    """The cores this process may use (the affinity mask where the platform has one)."""
    with contextlib.suppress(AttributeError, OSError):
        return max(1, len(os.sched_getaffinity(0)))
    return max(1, os.cpu_count() or 1)


class SerialExecutor(Executor):
    """Runs each call inline in `submit` and returns a finished future."""

    slots = 1

    def __init__(self) -> None:
        self._shutdown = False
        self._lock = threading.Lock()

    def submit(self, fn: Callable[P, T], /, *args: P.args, **kwargs: P.kwargs) -> Future[T]:
        with self._lock:
            if self._shutdown:
                raise RuntimeError("cannot schedule new futures after shutdown")
        future: Future[T] = Future()
        future.set_running_or_notify_cancel()
        try:
            future.set_result(fn(*args, **kwargs))
        except Exception as exc:  # KeyboardInterrupt and the like go on up, as inline code does
            future.set_exception(exc)
        return future

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
        with self._lock:
            self._shutdown = True

    def terminate(self) -> None:
        self.shutdown()


def _start_fork_server() -> None:
    """Start the fork server now, deaf to Ctrl-C: it imports the simulator before it ignores
    SIGINT itself, and a Ctrl-C (sent to the whole process group) in the first second of a
    sweep printed a traceback from it. A signal blocked by the thread that starts a process
    stays blocked in it until it ignores the signal for good (as Python starts its resource
    tracker, first: starting it unblocks SIGINT here). This process hears a Ctrl-C that came
    meanwhile once the server is started; ignoring it instead, which a child would inherit
    too, lost it when another thread of this process took it."""
    from multiprocessing import forkserver, resource_tracker

    resource_tracker.ensure_running()
    with _signals_after(), stops_held(frozenset({signal.SIGINT})):
        forkserver.ensure_running()


@contextlib.contextmanager
def _signals_after() -> Iterator[None]:
    """Ctrl-C and SIGTERM held back until the block is done: a submission may start a worker
    process, and one interrupted between its fork and its being recorded by the pool was left
    behind, to print a traceback when it found the pool gone. Main thread only (where Python
    runs signal handlers); elsewhere the block runs as it is."""
    held: list[int] = []
    try:
        with _interrupts_handled_by(lambda received, frame: held.append(received)):
            yield
    finally:
        if held:
            signal.raise_signal(held[0])  # now, to the handler it was meant for


@contextlib.contextmanager
def deaf_to_interrupts() -> Iterator[None]:
    """Ctrl-C and SIGTERM go unheard for the block: a sweep that is stopping stops once, and
    a second Ctrl-C (a terminal's user pressing it again) no longer cut short the stopping
    and left no index. Main thread only; elsewhere the block runs as it is."""
    with _interrupts_handled_by(signal.SIG_IGN):
        yield


@contextlib.contextmanager
def stopped_once() -> Iterator[None]:
    """The first Ctrl-C or SIGTERM in the block stops it (KeyboardInterrupt or Terminated);
    later ones go unheard until the block ends. The handler itself goes deaf, so no moment
    is left between a first press and the stopping where a second one cut the stopping
    short. Main thread only; elsewhere the block runs as it is."""
    with _interrupts_handled_by(_StopOnce()):
        yield


class _StopOnce:
    """A signal handler that raises for the first signal only."""

    def __init__(self) -> None:
        self.stopping = False

    def __call__(self, received: int, frame: object) -> None:
        if self.stopping:
            return
        self.stopping = True
        raise Terminated if received == signal.SIGTERM else KeyboardInterrupt

    def rearm(self) -> None:
        """The stop it raised was lost (raised in a callback that cannot raise) and is sent
        again: hear it."""
        self.stopping = False


@contextlib.contextmanager
def _interrupts_handled_by(handler: Any) -> Iterator[None]:
    """SIGINT and SIGTERM go to `handler` for the block, in the main thread (where Python
    runs signal handlers; elsewhere the block runs as it is); the handlers before, after."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {number: signal.signal(number, handler)
                for number in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for number, before in previous.items():
            signal.signal(number, before)


class ProcessExecutor(Executor):
    """A process pool whose workers ignore Ctrl-C and can be stopped at once, and which can
    be renewed when a worker died (which breaks a `ProcessPoolExecutor` for good)."""

    def __init__(self, jobs: int) -> None:
        self.slots = jobs
        self._pool = self._new_pool()

    def _new_pool(self) -> ProcessPoolExecutor:
        from hubero_dsl.sweep.worker import install_worker_signals

        context: Any
        try:
            if "forkserver" in multiprocessing.get_all_start_methods():
                context = multiprocessing.get_context("forkserver")
                # Import the simulator once in the fork server; every worker forked from it
                # then starts at once instead of importing numpy, scipy and shapely again.
                context.set_forkserver_preload(list(WORKER_MODULES))
                _start_fork_server()
            else:
                context = multiprocessing.get_context("spawn")
            return ProcessPoolExecutor(max_workers=self.slots, mp_context=context,
                                       initializer=install_worker_signals,
                                       initargs=(os.getpid(),))
        except OSError as exc:  # the system's to mend (no processes, no sockets): not a bug
            raise InputError(f"cannot start worker processes: {exc.strerror or exc}",
                             hint="`hubero sweep --executor serial` runs without them"
                             ) from None

    def submit(self, fn: Callable[P, T], /, *args: P.args, **kwargs: P.kwargs) -> Future[T]:
        with _signals_after():
            return self._pool.submit(fn, *args, **kwargs)

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
        self._pool.shutdown(wait=wait, cancel_futures=cancel_futures)

    def renew(self) -> None:
        """A fresh pool in place of one a dead worker broke (it refuses all work after)."""
        self._pool.shutdown(wait=False, cancel_futures=True)
        self._pool = self._new_pool()

    def workers(self) -> list[multiprocessing.process.BaseProcess]:
        """The pool's worker processes now."""
        return list((getattr(self._pool, "_processes", None) or {}).values())

    def terminate(self) -> None:
        """Cancel the queued runs and stop the running ones (their logs are not kept)."""
        workers = self.workers()
        self.shutdown(wait=False, cancel_futures=True)
        for process in workers:
            with contextlib.suppress(OSError, ValueError):
                process.terminate()  # SIGTERM: the worker's handler cleans up and exits
        for process in workers:
            with contextlib.suppress(OSError, ValueError, AssertionError):
                process.join(TERMINATE_TIMEOUT)
                if process.is_alive():
                    process.kill()
                    process.join()


class DaskExecutor(Executor):
    """Runs calls on a Dask distributed cluster, through the client's own executor."""

    def __init__(self, address: str, *, connect_timeout: float = DEFAULT_CONNECT_TIMEOUT
                 ) -> None:
        self._client = connect_dask(address, connect_timeout)
        # pure=False: every run is its own task, never merged with an equal-looking one
        self._executor = self._client.get_executor(pure=False)
        threads = self._client.nthreads()
        self.slots = max(1, sum(threads.values())) if threads else 1

    def submit(self, fn: Callable[P, T], /, *args: P.args, **kwargs: P.kwargs) -> Future[T]:
        future: Future[T] = self._executor.submit(fn, *args, **kwargs)
        return future

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
        self._executor.shutdown(wait=wait and not cancel_futures)
        self._client.close()

    def terminate(self) -> None:
        """Cancel every run not finished; a run already on a worker may still finish there."""
        self.shutdown(wait=False, cancel_futures=True)


def connect_dask(address: str, timeout: float) -> Any:
    """A `distributed.Client` for the scheduler at `address`; InputError when it cannot be."""
    try:
        from distributed import Client
    except ImportError:
        raise InputError("the Dask executor needs the 'distributed' package: "
                         "pip install 'hubero[dask]'") from None
    _check_dask_address(address)
    try:
        return Client(address, timeout=timeout, set_as_default=False)
    except (OSError, TimeoutError) as exc:
        raise InputError(f"cannot reach the Dask scheduler at {address} within {timeout:g} s "
                         f"({exc}); is it running, and is the address right "
                         "(tcp://HOST:8786)?") from None
    except (ValueError, TypeError) as exc:
        raise InputError(f"bad Dask scheduler address '{address}': {exc}") from None


def _check_dask_address(address: str) -> None:
    """InputError for an address Dask cannot connect to by its form (no protocol Dask knows,
    no port), before a Client is made: a Client that failed on it would wait out its timeout
    and print a traceback when it is collected."""
    from distributed.comm import parse_address
    from distributed.comm.addressing import parse_host_port
    from distributed.comm.registry import backends

    try:
        scheme, location = parse_address(address, strict=True)
        if scheme not in backends:
            known = ", ".join(sorted(backends))
            raise ValueError(f"unknown protocol '{scheme}' (protocols: {known})")
        if scheme in ("tcp", "tls", "ws", "wss"):
            parse_host_port(location)
    except ValueError as exc:
        raise InputError(f"bad Dask scheduler address '{address}': {exc}") from None


@contextlib.contextmanager
def open_executor(kind: ExecutorKind, *, jobs: int = 1, scheduler: str | None = None,
                  connect_timeout: float = DEFAULT_CONNECT_TIMEOUT) -> Iterator[Executor]:
    """The executor of this kind, shut down on the way out (waiting for its runs)."""
    executor: Executor
    if kind == "serial":
        executor = SerialExecutor()
    elif kind == "process":
        check_jobs(jobs)
        executor = ProcessExecutor(jobs)
    elif kind == "dask":
        if not scheduler:
            raise InputError("the Dask executor needs a scheduler address: "
                             "--scheduler tcp://HOST:8786")
        executor = DaskExecutor(scheduler, connect_timeout=connect_timeout)
    else:
        raise InputError(f"unknown executor '{kind}' (executors: {', '.join(EXECUTOR_KINDS)})")
    try:
        yield executor
    except BaseException:
        terminate(executor)  # interrupted or failed: do not wait for the runs in flight
        raise
    executor.shutdown(wait=True)


def executor_slots(executor: Executor) -> int:
    """How many runs the executor works on at once (1 when it does not say)."""
    slots = getattr(executor, "slots", 1)
    return slots if isinstance(slots, int) and slots > 0 else 1


def terminate(executor: Executor) -> None:
    """Stop the executor now: `terminate()` where it has one, else cancel what is queued."""
    stop = getattr(executor, "terminate", None)
    if callable(stop):
        stop()
    else:
        executor.shutdown(wait=False, cancel_futures=True)
