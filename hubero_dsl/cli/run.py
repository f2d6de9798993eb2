"""`hubero run FILE`: simulate a scenario with a progress bar, then a summary per human.

    hubero run scenarios/living_room.hub --variant ellipse --seed 3 -o run.mcap
    hubero run scenarios/living_room.hub --live --pace 2x   # watch it in Foxglove meanwhile

Exit 0 when every activity ended and every expectation holds, 1 when the scenario failed
(a stopping abort, the time limit, an expectation), 2 for bad input.
"""

from __future__ import annotations

import argparse
import contextlib
import sys
from contextlib import ExitStack
from pathlib import Path
from typing import TYPE_CHECKING, Any

from hubero_dsl.cli.outputs import named_file

if TYPE_CHECKING:
    from collections.abc import Callable, Iterator

    from hubero_dsl.log.live import LiveServer
    from hubero_dsl.model.program import Program
    from hubero_dsl.sim.loop import RunResult
    from hubero_dsl.sim.simulation import Simulation


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    parser: argparse.ArgumentParser = subparsers.add_parser(
        "run", help="run a scenario", description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("file", metavar="FILE", help="scenario file (.hub)")
    add_run_options(parser)
    where = parser.add_mutually_exclusive_group()
    where.add_argument("-o", "--output", metavar="OUT.mcap", type=named_file,
                       help="write the run's MCAP log here (default: runs/SCENARIO.mcap, or "
                            "runs/SCENARIO-VARIANT.mcap)")
    where.add_argument("--out-dir", metavar="DIR", type=Path,
                       help="write one MCAP log per run into DIR (VARIANT.mcap)")
    where.add_argument("--no-log", action="store_true", help="write no log")
    parser.add_argument("--log-rate", metavar="HZ", type=float, default=10.0,
                        help="how often the log records the humans' state (default 10 Hz)")
    parser.add_argument("--members", action="store_true",
                        help="list every member of a crowd or flow in the summary, not one "
                        "row per crowd or flow")
    add_live_options(parser)
    return parser


def add_live_options(parser: argparse.ArgumentParser) -> None:
    live = parser.add_argument_group("watching the run live (Foxglove WebSocket)")
    live.add_argument("--live", action="store_true",
                      help="serve the run to Foxglove while it runs (needs hubero[live])")
    live.add_argument("--host", metavar="H", help="address to listen on (default 127.0.0.1)")
    live.add_argument("--port", metavar="N", type=_port,
                      help="port to listen on (default 8765; 0 for any free port)")
    live.add_argument("--pace", metavar="1x|10x|max", type=_pace,
                      help="how fast the run goes: a factor of real time (1x, 10x, 0.5x) or "
                           "max, no waiting (default 1x)")
    live.add_argument("--live-wait", action="store_true",
                      help="start the run when a client subscribes, and after the end keep "
                           "serving until no client is subscribed (it disconnected)")


def refuse_live(parser: argparse.ArgumentParser, advice: str) -> None:
    """`--live` on a command that does not watch one run: a usage error saying what to do
    instead, rather than argparse's "unrecognized arguments"."""

    class Refused(argparse.Action):
        def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace,
                     values: Any, option: str | None = None) -> None:
            parser.error(f"--live watches one run as it runs: {advice}")

    parser.add_argument("--live", nargs=0, action=Refused, help=argparse.SUPPRESS)


def _port(text: str) -> int:
    if not text.isdigit() or int(text) > 65535:
        raise argparse.ArgumentTypeError(f"invalid port '{text}': give a number from 0 to "
                                         "65535")
    return int(text)


def seed_number(text: str) -> int:
    """A seed as the scenario language takes one: a whole number from 0 on."""
    from hubero_dsl.model.params import SEED_DIGITS

    if not text.isdigit() or len(text) > SEED_DIGITS:
        shown = text if len(text) <= 40 else f"{text[:37]}... ({len(text)} characters)"
        raise argparse.ArgumentTypeError(f"invalid seed '{shown}': give a whole number from 0 "
                                         f"on, of at most {SEED_DIGITS} digits")
    return int(text)


def _pace(text: str) -> str:
    from hubero_dsl.log.live import parse_pace

    try:
        parse_pace(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    return text  # kept as written: None is "not given", while max parses to None


def add_run_options(parser: argparse.ArgumentParser) -> None:
    """Options shared by `run` and `test`."""
    which = parser.add_mutually_exclusive_group()
    which.add_argument("--variant", metavar="NAME", help="run this variant")
    which.add_argument("--all-variants", action="store_true", help="run every variant")
    parser.add_argument("--seed", type=seed_number, metavar="N",
                        help="override the scenario's seed")
    parser.add_argument("--quiet", "-q", action="store_true",
                        help="no progress bar and no summary, only problems")
    parser.add_argument("--controller", metavar="ROBOT=MODULE:CLASS", action="append",
                        default=[], help="drive robot ROBOT with your own controller class "
                        "(importable MODULE; repeat for several robots)")


def variants_to_run(program: Program, args: argparse.Namespace) -> list[str | None]:
    from hubero_dsl.errors import InputError
    from hubero_dsl.model.program import unknown_variants

    if args.all_variants:
        return list(program.variants) or [None]
    if args.variant is not None and args.variant not in program.variants:
        raise InputError(unknown_variants([args.variant], program.variants))
    return [args.variant]


def run(args: argparse.Namespace) -> int:
    from hubero_dsl.errors import InputError
    from hubero_dsl.pipeline import compile_file

    if args.log_rate <= 0:
        raise InputError("--log-rate must be greater than zero")
    _check_live_options(args)
    program = compile_file(args.file)
    variants = variants_to_run(program, args)
    if args.output is not None and len(variants) > 1:
        raise InputError("--all-variants writes several logs: use --out-dir DIR, or leave "
                         "them in runs/")
    controllers = handed_controllers(args)
    unknown = sorted(set(controllers) - {robot.name for robot in program.robots})
    if unknown:
        raise InputError(f"--controller: no robot named '{unknown[0]}' in {args.file}")
    with _removed_if_left_empty(_log_folder(args)):
        return _run_variants(program, variants, args, controllers)


def _log_folder(args: argparse.Namespace) -> Path | None:
    """The folder the command makes for its logs, if any (`-o` names a file in one that is)."""
    if args.no_log or args.output is not None:
        return None
    return Path(args.out_dir) if args.out_dir is not None else DEFAULT_LOG_FOLDER


@contextlib.contextmanager
def _removed_if_left_empty(folder: Path | None) -> Iterator[None]:
    """A folder this command makes and leaves empty (every run failed before its log was
    written) is removed again: a failed command leaves nothing behind."""
    made = folder is not None and not folder.exists()
    try:
        yield
    finally:
        if made and folder is not None:
            with contextlib.suppress(OSError):  # not empty, or gone: left as it is
                folder.rmdir()


def _run_variants(program: Program, variants: list[str | None], args: argparse.Namespace,
                  controllers: dict[str, type]) -> int:
    """Run each variant in turn, its summary after it: 1 when any failed."""
    from hubero_dsl.errors import SimulationError
    from hubero_dsl.sweep.plan import variant_label

    if args.out_dir is not None:
        from hubero_dsl.log.writer import ensure_directory

        ensure_directory(args.out_dir)
    failed = False
    for variant in variants:
        output = _log_path(args, variant)
        try:
            if args.live:
                result = _run_live(program, variant, output, args, controllers)
            else:
                result = run_one(program, variant, args.seed, output, args.log_rate,
                                 quiet=args.quiet, controllers=controllers)
        except SimulationError as exc:
            if len(variants) == 1:
                raise
            # one variant's error (a robot's controller raised): said, and the others run
            from hubero_dsl.cli.diagnostic_formats import report_error

            report_error(SimulationError(f"variant {variant_label(variant)}: {exc.message}",
                                         exc.span, exc.hint))
            failed = True
            continue
        if not args.quiet:
            from hubero_dsl.cli.summary import print_summary

            print_summary(program, result, output, members=args.members)
        elif not result.succeeded:  # quiet means no progress and no tables, not silence
            from hubero_dsl.cli.summary import print_failure

            print_failure(program, result)
        failed = failed or not result.succeeded
    return 1 if failed else 0


DEFAULT_LOG_FOLDER = Path("runs")  # where a run's log goes unless told otherwise


def _log_path(args: argparse.Namespace, variant: str | None) -> Path | None:
    from hubero_dsl.sweep.plan import safe_name  # the file names `hubero sweep` uses

    if args.no_log:
        return None
    if args.output is not None:
        return writable_log_path(Path(args.output))
    if args.out_dir is not None:
        return writable_log_path(Path(args.out_dir) / f"{safe_name(variant)}.mcap")
    stem = Path(args.file).stem + (f"-{safe_name(variant)}" if variant is not None else "")
    return default_log_path(stem)


def default_log_path(stem: str) -> Path:
    """`runs/STEM.mcap` in the folder hubero runs in; never over a file that is not a log."""
    from hubero_dsl.log.writer import ensure_directory

    return writable_log_path(ensure_directory(DEFAULT_LOG_FOLDER) / f"{stem}.mcap")


def writable_log_path(path: Path) -> Path:
    """`path`, unless a file that is not a hubero run log is there (InputError): a run's log
    is written over, a user's file never (nor a folder, a device or a FIFO: `RunLog` refuses
    those)."""
    from hubero_dsl.log.reader import refuse_unless_run_log

    refuse_unless_run_log(path, "give another -o OUT.mcap, or --no-log")
    return path


def handed_controllers(args: argparse.Namespace) -> dict[str, type]:
    """`--controller ROBOT=MODULE:CLASS` options: each robot's class (InputError if bad)."""
    from hubero_dsl.controllers.registry import import_controller
    from hubero_dsl.errors import InputError

    handed: dict[str, type] = {}
    for option in args.controller:
        robot, equals, target = option.partition("=")
        if not equals or not robot:
            raise InputError(f"--controller takes ROBOT=MODULE:CLASS, not '{option}'")
        if robot in handed:
            raise InputError(f"--controller: robot '{robot}' is given a class twice")
        handed[robot] = import_controller(target)
    return handed


def _check_live_options(args: argparse.Namespace) -> None:
    from hubero_dsl.errors import InputError

    if not args.live:
        given = [option for option, value in (("--host", args.host), ("--port", args.port),
                                              ("--pace", args.pace),
                                              ("--live-wait", args.live_wait or None))
                 if value is not None]
        if given:
            raise InputError(f"{given[0]} is an option of --live: add --live to watch the run")
    elif args.all_variants:
        raise InputError("--live serves one run: choose one with --variant NAME instead of "
                         "--all-variants")


def _run_live(program: Program, variant: str | None, output: Path | None,
              args: argparse.Namespace, controllers: dict[str, type]) -> RunResult:
    """Run one variant while serving it; with --live-wait, from the first client to its
    leaving (Ctrl-C after the end stops serving, and the run's status stands)."""
    from hubero_dsl.log.live import DEFAULT_HOST, DEFAULT_PACE, DEFAULT_PORT, LiveServer, parse_pace

    _show_server_warnings()
    pace = parse_pace(args.pace or DEFAULT_PACE)

    def ready(live: LiveServer) -> None:  # every channel advertised: clients may come
        if not args.quiet:
            print(f"hubero: serving the run live on {live.address} (Foxglove: Open "
                  "connection, Foxglove WebSocket)", file=sys.stderr, flush=True)
        if args.live_wait and not args.quiet:
            print("hubero: the run starts when a client subscribes", file=sys.stderr,
                  flush=True)

    with LiveServer(host=args.host or DEFAULT_HOST,
                    port=DEFAULT_PORT if args.port is None else args.port, pace=pace,
                    wait=args.live_wait, on_ready=ready) as live:
        result = run_one(program, variant, args.seed, output, args.log_rate, quiet=args.quiet,
                         controllers=controllers, live=live)
        if args.live_wait:
            if not args.quiet:
                print("hubero: the run has ended; serving until no client is subscribed "
                      "(Ctrl-C to stop)", file=sys.stderr, flush=True)
            with contextlib.suppress(KeyboardInterrupt):  # also SIGTERM: stop serving, and
                live.serve_until_clients_leave()        # report the run as it ended
    return result


def _show_server_warnings() -> None:
    """The SDK's server logs through `logging` (a client dropped, a slow client's messages
    dropped): its warnings are shown as hubero's own lines, on stderr as it is then."""
    import logging

    class Say(logging.Handler):
        def emit(self, record: logging.LogRecord) -> None:
            with contextlib.suppress(OSError, ValueError):
                print(f"hubero: live: {record.getMessage()}", file=sys.stderr, flush=True)

    logger = logging.getLogger("foxglove")
    logger.handlers = [Say(logging.WARNING)]  # replaced, not added: one line per warning
    logger.propagate = False


def run_one(program: Program, variant: str | None, seed: int | None, output: Path | None,
            log_rate: float, *, quiet: bool, controllers: dict[str, type] | None = None,
            live: LiveServer | None = None) -> RunResult:
    """Simulate one variant with a progress bar unless quiet, and a log if asked."""
    from hubero_dsl.simulate import simulate

    with ExitStack() as stack:
        observers: list[Callable[[Simulation], None]] = []
        if not quiet:
            from hubero_dsl.cli.summary import progress_observer

            observers.append(stack.enter_context(progress_observer(program, variant)))
        return simulate(program, variant=variant, seed=seed, log=output, log_rate=log_rate,
                        observers=observers, controllers=controllers, live=live)
