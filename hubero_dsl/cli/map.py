"""`hubero map draw SHAPES.yaml -o NAME.yaml` and `hubero map show NAME.yaml`: maps of your own.

    hubero map draw my_office.shapes.yaml -o my_office.yaml
    hubero map show my_office.yaml -o my_office.png --scenario my_office.hub

`draw` turns a shape description (a frame, an interior, rectangles, circles and polygons in
metres: docs/maps.md) into a ROS map_server map (YAML and PGM). `show` draws a map as a PNG with
metric axes, free, occupied and unknown space, and with --scenario the places, areas and starts
of a scenario. Exit 0 when written, 1 for a scenario with errors, 2 for input that cannot be
read or an output that cannot be written.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from hubero_dsl.cli.outputs import PNG, YAML


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    parser: argparse.ArgumentParser = subparsers.add_parser(
        "map", help="draw a map from shapes, or show a map as a picture", description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter)
    actions = parser.add_subparsers(dest="action", metavar="ACTION", required=True)
    draw = actions.add_parser("draw", help="draw a map from a shape description")
    draw.add_argument("shapes", metavar="SHAPES.yaml", type=Path, help="a shape description")
    draw.add_argument("-o", "--output", metavar="NAME.yaml", type=YAML, required=True,
                      help="the map to write (its image goes beside it as NAME.pgm)")
    show = actions.add_parser("show", help="draw a map as a PNG")
    show.add_argument("map", metavar="NAME.yaml", type=Path, help="a ROS map_server map")
    show.add_argument("-o", "--output", metavar="OUT.png", type=PNG,
                      help="the picture to write (default: NAME.png beside the map)")
    show.add_argument("--scenario", metavar="FILE.hub", type=Path,
                      help="also draw this scenario's places, areas and starts")
    return parser


def run(args: argparse.Namespace) -> int:
    from hubero_dsl.files import check_output

    if args.action == "draw":
        from hubero_dsl.world.drawing import draw_map

        image = args.output.with_suffix(".pgm")
        for out in (args.output, image):
            check_output(out, (args.shapes,))
        _refuse_to_overwrite_other_files(args.output, image)
        written = draw_map(args.shapes, args.output,
                           comment=f"drawn by hubero map draw from {args.shapes.name}")
        print(f"wrote {written} and {image.name}")
        return 0
    from hubero_dsl.analysis.mapview import show_map
    from hubero_dsl.cli.outputs import check_picture
    from hubero_dsl.world.mapfile import map_files

    output = args.output or args.map.with_suffix(".png")
    check_picture(output, (*map_files(args.map), *([args.scenario] if args.scenario else [])))
    program = None
    if args.scenario is not None:
        from hubero_dsl.pipeline import compile_file

        program = compile_file(args.scenario)
        if not _same_file(program.map_path, args.map):
            from hubero_dsl.cli.diagnostic_formats import printable

            print(printable(f"hubero: warning: {args.scenario} is written for the map "
                            f"{_shown(program.map_path)}, not {args.map}: its places are "
                            "drawn where its coordinates fall on this one"), file=sys.stderr)
    show_map(args.map, output, program=program)
    print(f"wrote {output}")
    return 0


def _shown(path: Path) -> str:
    """`path` without its `..` steps, from the working folder when it lies below it."""
    resolved = path.resolve()
    return str(resolved.relative_to(Path.cwd()) if resolved.is_relative_to(Path.cwd())
               else resolved)


def _same_file(a: Path, b: Path) -> bool:
    try:
        return a.samefile(b)
    except OSError:  # one of them is gone: they are not one file
        return False


def _refuse_to_overwrite_other_files(yaml_path: Path, image: Path) -> None:
    """A map is drawn again over a map, never over a user's other files."""
    from hubero_dsl.errors import InputError
    from hubero_dsl.files import refuse_other_kind
    from hubero_dsl.world.mapfile import PGM_MAGIC, is_map_file

    advice = "remove it, or give another -o NAME.yaml"
    if yaml_path.is_file() and not is_map_file(yaml_path):
        raise InputError(f"{yaml_path} exists and is not a map file: not writing over it "
                         f"({advice})")
    refuse_other_kind(image, PGM_MAGIC, "a map's image (a binary PGM)", advice)
