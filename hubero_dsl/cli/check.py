"""`hubero check FILE...`: parse and check scenario files, report every diagnostic of every file.

The report goes to standard output: text (rustc style, coloured on a terminal), one JSON
document, or GitHub Actions annotations. Every file given is checked before the exit status is
decided: 0 clean (warnings allowed), 1 errors (or warnings under --strict), 2 unreadable input.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any

from hubero_dsl.cli.diagnostic_formats import (
    FileReport,
    Printer,
    exit_status,
    github_report,
    json_report,
    text_report,
)

if TYPE_CHECKING:
    from hubero_dsl.pipeline import CheckResult

FORMATS = ("text", "json", "github")

_DESCRIPTION = """\
Parse and check scenario files and report every error and warning of every file.
The report goes to standard output."""

_EPILOG = """\
formats:
  text    rustc-style diagnostics with the source line underlined (colour on a terminal;
          NO_COLOR turns it off, FORCE_COLOR on)
  json    one JSON document: {"version": 1, "files": [...], "summary": {...}}
  github  GitHub Actions annotations (::error file=...,line=...::message)

exit status:
  0  every file is clean (warnings allowed without --strict)
  1  some file has errors (or warnings, with --strict)
  2  usage error, or some file could not be read

examples:
  hubero check scenarios/*.hub
  hubero check --strict --format github scenarios/living_room.hub"""


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    parser: argparse.ArgumentParser = subparsers.add_parser(
        "check", help="parse and check scenario files", description=_DESCRIPTION,
        epilog=_EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("files", nargs="+", metavar="FILE", help="scenario files (.hub)")
    parser.add_argument("--format", choices=FORMATS, default="text",
                        help="how to report diagnostics (default: text)")
    parser.add_argument("--strict", action="store_true",
                        help="warnings fail the check too (exit status 1)")
    return parser


def run(args: argparse.Namespace) -> int:
    from hubero_dsl.files import distinct_files

    reports = check_paths(distinct_files(args.files))
    printer = Printer.to(sys.stdout)
    if args.format == "json":
        printer.text(json_report(reports, strict=args.strict))
    elif args.format == "github":
        printer.text("\n".join(github_report(reports, strict=args.strict)))
    else:
        printer.lines(text_report(reports, strict=args.strict))
    return exit_status(reports, strict=args.strict)


def check_paths(paths: Sequence[str]) -> list[FileReport]:
    """Check each file; an unreadable one becomes a report of why, and the others go on."""
    check_file = _checker()
    return [check_one(path, check_file) for path in paths]


def check_one(path: str, check_file: Callable[[str], CheckResult]) -> FileReport:
    from hubero_dsl.errors import CompileError, InputError

    try:
        result = check_file(path)
    except InputError as exc:
        return FileReport(path, None, input_error=str(exc))
    except CompileError as exc:  # the checker reports through its result, but be forgiving
        return FileReport(path, None, tuple(exc.diagnostics))
    text = result.source.text if result.source is not None else None
    return FileReport(path, text, tuple(result.diagnostics))


def _checker() -> Callable[[str], CheckResult]:
    # Imported here, not at module level: it pulls in the parser and the checker.
    from hubero_dsl.pipeline import check_file

    return check_file

