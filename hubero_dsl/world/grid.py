"""The occupancy grid: the static world that the engine and every planner navigate.

Owns the map's geometry (world coordinates <-> cells), what is free, how far each cell is from
the nearest obstacle (clearance), which way points away from it (for wall repulsion), and which
free cells a body of a given radius can reach. Every query is vectorised over arrays of points of
shape (..., 2); fields derived from the cells are computed once per grid and cached.

Conventions: row 0 is the lowest y (image rows are already flipped by the loader), cell (r, c)
covers x in [ox + c*res, ox + (c+1)*res) and y in [oy + r*res, oy + (r+1)*res). Unknown cells
count as occupied. The map border counts as an obstacle, so clearance never lets a body leave
the map. Distances are measured between cell centres (scipy's Euclidean distance transform).
Returned masks and fields are read-only arrays shared between callers.
"""

from __future__ import annotations

import hashlib
import math
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass, field, fields
from functools import cached_property, lru_cache
from typing import Any

import numpy as np
import numpy.typing as npt
from numpy.typing import ArrayLike

from hubero_dsl.errors import MapError


def _ndimage() -> Any:
    # scipy.ndimage costs a noticeable part of a cold `hubero check`, which never needs it:
    # it is imported when a distance or connectivity field is first computed.
    from scipy import ndimage

    return ndimage

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]
BoolArray = npt.NDArray[np.bool_]

# The most cells a map may have, whether read from a map file, drawn or read back from a log:
# 4000 x 4000, 200 m x 200 m at 5 cm. Its fields cost tens of bytes a cell.
MAX_MAP_CELLS = 16_000_000

# A body moves continuously, so diagonal neighbours are connected too.
_EIGHT_CONNECTED = np.ones((3, 3), dtype=bool)
# Cell index given to non-finite coordinates: far outside any grid, still a valid integer.
_FAR_AWAY = np.iinfo(np.int32).max
# Up to this many points, the clearance and direction queries run in floats, point by point:
# for the few bodies of a small scene numpy's calls cost more than the arithmetic. The answers
# are the arrays' bit for bit (tests compare them), scipy's bilinear interpolation included.
FEW_POINTS = 8
# Masks and labels kept per grid (least recently used dropped first): body radii drawn from a
# distribution would otherwise each keep a map-sized array alive.
_CACHE_ENTRIES = 48
# Obstacle fields by the cells they were computed from, shared between grids: every run of a
# sweep loads its map afresh, and the field is the costliest thing derived from it. A few maps
# are kept (least recently used dropped first); each field is 16 bytes per cell.
_SHARED_FIELDS = 4
_OBSTACLE_FIELDS: OrderedDict[tuple[Any, ...], tuple[FloatArray, npt.NDArray[np.int32]]] = \
    OrderedDict()


def _points(xy: ArrayLike) -> FloatArray:
    points = np.asarray(xy, dtype=np.float64)
    if points.ndim == 0 or points.shape[-1] != 2:
        raise ValueError(f"expected points of shape (..., 2), got shape {points.shape}")
    return points


def _read_only(array: npt.NDArray[Any]) -> npt.NDArray[Any]:
    array.setflags(write=False)
    return array


def _unit_vectors(vectors: FloatArray) -> FloatArray:
    """Each vector scaled to length 1; zero vectors stay zero."""
    # the root of x*x + y*y is bit for bit np.linalg.norm's, with less overhead per call
    x, y = vectors[..., 0], vectors[..., 1]
    norms = np.sqrt(x * x + y * y)[..., None]
    return np.divide(vectors, norms, out=np.zeros(vectors.shape), where=norms > 0.0)


# Where one finite point lies: its fractional row and column, its cell (row, column) clipped
# into the grid, and whether it is inside the map. A plain tuple: it is built every tick.
_PointCell = tuple[float, float, int, int, bool]


def _few_finite(points: FloatArray) -> bool:
    """Whether `points` is a list of at most FEW_POINTS finite points (asked in floats)."""
    return points.ndim == 2 and len(points) <= FEW_POINTS and bool(np.isfinite(points).all())


def _sample_count(longest: float, resolution: float) -> int:
    """How many points `crosses_obstacle` samples each segment of a call at: every half cell
    of the call's longest segment, both ends included."""
    return max(2, math.ceil(longest / (0.5 * resolution)) + 1)


@lru_cache(maxsize=64)  # a few short moves use a few counts; a long one must not stay
def _sample_fractions(samples: int) -> tuple[float, ...]:
    """Where `crosses_obstacle` samples a segment: `np.linspace(0, 1, samples)`."""
    return tuple(np.linspace(0.0, 1.0, samples).tolist())


def _bilinear(values: FloatArray, row: float, col: float) -> float:
    """scipy.ndimage.map_coordinates(values, order=1, mode="nearest") at one point, with its
    arithmetic: weights from the coordinate as given, neighbours clipped into the grid, and
    the four products summed in C order (tests compare the two bit for bit)."""
    rows, cols = values.shape
    r0, c0 = math.floor(row), math.floor(col)
    wr0 = 1.0 - (row - r0)
    wc0 = 1.0 - (col - c0)
    wr1, wc1 = 1.0 - wr0, 1.0 - wc0
    ra, rb = min(max(r0, 0), rows - 1), min(max(r0 + 1, 0), rows - 1)
    ca, cb = min(max(c0, 0), cols - 1), min(max(c0 + 1, 0), cols - 1)
    total = 0.0
    total += float(values[ra, ca]) * wr0 * wc0
    total += float(values[ra, cb]) * wr0 * wc1
    total += float(values[rb, ca]) * wr1 * wc0
    total += float(values[rb, cb]) * wr1 * wc1
    return total


def _check_radius(body_radius: float) -> float:
    radius = float(body_radius)
    if not math.isfinite(radius) or radius < 0.0:
        raise ValueError(f"body radius must be a finite number >= 0, got {body_radius!r}")
    return radius


def _obstacle_field(occupied: BoolArray, resolution: float
                    ) -> tuple[FloatArray, npt.NDArray[np.int32]]:
    """`OccupancyGrid._obstacle_field` of these cells, computed.

    The distance transform runs over the free cells' bounding box and one ring around it only;
    every cell outside is occupied, so its distance is 0 and its nearest occupied cell itself.
    The result is exactly scipy's transform of the whole grid padded with one occupied ring:
    that ring (occupied cells or the padding) lies between every cell of the box and every
    cell beyond it, so a cell beyond is strictly further than a ring cell from any cell of the
    box, and scipy's line scans never pass a ring cell (an occupied cell is its own nearest)
    to reach one. Maps are mostly walls and unknown space around the free part, so this
    skips most of the work (over half of it on the parking lot).
    """
    nearest = np.indices(occupied.shape, dtype=np.int32)
    distances = np.zeros(occupied.shape)
    free_rows = np.flatnonzero(~occupied.all(axis=1))
    if free_rows.size == 0:
        return _read_only(distances), _read_only(nearest)
    free_cols = np.flatnonzero(~occupied.all(axis=0))
    # the box with its ring, in the coordinates of the grid padded by one occupied ring
    row_start, row_stop = int(free_rows[0]), int(free_rows[-1]) + 3
    col_start, col_stop = int(free_cols[0]), int(free_cols[-1]) + 3
    padded = np.pad(occupied, 1, constant_values=True)
    window = padded[row_start:row_stop, col_start:col_stop]
    window_distances, window_nearest = _ndimage().distance_transform_edt(
        ~window, sampling=resolution, return_indices=True)
    window_nearest[0] += row_start - 1
    window_nearest[1] += col_start - 1
    # the window's cells inside the grid (its ring may lie on the padding)
    rows, cols = occupied.shape
    top, left = max(row_start - 1, 0), max(col_start - 1, 0)
    bottom, right = min(row_stop - 1, rows), min(col_stop - 1, cols)
    inside = (slice(top - row_start + 1, bottom - row_start + 1),
              slice(left - col_start + 1, right - col_start + 1))
    distances[top:bottom, left:right] = window_distances[inside]
    nearest[:, top:bottom, left:right] = window_nearest[(slice(None), *inside)]
    return _read_only(distances), _read_only(nearest)


REACH_MARGIN = 0.05  # m beyond a body's radius that reachable cells keep from obstacles
_TIE = 1e-9  # m: a clearance this near a radius is left to the distance field to judge
_FAR = 1e15  # cells: a point further off than this is off every map (and floors exactly)


@dataclass(frozen=True, eq=False)
class OccupancyGrid:
    """A 2-D occupancy map on a regular grid, with cached distance and connectivity fields."""

    occupied: BoolArray   # (rows, cols); True = cannot be entered (includes unknown cells)
    resolution: float     # metres per cell
    origin: tuple[float, float]  # world (x, y) of the lower-left corner of cell (0, 0)
    source: str = "<memory>"     # where the map came from, for messages
    unknown: BoolArray | None = None  # (rows, cols) cells of unknown state, kept for drawing
    _cache: OrderedDict[tuple[Any, ...], npt.NDArray[Any]] = field(
        default_factory=OrderedDict, init=False, repr=False)

    def __post_init__(self) -> None:
        occupied = np.array(self.occupied, dtype=np.bool_)  # a copy: the grid owns its cells
        if occupied.ndim != 2 or occupied.size == 0:
            raise MapError(f"map {self.source} must be a non-empty 2-D grid of cells, "
                           f"got shape {occupied.shape}")
        resolution = float(self.resolution)
        if not math.isfinite(resolution) or resolution <= 0.0:
            raise MapError(f"map {self.source}: resolution must be a positive number of metres "
                           f"per cell, got {self.resolution!r}")
        origin = (float(self.origin[0]), float(self.origin[1]))
        if not all(math.isfinite(v) for v in origin):
            raise MapError(f"map {self.source}: origin must be finite, got {self.origin!r}")
        unknown = None
        if self.unknown is not None:
            unknown = np.array(self.unknown, dtype=np.bool_)
            if unknown.shape != occupied.shape:
                raise MapError(f"map {self.source}: unknown cells have shape {unknown.shape}, "
                               f"occupied cells {occupied.shape}")
            occupied |= unknown  # unknown space is never entered
            _read_only(unknown)
        object.__setattr__(self, "occupied", _read_only(occupied))
        object.__setattr__(self, "unknown", unknown)
        object.__setattr__(self, "resolution", resolution)
        object.__setattr__(self, "origin", origin)

    def __repr__(self) -> str:
        rows, cols = self.shape
        return (f"OccupancyGrid({cols}x{rows} cells, {self.resolution:g} m, "
                f"origin ({self.origin[0]:g}, {self.origin[1]:g}), source={self.source!r})")

    def __getstate__(self) -> dict[str, Any]:
        # Pickle only the map itself; derived fields are rebuilt on demand in the receiver.
        state = {f.name: getattr(self, f.name) for f in fields(self) if f.init}
        state["_cache"] = OrderedDict()
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        for array in (self.occupied, self.unknown):
            if array is not None:
                array.setflags(write=False)

    # --- geometry -------------------------------------------------------------------------

    @property
    def shape(self) -> tuple[int, int]:
        """(rows, cols)."""
        rows, cols = self.occupied.shape
        return int(rows), int(cols)

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """(xmin, ymin, xmax, ymax) of the map rectangle, in metres."""
        rows, cols = self.shape
        x0, y0 = self.origin
        return (x0, y0, x0 + cols * self.resolution, y0 + rows * self.resolution)

    def _fractional_cells(self, points: FloatArray) -> FloatArray:
        """(..., 2) continuous (row, col) coordinates; cell (r, c) spans [r, r+1) x [c, c+1)."""
        row, col = self._fractional_rows_cols(points)
        return np.stack((row, col), axis=-1)

    def _fractional_rows_cols(self, points: FloatArray) -> tuple[FloatArray, FloatArray]:
        col = (points[..., 0] - self.origin[0]) / self.resolution
        row = (points[..., 1] - self.origin[1]) / self.resolution
        return row, col

    def _locate(self, points: FloatArray) -> tuple[IntArray, IntArray, BoolArray]:
        """Row and column of each point's cell clipped into the grid, and whether it is inside.

        The per-tick form of `world_to_cell` + `_clipped` + `_inside`: the same cells, without
        the intermediate arrays (non-finite coordinates are outside; their clipped cell is an
        edge cell, which callers never read without checking `inside`).
        """
        return self._locate_fractional(*self._fractional_rows_cols(points))

    def _locate_fractional(self, row: FloatArray, col: FloatArray
                           ) -> tuple[IntArray, IntArray, BoolArray]:
        row, col = np.floor(row), np.floor(col)
        rows, cols = self.occupied.shape
        # fmax / fmin map NaN to the bound, so the cast below never sees a NaN; a cell is
        # inside when clipping leaves it where it is (NaN and inf never compare equal)
        row_clipped = np.fmin(np.fmax(row, 0.0), rows - 1)
        col_clipped = np.fmin(np.fmax(col, 0.0), cols - 1)
        inside: BoolArray = (row_clipped == row) & (col_clipped == col)
        return row_clipped.astype(np.intp), col_clipped.astype(np.intp), inside

    def world_to_cell(self, xy: ArrayLike) -> IntArray:
        """(..., 2) world points -> (..., 2) cells as (row, col); may be out of range."""
        cells = np.floor(self._fractional_cells(_points(xy)))
        # Non-finite coordinates land far outside the grid rather than on an arbitrary integer.
        cells = np.where(np.isfinite(cells), np.clip(cells, -_FAR_AWAY, _FAR_AWAY), -_FAR_AWAY)
        return cells.astype(np.intp)

    def cell_to_world(self, rc: ArrayLike) -> FloatArray:
        """(..., 2) cells as (row, col) -> (..., 2) world (x, y) of the cell centres."""
        cells = np.asarray(rc, dtype=np.float64)
        if cells.ndim == 0 or cells.shape[-1] != 2:
            raise ValueError(f"expected cells of shape (..., 2), got shape {cells.shape}")
        x = self.origin[0] + (cells[..., 1] + 0.5) * self.resolution
        y = self.origin[1] + (cells[..., 0] + 0.5) * self.resolution
        return np.stack((x, y), axis=-1)

    def _inside(self, cells: IntArray) -> BoolArray:
        rows, cols = self.shape
        row, col = cells[..., 0], cells[..., 1]
        inside: BoolArray = (row >= 0) & (row < rows) & (col >= 0) & (col < cols)
        return inside

    def _clipped(self, cells: IntArray) -> tuple[IntArray, IntArray]:
        """Row and column indices clipped into the grid, safe for fancy indexing."""
        rows, cols = self.shape
        return np.clip(cells[..., 0], 0, rows - 1), np.clip(cells[..., 1], 0, cols - 1)

    def with_discs(self, centres: ArrayLike, radii: ArrayLike) -> OccupancyGrid:
        """A copy with the cells whose centres lie within each disc made occupied (people
        standing in the way, for a plan around them)."""
        occupied = self.occupied.copy()
        discs = zip(_points(centres).reshape(-1, 2).tolist(),
                    np.asarray(radii, dtype=np.float64).reshape(-1).tolist(), strict=True)
        for (x, y), radius in discs:
            low = self.world_to_cell((x - radius, y - radius))
            high = self.world_to_cell((x + radius, y + radius)) + 1
            r0, c0 = np.maximum(low, 0)
            r1, c1 = np.minimum(high, occupied.shape)
            if r0 >= r1 or c0 >= c1:
                continue
            rows, cols = np.mgrid[r0:r1, c0:c1]
            centres_xy = self.cell_to_world(np.stack([rows, cols], axis=-1))
            inside = np.hypot(centres_xy[..., 0] - x, centres_xy[..., 1] - y) <= radius
            occupied[r0:r1, c0:c1] |= inside
        return OccupancyGrid(occupied, self.resolution, self.origin, source=self.source,
                             unknown=self.unknown)

    def contains(self, xy: ArrayLike) -> BoolArray:
        """Whether each point lies inside the map rectangle."""
        with np.errstate(over="ignore"):  # a coordinate near 1e308 is as much outside as 1e9
            return self._locate(_points(xy))[2]

    def is_free(self, xy: ArrayLike) -> BoolArray:
        """Whether each point lies inside the map on a free cell (outside counts as occupied)."""
        row, col, inside = self._locate(_points(xy))
        free: BoolArray = inside & ~self.occupied[row, col]
        return free

    def crosses_obstacle(self, start: ArrayLike, end: ArrayLike) -> BoolArray:
        """(N,) whether each straight segment from start to end passes an occupied cell (or
        leaves the map), sampled every half cell."""
        a, b = _points(start).reshape(-1, 2), _points(end).reshape(-1, 2)
        step = np.hypot(*(b - a).T)
        samples = _sample_count(float(step.max(initial=0.0)), self.resolution)
        fractions = np.linspace(0.0, 1.0, samples)
        points = a[:, None, :] + (b - a)[:, None, :] * fractions[None, :, None]
        free = self.is_free(points.reshape(-1, 2)).reshape(len(a), samples)
        crossed: BoolArray = np.logical_not(free.all(axis=1))
        return crossed

    def is_free_point(self, x: float, y: float) -> bool:
        """`is_free` of one finite point, in floats."""
        _, _, row, col, inside = self._locate_point(x, y)
        return inside and not self.occupied[row, col]

    def segment_fractions(self, longest: float) -> tuple[float, ...]:
        """Where `crosses_obstacle` samples the segments of a call whose longest is `longest`
        m long (every half cell of it), as fractions of each segment."""
        return _sample_fractions(_sample_count(longest, self.resolution))

    def crosses_obstacle_point(self, x0: float, y0: float, x1: float, y1: float,
                               fractions: tuple[float, ...]) -> bool:
        """`crosses_obstacle` of one finite segment of a call, in floats with its arithmetic,
        sampled at `fractions` (`segment_fractions` of the call's longest segment)."""
        return not all(self.is_free_point(x0 + (x1 - x0) * f, y0 + (y1 - y0) * f)
                       for f in fractions)

    # --- distance fields ------------------------------------------------------------------

    @cached_property
    def _obstacle_field(self) -> tuple[FloatArray, npt.NDArray[np.int32]]:
        """Distance from each cell centre to the nearest occupied cell, and that cell (row, col).

        The border acts as a wall: the nearest cell of a border-bound cell may be row/col -1 or
        rows/cols. Grids with the same cells share one field (see `_OBSTACLE_FIELDS`).
        """
        key = (self.occupied.shape, self.resolution,
               hashlib.blake2b(np.packbits(self.occupied).tobytes(), digest_size=16).digest())
        field = _OBSTACLE_FIELDS.get(key)
        if field is None:
            field = _obstacle_field(self.occupied, self.resolution)
            _OBSTACLE_FIELDS[key] = field
            if len(_OBSTACLE_FIELDS) > _SHARED_FIELDS:
                _OBSTACLE_FIELDS.popitem(last=False)
        else:
            _OBSTACLE_FIELDS.move_to_end(key)
        return field

    @cached_property
    def _free_field(self) -> npt.NDArray[np.int32] | None:
        """For each cell, the nearest free cell (row, col); None when no cell is free."""
        if self.occupied.all():
            return None
        nearest = _ndimage().distance_transform_edt(
            self.occupied, return_distances=False, return_indices=True)
        return _read_only(nearest.astype(np.int32))

    @property
    def clearance(self) -> FloatArray:
        """(rows, cols) metres from each cell centre to the nearest occupied cell, 0 on one."""
        return self._obstacle_field[0]

    def clearance_at(self, xy: ArrayLike) -> FloatArray:
        """Clearance at each point, bilinear between cell centres; 0 off free cells."""
        return self._probe(_points(xy), direction=False)[0]

    def clearance_at_point(self, x: float, y: float) -> float:
        """`clearance_at` of one finite point, in floats."""
        return self._probe_point(x, y, self._locate_point(x, y), direction=False)[0]

    def clearance_and_direction_at(self, xy: ArrayLike) -> tuple[FloatArray, FloatArray]:
        """`clearance_at` and `obstacle_direction_at` in one pass over the cell lookups."""
        return self._probe(_points(xy), direction=True)

    def _probe(self, points: FloatArray, *, direction: bool) -> tuple[FloatArray, FloatArray]:
        if _few_finite(points):
            probes = [self._probe_point(x, y, self._locate_point(x, y), direction=direction)
                      for x, y in points.tolist()]
            clearance = np.array([probe[0] for probe in probes]).reshape(len(points))
            if not direction:
                return clearance, clearance
            return clearance, np.array([probe[1] for probe in probes]).reshape(len(points), 2)
        row, col = self._fractional_rows_cols(points)
        row_index, col_index, inside = self._locate_fractional(row, col)
        free: BoolArray = inside & ~self.occupied[row_index, col_index]
        clearance = self._interpolated(row, col, free)
        if not direction:
            return clearance, clearance
        return clearance, self._direction(points, row_index, col_index, inside, free)

    def _interpolated(self, row: FloatArray, col: FloatArray, free: BoolArray) -> FloatArray:
        """Clearance bilinear between cell centres at fractional cells; 0 where not free."""
        # Shift so cell centres sit on integer coordinates, as map_coordinates expects.
        coords = np.empty((2, row.size))
        np.subtract(row.reshape(-1), 0.5, out=coords[0])
        np.subtract(col.reshape(-1), 0.5, out=coords[1])
        if not np.isfinite(coords).all():
            coords = np.nan_to_num(coords, nan=0.0, posinf=0.0, neginf=0.0)
        values = _ndimage().map_coordinates(self.clearance, coords, order=1, mode="nearest")
        clearance: FloatArray = np.where(free, values.reshape(row.shape), 0.0)
        return clearance

    def surely_clear(self, xy: ArrayLike, distance: FloatArray | float) -> BoolArray:
        """True where `clearance_at(xy) >= distance` holds for certain (`distance` > 0).

        A cheap lower bound for bodies far from walls: the clearance of the point's cell less
        the distance to the farthest cell centre the interpolation reads (one cell diagonal),
        clearance being 1-Lipschitz. False is no verdict: ask `clearance_at`. Points off the map
        read an edge cell, whose bound is negative, so they are never surely clear.
        """
        row, col, _ = self._locate(_points(xy))
        clear: BoolArray = self._clearance_floor[row, col] >= distance
        return clear

    def surely_clear_point(self, x: float, y: float, distance: float) -> bool:
        """`surely_clear` for one point, in floats: for the few bodies of a small scene, whose
        arrays would cost more in numpy's calls than in the arithmetic."""
        if not (math.isfinite(x) and math.isfinite(y)):
            return False
        _, _, row, col, inside = self._locate_point(x, y)
        # off the map it is never surely clear (`surely_clear` reads an edge cell there)
        return inside and bool(self._clearance_floor[row, col] >= distance)

    def walls_within(self, xy: ArrayLike, reach: float
                     ) -> tuple[IntArray, FloatArray, FloatArray]:
        """The points that may have a wall within `reach`, with their clearance and direction.

        Returns (index into the points, `clearance_at`, `obstacle_direction_at`) for every point
        whose cell is not surely clear by `reach` (see `surely_clear`); the others certainly
        have more than `reach` of clearance. One cell lookup serves all three.
        """
        points = _points(xy)
        if _few_finite(points):
            return self._few_walls_within(points, reach)
        row, col = self._fractional_rows_cols(points)
        row_index, col_index, inside = self._locate_fractional(row, col)
        maybe = (self._clearance_floor[row_index, col_index] < reach).nonzero()[0]
        if maybe.size == 0:
            return maybe, np.zeros(0), np.zeros((0, 2))
        if maybe.size < row.size:
            points, row, col = points[maybe], row[maybe], col[maybe]
            row_index, col_index, inside = row_index[maybe], col_index[maybe], inside[maybe]
        free: BoolArray = inside & ~self.occupied[row_index, col_index]
        clearance = self._interpolated(row, col, free)
        return maybe, clearance, self._direction(points, row_index, col_index, inside, free)

    def _few_walls_within(self, points: FloatArray, reach: float
                          ) -> tuple[IntArray, FloatArray, FloatArray]:
        """`walls_within` for a few finite points, in floats."""
        found: list[int] = []
        probes: list[tuple[float, tuple[float, float]]] = []
        for index, (x, y) in enumerate(points.tolist()):
            cell = self._locate_point(x, y)
            _, _, row, col, _ = cell
            if self._clearance_floor[row, col] < reach:
                found.append(index)
                probes.append(self._probe_point(x, y, cell, direction=True))
        return (np.array(found, dtype=np.intp), np.array([p[0] for p in probes]),
                np.array([p[1] for p in probes]).reshape(len(found), 2))

    def _locate_point(self, x: float, y: float) -> _PointCell:
        """`_locate_fractional` of one finite point, in floats."""
        x0, y0, resolution, last_row, last_col = self._point_frame
        row_f = (y - y0) / resolution
        col_f = (x - x0) / resolution
        if not (-_FAR < row_f < _FAR and -_FAR < col_f < _FAR):  # far off the map (or inf)
            return row_f, col_f, 0, 0, False
        row_floor, col_floor = math.floor(row_f), math.floor(col_f)
        row = 0 if row_floor < 0 else last_row if row_floor > last_row else row_floor
        col = 0 if col_floor < 0 else last_col if col_floor > last_col else col_floor
        return row_f, col_f, row, col, row == row_floor and col == col_floor

    @cached_property
    def _point_frame(self) -> tuple[float, float, float, int, int]:
        """What `_locate_point` reads of the grid, unpacked once (it runs a few times a tick
        for each body of a small scene)."""
        rows, cols = self.shape
        return self.origin[0], self.origin[1], self.resolution, rows - 1, cols - 1

    def _probe_point(self, x: float, y: float, cell: _PointCell, *, direction: bool
                     ) -> tuple[float, tuple[float, float]]:
        """`_probe` of one finite point, in floats, with the arrays' arithmetic (and scipy's
        order-1 `map_coordinates`); the direction is (0, 0) unless asked for."""
        row_f, col_f, row, col, inside = cell
        free = inside and not self.occupied[row, col]
        clearance = _bilinear(self.clearance, row_f - 0.5, col_f - 0.5) if free else 0.0
        if not direction:
            return clearance, (0.0, 0.0)
        if free:  # away from the nearest point of the nearest obstacle cell
            obstacle = (int(self._obstacle_field[1][0][row, col]),
                        int(self._obstacle_field[1][1][row, col]))
            lx, ly, ux, uy = self._cell_square(*obstacle)
            away = (x - min(max(x, lx), ux), y - min(max(y, ly), uy))
            if away == (0.0, 0.0):  # on the obstacle's very edge: cell to cell
                cx = self.origin[0] + (col + 0.5) * self.resolution  # its centre
                cy = self.origin[1] + (row + 0.5) * self.resolution
                away = (cx - 0.5 * (lx + ux), cy - 0.5 * (ly + uy))
        elif inside:  # towards the nearest free cell
            away = (0.0, 0.0)
            if self._free_field is not None:
                lx, ly, ux, uy = self._cell_square(int(self._free_field[0, row, col]),
                                                   int(self._free_field[1, row, col]))
                away = (min(max(x, lx), ux) - x, min(max(y, ly), uy) - y)
        else:  # towards the map
            xmin, ymin, xmax, ymax = self.bounds
            away = (min(max(x, xmin), xmax) - x, min(max(y, ymin), ymax) - y)
        norm = math.sqrt(away[0] * away[0] + away[1] * away[1])
        return clearance, (away[0] / norm, away[1] / norm) if norm > 0.0 else (0.0, 0.0)

    def _cell_square(self, row: int, col: int) -> tuple[float, float, float, float]:
        """The lower-left and upper-right corners of a cell, with `_cell_squares`' arithmetic."""
        lx = self.origin[0] + (col + 0.5) * self.resolution - 0.5 * self.resolution
        ly = self.origin[1] + (row + 0.5) * self.resolution - 0.5 * self.resolution
        return lx, ly, lx + self.resolution, ly + self.resolution

    @cached_property
    def _clearance_floor(self) -> FloatArray:
        """Clearance of each cell less one cell diagonal (and a rounding margin)."""
        margin = math.sqrt(2.0) * self.resolution * (1.0 + 1e-9) + 1e-12
        return _read_only(self.clearance - margin)

    def _cell_centres(self, row: npt.NDArray[Any], col: npt.NDArray[Any]) -> FloatArray:
        """(..., 2) world centres of cells, with exactly the arithmetic of `cell_to_world`."""
        centres = np.empty((*row.shape, 2))
        centres[..., 0] = self.origin[0] + (col + 0.5) * self.resolution
        centres[..., 1] = self.origin[1] + (row + 0.5) * self.resolution
        return centres

    def _cell_squares(self, cells: npt.NDArray[np.int32]) -> tuple[FloatArray, FloatArray]:
        """(2, ...) cells -> (..., 2) lower-left and upper-right world corners of each cell."""
        lower = self._cell_centres(cells[0], cells[1])
        lower -= 0.5 * self.resolution
        return lower, lower + self.resolution

    def obstacle_direction_at(self, xy: ArrayLike) -> FloatArray:
        """(..., 2) unit vectors pointing away from the nearest occupied cell.

        On a free cell: from the nearest point of the nearest occupied cell (as a square) to the
        point, so a straight wall pushes straight out. On an occupied cell: towards the nearest
        free cell, so a body pushed into a wall is pushed back out. Outside the map: towards
        the map. Zero where no direction exists (a fully occupied map).
        """
        points = _points(xy)
        row, col, inside = self._locate(points)
        free = inside & ~self.occupied[row, col]
        return self._direction(points, row, col, inside, free)

    def _direction(self, points: FloatArray, row: IntArray, col: IntArray, inside: BoolArray,
                   free: BoolArray) -> FloatArray:
        nearest_row, nearest_col = self._obstacle_field[1]
        lower = self._cell_centres(nearest_row[row, col], nearest_col[row, col])
        lower -= 0.5 * self.resolution
        upper = lower + self.resolution
        away = points - np.minimum(np.maximum(points, lower), upper)
        # A point on the obstacle's very edge falls back to the cell-to-cell direction.
        on_edge = (away[..., 0] == 0.0) & (away[..., 1] == 0.0)
        if on_edge.any():
            centres = self._cell_centres(row, col)
            away = np.where(on_edge[..., None], centres - 0.5 * (lower + upper), away)
        direction = away
        if not free.all():
            towards_free = np.zeros_like(points)
            # the free field is a whole distance transform: computed only once it is needed
            if (inside & ~free).any() and self._free_field is not None:
                lower, upper = self._cell_squares(self._free_field[:, row, col])
                towards_free = np.minimum(np.maximum(points, lower), upper) - points
            xmin, ymin, xmax, ymax = self.bounds
            towards_map = np.clip(points, (xmin, ymin), (xmax, ymax)) - points
            direction = np.where(free[..., None], away,
                                 np.where(inside[..., None], towards_free, towards_map))
        return _unit_vectors(direction)

    # --- where a body fits ----------------------------------------------------------------

    def _cached(self, key: tuple[Any, ...],
                compute: Callable[[], npt.NDArray[Any]]) -> npt.NDArray[Any]:
        if key in self._cache:
            self._cache.move_to_end(key)
            return self._cache[key]
        value = _read_only(compute())
        self._cache[key] = value
        if len(self._cache) > _CACHE_ENTRIES:
            self._cache.popitem(last=False)
        return value

    def body_fits(self, xy: tuple[float, float], body_radius: float) -> bool:
        """Whether a body of this radius fits at the point's cell: `free_mask` there, found
        from the cells within reach when they decide it, without the whole map's distance
        field (and the import of scipy.ndimage that builds it, most of a cold `hubero
        check`). Only a distance within a hair of the radius, where the two computations
        could round apart, is left to the field."""
        radius = _check_radius(body_radius)
        cell = self.world_to_cell(np.asarray(xy, dtype=np.float64))
        if not self._inside(cell):
            return False
        if "_obstacle_field" in self.__dict__:  # computed already: no cheaper answer
            return bool(self.free_mask(radius)[self._clipped(cell)])
        nearest = self._nearest_obstacle_within(int(cell[0]), int(cell[1]), radius)
        if abs(nearest - radius) > _TIE:
            return nearest > radius
        return bool(self.free_mask(radius)[self._clipped(cell)])

    def _nearest_obstacle_within(self, row: int, col: int, radius: float) -> float:
        """Metres from cell (row, col)'s centre to the nearest occupied cell's within `radius`
        (and a cell more), cells beyond the map counting as occupied; inf when there is none."""
        reach = math.ceil(radius / self.resolution) + 1
        rows, cols = self.shape
        top, left = row - reach, col - reach
        window = np.ones((2 * reach + 1, 2 * reach + 1), dtype=bool)  # beyond the map: walls
        r0, r1 = max(top, 0), min(row + reach + 1, rows)
        c0, c1 = max(left, 0), min(col + reach + 1, cols)
        window[r0 - top:r1 - top, c0 - left:c1 - left] = self.occupied[r0:r1, c0:c1]
        dr, dc = np.nonzero(window)
        if not dr.size:
            return math.inf
        return float(np.hypot((dr - reach) * self.resolution,
                              (dc - reach) * self.resolution).min())

    def free_mask(self, body_radius: float) -> BoolArray:
        """(rows, cols) cells with clearance > `body_radius`: where that body's centre fits."""
        radius = _check_radius(body_radius)
        return self._cached(("free", radius), lambda: self.clearance > radius)

    def components(self, radius: float) -> npt.NDArray[np.int32]:
        """Connected components (8-connected) of free_mask(radius): 0 marks blocked cells,
        cells with the same label can reach each other."""
        return self._components(radius)

    def _components(self, radius: float) -> npt.NDArray[np.int32]:
        """Connected components (8-connected) of free_mask(radius); 0 marks blocked cells."""
        def label() -> npt.NDArray[np.int32]:
            labels, _ = _ndimage().label(self.free_mask(radius), structure=_EIGHT_CONNECTED)
            return labels.astype(np.int32)

        return self._cached(("components", radius), label)

    def reachable_mask(self, start: tuple[float, float], body_radius: float) -> BoolArray:
        """(rows, cols) cells a body of this radius can reach from `start`, 8-connected.

        All False when the body does not fit at `start` (or `start` is outside the map).
        """
        radius = _check_radius(body_radius)
        cell = self.world_to_cell(start)
        labels = self._components(radius)
        label = int(labels[self._clipped(cell)]) if self._inside(cell) else 0
        if not label:
            return self._cached(("nowhere",), lambda: np.zeros(self.shape, dtype=np.bool_))
        return self._cached(("reachable", radius, label), lambda: labels == label)

    def entry_places(self, area: Any, goal: tuple[float, float],
                     body_radius: float) -> FloatArray:
        """(K, 2) centres of the cells inside `area` (a shapely polygon) where a body of this
        radius fits and from which it can walk to `goal`: where people may appear who are
        going there. Empty when there are none."""
        reachable = self.reachable_mask(goal, body_radius + REACH_MARGIN)
        return self.cells_in(area, reachable)[2]

    def cells_in(self, area: Any, mask: npt.NDArray[Any]) -> tuple[IntArray, IntArray, FloatArray]:
        """The cells set in `mask` (of the grid's shape) whose centres lie inside `area` (a
        shapely polygon), in row-major order: their rows, columns and (K, 2) centres. Only the
        cells under the area's bounding box are looked at."""
        import shapely

        x0, y0, x1, y1 = area.bounds
        (r0, c0), (r1, c1) = self.world_to_cell([(x0, y0), (x1, y1)])
        rows_, cols_ = self.shape
        r0, c0 = max(int(r0), 0), max(int(c0), 0)
        r1, c1 = min(int(r1) + 1, rows_), min(int(c1) + 1, cols_)
        if r0 >= r1 or c0 >= c1:
            nothing = np.zeros(0, dtype=np.intp)
            return nothing, nothing, np.zeros((0, 2))
        rows, cols = np.nonzero(mask[r0:r1, c0:c1])
        rows, cols = rows + r0, cols + c0
        centres = self.cell_to_world(np.stack((rows, cols), axis=-1))
        inside = shapely.contains_xy(area, centres[:, 0], centres[:, 1])
        return rows[inside], cols[inside], centres[inside]

    def nearest_free(self, xy: tuple[float, float],
                     body_radius: float = 0.0) -> tuple[tuple[float, float], float]:
        """The nearest point whose cell fits a body of this radius, and the distance to it.

        The point itself (distance 0) when its own cell fits the body; otherwise the centre of
        the nearest such cell. Raises MapError when the body fits nowhere on the map.
        """
        point = _points(xy)
        if point.shape != (2,):
            raise ValueError(f"expected one point (x, y), got shape {point.shape}")
        mask = self.free_mask(body_radius)
        cell = self.world_to_cell(point)
        if self._inside(cell) and mask[self._clipped(cell)]:
            return (float(point[0]), float(point[1])), 0.0
        nearest = self._nearest_free_cells(body_radius)
        if nearest is None:
            raise MapError(f"no place on map {self.source} fits a body of radius "
                           f"{body_radius:g} m")
        # the free cell nearest to the point's (clipped) cell bounds the search: every free
        # cell centre nearer to the point lies in the box of that reach around it
        row, col = (int(i) for i in self._clipped(cell))
        guess = self.cell_to_world(nearest[:, row, col])
        reach = float(np.hypot(*(guess - point))) + self.resolution
        low = self.world_to_cell(point - reach)
        high = self.world_to_cell(point + reach)
        r0, c0 = max(int(low[0]), 0), max(int(low[1]), 0)
        rows, cols = np.nonzero(mask[r0:max(int(high[0]) + 1, r0), c0:max(int(high[1]) + 1, c0)])
        centres = self.cell_to_world(np.stack((rows + r0, cols + c0), axis=-1))
        distances = np.hypot(centres[:, 0] - point[0], centres[:, 1] - point[1])
        best = int(np.argmin(distances))
        return (float(centres[best, 0]), float(centres[best, 1])), float(distances[best])

    def _nearest_free_cells(self, body_radius: float) -> IntArray | None:
        """(2, rows, cols): for each cell the (row, col) of the nearest cell where a body of
        this radius fits (scipy's distance transform, once per radius); None: it fits
        nowhere."""
        radius = _check_radius(body_radius)
        mask = self.free_mask(radius)
        if not mask.any():
            return None
        return self._cached(("nearest free", radius), lambda: _ndimage().distance_transform_edt(
            ~mask, return_distances=False, return_indices=True))
