"""Maps drawn from a shape description: `NAME.shapes.yaml` -> a ROS map_server map.

A description gives a map's frame (`origin`, `size` in metres, `resolution`), an optional
`interior` (cells outside it are unknown space) and a list of named `obstacles`, each one of

    {name: table, rect: [[x0, y0], [x1, y1]]}          two opposite corners
    {name: plant, circle: [x, y], radius: r}
    {name: kerb, polygon: [[x, y], [x, y], [x, y], ...]}

in metres in the map frame. A cell is occupied when its centre lies in (or on the edge of) an
obstacle. `marks` (named points) are not drawn; they document the points the layout was designed
around, and `hubero map show` labels them. `description` is free text.

`draw_map` writes `NAME.yaml` + `NAME.pgm` (`save_map`), through a temporary folder beside them
and renamed into place, so a failure leaves no half-written map. Drawing is deterministic: the
same description gives the same bytes. Descriptions come from anyone: the file is read up to a
limit, YAML anchors and aliases are refused, and the map's cells are counted before any is
allocated. Errors name the file, line and column of the entry at fault.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import shapely
import yaml
from shapely.geometry import Point, Polygon, box
from shapely.geometry.base import BaseGeometry

from hubero_dsl.diagnostics import Span, closest
from hubero_dsl.errors import MapError
from hubero_dsl.files import read_bounded, scratch_folder_beside
from hubero_dsl.world.grid import MAX_MAP_CELLS, OccupancyGrid
from hubero_dsl.world.mapfile import save_map, unsafe_yaml

SHAPES_SUFFIX = ".shapes.yaml"
MAX_SHAPES_BYTES = 4 << 20  # a description is a page or two of YAML
# cells tested against obstacles, summed over each obstacle's window: some ten seconds' work
MAX_CELL_TESTS = 200_000_000
DRAWING_KEYS = ("description", "resolution", "origin", "size", "obstacles", "marks", "interior")
SHAPE_KEYS = ("rect", "circle", "radius", "polygon")


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


class _Reader:
    """Reads the fields of one description, with the span of each for messages."""

    def __init__(self, path: Path) -> None:
        self.path = path
        data = read_bounded(path, MAX_SHAPES_BYTES, "shape description", MapError)
        try:
            text = data.decode("utf-8")
        except UnicodeDecodeError as exc:
            raise MapError(f"shape description {path} is not UTF-8 text (byte {exc.start})"
                           ) from None
        try:
            unsafe = unsafe_yaml(text)
            if unsafe is not None:
                token, why = unsafe
                raise MapError(f"a shape description {why}: it may not",
                               self._span(token.start_mark, token.end_mark))
            self.root = yaml.compose(text, Loader=yaml.SafeLoader)
            self.values = yaml.safe_load(text)
        except yaml.MarkedYAMLError as exc:
            mark = exc.problem_mark or exc.context_mark
            if mark is None:
                raise MapError(f"{path} is not valid YAML: {exc.problem}") from None
            raise MapError(f"not valid YAML: {exc.problem}", self._span(mark, mark)) from None
        except yaml.YAMLError:
            raise MapError(f"{path} is not valid YAML") from None
        if not isinstance(self.values, dict) or not isinstance(self.root, yaml.MappingNode):
            raise MapError(f"{path}: a shape description is a YAML mapping of `origin`, `size`, "
                           "`resolution` and `obstacles`")

    def _span(self, start: yaml.Mark, end: yaml.Mark) -> Span:
        return Span(str(self.path), start.line + 1, start.column + 1, end.line + 1,
                    end.column + 1)

    def node(self, key: str) -> yaml.Node | None:
        """The value of a top-level key."""
        assert isinstance(self.root, yaml.MappingNode)
        return next((value for name, value in self.root.value
                     if isinstance(name, yaml.ScalarNode) and name.value == key), None)

    def key_node(self, key: object) -> yaml.Node | None:
        """A top-level key itself."""
        assert isinstance(self.root, yaml.MappingNode)
        return next((name for name, _ in self.root.value
                     if isinstance(name, yaml.ScalarNode) and name.value == str(key)), None)

    def fail(self, where: str, message: str, node: yaml.Node | None) -> MapError:
        """An error at `node` (the message then shows its file, line, column and line)."""
        if node is None:
            return MapError(f"{self.path}: {where}: {message}")
        return MapError(f"{where}: {message}", self._span(node.start_mark, node.end_mark))


def _number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(
        value)


def _point(reader: _Reader, value: Any, where: str, node: yaml.Node | None
           ) -> tuple[float, float]:
    if not isinstance(value, list) or len(value) != 2 or not all(_number(v) for v in value):
        raise reader.fail(where, f"expected a point [x, y], got {str(value)[:60]}", node)
    return float(value[0]), float(value[1])


def _geometry(reader: _Reader, entry: Any, where: str, node: yaml.Node | None, *,
              named: bool = False) -> BaseGeometry:
    """One shape: `rect`, `circle` (+ `radius`) or `polygon` (and its `name`, when `named`)."""
    if not isinstance(entry, dict):
        raise reader.fail(where, "expected a mapping with rect, circle or polygon", node)
    _known_keys(reader, entry, ("name", *SHAPE_KEYS) if named else SHAPE_KEYS, where, node)
    kinds = [kind for kind in ("rect", "circle", "polygon") if kind in entry]
    if len(kinds) != 1:
        raise reader.fail(where, "give exactly one of rect, circle, polygon", node)
    kind = kinds[0]
    if kind == "rect":
        corners = entry["rect"]
        if not isinstance(corners, list) or len(corners) != 2:
            raise reader.fail(where, "rect needs two corners [[x0, y0], [x1, y1]]", node)
        (x0, y0), (x1, y1) = (_point(reader, c, where, node) for c in corners)
        geometry: BaseGeometry = box(min(x0, x1), min(y0, y1), max(x0, x1), max(y0, y1))
    elif kind == "circle":
        radius = entry.get("radius")
        if not isinstance(radius, int | float) or not _number(radius) or radius <= 0:
            raise reader.fail(where, f"circle needs a radius > 0, got {str(radius)[:60]}", node)
        # 64 segments per quarter: the polygon is within a micrometre of the circle.
        geometry = Point(_point(reader, entry["circle"], where, node)).buffer(float(radius), 64)
    else:
        vertices = entry["polygon"]
        if not isinstance(vertices, list) or not 3 <= len(vertices) <= 10_000:
            raise reader.fail(where, "polygon needs 3 to 10,000 vertices", node)
        geometry = Polygon([_point(reader, v, where, node) for v in vertices])
    if geometry.is_empty or not geometry.is_valid or geometry.area <= 0.0:
        raise reader.fail(where, "shape is empty or self-intersecting", node)
    return geometry


def _known_keys(reader: _Reader, mapping: dict[Any, Any], known: tuple[str, ...], where: str,
                node: yaml.Node | None) -> None:
    """A key the format does not have is an error: a misspelt `obstacels:` drew a map with no
    obstacles at all."""
    for key in mapping:
        if key not in known:
            meant = closest(str(key), known)
            hint = f"did you mean `{meant}`?" if meant else f"the keys are {', '.join(known)}"
            raise reader.fail(where, f"unknown key `{str(key)[:60]}` ({hint})",
                              node if node is not None else reader.key_node(key))


def _cells(reader: _Reader, size: tuple[float, float], resolution: float) -> tuple[int, int]:
    counts = []
    for length in (size[1], size[0]):
        cells = length / resolution
        if not math.isclose(cells, round(cells), abs_tol=1e-6) or round(cells) < 1:
            raise reader.fail("size", f"{length:g} m is not a whole number of {resolution:g} m "
                              "cells", reader.node("size"))
        counts.append(round(cells))
    if counts[0] * counts[1] > MAX_MAP_CELLS:
        raise reader.fail("size", f"{counts[1]} x {counts[0]} cells is more than "
                          f"{MAX_MAP_CELLS:,}, the most a map may have: use larger cells or a "
                          "smaller map", reader.node("size"))
    return counts[0], counts[1]


def load_drawing(path: str | Path) -> MapDrawing:
    """Parse and check a shape description."""
    path = Path(path)
    reader = _Reader(path)
    spec = reader.values
    resolution = spec.get("resolution")
    if not _number(resolution) or resolution <= 0:
        raise reader.fail("resolution", f"expected metres per cell > 0, got "
                          f"{str(resolution)[:60]}", reader.node("resolution"))
    size = _point(reader, spec.get("size"), "size", reader.node("size"))
    if min(size) <= 0:
        raise reader.fail("size", "width and height must be positive", reader.node("size"))
    cells = _cells(reader, size, float(resolution))
    _known_keys(reader, spec, DRAWING_KEYS, "a shape description", None)
    obstacles_node = reader.node("obstacles")
    entries = spec.get("obstacles") or []
    if not isinstance(entries, list):
        raise reader.fail("obstacles", "expected a list of shapes", obstacles_node)
    nodes = obstacles_node.value if isinstance(obstacles_node, yaml.SequenceNode) else []
    obstacles = []
    for index, entry in enumerate(entries):
        node = nodes[index] if index < len(nodes) else obstacles_node
        if not isinstance(entry, dict) or not isinstance(entry.get("name"), str):
            raise reader.fail(f"obstacle {index + 1}", "expected a mapping with a `name`", node)
        obstacles.append(Obstacle(entry["name"], _geometry(
            reader, entry, f"obstacle '{entry['name'][:60]}'", node, named=True)))
    origin = _point(reader, spec.get("origin"), "origin", reader.node("origin"))
    _bounded_work(reader, obstacles, cells, float(resolution), origin, obstacles_node)
    marks_value = spec.get("marks") or {}
    if not isinstance(marks_value, dict):
        raise reader.fail("marks", "expected a mapping of names to points", reader.node("marks"))
    marks = {str(name): _point(reader, at, f"mark '{str(name)[:60]}'", reader.node("marks"))
             for name, at in marks_value.items()}
    interior = spec.get("interior")
    name = path.name.removesuffix(SHAPES_SUFFIX).removesuffix(".yaml").removesuffix(".yml")
    return MapDrawing(
        name=name, source=path, origin=origin, cells=cells, resolution=float(resolution),
        interior=None if interior is None else _geometry(reader, interior, "interior",
                                                         reader.node("interior")),
        obstacles=tuple(obstacles), marks=marks,
        description=str(spec.get("description", "")).strip())


def _bounded_work(reader: _Reader, obstacles: list[Obstacle], cells: tuple[int, int],
                  resolution: float, origin: tuple[float, float],
                  node: yaml.Node | None) -> None:
    """MapError when drawing the obstacles would test more than MAX_CELL_TESTS cells (each
    obstacle's cells are those of its bounding box on the map): many large obstacles on fine
    cells would take hours."""
    tests = sum(_window_cells(o.geometry, cells, resolution, origin) for o in obstacles)
    if tests > MAX_CELL_TESTS:
        raise reader.fail("obstacles", f"drawing these {len(obstacles):,} obstacles tests "
                          f"{tests:,} cells, more than {MAX_CELL_TESTS:,}: use fewer or "
                          "smaller obstacles, or larger cells", node)


def _window_cells(geometry: BaseGeometry, cells: tuple[int, int], resolution: float,
                  origin: tuple[float, float]) -> int:
    rows, cols = _window(geometry, cells, resolution, origin)
    return max(0, rows.stop - rows.start) * max(0, cols.stop - cols.start)


def _window(geometry: BaseGeometry, cells: tuple[int, int], resolution: float,
            origin: tuple[float, float]) -> tuple[slice, slice]:
    """The rows and columns of the map's cells within `geometry`'s bounding box."""
    rows, cols = cells
    res, (ox, oy) = resolution, origin
    xmin, ymin, xmax, ymax = geometry.bounds
    col0, col1 = max(0, math.floor((xmin - ox) / res)), min(cols, math.ceil((xmax - ox) / res))
    row0, row1 = max(0, math.floor((ymin - oy) / res)), min(rows, math.ceil((ymax - oy) / res))
    return slice(row0, row1), slice(col0, col1)


def _cells_covered(geometry: BaseGeometry, cells: tuple[int, int], resolution: float,
                   origin: tuple[float, float]) -> tuple[slice, slice, npt.NDArray[np.bool_]]:
    """The window of cells around `geometry` and which of them have their centre in it."""
    rows, cols = _window(geometry, cells, resolution, origin)
    xs = origin[0] + (np.arange(cols.start, cols.stop) + 0.5) * resolution
    ys = origin[1] + (np.arange(rows.start, rows.stop) + 0.5) * resolution
    grid_x, grid_y = np.meshgrid(xs, ys)
    inside = shapely.intersects_xy(geometry, grid_x, grid_y)
    return rows, cols, np.asarray(inside, dtype=np.bool_)


def centres_in(geometry: BaseGeometry, cells: tuple[int, int], resolution: float,
               origin: tuple[float, float]) -> npt.NDArray[np.bool_]:
    """(rows, cols): which cells of the frame (row 0 = lowest y) have their centre in (or on
    the edge of) `geometry`."""
    mask = np.zeros(cells, dtype=np.bool_)
    rows, cols, inside = _cells_covered(geometry, cells, resolution, origin)
    mask[rows, cols] = inside
    return mask


def rasterise(drawing: MapDrawing) -> OccupancyGrid:
    """The occupancy grid of a drawing (grid row 0 = lowest y)."""
    frame = (drawing.cells, drawing.resolution, drawing.origin)
    occupied = np.zeros(drawing.cells, dtype=np.bool_)
    for obstacle in drawing.obstacles:  # each within its own window: not the whole map each
        rows, cols, inside = _cells_covered(obstacle.geometry, *frame)
        occupied[rows, cols] |= inside
    unknown = None
    if drawing.interior is not None:
        unknown = ~centres_in(drawing.interior, *frame) & ~occupied
    return OccupancyGrid(occupied, drawing.resolution, drawing.origin,
                         source=str(drawing.source), unknown=unknown)


def grid_from_walkable(walkable: BaseGeometry, resolution: float = 0.05,
                       margin: float = 0.5, source: str = "<memory>") -> OccupancyGrid:
    """A map built in code from the walkable space of a place (the validation corridors): a
    grid covering `walkable` plus `margin` metres of wall on every side, free where a cell's
    centre lies in `walkable`, as obstacles are drawn."""
    x0, y0, x1, y1 = walkable.bounds
    origin = (x0 - margin, y0 - margin)
    cells = (math.ceil((y1 - y0 + 2 * margin) / resolution),
             math.ceil((x1 - x0 + 2 * margin) / resolution))
    free = centres_in(walkable, cells, resolution, origin)
    return OccupancyGrid(occupied=~free, resolution=resolution, origin=origin, source=source)


def draw_map(shapes_path: str | Path, yaml_path: str | Path, *, comment: str) -> Path:
    """Rasterise a description and save it as `yaml_path` and its PGM image (written beside
    and renamed into place: a failure leaves neither); returns the YAML path."""
    drawing = load_drawing(shapes_path)
    grid = rasterise(drawing)
    target = Path(yaml_path)
    with scratch_folder_beside(target.resolve(), shown=target) as work:
        image = save_map(grid, work / target.name, comment=comment)
        image.replace(target.with_suffix(".pgm"))
        (work / target.name).replace(target)
    return target
