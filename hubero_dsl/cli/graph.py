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
from hubero_dsl.cli.outputs import named_file

FORMATS = ("mermaid", "dot", "png")
_FORMAT_OF_SUFFIX = {".mmd": "mermaid", ".mermaid": "mermaid", ".dot": "dot", ".gv": "dot",
                     ".png": "png"}
# pictures hubero does not draw: Mermaid text under such a name was a file no viewer opens
_OTHER_PICTURES = frozenset({".svg", ".pdf", ".jpg", ".jpeg", ".gif", ".bmp", ".tif", ".tiff",
                             ".webp", ".eps", ".ps"})

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
    parser.add_argument("-o", "--output", metavar="OUT", default=None, type=named_file,
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
    from hubero_dsl.graph import render

    graph = render.drawn_graph(program.activities)

    if args.output is not None:
        from hubero_dsl.world.mapfile import map_files

        _check_out(Path(args.output), output_format,
                   (Path(args.file), *map_files(program.map_path)))
    from hubero_dsl.files import write_replacing

    if output_format == "png":
        from hubero_dsl.graph import picture

        write_replacing(Path(args.output), lambda temp: picture.to_png(graph, temp))
        return 0
    text = render.to_dot(graph) if output_format == "dot" else render.to_mermaid(graph)
    text = text if text.endswith("\n") else text + "\n"
    if args.output is None:
        sys.stdout.write(text)
    else:
        write_replacing(Path(args.output), lambda temp: temp.write_text(text, encoding="utf-8"))
    return 0


def _check_out(out: Path, output_format: str, reads: tuple[Path, ...]) -> None:
    """OUT must be writable and not one of the inputs; a PNG's name ends in .png (the picture
    is written to exactly the name given); and an existing file is written over only when it
    is a graph of the same kind: a PNG, or text named as a graph (.mmd, .dot, ...)."""
    from hubero_dsl.cli.outputs import check_picture
    from hubero_dsl.errors import InputError
    from hubero_dsl.files import check_output

    if output_format == "png":
        if out.suffix.lower() != ".png":
            raise InputError(f"{out}: --format png writes a PNG: give -o a name ending in .png")
        check_picture(out, reads)
        return
    if out.suffix.lower() in (".png", *_OTHER_PICTURES):
        raise InputError(f"{out}: --format {output_format} writes text, not a picture: give "
                         f"-o a name such as graph.{'dot' if output_format == 'dot' else 'mmd'}"
                         ", or --format png")
    check_output(out, reads)
    if out.is_file() and out.suffix.lower() not in _FORMAT_OF_SUFFIX:
        raise InputError(f"{out} exists and is not a graph (.mmd, .mermaid, .dot, .gv): not "
                         "writing over it (give another -o)")


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


def _format_from_suffix(output: Path | None) -> str:
    from hubero_dsl.errors import InputError

    if output is None:
        return "mermaid"
    suffix = Path(output).suffix.lower()
    if suffix in _OTHER_PICTURES:
        raise InputError(f"{output}: hubero graph draws PNG only; for {suffix[1:].upper()}, "
                         f"pipe DOT to Graphviz: hubero graph FILE --format dot | dot "
                         f"-T{suffix[1:]} > {Path(output).name}")
    return _FORMAT_OF_SUFFIX.get(suffix, "mermaid")
