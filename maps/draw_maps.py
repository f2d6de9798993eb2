"""Draw the project's maps from their shape descriptions: `python maps/draw_maps.py [NAME ...]`.

Each `maps/NAME.shapes.yaml` (the format is `hubero_dsl.world.drawing`'s, the one `hubero map
draw` reads for maps of your own: docs/maps.md) is drawn next to itself as `NAME.yaml` +
`NAME.pgm`. Drawing is deterministic: the same description gives the same bytes. `--preview DIR`
also writes a PNG of each map with its marks labelled (`hubero map show`'s picture).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from hubero_dsl.analysis.mapview import show_map
from hubero_dsl.errors import HuberoError
from hubero_dsl.world.drawing import SHAPES_SUFFIX, draw_map, load_drawing

MAPS_DIR = Path(__file__).resolve().parent


def draw(shapes_path: Path, out_dir: Path | None = None) -> Path:
    """Draw one of the project's descriptions; returns the written YAML path."""
    name = shapes_path.name.removesuffix(SHAPES_SUFFIX)
    comment = (f"{name}: drawn by maps/draw_maps.py from {shapes_path.name}; "
               "edit that file and re-run the script instead of editing this map.")
    return draw_map(shapes_path, (out_dir or shapes_path.parent) / f"{name}.yaml",
                    comment=comment)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    parser.add_argument("names", nargs="*", help="maps to draw (default: every *.shapes.yaml)")
    parser.add_argument("--out", type=Path, default=None, help="write here instead of maps/")
    parser.add_argument("--preview", type=Path, default=None, metavar="DIR",
                        help="also write a labelled PNG of each map into DIR")
    args = parser.parse_args(argv)
    # the benchmark suite's maps live in their own folder, named benchmark/NAME
    names = args.names or sorted(
        str(p.relative_to(MAPS_DIR)).removesuffix(SHAPES_SUFFIX)
        for pattern in (f"*{SHAPES_SUFFIX}", f"benchmark/*{SHAPES_SUFFIX}")
        for p in MAPS_DIR.glob(pattern))
    try:
        for name in names:
            shapes_path = MAPS_DIR / f"{name}{SHAPES_SUFFIX}"
            written = draw(shapes_path, args.out)
            print(f"wrote {written} and {written.with_suffix('.pgm').name}")
            if args.preview is not None:
                args.preview.mkdir(parents=True, exist_ok=True)
                png_path = args.preview / f"{name.replace('/', '_')}.png"
                show_map(written, png_path, marks=load_drawing(shapes_path).marks)
                print(f"wrote {png_path}")
    except HuberoError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
