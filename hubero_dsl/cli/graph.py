"""`hubero graph FILE`: the activity graph of a scenario as Mermaid, DOT or a PNG picture.

The graph goes to standard output (or to `-o OUT`); diagnostics go to standard error, so a
pipeline never mistakes them for the graph. A file with errors prints them and exits 1.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from hubero_dsl.cli.diagnostic_formats import FileReport, Printer, text_report

FORMATS = ("mermaid", "dot", "png")
_FORMAT_OF_SUFFIX = {".mmd": "mermaid", ".mermaid": "mermaid", ".dot": "dot", ".gv": "dot",
                     ".png": "png"}

_EPILOG = """\
The format defaults to the one OUT's suffix names (.mmd/.mermaid, .dot/.gv, .png), else mermaid.
png needs -o.

exit status:
  0  the graph was written
  1  the scenario has errors (they are printed to standard error)
  2  usage error, unreadable input, or OUT cannot be written

examples:
  hubero graph scenarios/living_room.hub
  hubero graph scenarios/living_room.hub --format dot | dot -Tsvg > graph.svg
  hubero graph scenarios/living_room.hub -o graph.png"""


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    parser: argparse.ArgumentParser = subparsers.add_parser(
        "graph", help="print the activity graph (Mermaid, DOT or PNG)",
        description="Print the activity graph of a scenario: its steps and what each waits for.",
        epilog=_EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("file", metavar="FILE", help="scenario file (.hub)")
    parser.add_argument("--format", choices=FORMATS, default=None,
                        help="output format (default: from OUT's suffix, else mermaid)")
    parser.add_argument("-o", "--output", metavar="OUT", default=None,
                        help="write to OUT instead of standard output")
    return parser


def run(args: argparse.Namespace) -> int:
    from hubero_dsl.errors import InputError

    output_format = args.format or _format_from_suffix(args.output)
    if output_format == "png" and args.output is None:
        raise InputError("--format png needs an output file: add -o OUT.png")
    program = _checked_program(args.file)
    if program is None:
        return 1
    graph = program.graph
    from hubero_dsl.graph import render

    if args.output is not None:
        from hubero_dsl.files import check_output
        from hubero_dsl.world.mapfile import map_files

        check_output(Path(args.output), (Path(args.file), *map_files(program.map_path)))
    if output_format == "png":
        try:
            from hubero_dsl.graph import picture

            picture.to_png(graph, Path(args.output))
        except OSError as exc:
            raise InputError(f"{args.output}: cannot be written ({exc.strerror or exc})") from None
        return 0
    text = render.to_dot(graph) if output_format == "dot" else render.to_mermaid(graph)
    if args.output is None:
        sys.stdout.write(text if text.endswith("\n") else text + "\n")
    else:
        _write_text(Path(args.output), text)
    return 0


def _checked_program(path: str) -> Any:
    """The program (its activity graph, its map), or None after printing the errors that
    prevent one."""
    from hubero_dsl.pipeline import check_file

    result = check_file(path)
    if result.diagnostics:
        text = result.source.text if result.source is not None else None
        report = FileReport(path, text, tuple(result.diagnostics))
        Printer.to(sys.stderr).lines(text_report([report]))
    if result.errors:
        return None
    if result.program is None:  # a checker bug, reported by main as an internal error
        raise RuntimeError(f"{path}: the checker found no errors but built no program")
    return result.program


def _format_from_suffix(output: str | None) -> str:
    if output is None:
        return "mermaid"
    return _FORMAT_OF_SUFFIX.get(Path(output).suffix.lower(), "mermaid")


def _write_text(path: Path, text: str) -> None:
    from hubero_dsl.errors import InputError

    try:
        path.write_text(text if text.endswith("\n") else text + "\n", encoding="utf-8")
    except OSError as exc:
        raise InputError(f"{path}: cannot be written ({exc.strerror or exc})") from None
