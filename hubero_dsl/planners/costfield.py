"""Cost grids and cost-to-go fields over an occupancy grid, and the caches that make re-plans cheap.

A `CostGrid` turns the map's clearance into a travel cost per cell for one body size and one
comfort radius: cells where the body does not fit are lethal (infinite cost), cells closer to a
wall than the comfort radius cost more the closer they get (like costmap_2d's inflation), every
other cell costs 1 per cell of travel. Its non-lethal cells are split into 8-connected components,
so "start and goal are not connected" is answered by comparing two labels.

A `CostToGo` is a field of minimum travel costs towards one goal cell, computed by Dijkstra in
compiled code (`skimage.graph.MCP_Geometric`) on the bounding box of the goal's component. The
search may stop as soon as the cell asked for is settled: every finite value it leaves is exact
(Dijkstra settles cells in cost order), so a partial field answers every start it covers exactly,
and `FieldCache` widens it to the whole component only when a start outside it asks.

A first plan to a goal searches less than that (`ComponentSearch.solve_between`): every cell
costs at least 1 per cell of travel and an 8-connected path is at least as long as the octile
distance oct(a, b) = max(|dr|, |dc|) + (sqrt 2 - 1) min(|dr|, |dc|) between its ends, so a path
through a cell u costs at least oct(start, u) + oct(u, goal), and a path that leaves the region
where that sum is at most a bound L costs more than L. Dijkstra on the region alone (the rest
made impassable) therefore finds the optimal cost whenever the start's cost inside it is at most
L (A*'s guarantee, with the region in place of its priority). The octile region lies inside the
Euclidean ellipse of the same L, and its bounding box, on which the search is set up, is cropped
to it. A cell v of that field is kept only where its value cannot be beaten by a path leaving
the region either, val(v) <= L - oct(start, v) (up to float rounding, relative 1e-9); the path of
the start always qualifies. A bound too small is raised to the cost the search found, or doubled
when that is more, so a plan costs a few small searches before the region covers the component.

That region grows with the square of the distance, and a crowd wandering to goals of its own
pays it at every walk (about 20 ms a plan across a car park at 5 cm). A first plan between
cells at least 16 blocks apart therefore searches a corridor instead
(`CostGrid.field_between`), as hierarchical planners do: the cheapest path on a coarse grid of
blocks about 0.4 m wide, each costing its cheapest cell (so the blocks of any fine path are
passable there), then Dijkstra on the fine cells of that path's blocks and of the blocks next
to them (scipy's Dijkstra on a graph of those cells alone). The cells it searches grow with the
distance only. A nearer plan searches the first region only (the bound 1.1 times the octile
distance): when that proves its path, the plan is optimal; when the way bends round furniture,
the region would grow until it covers the room (on the living room's 2 cm cells, 20-75 ms a
plan), and the plan searches a corridor too. The path is the cheapest inside the corridor, not
always the cheapest of all: on the project's car park map, over 629 walks of a wandering crowd,
the plans came out 0.04 % longer on average and at most 4 %; in the living room, over 387 walks
of 20 people wandering among the furniture (214 searches), their costs came out at most 0.16 %
above the optimum (a path can still be much longer where two ways round a table cost almost the
same). When the corridor holds no way (the coarse path cut a corner or crossed a wall that the
fine cells do not), it is widened once, then the plan falls back to the region search. navfn's
`corridor` parameter turns it off.

`segment_costs` integrates a cost grid along straight segments (exact cell traversal), which is
how the planner checks line of sight and compares a shortcut with the path it replaces.
All coordinates here are in cell units: a point (u, v) lies in cell (floor(u), floor(v)), so the
centre of cell (r, c) is (r + 0.5, c + 0.5). `to_cell_units` and `goal_obstruction` are the map
queries every global planner shares, so they all word a blocked goal the same way.
"""

from __future__ import annotations

import math
from collections import OrderedDict
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

if TYPE_CHECKING:
    from skimage.graph import MCP_Geometric

    from hubero_dsl.world.grid import OccupancyGrid


FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]
BoolArray = npt.NDArray[np.bool_]

Cell = tuple[int, int]

_EIGHT_CONNECTED = np.ones((3, 3), dtype=bool)  # MCP moves diagonally, so components must too


# The compiled searches and fields are imported when a plan first needs them, not with this
# module: `hubero check` loads it for the navigator's and navfn's parameters only, and these
# imports were most of a cold check of a scenario with a robot.

def _mcp(cost: FloatArray) -> MCP_Geometric:
    """skimage's compiled Dijkstra over `cost`, moves in eight directions."""
    from skimage.graph import MCP_Geometric

    return MCP_Geometric(cost, fully_connected=True)


def _label(passable: BoolArray) -> npt.NDArray[np.int32]:
    """8-connected components of `passable`; 0 marks the rest."""
    from scipy import ndimage

    labels, _ = ndimage.label(passable, structure=_EIGHT_CONNECTED)
    return labels.astype(np.int32)


# The eight moves in MCP_Geometric's order (its `offsets`), their lengths, and the index of
# each by (row step + 1, column step + 1).
_MOVES = np.array([(-1, -1), (-1, 0), (-1, 1), (0, -1), (0, 1), (1, -1), (1, 0), (1, 1)],
                  dtype=np.intp)
_MOVE_LENGTHS = np.hypot(_MOVES[:, 0], _MOVES[:, 1])
_MOVE_INDEX = np.full((3, 3), -1, dtype=np.int8)
_MOVE_INDEX[_MOVES[:, 0] + 1, _MOVES[:, 1] + 1] = np.arange(8)
_KEY_DIGITS = 9                                # radii closer than a nanometre share a cache entry
_EMPTY_INTERVAL = 1e-9                         # cell units: touching a cell corner is not entering
# First region bound, in cell units: most paths cost under 1.1 times the octile distance; the
# slack covers short plans, where walls and comfort weigh more.
_FIRST_BOUND = 1.1
_BOUND_SLACK = 10.0
_DIAGONAL_EXTRA = math.sqrt(2.0) - 1.0  # a diagonal move is this much longer than a straight one
# A first region too small finds a path through its narrow part, far costlier than the best one
# (comfort costs near walls make detours dear): growing the bound a quarter at a time, rather
# than to that path's cost, keeps the next region from spanning the whole map.
_BOUND_GROWTH = 1.25
_TIE_TOLERANCE = 1e-9    # relative: float rounding, when a path costs exactly the octile bound
# Plans search a corridor of blocks about this wide (m) along a coarse path when start and
# goal are at least _CORRIDOR_MIN_BLOCKS blocks apart, or nearer when the first region does
# not prove their path: the blocks of the coarse path and one block on each side of it, then
# two when that holds no way (a coarse path may cut a corner the fine cells cannot: on the
# paper's car park with a 0.125 m comfort radius, 13 of its 21 far plans found their way in
# the narrower corridor, 18 in the wider one).
CORRIDOR_BLOCK = 0.4
_CORRIDOR_MIN_BLOCKS = 16
_CORRIDOR_WIDTHS = (1, 2)


@dataclass(frozen=True, slots=True)
class CostKey:
    """What a cost grid depends on: the lethal radius and the (effective) comfort radius."""

    lethal_radius: float
    comfort_radius: float

    @staticmethod
    def of(lethal_radius: float, comfort_radius: float) -> CostKey:
        # A comfort radius inside the lethal zone adds nothing, so all such radii share a grid.
        lethal = round(lethal_radius, _KEY_DIGITS)
        return CostKey(lethal, max(lethal, round(comfort_radius, _KEY_DIGITS)))


@dataclass(frozen=True, slots=True, eq=False)
class CostToGo:
    """Minimum travel cost (cell units) from each settled cell to `goal`, and the first move there.

    Arrays cover the window `offset` .. `offset + cost.shape` of the map; unsettled cells hold
    inf and step -1. `complete` says whether the whole component was settled.
    """

    goal: Cell
    offset: Cell
    cost: npt.NDArray[np.float32]
    step: npt.NDArray[np.int8]       # index into `moves` of the move that led here from the goal
    moves: npt.NDArray[np.intp]      # (8, 2) MCP offsets (row, col)
    complete: bool

    def covers(self, cell: Cell) -> bool:
        local = self._local(cell)
        return local is not None and bool(np.isfinite(self.cost[local]))

    def value(self, cell: Cell) -> float:
        local = self._local(cell)
        return math.inf if local is None else float(self.cost[local])

    def descend(self, cell: Cell) -> IntArray:
        """(K, 2) cells of the cheapest path from `cell` (first) to the goal (last).

        Following predecessor links is inherently sequential; it walks the path's own cells
        (hundreds), never the grid's.
        """
        local = self._local(cell)
        if local is None or not np.isfinite(self.cost[local]):
            raise ValueError(f"cell {cell} is not covered by this field")
        width = self.cost.shape[1]
        backward = [int(dr) * width + int(dc) for dr, dc in self.moves]
        steps = self.step.ravel()
        index = local[0] * width + local[1]
        visited = [index]
        for _ in range(steps.size):
            move = int(steps[index])
            if move < 0:
                break
            index -= backward[move]
            visited.append(index)
        rows, cols = np.divmod(np.asarray(visited, dtype=np.intp), width)
        return np.stack([rows + self.offset[0], cols + self.offset[1]], axis=1)

    def _local(self, cell: Cell) -> Cell | None:
        r, c = cell[0] - self.offset[0], cell[1] - self.offset[1]
        rows, cols = self.cost.shape
        return (r, c) if 0 <= r < rows and 0 <= c < cols else None


class ComponentSearch:
    """Dijkstra over one connected component, set up once and run for as many goals as asked."""

    def __init__(self, cost: FloatArray, labels: npt.NDArray[np.int32], label: int) -> None:
        rows, cols = np.nonzero(labels == label)
        self.offset: Cell = (int(rows.min()), int(cols.min()))
        self.shape = (int(rows.max()) + 1 - self.offset[0], int(cols.max()) + 1 - self.offset[1])
        self._cost = cost
        self._mcp: MCP_Geometric | None = None   # built when a whole search first needs it

    def solve(self, goal: Cell, until: Cell | None = None) -> CostToGo:
        """The cost-to-go field of `goal`; stops once `until` is settled when it is given.

        A search that stops early leaves skimage's heap with entries that its next search on
        the same MCP object does not fully clear (it then settles fewer cells, some at higher
        costs), so early-stopping searches get a fresh MCP; whole searches share one, which
        each leaves empty.
        """
        window = (slice(self.offset[0], self.offset[0] + self.shape[0]),
                  slice(self.offset[1], self.offset[1] + self.shape[1]))
        if until is not None:
            mcp = _mcp(self._cost[window])
            return _search(mcp, self.offset, goal, until, complete=False)
        if self._mcp is None:
            self._mcp = _mcp(self._cost[window])
        return _search(self._mcp, self.offset, goal, None, complete=True)

    def solve_between(self, goal: Cell, start: Cell, bound: float | None = None) -> CostToGo:
        """The field of `goal` over as small a region around start and goal as proves optimal
        the start's path (see the module docstring); the component's when the region grows
        to it. `bound` resumes from a bound `region_step` has already tried and raised."""
        bound = _first_bound(goal, start) if bound is None else bound
        while True:
            found, bound = self.region_step(goal, start, bound)
            if found is not None:
                return found

    def region_step(self, goal: Cell, start: Cell, bound: float | None = None
                    ) -> tuple[CostToGo | None, float]:
        """One search of `solve_between` (the first when `bound` is None): the field when its
        region proves the start's path optimal, else None and the bound to try next."""
        bound = _first_bound(goal, start) if bound is None else bound
        window = self._region_window(goal, start, bound)
        if window is None:
            return self.solve(goal, start), bound
        found, cost = self._solve_region(goal, start, window, bound)
        # the path found proves the optimum is at most `cost` (see _BOUND_GROWTH)
        return found, min(cost, _BOUND_GROWTH * bound)

    def _solve_region(self, goal: Cell, start: Cell,
                      window: tuple[Cell, FloatArray, FloatArray], bound: float
                      ) -> tuple[CostToGo | None, float]:
        """Dijkstra on one region: its proven field (None when the start's cost there exceeds
        `bound`, so that a path leaving the region might beat it) and the start's cost."""
        offset, cost, to_start = window
        mcp = _mcp(cost)
        cumulative, traceback = _find_costs(mcp, offset, goal, start)
        found = float(cumulative[start[0] - offset[0], start[1] - offset[1]])
        if found > bound:
            return None, found
        # a value v is exact where no path leaving the region can beat it: v <= bound -
        # octile(start, u) (module docstring); the tolerance absorbs float rounding on ties
        proven = cumulative <= bound - to_start + _TIE_TOLERANCE * bound
        return _field(mcp, offset, goal, np.where(proven, cumulative, np.inf), traceback,
                      complete=False), found

    def solve_within(self, goal: Cell, start: Cell, offset: Cell, mask: BoolArray
                     ) -> CostToGo | None:
        """The field of `goal` over the cells of `mask` (a box at `offset`) only: the cheapest
        ways inside the mask, or None when none leads to `start`.

        Dijkstra (scipy's) on a graph of the mask's passable cells alone, so that its cost
        follows the corridor's cells; MCP would be set up on the whole box, most of it outside
        a diagonal corridor. A move costs what MCP_Geometric charges, the mean of its two
        cells' costs times its length, so the values are the other searches' (tested).
        """
        height, width = mask.shape[0] + 2, mask.shape[1] + 2   # a ring of inf round the box
        cost = np.full((height, width), np.inf)
        cost[1:-1, 1:-1] = np.where(mask, self._cost[offset[0]:offset[0] + mask.shape[0],
                                                     offset[1]:offset[1] + mask.shape[1]], np.inf)
        cells = np.flatnonzero(np.isfinite(cost))
        number = np.full(height * width, -1, dtype=np.intp)
        number[cells] = np.arange(len(cells))
        source = int(number[(goal[0] - offset[0] + 1) * width + goal[1] - offset[1] + 1])
        target = int(number[(start[0] - offset[0] + 1) * width + start[1] - offset[1] + 1])
        if source < 0 or target < 0:
            return None
        # each cell's eight neighbours in _MOVES order, cell by cell: already in CSR order,
        # eight entries a cell. A neighbour outside the corridor becomes a loop of infinite
        # weight, which relaxes nothing: cheaper than dropping it from every row.
        count = len(cells)
        around = cells[:, None] + (_MOVES[:, 0] * width + _MOVES[:, 1])
        flat = cost.ravel()
        weights = (flat[cells][:, None] + flat[around]) * (0.5 * _MOVE_LENGTHS)
        neighbour = number[around]
        outside = neighbour < 0
        neighbour[outside] = np.broadcast_to(np.arange(count)[:, None], neighbour.shape)[outside]
        from scipy.sparse import csr_matrix
        from scipy.sparse.csgraph import dijkstra

        graph = csr_matrix((weights.ravel(), neighbour.ravel(), np.arange(0, 8 * count + 1, 8)),
                           shape=(count, count))
        distance, previous = dijkstra(graph, indices=source, return_predecessors=True)
        if not math.isfinite(distance[target]):
            return None
        return self._corridor_field(goal, offset, mask.shape, width, cells, distance, previous)

    @staticmethod
    def _corridor_field(goal: Cell, offset: Cell, shape: tuple[int, int], width: int,
                        cells: IntArray, distance: FloatArray, previous: IntArray) -> CostToGo:
        """A CostToGo over the box from Dijkstra's distances and predecessors on its cells
        (numbered in `cells`, flat indices of the box with its ring of `width` columns)."""
        rows, cols = np.divmod(cells, width)
        rows -= 1
        cols -= 1
        reached = np.flatnonzero(np.isfinite(distance))
        field_cost = np.full(shape, np.inf, dtype=np.float32)
        field_cost[rows[reached], cols[reached]] = distance[reached]
        step = np.full(shape, -1, dtype=np.int8)
        came = reached[previous[reached] >= 0]      # every reached cell but the goal
        before = previous[came]
        step[rows[came], cols[came]] = _MOVE_INDEX[rows[came] - rows[before] + 1,
                                                   cols[came] - cols[before] + 1]
        return CostToGo(goal=goal, offset=offset, cost=field_cost, step=step, moves=_MOVES,
                        complete=False)

    def _region_window(self, goal: Cell, start: Cell, bound: float
                       ) -> tuple[Cell, FloatArray, FloatArray] | None:
        """The costs on the bounding box of the region where octile(start, u) + octile(u, goal)
        is at most `bound`, inf outside it, and each cell's octile distance to the start; None
        when the box is the component's (whose own search is then the one to run)."""
        low, high = self._ellipse_box(goal, start, bound)
        if (high[0] - low[0], high[1] - low[1]) == self.shape:
            return None
        to_start = _octile_field(low, high, start)
        through = to_start + _octile_field(low, high, goal)
        cost = self._cost[low[0]:high[0], low[1]:high[1]]
        inside = (through <= bound) & np.isfinite(cost)
        # crop to the cells that can be searched: the search set-up costs per cell of its box
        rows = np.flatnonzero(inside.any(axis=1))
        cols = np.flatnonzero(inside.any(axis=0))
        crop = (slice(int(rows[0]), int(rows[-1]) + 1), slice(int(cols[0]), int(cols[-1]) + 1))
        cost = np.where(inside[crop], cost[crop], np.inf)
        return (low[0] + int(rows[0]), low[1] + int(cols[0])), cost, to_start[crop]

    def _ellipse_box(self, goal: Cell, start: Cell, bound: float) -> tuple[list[int], list[int]]:
        """Bounds of the box around the Euclidean ellipse |start - u| + |u - goal| <= bound
        (which holds the octile region, octile distances being the longer), within the
        component's box."""
        half_major = bound / 2.0
        centre = ((goal[0] + start[0]) / 2.0, (goal[1] + start[1]) / 2.0)
        span = math.dist(goal, start)
        along = ((start[0] - goal[0]) / span, (start[1] - goal[1]) / span) if span else (1.0, 0.0)
        half_minor = math.sqrt(max(half_major ** 2 - (span / 2.0) ** 2, 0.0))
        reach = (math.hypot(half_major * along[0], half_minor * along[1]) + 1.0,
                 math.hypot(half_major * along[1], half_minor * along[0]) + 1.0)
        low = [max(math.floor(centre[k] - reach[k]), self.offset[k]) for k in (0, 1)]
        high = [min(math.ceil(centre[k] + reach[k]) + 1, self.offset[k] + self.shape[k])
                for k in (0, 1)]
        return low, high


def _first_bound(goal: Cell, start: Cell) -> float:
    straight = _octile(goal[0] - start[0], goal[1] - start[1])
    return max(_FIRST_BOUND * straight, straight + _BOUND_SLACK)


def _octile(rows: float, cols: float) -> float:
    """Length of the shortest 8-connected move sequence spanning (rows, cols) cells."""
    rows, cols = abs(rows), abs(cols)
    return max(rows, cols) + _DIAGONAL_EXTRA * min(rows, cols)


def _octile_field(low: list[int], high: list[int], cell: Cell) -> FloatArray:
    """Octile distance from `cell` to every cell of the box low .. high."""
    rows = np.abs(np.arange(low[0] - cell[0], high[0] - cell[0], dtype=np.float64))[:, None]
    cols = np.abs(np.arange(low[1] - cell[1], high[1] - cell[1], dtype=np.float64))[None, :]
    shorter = np.minimum(rows, cols)
    return (rows + cols) - (1.0 - _DIAGONAL_EXTRA) * shorter


def _search(mcp: MCP_Geometric, offset: Cell, goal: Cell, until: Cell | None, *,
            complete: bool) -> CostToGo:
    cumulative, traceback = _find_costs(mcp, offset, goal, until)
    return _field(mcp, offset, goal, cumulative, traceback, complete=complete)


def _find_costs(mcp: MCP_Geometric, offset: Cell, goal: Cell, until: Cell | None
                ) -> tuple[FloatArray, npt.NDArray[np.int16]]:
    """MCP's cumulative costs from `goal` (double precision) and its traceback, over its box."""
    local_goal = (goal[0] - offset[0], goal[1] - offset[1])
    ends = None if until is None else [(until[0] - offset[0], until[1] - offset[1])]
    cumulative, traceback = mcp.find_costs([local_goal], ends=ends)
    return cumulative, traceback


def _field(mcp: MCP_Geometric, offset: Cell, goal: Cell, cumulative: FloatArray,
           traceback: npt.NDArray[np.int16], *, complete: bool) -> CostToGo:
    # The arrays MCP returns are views of buffers its next search overwrites: copy them.
    return CostToGo(goal=goal, offset=offset,
                    cost=np.ascontiguousarray(cumulative, dtype=np.float32),
                    step=np.ascontiguousarray(traceback, dtype=np.int8),
                    moves=np.asarray(mcp.offsets, dtype=np.intp), complete=complete)


@dataclass(eq=False)
class CostGrid:
    """Travel cost per cell for one `CostKey`, its lethal mask and its components.

    `block` is the side, in cells, of the blocks of its coarse grid (0: no coarse grid), on
    which long plans find their corridor (`field_between`).
    """

    key: CostKey
    cost: FloatArray                   # (rows, cols); inf where lethal
    lethal: BoolArray
    labels: npt.NDArray[np.int32]      # 0 on lethal cells, 1.. per 8-connected component
    block: int = 0
    _searches: dict[int, ComponentSearch] = field(default_factory=dict)
    _coarse: CostGrid | None = None

    def search(self, label: int) -> ComponentSearch:
        if label not in self._searches:
            self._searches[label] = ComponentSearch(self.cost, self.labels, label)
        return self._searches[label]

    def field_between(self, goal: Cell, start: Cell, *, corridor: bool = True) -> CostToGo:
        """The field of a first plan from `start` to `goal`: with `corridor`, searched in a
        corridor along the coarse grid's path when they are far apart, or near but with a
        way that leaves the first region (the module docstring says why and what that costs
        in optimality); else, or when the corridor holds no way, over the region that proves
        the path optimal (`ComponentSearch.solve_between`)."""
        search = self.search(int(self.labels[goal]))
        if not (corridor and self.block):
            return search.solve_between(goal, start)
        bound = None  # the region search's next bound, once its first search has failed
        if _octile(goal[0] - start[0], goal[1] - start[1]) < _CORRIDOR_MIN_BLOCKS * self.block:
            near, bound = search.region_step(goal, start)
            if near is not None:
                return near
        path = self._coarse_path(goal, start)
        for width in _CORRIDOR_WIDTHS:
            found = search.solve_within(goal, start, *self._corridor(path, width))
            if found is not None:
                return found
        return search.solve_between(goal, start, bound)

    def _coarse_path(self, goal: Cell, start: Cell) -> IntArray:
        """The blocks of the coarse grid's cheapest path from `start`'s block to `goal`'s."""
        coarse, block = self.coarse(), self.block
        coarse_goal, coarse_start = (goal[0] // block, goal[1] // block), \
            (start[0] // block, start[1] // block)
        return coarse.search(int(coarse.labels[coarse_goal])).solve_between(
            coarse_goal, coarse_start).descend(coarse_start)

    def _corridor(self, path: IntArray, width: int) -> tuple[Cell, BoolArray]:
        """The fine cells (a box's offset and mask) of the blocks of a coarse path and of the
        blocks up to `width` blocks around them."""
        coarse, block = self.coarse(), self.block
        low = np.maximum(path.min(axis=0) - width, 0)
        high = np.minimum(path.max(axis=0) + width + 1, coarse.cost.shape)
        blocks = np.zeros(high - low, dtype=bool)
        blocks[path[:, 0] - low[0], path[:, 1] - low[1]] = True
        from scipy import ndimage

        blocks = ndimage.binary_dilation(blocks, _EIGHT_CONNECTED, iterations=width)
        rows, cols = self.cost.shape
        fine = np.repeat(np.repeat(blocks, block, axis=0), block, axis=1)
        offset = (int(low[0]) * block, int(low[1]) * block)
        return offset, fine[:rows - offset[0], :cols - offset[1]]

    def coarse(self) -> CostGrid:
        """Blocks of `block` x `block` cells, each costing its cheapest cell (lethal when all
        its cells are): a path's blocks are passable in it, so fine components stay connected
        in it, and a coarse path is never dearer per block than the fine ones it stands for."""
        if self._coarse is None:
            block = self.block
            rows, cols = self.cost.shape
            padded = np.pad(self.cost, ((0, -rows % block), (0, -cols % block)),
                            constant_values=np.inf)
            cost = padded.reshape(padded.shape[0] // block, block,
                                  padded.shape[1] // block, block).min(axis=(1, 3))
            lethal = np.isinf(cost)
            self._coarse = CostGrid(key=self.key, cost=cost, lethal=lethal,
                                    labels=_label(~lethal))
        return self._coarse


def build_cost_grid(clearance: FloatArray, resolution: float, key: CostKey,
                    comfort_weight: float) -> CostGrid:
    """Cost 1 per cell, +`comfort_weight` × s² inside the comfort zone, inf where lethal.

    s falls from 1 at the lethal boundary to 0 at the comfort radius; squaring it keeps the
    cost's slope continuous where the comfort zone ends, so paths do not kink there.
    """
    lethal = clearance <= key.lethal_radius
    cost = np.ones(clearance.shape, dtype=np.float64)
    depth = key.comfort_radius - key.lethal_radius
    if depth > resolution * 1e-6 and comfort_weight > 0.0:
        s = np.clip((key.comfort_radius - clearance) / depth, 0.0, 1.0)
        cost += comfort_weight * s * s
    cost[lethal] = np.inf
    block = max(2, round(CORRIDOR_BLOCK / resolution))
    return CostGrid(key=key, cost=cost, lethal=lethal, labels=_label(~lethal), block=block)


@dataclass(frozen=True, slots=True)
class CacheStats:
    """How often each cache answered; tests and benchmarks read these."""

    grid_builds: int
    field_builds: int
    field_hits: int


class FieldCache:
    """LRU caches of cost grids per `CostKey` and of cost-to-go fields per (goal cell, key)."""

    def __init__(self, clearance: FloatArray, resolution: float, comfort_weight: float, *,
                 max_fields: int, max_grids: int, corridor: bool = True) -> None:
        self._clearance = clearance
        self._corridor = corridor
        self._resolution = resolution
        self._comfort_weight = comfort_weight
        self._max_fields = max_fields
        self._max_grids = max_grids
        self._grids: OrderedDict[CostKey, CostGrid] = OrderedDict()
        self._fields: OrderedDict[tuple[Cell, CostKey], CostToGo] = OrderedDict()
        self._grid_builds = self._field_builds = self._field_hits = 0

    @property
    def stats(self) -> CacheStats:
        return CacheStats(self._grid_builds, self._field_builds, self._field_hits)

    def cost_grid(self, key: CostKey) -> CostGrid:
        grid = self._grids.get(key)
        if grid is None:
            grid = build_cost_grid(self._clearance, self._resolution, key, self._comfort_weight)
            self._grid_builds += 1
            self._grids[key] = grid
            if len(self._grids) > self._max_grids:
                self._grids.popitem(last=False)
        self._grids.move_to_end(key)
        return grid

    def field(self, key: CostKey, goal: Cell, start: Cell | None = None) -> CostToGo:
        """The field of `goal`, covering `start` (or the whole component when start is None).

        A first request searches just enough to prove the start's path optimal; a later start
        outside that partial field rebuilds it over the whole component.
        """
        entry = self._fields.get((goal, key))
        wanted = entry is not None and (entry.complete if start is None else entry.covers(start))
        if entry is not None and wanted:
            self._field_hits += 1
        else:
            grid = self.cost_grid(key)
            if entry is None and start is not None:
                entry = grid.field_between(goal, start, corridor=self._corridor)
            else:
                entry = grid.search(int(grid.labels[goal])).solve(goal)
            self._field_builds += 1
            self._fields[(goal, key)] = entry
            if len(self._fields) > self._max_fields:
                self._fields.popitem(last=False)
        self._fields.move_to_end((goal, key))
        return entry


def segment_costs(cost: FloatArray, start: FloatArray, ends: FloatArray) -> FloatArray:
    """(M,) integral of `cost` (per cell unit of length) along each segment start -> ends[i].

    Every cell a segment passes through counts for the length inside it; a segment that only
    touches a cell's corner does not enter it. Leaving the grid costs inf.
    """
    ends = np.atleast_2d(np.asarray(ends, dtype=np.float64))
    delta = ends - start
    seg, t0, t1 = _cell_intervals(start, delta)
    inside = t1 - t0 > _EMPTY_INTERVAL
    seg, t0, t1 = seg[inside], t0[inside], t1[inside]
    middle = start + ((t0 + t1) / 2.0)[:, None] * delta[seg]
    cells = np.floor(middle).astype(np.intp)
    rows, cols = cost.shape
    on_map = (cells[:, 0] >= 0) & (cells[:, 0] < rows) & (cells[:, 1] >= 0) & (cells[:, 1] < cols)
    unit_cost = np.full(seg.size, np.inf)
    unit_cost[on_map] = cost[cells[on_map, 0], cells[on_map, 1]]
    length = (t1 - t0) * np.hypot(delta[seg, 0], delta[seg, 1])
    return np.bincount(seg, weights=unit_cost * length, minlength=len(ends)).astype(np.float64)


def _cell_intervals(start: FloatArray, delta: FloatArray) -> tuple[IntArray, FloatArray,
                                                                   FloatArray]:
    """Per segment, the parameter intervals [t0, t1] between successive grid-line crossings."""
    count = len(delta)
    seg_parts, t_parts = [np.arange(count), np.arange(count)], [np.zeros(count), np.ones(count)]
    for axis in (0, 1):
        low = np.minimum(start[axis], start[axis] + delta[:, axis])
        high = np.maximum(start[axis], start[axis] + delta[:, axis])
        first = np.floor(low).astype(np.intp) + 1
        crossings = np.maximum(np.ceil(high).astype(np.intp) - first, 0)
        seg = np.repeat(np.arange(count), crossings)
        within = np.arange(seg.size) - np.repeat(np.cumsum(crossings) - crossings, crossings)
        line = (first[seg] + within).astype(np.float64)
        seg_parts.append(seg)
        t_parts.append((line - start[axis]) / delta[seg, axis])
    seg = np.concatenate(seg_parts)
    t = np.concatenate(t_parts)
    order = np.lexsort((t, seg))
    seg, t = seg[order], t[order]
    same = seg[1:] == seg[:-1]
    return seg[:-1][same], t[:-1][same], t[1:][same]


def to_cell_units(grid: OccupancyGrid, xy: tuple[float, float]) -> FloatArray:
    """World (x, y) -> continuous (row, col) cell coordinates of `grid`."""
    return np.array([(xy[1] - grid.origin[1]) / grid.resolution,
                     (xy[0] - grid.origin[0]) / grid.resolution])


def cell_at(uv: FloatArray, shape: tuple[int, int]) -> Cell | None:
    """The cell holding a point in cell units, or None off the map."""
    row, col = math.floor(uv[0]), math.floor(uv[1])
    return (row, col) if 0 <= row < shape[0] and 0 <= col < shape[1] else None


def fmt_point(xy: tuple[float, float]) -> str:
    return f"({xy[0]:.2f}, {xy[1]:.2f})"


def body_words(body_radius: float, margin: float = 0.0) -> str:
    extra = f" (with a {margin:.2f} m margin)" if margin > 0.0 else ""
    return f"a body of radius {body_radius:.2f} m{extra}"


def goal_obstruction(grid: OccupancyGrid, goal: tuple[float, float], body_radius: float,
                     margin: float = 0.0) -> str | None:
    """Why the body cannot stand at `goal` (off the map, in or too near an obstacle), or None."""
    cell = cell_at(to_cell_units(grid, goal), grid.occupied.shape)
    if cell is None:
        return f"goal {fmt_point(goal)} is outside the map"
    clearance = float(grid.clearance[cell])
    if clearance > CostKey.of(body_radius + margin, 0.0).lethal_radius:  # as the lethal mask
        return None
    if grid.occupied[cell]:
        where = "is inside an obstacle"
    else:
        where = f"is {clearance:.2f} m from an obstacle"
    return f"goal {fmt_point(goal)} {where}; {body_words(body_radius, margin)} does not fit"
