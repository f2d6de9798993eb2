"""Draw the project's maps from their shape descriptions: `python maps/draw_maps.py [NAME ...]`.

Each `maps/NAME.shapes.yaml` gives a map's frame (`origin`, `size` in metres, `resolution`), an
optional `interior` (cells outside it are unknown space, drawn grey) and a list of named
`obstacles`, each one of

    {name: table, rect: [[x0, y0], [x1, y1]]}          two opposite corners
    {name: plant, circle: [x, y], radius: r}
    {name: kerb, polygon: [[x, y], [x, y], [x, y], ...]}

in metres in the map frame. A cell is occupied when its centre lies in (or on the edge of) an
obstacle. `marks` (named points) are not drawn; they document the scenario points the layout was
designed around. The result is written next to the description as `NAME.yaml` + `NAME.pgm` by
`hubero_dsl.world.mapfile.save_map`. Drawing is deterministic: the same description gives the
same bytes.
"""

from __future__ import annotations

import argparse
import math
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import shapely
import yaml
from shapely.geometry import Point, Polygon, box
from shapely.geometry.base import BaseGeometry

from hubero_dsl.errors import HuberoError, MapError
from hubero_dsl.world.grid import OccupancyGrid
from hubero_dsl.world.mapfile import save_map

MAPS_DIR = Path(__file__).resolve().parent
SHAPES_SUFFIX = ".shapes.yaml"


@dataclass(frozen=True)
class Obstacle:
    name: str
    geometry: BaseGeometry


@dataclass(frozen=True)
class MapDrawing:
    """A parsed shape description: the frame and what to draw in it."""

    name: str
    source: Path
    origin: tuple[float, float]
    cells: tuple[int, int]  # (rows, cols)
    resolution: float
    interior: BaseGeometry | None
    obstacles: tuple[Obstacle, ...]
    marks: dict[str, tuple[float, float]]
    description: str


def _fail(source: Path, where: str, message: str) -> MapError:
    return MapError(f"{source}: {where}: {message}")


def _point(value: Any, source: Path, where: str) -> tuple[float, float]:
    if (not isinstance(value, list) or len(value) != 2
            or not all(isinstance(v, int | float) and not isinstance(v, bool) for v in value)):
        raise _fail(source, where, f"expected a point [x, y], got {value!r}")
    return float(value[0]), float(value[1])


def _geometry(entry: dict[str, Any], source: Path, where: str) -> BaseGeometry:
    """One shape: `rect`, `circle` (+ `radius`) or `polygon`."""
    kinds = [kind for kind in ("rect", "circle", "polygon") if kind in entry]
    if len(kinds) != 1:
        raise _fail(source, where, "give exactly one of rect, circle, polygon")
    kind = kinds[0]
    if kind == "rect":
        corners = entry["rect"]
        if not isinstance(corners, list) or len(corners) != 2:
            raise _fail(source, where, f"rect needs two corners, got {corners!r}")
        (x0, y0), (x1, y1) = (_point(c, source, where) for c in corners)
        geometry: BaseGeometry = box(min(x0, x1), min(y0, y1), max(x0, x1), max(y0, y1))
    elif kind == "circle":
        radius = entry.get("radius")
        if not isinstance(radius, int | float) or isinstance(radius, bool) or radius <= 0:
            raise _fail(source, where, f"circle needs a radius > 0, got {radius!r}")
        # 64 segments per quarter: the polygon is within a micrometre of the circle.
        geometry = Point(_point(entry["circle"], source, where)).buffer(float(radius), 64)
    else:
        vertices = entry["polygon"]
        if not isinstance(vertices, list) or len(vertices) < 3:
            raise _fail(source, where, "polygon needs at least three vertices")
        geometry = Polygon([_point(v, source, where) for v in vertices])
    if geometry.is_empty or not geometry.is_valid or geometry.area <= 0.0:
        raise _fail(source, where, "shape is empty or self-intersecting")
    return geometry


def _cell_count(length: float, resolution: float, source: Path) -> int:
    cells = length / resolution
    if not math.isclose(cells, round(cells), abs_tol=1e-6) or round(cells) < 1:
        raise _fail(source, "size", f"{length:g} m is not a whole number of "
                                    f"{resolution:g} m cells")
    return round(cells)


def load_drawing(path: Path) -> MapDrawing:
    """Parse and check a `NAME.shapes.yaml` description."""
    try:
        spec = yaml.safe_load(path.read_text(encoding="utf-8"))
    except (OSError, yaml.YAMLError) as exc:
        raise MapError(f"cannot read shape description {path}: {exc}") from None
    if not isinstance(spec, dict):
        raise _fail(path, "top level", "expected a mapping")
    resolution = spec.get("resolution")
    if not isinstance(resolution, int | float) or isinstance(resolution, bool) or resolution <= 0:
        raise _fail(path, "resolution", f"expected metres per cell > 0, got {resolution!r}")
    width, height = _point(spec.get("size"), path, "size")
    cells = (_cell_count(height, resolution, path), _cell_count(width, resolution, path))
    interior = spec.get("interior")
    obstacles: list[Obstacle] = []
    for index, entry in enumerate(spec.get("obstacles") or []):
        if not isinstance(entry, dict) or not isinstance(entry.get("name"), str):
            raise _fail(path, f"obstacle {index + 1}", "expected a mapping with a `name`")
        where = f"obstacle '{entry['name']}'"
        obstacles.append(Obstacle(entry["name"], _geometry(entry, path, where)))
    marks = {str(name): _point(at, path, f"mark '{name}'")
             for name, at in (spec.get("marks") or {}).items()}
    return MapDrawing(
        name=path.name.removesuffix(SHAPES_SUFFIX), source=path,
        origin=_point(spec.get("origin"), path, "origin"), cells=cells,
        resolution=float(resolution),
        interior=_geometry(interior, path, "interior") if interior is not None else None,
        obstacles=tuple(obstacles), marks=marks,
        description=str(spec.get("description", "")).strip())


def _cells_covered(geometry: BaseGeometry, drawing: MapDrawing) -> tuple[slice, slice,
                                                                          npt.NDArray[np.bool_]]:
    """The window of cells around `geometry` and which of them have their centre in it."""
    rows, cols = drawing.cells
    res, (ox, oy) = drawing.resolution, drawing.origin
    xmin, ymin, xmax, ymax = geometry.bounds
    col0, col1 = max(0, math.floor((xmin - ox) / res)), min(cols, math.ceil((xmax - ox) / res))
    row0, row1 = max(0, math.floor((ymin - oy) / res)), min(rows, math.ceil((ymax - oy) / res))
    xs = ox + (np.arange(col0, col1) + 0.5) * res
    ys = oy + (np.arange(row0, row1) + 0.5) * res
    grid_x, grid_y = np.meshgrid(xs, ys)
    inside = shapely.intersects_xy(geometry, grid_x, grid_y)
    return slice(row0, row1), slice(col0, col1), np.asarray(inside, dtype=np.bool_)


def _centres_in(geometry: BaseGeometry, drawing: MapDrawing) -> npt.NDArray[np.bool_]:
    """(rows, cols): which cells have their centre in (or on the edge of) `geometry`."""
    mask = np.zeros(drawing.cells, dtype=np.bool_)
    rows, cols, inside = _cells_covered(geometry, drawing)
    mask[rows, cols] = inside
    return mask


def rasterise(drawing: MapDrawing) -> OccupancyGrid:
    """The occupancy grid of a drawing (grid row 0 = lowest y)."""
    occupied = np.zeros(drawing.cells, dtype=np.bool_)
    for obstacle in drawing.obstacles:
        occupied |= _centres_in(obstacle.geometry, drawing)
    unknown = None
    if drawing.interior is not None:
        unknown = ~_centres_in(drawing.interior, drawing) & ~occupied
    return OccupancyGrid(occupied, drawing.resolution, drawing.origin,
                         source=str(drawing.source), unknown=unknown)


def draw(shapes_path: Path, out_dir: Path | None = None) -> Path:
    """Rasterise one description and save it; returns the written YAML path."""
    drawing = load_drawing(shapes_path)
    grid = rasterise(drawing)
    yaml_path = (out_dir or shapes_path.parent) / f"{drawing.name}.yaml"
    comment = (f"{drawing.name}: drawn by maps/draw_maps.py from {shapes_path.name}; "
               "edit that file and re-run the script instead of editing this map.")
    save_map(grid, yaml_path, comment=comment)
    return yaml_path


def preview(yaml_path: Path, drawing: MapDrawing, png_path: Path) -> None:
    """A labelled PNG of a drawn map: black obstacles, grey unknown space, the marks in red, and
    in yellow the floor where a body fits with 0.25 m clearance but not with 0.70 m."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from hubero_dsl.world.mapfile import load_map

    grid = load_map(yaml_path)
    colours = np.ones((*grid.shape, 3))
    colours[grid.free_mask(0.25) & ~grid.free_mask(0.70)] = (1.0, 0.93, 0.55)
    colours[grid.occupied] = 0.0
    if grid.unknown is not None:
        colours[grid.unknown] = 0.6
    xmin, ymin, xmax, ymax = grid.bounds
    figure, axes = plt.subplots(figsize=(8, 8), dpi=90)
    axes.imshow(colours, origin="lower", extent=(xmin, xmax, ymin, ymax))
    for name, (x, y) in sorted(drawing.marks.items()):
        axes.plot(x, y, "o", color="tab:red", markersize=4)
        axes.annotate(name, (x, y), xytext=(3, 3), textcoords="offset points", fontsize=7,
                      color="tab:red")
    if drawing.interior is not None:  # show the known part of the map only
        x0, y0, x1, y1 = drawing.interior.bounds
        axes.set_xlim(x0 - 0.5, x1 + 0.5)
        axes.set_ylim(y0 - 0.5, y1 + 0.5)
    axes.set_title(f"{drawing.name} ({grid.shape[1]} x {grid.shape[0]} cells of "
                   f"{grid.resolution:g} m)")
    axes.grid(alpha=0.25)
    figure.savefig(png_path, bbox_inches="tight", metadata={"Software": None})
    plt.close(figure)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    parser.add_argument("names", nargs="*", help="maps to draw (default: every *.shapes.yaml)")
    parser.add_argument("--out", type=Path, default=None, help="write here instead of maps/")
    parser.add_argument("--preview", type=Path, default=None, metavar="DIR",
                        help="also write a labelled PNG of each map into DIR")
    args = parser.parse_args(argv)
    names = args.names or sorted(p.name.removesuffix(SHAPES_SUFFIX)
                                 for p in MAPS_DIR.glob(f"*{SHAPES_SUFFIX}"))
    try:
        for name in names:
            shapes_path = MAPS_DIR / f"{name}{SHAPES_SUFFIX}"
            written = draw(shapes_path, args.out)
            print(f"wrote {written} and {written.with_suffix('.pgm').name}")
            if args.preview is not None:
                args.preview.mkdir(parents=True, exist_ok=True)
                png_path = args.preview / f"{name}.png"
                preview(written, load_drawing(shapes_path), png_path)
                print(f"wrote {png_path}")
    except HuberoError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
