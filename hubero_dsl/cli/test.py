"""`hubero test FILE...`: run scenarios and judge every `expect`, for CI.

Every variant of every file runs (or the one named with --variant); the exit status is 0 when
every run completed and every expectation held, 1 otherwise, 2 for bad input. A file that does
not compile, or a run that ends in an error (a robot's controller that raised), is an ERROR line
counted as failed, and the other files and runs go on. `--controller ROBOT=...` hands the class
to that robot in every file that has one.
"""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING, Any

from hubero_dsl.cli.run import (
    add_run_options,
    handed_controllers,
    refuse_live,
    run_one,
    variants_to_run,
)

if TYPE_CHECKING:
    from hubero_dsl.model.program import Program


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    parser: argparse.ArgumentParser = subparsers.add_parser(
        "test", help="run scenarios and judge their expectations", description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("files", nargs="+", metavar="FILE", help="scenario files (.hub)")
    add_run_options(parser)
    refuse_live(parser, "hubero test runs without waiting or serving; watch a run with "
                "hubero run FILE --live")
    parser.set_defaults(all_variants=True)
    return parser


def run(args: argparse.Namespace) -> int:
    from rich.markup import escape

    from hubero_dsl.cli.console import make_console
    from hubero_dsl.cli.diagnostic_formats import report_error
    from hubero_dsl.errors import HuberoError, InputError, SimulationError
    from hubero_dsl.files import distinct_files
    from hubero_dsl.pipeline import compile_file

    console = make_console()
    failures = runs = 0
    bad_input = False
    controllers = handed_controllers(args)
    if args.variant is not None:
        args.all_variants = False
    programs: list[tuple[str, Program]] = []
    for file in distinct_files(args.files):
        try:
            programs.append((file, compile_file(file)))
        except HuberoError as exc:  # this file's mistakes are said; the other files still run
            report_error(exc)
            unreadable = isinstance(exc, InputError)
            console.print(f"[red]ERROR[/] {escape(file)}: "
                          f"{'cannot be read' if unreadable else 'does not compile'}")
            runs, failures = runs + 1, failures + 1
            bad_input = bad_input or unreadable
    # the options are checked against every file before anything runs
    planned = [(file, program, _variants(file, program, args)) for file, program in programs]
    robots = {robot.name for _, program, _ in planned for robot in program.robots}
    unused = sorted(set(controllers) - robots)
    if unused:
        raise InputError(f"--controller: no robot named '{unused[0]}' in any of the files")
    for file, program, variants in planned:
        mine = {name: cls for name, cls in controllers.items()
                if name in {robot.name for robot in program.robots}}
        for variant in variants:
            runs += 1
            name = escape(file + (f" [{variant}]" if variant else ""))
            try:
                result = run_one(program, variant, args.seed, None, 10.0, quiet=True,
                                 controllers=mine)
            except SimulationError as exc:  # a controller raised: this run's error
                failures += 1
                console.print(f"[red]ERROR[/] {name}: {escape(exc.message)}")
                continue
            ok = result.succeeded
            failures += not ok
            if not ok or not args.quiet:
                verdict = "[green]PASS[/]" if ok else "[red]FAIL[/]"
                console.print(f"{verdict} {name}: {result.state.value} at "
                              f"t = {result.time:.2f} s" + (f" ({escape(result.reason)})"
                                                            if result.reason else ""))
            for expectation in result.expectations:
                if not expectation.held:
                    console.print(f"    expectation fails: {escape(expectation.text)}")
    console.print(f"{runs - failures} passed, {failures} failed")
    return 2 if bad_input else 1 if failures else 0


def _variants(file: str, program: Program, args: argparse.Namespace) -> list[str | None]:
    """The variants of `file` to run; InputError naming the file for an unknown --variant."""
    from hubero_dsl.errors import InputError

    try:
        return variants_to_run(program, args)
    except InputError as exc:
        raise InputError(f"{file}: {exc.message}") from None
