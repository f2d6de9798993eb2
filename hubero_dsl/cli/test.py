"""`hubero test FILE...`: run scenarios and judge every `expect`, for CI.

Every variant of every file runs (or the one named with --variant); the exit status is 0 when
every run completed and every expectation held, 1 otherwise, 2 for bad input.
"""

from __future__ import annotations

import argparse
from typing import Any

from hubero_dsl.cli.run import (
    add_run_options,
    handed_controllers,
    refuse_live,
    run_one,
    variants_to_run,
)


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
    from hubero_dsl.pipeline import compile_file

    console = make_console()
    failures = 0
    runs = 0
    controllers = handed_controllers(args)
    for file in args.files:
        program = compile_file(file)
        if args.variant is not None:
            args.all_variants = False
        for variant in variants_to_run(program, args):
            result = run_one(program, variant, args.seed, None, 10.0, quiet=True,
                             controllers=controllers)
            runs += 1
            name = escape(file + (f" [{variant}]" if variant else ""))
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
    return 1 if failures else 0
