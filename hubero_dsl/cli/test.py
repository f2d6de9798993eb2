"""`hubero test FILE...`: run scenarios and judge every `expect`, for CI.

Every variant of every file runs (or the one named with --variant); the exit status is 0 when
every run completed and every expectation held, 1 otherwise, 2 for bad input. A file that does
not compile, or a run that ends in an error (a controller or planner plugin that raised), is
an ERROR line counted as failed, and the other files and runs go on. `--controller
ROBOT=...` hands the class to that robot in every file that has one; a file whose parameters
for the robot the class does not take is an ERROR line too. `--junit-xml
REPORT.xml` also writes the verdicts as a JUnit XML report (one test case a run), which CI
systems show beside their own tests.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

from hubero_dsl.cli.junit import UNCOMPILED, UNFITTING, UNREADABLE, TestOutcome
from hubero_dsl.cli.outputs import named_file
from hubero_dsl.cli.run import (
    add_run_options,
    handed_controllers,
    refuse_live,
    run_one,
    variants_to_run,
)

if TYPE_CHECKING:
    from rich.console import Console

    from hubero_dsl.model.program import Program


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    parser: argparse.ArgumentParser = subparsers.add_parser(
        "test", help="run scenarios and judge their expectations", description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("files", nargs="+", metavar="FILE", help="scenario files (.hub)")
    add_run_options(parser)
    parser.add_argument("--junit-xml", metavar="REPORT.xml", type=named_file,
                        help="also write the verdicts as a JUnit XML report, for CI")
    refuse_live(parser, "hubero test runs without waiting or serving; watch a run with "
                "hubero run FILE --live")
    parser.set_defaults(all_variants=True)
    return parser


def run(args: argparse.Namespace) -> int:
    from hubero_dsl.cli.console import make_console
    from hubero_dsl.cli.junit import check_report_path, write_report
    from hubero_dsl.errors import InputError
    from hubero_dsl.files import distinct_files

    if args.junit_xml is not None:
        check_report_path(args.junit_xml, [Path(f) for f in args.files])
    console = make_console()
    controllers = handed_controllers(args)
    if args.variant is not None:
        args.all_variants = False
    files = distinct_files(args.files)
    programs, outcomes = _compiled(files, console)
    # the options are checked against every file before anything runs
    planned = [(file, program, _variants(file, program, args)) for file, program in programs]
    robots = {robot.name for _, program, _ in planned for robot in program.robots}
    unused = sorted(set(controllers) - robots)
    if unused:
        raise InputError(f"--controller: no robot named '{unused[0]}' in any of the files")
    fitting = []
    for file, program, variants in planned:
        mine = {name: cls for name, cls in controllers.items()
                if name in {robot.name for robot in program.robots}}
        refused = _refused_by_controllers(file, program, mine, console)
        if refused is None:
            fitting.append((file, program, variants, mine))
        else:
            outcomes.append(refused)
    for file, program, variants, mine in fitting:
        for variant in variants:
            outcomes.append(_run(file, program, variant, args, mine, console))
    failures = sum(o.verdict != "pass" for o in outcomes)
    console.print(f"{len(outcomes) - failures} passed, {failures} failed")
    if args.junit_xml is not None:  # in the files' order, as they were given
        order = {file: index for index, file in enumerate(files)}
        write_report(args.junit_xml, sorted(outcomes, key=lambda o: order[o.file]))
    unreadable = any(o.case == UNREADABLE for o in outcomes)
    return 2 if unreadable else 1 if failures else 0


def _compiled(files: list[str], console: Console) -> tuple[list[tuple[str, Program]],
                                                          list[TestOutcome]]:
    """The files that compile, and an ERROR outcome for each that does not: its mistakes are
    said, and the other files still run."""
    from rich.markup import escape

    from hubero_dsl.cli.diagnostic_formats import report_error
    from hubero_dsl.errors import CompileError, HuberoError, InputError
    from hubero_dsl.pipeline import compile_file

    programs: list[tuple[str, Program]] = []
    outcomes: list[TestOutcome] = []
    for file in files:
        try:
            programs.append((file, compile_file(file)))
        except HuberoError as exc:
            report_error(exc)
            unreadable = isinstance(exc, InputError)
            said = "cannot be read" if unreadable else "does not compile"
            console.print(f"[red]ERROR[/] {escape(file)}: {said}")
            found = exc.diagnostics if isinstance(exc, CompileError) else ()
            outcomes.append(TestOutcome(
                file, UNREADABLE if unreadable else UNCOMPILED, "error", f"{said}: {exc}",
                tuple(f"{d.span or file}: {d.severity}[{d.code}]: {d.message}"
                      for d in found if d.is_error)))
    return programs, outcomes


def _refused_by_controllers(file: str, program: Program, controllers: dict[str, type],
                            console: Console) -> TestOutcome | None:
    """An ERROR outcome for a file whose parameters for a robot the class handed to it does
    not take (said, with where), as for a file that does not compile; None when they fit."""
    from rich.markup import escape

    from hubero_dsl.cli.diagnostic_formats import report_error
    from hubero_dsl.errors import InputError
    from hubero_dsl.sim.simulation import check_handed_controllers

    try:
        check_handed_controllers(program, controllers)
    except InputError as exc:
        report_error(exc)  # the refusal, with where, as a file that does not compile's
        said = "does not fit the controller"
        console.print(f"[red]ERROR[/] {escape(file)}: {said}")
        return TestOutcome(file, UNFITTING, "error", f"{said}: {exc}", (str(exc),))
    return None


def _run(file: str, program: Program, variant: str | None, args: argparse.Namespace,
         controllers: dict[str, type], console: Console) -> TestOutcome:
    """Run one variant, say its verdict, and return it."""
    from rich.markup import escape

    from hubero_dsl.errors import SimulationError

    name = escape(file + (f" [{variant}]" if variant else ""))
    case = variant or "as written"
    started = time.monotonic()  # the report's time: wall clock, as test reports keep it
    try:
        result = run_one(program, variant, args.seed, None, 10.0, quiet=True,
                         controllers=controllers)
    except SimulationError as exc:  # a plugin raised: this run's error
        console.print(f"[red]ERROR[/] {name}: {escape(exc.message)}")
        return TestOutcome(file, case, "error", exc.message, (),
                           time.monotonic() - started)
    seconds = time.monotonic() - started
    ended = f"{result.state.value} at t = {result.time:.2f} s" + (
        f" ({result.reason})" if result.reason else "")
    failing = tuple(f"expectation fails: {e.text}" for e in result.expectations if not e.held)
    if not result.succeeded or not args.quiet:
        verdict = "[green]PASS[/]" if result.succeeded else "[red]FAIL[/]"
        console.print(f"{verdict} {name}: {escape(ended)}")
    for line in failing:
        console.print(f"    {escape(line)}")
    return TestOutcome(file, case, "pass" if result.succeeded else "fail", ended, failing,
                       seconds)


def _variants(file: str, program: Program, args: argparse.Namespace) -> list[str | None]:
    """The variants of `file` to run; InputError naming the file for an unknown --variant."""
    from hubero_dsl.errors import InputError

    try:
        return variants_to_run(program, args)
    except InputError as exc:
        raise InputError(f"{file}: {exc.message}") from None
