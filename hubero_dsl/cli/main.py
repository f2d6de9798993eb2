"""The `hubero` command: argument parsing, dispatch, and the mapping of outcomes to exit statuses.

Each command is one module in `hubero_dsl.cli` exposing

    add_parser(subparsers) -> argparse.ArgumentParser   # registers the command and its options
    run(args: argparse.Namespace) -> int                 # does it; returns the exit status

and is listed in `COMMANDS`; adding a command is adding its module and its name there. Command
modules import only the standard library and `hubero_dsl.cli.diagnostic_formats` at module level
and load the heavy parts of hubero (the checker, numpy, networkx, the simulator) inside `run`, so
that `hubero --help` and a cold `hubero check` stay fast.

This module is the only place that turns exceptions into messages: no traceback reaches the user
unless HUBERO_DEBUG=1 asks for one.
"""

from __future__ import annotations

import _thread
import argparse
import contextlib
import importlib
import os
import signal
import sys
import threading
import time
import traceback
import warnings
from collections.abc import Sequence
from typing import Any, TextIO

from hubero_dsl import __version__
from hubero_dsl.errors import HuberoError, InputError, Terminated

# Command modules in the order `hubero --help` lists them.
COMMANDS: tuple[str, ...] = ("check", "run", "test", "graph", "sweep", "plot", "diff",
                             "export", "map", "validate", "calibrate", "bench")

EXIT_OK = 0
EXIT_FAILED = 1  # the input has errors, or the run or test failed
EXIT_USAGE = 2  # bad arguments or unreadable input
EXIT_INTERNAL = 3  # a bug in hubero
EXIT_INTERRUPTED = 130  # 128 + SIGINT, as shells report it
EXIT_TERMINATED = 143   # 128 + SIGTERM
EXIT_BROKEN_PIPE = 141  # 128 + SIGPIPE, as `cmd | head` reports for other tools

_EPILOG = """\
exit status:
  0    success
  1    the scenario has errors (or a run or test failed)
  2    usage error or unreadable input
  3    internal error (a bug: please report it)
  130  interrupted

Set HUBERO_DEBUG=1 to see the traceback of an internal error."""


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="hubero",
        description="Declarative human-behaviour scenarios for robot research.",
        epilog=_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"hubero {__version__}")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND", title="commands")
    subparsers.required = True
    for name in COMMANDS:
        module = importlib.import_module(f"hubero_dsl.cli.{name}")
        command_parser = module.add_parser(subparsers)
        command_parser.set_defaults(run=module.run, command_parser=command_parser)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the exit status (the console script passes it to exit)."""
    _tolerate_unencodable_output()
    # Library warnings (numpy's overflow notes, Pillow's size notes) are not the user's to
    # read: hubero checks what they warn about itself (finite values, map sizes).
    warnings.simplefilter("ignore")
    _stop_cleanly_on_sigterm()
    _lose_no_interrupt_in_callbacks()
    try:
        return _exit_status(argv)
    finally:
        _forget_handled_interrupts()


def program() -> int:
    """The `hubero` program (`python -m hubero_dsl` too): `main`, and, once a command has
    been stopped, deaf to Ctrl-C while the process ends. A user pressing Ctrl-C again and
    again had a press after the stopping kill the ending process, which then did not exit
    with `main`'s status. SIGTERM then ends the process at once, as it ends any: a shutdown
    that hangs can still be stopped without SIGKILL."""
    global _AS_PROGRAM
    _AS_PROGRAM = True
    status = main()
    if status in (EXIT_INTERRUPTED, EXIT_TERMINATED):
        _deaf_while_ending()
    return status


_AS_PROGRAM = False  # `main` runs as the process's program, not called by other code


def _deaf_while_ending() -> None:
    """A stopped program: Ctrl-C goes unheard from now on, SIGTERM kills. Only as the program:
    code that calls `main` (tests among it) keeps its handlers."""
    if _AS_PROGRAM and threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        signal.signal(signal.SIGTERM, signal.SIG_DFL)


def _exit_status(argv: Sequence[str] | None) -> int:
    """Run the command; every way it can end is answered by an exit status."""
    try:
        status = _dispatch(argv)
        sys.stdout.flush()
        return status
    except BrokenPipeError as exc:
        if not _stdout_closed():  # a pipe of hubero's own (to a worker): a failure to tell
            return _internal_error(exc)
        _discard_stdout()
        return EXIT_BROKEN_PIPE
    except Terminated:
        _deaf_while_ending()
        _say("terminated")
        return EXIT_TERMINATED
    except KeyboardInterrupt:
        _deaf_while_ending()
        _say("interrupted")
        return EXIT_INTERRUPTED
    except HuberoError as exc:
        from hubero_dsl.cli.diagnostic_formats import report_error

        report_error(exc)
        return exc.exit_status
    except OSError as exc:  # a file the command was given could not be read or written
        from hubero_dsl.cli.diagnostic_formats import report_error

        report_error(InputError(_os_error_message(exc)))
        return EXIT_USAGE
    except Exception as exc:
        return _internal_error(exc)


def _internal_error(exc: Exception) -> int:
    _say(f"internal error: {type(exc).__name__}: {exc} (please report)")
    if os.environ.get("HUBERO_DEBUG") == "1":
        _say(traceback.format_exc().rstrip("\n"))
    else:
        _say("set HUBERO_DEBUG=1 to see the traceback")
    return EXIT_INTERNAL


def _dispatch(argv: Sequence[str] | None) -> int:
    parser = build_parser()
    try:
        args, unknown = parser.parse_known_args(argv)
        if unknown:  # told with the command's usage, not the list of commands
            args.command_parser.error(f"unrecognized arguments: {' '.join(unknown)}")
    except SystemExit as exc:  # --help, --version and usage errors: argparse has printed already
        return exc.code if isinstance(exc.code, int) else EXIT_USAGE if exc.code else EXIT_OK
    status: int = args.run(args)
    return status


def _forget_handled_interrupts() -> None:
    """Every interrupt has been answered by the time `main` returns. But CPython remembers a
    Ctrl-C that passed through any `exec` of a string (numpy's imports run one), handled
    later or not, and `python -m hubero_dsl` then ends by killing itself with SIGINT in place
    of exiting with the status `main` returned. Each `exec` of a string starts by forgetting
    it: an empty one does just that."""
    exec("")  # a constant: nothing is run


def _lose_no_interrupt_in_callbacks() -> None:
    """Python runs a signal's handler wherever the main thread is, also inside a callback it
    cannot raise from (a weak reference's, as an import finishes): the KeyboardInterrupt
    was then printed as "Exception ignored" and the Ctrl-C lost. The signal is sent again
    instead, a moment later, to be raised where the main thread has gone on (raised in the
    hook itself, it would be lost there in turn)."""
    if getattr(sys.unraisablehook, "resends_interrupts", False):
        return  # `main` called again in the same process
    previous = sys.unraisablehook

    def resend_interrupts(unraisable: Any) -> None:
        if isinstance(unraisable.exc_value, KeyboardInterrupt):
            terminated = isinstance(unraisable.exc_value, Terminated)
            signum = signal.SIGTERM if terminated else signal.SIGINT
            with contextlib.suppress(AttributeError):  # a handler that hears one stop only
                signal.getsignal(signum).rearm()  # type: ignore[union-attr]
            _thread.start_new_thread(_send_again, (signum,))
        else:
            previous(unraisable)

    resend_interrupts.resends_interrupts = True  # type: ignore[attr-defined]
    sys.unraisablehook = resend_interrupts


def _send_again(signum: int) -> None:
    time.sleep(0.01)  # the hook that started this thread has returned
    os.kill(os.getpid(), signum)  # to the process: its main thread takes it


def _on_sigterm(signum: int, frame: object) -> None:
    raise Terminated


def _stop_cleanly_on_sigterm() -> None:
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGTERM, _on_sigterm)


def _os_error_message(exc: OSError) -> str:
    """An operating system's refusal (no space left, a read-only folder, a name too long) in
    the words hubero uses for a file it cannot read or write."""
    where = f"{exc.filename}: " if exc.filename else ""
    return f"{where}{exc.strerror or exc}"


def _say(message: str, stream: TextIO | None = None) -> None:
    """Best effort: a message about a failure must not fail in turn."""
    with contextlib.suppress(OSError, ValueError):
        print(f"hubero: {message}", file=stream or sys.stderr)


def _tolerate_unencodable_output() -> None:
    # A source line in a script the terminal's encoding cannot show must not crash the report.
    for stream in (sys.stdout, sys.stderr):
        reconfigure = getattr(stream, "reconfigure", None)
        if reconfigure is not None:
            with contextlib.suppress(ValueError, OSError):
                reconfigure(errors="backslashreplace")


def _stdout_closed() -> bool:
    """Whether standard output is a pipe whose reader has gone (`hubero graph x | head`):
    the system reports an error on its end. Where that cannot be asked, assume so."""
    try:
        import select

        poller = select.poll()
        poller.register(sys.stdout.fileno(), select.POLLOUT)
        return any(events & (select.POLLERR | select.POLLHUP) for _, events in poller.poll(0))
    except (OSError, ValueError, AttributeError):
        return True


def _discard_stdout() -> None:
    # The reader went away (`hubero graph x | head`): point stdout at /dev/null so the
    # interpreter's final flush does not complain about the pipe once more.
    with contextlib.suppress(OSError, ValueError, AttributeError):
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
