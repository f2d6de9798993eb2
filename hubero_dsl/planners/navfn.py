"""The `navfn` global planner: descend a cost-to-go field from the start, then shorten the path.

Like ROS navfn over a costmap_2d, the cost of a cell grows near walls: cells where the body does
not fit are lethal, and cells closer to a wall than the human's comfort radius (half the width of
its personal space) cost more the closer they are, so a human with a large personal space takes
a detour rather than a narrow aisle when one exists, and still squeezes through when none does.

The field is computed from the goal (see `costfield`) and cached per (goal cell, body radius,
comfort radius): every human heading to the same goal, and every re-plan on the way, reuses it.
The 8-connected path read off the field is then shortened greedily: a waypoint is dropped when
the straight segment replacing it crosses no lethal cell and costs no more than the path it cuts.
"""

from __future__ import annotations

import math
from collections import OrderedDict
from typing import TYPE_CHECKING, ClassVar

import numpy as np
from pydantic import Field

from hubero_dsl.errors import SimulationError
from hubero_dsl.planners.base import NoPath, Plan, PlannerParams
from hubero_dsl.planners.costfield import (
    CacheStats,
    Cell,
    CostGrid,
    CostKey,
    CostToGo,
    FieldCache,
    FloatArray,
    IntArray,
    body_words,
    cell_at,
    fmt_point,
    goal_obstruction,
    segment_costs,
    to_cell_units,
)

if TYPE_CHECKING:
    from numpy.typing import ArrayLike

    from hubero_dsl.world.grid import OccupancyGrid

Point = tuple[float, float]

_ENTRY_SEARCH = 0.5     # m beyond the lethal radius searched for a way out of the lethal zone
_BATCH = 32             # shortcut candidates tested per vectorised round
_COST_SLACK = 1e-9      # relative: a shortcut may cost this much more (float noise) than its path
_MAX_GRIDS = 4          # cost grids kept: one per distinct (body, comfort) pair of a run
_MAX_PLANS = 4096       # plans an independent planner remembers (least recently used go)


class NavfnParams(PlannerParams):
    """Parameters of the `navfn` planner."""

    comfort_weight: float = Field(
        default=40.0, ge=0.0, allow_inf_nan=False,
        description="extra cost per metre of walking right at the lethal boundary, relative to "
                    "1 in open space; it falls smoothly to 0 at the comfort radius. 0 ignores "
                    "personal space when planning")
    lethal_margin: float = Field(
        default=0.0, ge=0.0, le=2.0, allow_inf_nan=False, json_schema_extra={"dimension": "length"},
        description="metres added to the body radius when deciding where the body fits")
    smooth: bool = Field(
        default=True,
        description="shorten the grid path into straight segments; False keeps every turn of "
                    "the 8-connected grid path")
    corridor: bool = Field(
        default=True,
        description="a plan between points farther apart than 16 blocks of 0.4 m, or a "
                    "nearer one whose way bends far from the straight line, searches a "
                    "corridor along a coarse plan (bounded, near-optimal); False: every plan "
                    "searches the region that proves it optimal")
    cache_size: int = Field(
        default=32, ge=1, le=4096,
        description="cost-to-go fields kept (least recently used are dropped first)")


class NavfnPlanner:
    """Cost-to-go planner over the static map; one instance serves every human of a run."""

    name: ClassVar[str] = "navfn"
    Params: ClassVar[type[PlannerParams]] = NavfnParams

    def __init__(self, grid: OccupancyGrid, params: PlannerParams, *,
                 independent: bool = False) -> None:
        self.grid = grid
        # A first plan to a goal searches only the region that proves its path optimal; a
        # later plan to that goal reuses that field when it covers the start. Of paths of equal
        # cost, which one a field holds depends on the region searched, so a plan can depend
        # on the plans before it. An independent planner searches each query's own region and
        # remembers whole plans by their query instead: every plan is a function of its query.
        self.independent = independent
        self._plans: OrderedDict[tuple[Point, Point, float, float], Plan] = OrderedDict()
        self.remembered_plans = 0  # plans an independent planner answered from memory
        self.params = (params if isinstance(params, NavfnParams)
                       else NavfnParams.model_validate(params.model_dump()))
        self._cache = FieldCache(np.asarray(grid.clearance, dtype=np.float64), grid.resolution,
                                 self.params.comfort_weight, max_fields=self.params.cache_size,
                                 max_grids=_MAX_GRIDS, corridor=self.params.corridor)
        # Walls as a cost grid (0 free, inf occupied): the way out of the lethal zone must not
        # pass through one.
        self._walls: FloatArray = np.where(np.asarray(grid.occupied, dtype=bool), np.inf, 0.0)
        self.straight_plans = 0  # plans that were a free straight segment: no search

    @classmethod
    def for_sharing(cls, grid: OccupancyGrid, params: PlannerParams) -> NavfnPlanner:
        """A planner whose plans do not depend on the queries before them, so that runs can
        share it (and its cached fields) and each still plans as if it were alone."""
        return cls(grid, params, independent=True)

    @property
    def cache_stats(self) -> CacheStats:
        return self._cache.stats

    def plan(self, start: Point, goal: Point, *, body_radius: float,
             comfort_radius: float) -> Plan:
        """A path the body fits along, avoiding the comfort zone where it pays to.

        Raises NoPath when the goal is off the map, in or too near an obstacle, or cut off.
        """
        if not self.independent:
            return self._plan(start, goal, body_radius, comfort_radius)
        query = (start, goal, body_radius, comfort_radius)
        plan = self._plans.get(query)
        if plan is not None:
            self.remembered_plans += 1
        else:
            plan = self._plan(start, goal, body_radius, comfort_radius)
            plan.waypoints.setflags(write=False)  # handed out again: nobody may change it
            self._plans[query] = plan
            if len(self._plans) > _MAX_PLANS:
                self._plans.popitem(last=False)
        self._plans.move_to_end(query)
        return plan

    def _plan(self, start: Point, goal: Point, body_radius: float,
              comfort_radius: float) -> Plan:
        key = self._key(body_radius, comfort_radius)
        costs = self._cache.cost_grid(key)
        goal_cell = self._goal_cell(goal, body_radius, costs)
        start_uv = to_cell_units(self.grid, start)
        entry = self._entry_cell(start, start_uv, costs)
        if entry is None or costs.labels[entry] != costs.labels[goal_cell]:
            raise NoPath(f"goal {fmt_point(goal)} cannot be reached from {fmt_point(start)}: "
                         f"no free path for {body_words(body_radius, self.params.lethal_margin)}")
        goal_uv = to_cell_units(self.grid, goal)
        if entry == cell_at(start_uv, costs.cost.shape) and _straight_is_free(
                costs.cost, start_uv, goal_uv):
            # the straight segment costs its length (no comfort zone, no wall): no path is
            # shorter or cheaper, so no search is needed (a crowd's thousand plans in the open)
            self.straight_plans += 1
            return self._to_world(np.vstack([start_uv, goal_uv]), start, goal)
        field = (costs.field_between(goal_cell, entry, corridor=self.params.corridor)
                 if self.independent
                 else self._cache.field(key, goal_cell, entry))
        cells = _turns(field.descend(entry))
        forced = entry != cell_at(start_uv, costs.cost.shape)
        points, to_go = self._polyline(start_uv, goal_uv, cells, field, costs,
                                       forced_entry=forced)
        first_free = 1 if math.isinf(to_go[0]) else 0
        keep = (_shortcut(points, to_go, costs.cost, first_free) if self.params.smooth
                else list(range(len(points))))
        return self._to_world(points[keep], start, goal)

    def cost_to_go(self, goal: Point, *, body_radius: float, comfort_radius: float) -> CostToGo:
        """The whole-component cost-to-go field of `goal` (cached like the planner's own)."""
        key = self._key(body_radius, comfort_radius)
        goal_cell = self._goal_cell(goal, body_radius, self._cache.cost_grid(key))
        return self._cache.field(key, goal_cell)

    def _key(self, body_radius: float, comfort_radius: float) -> CostKey:
        for what, value in (("body radius", body_radius), ("comfort radius", comfort_radius)):
            if not (math.isfinite(value) and value >= 0.0):
                raise SimulationError(f"{what} must be a finite number >= 0 m, not {value}")
        return CostKey.of(body_radius + self.params.lethal_margin, comfort_radius)

    def _goal_cell(self, goal: Point, body_radius: float, costs: CostGrid) -> Cell:
        reason = goal_obstruction(self.grid, goal, body_radius, self.params.lethal_margin)
        cell = cell_at(to_cell_units(self.grid, goal), costs.cost.shape)
        if reason is not None or cell is None:
            raise NoPath(reason or f"goal {fmt_point(goal)} is outside the map")
        return cell

    def _entry_cell(self, start: Point, start_uv: FloatArray, costs: CostGrid) -> Cell | None:
        """The start's cell, or, for a body pushed into the lethal zone, the nearest cell where
        it fits that a straight step reaches without crossing a wall. None when there is none."""
        cell = cell_at(start_uv, costs.cost.shape)
        if cell is None:
            raise NoPath(f"start {fmt_point(start)} is outside the map")
        if not costs.lethal[cell]:
            return cell
        if self._walls[cell] > 0.0:
            raise NoPath(f"start {fmt_point(start)} is inside an obstacle")
        reach = math.ceil((costs.key.lethal_radius + _ENTRY_SEARCH) / self.grid.resolution)
        r0, c0 = max(cell[0] - reach, 0), max(cell[1] - reach, 0)
        window = costs.lethal[r0:cell[0] + reach + 1, c0:cell[1] + reach + 1]
        free = np.argwhere(~window) + np.array([r0, c0])
        if free.size == 0:
            return None
        centres = free + 0.5
        order = np.argsort(((centres - start_uv) ** 2).sum(axis=1), kind="stable")
        clear = np.isfinite(segment_costs(self._walls, start_uv, centres[order]))
        if not clear.any():
            return None
        best = free[order[int(np.argmax(clear))]]
        return int(best[0]), int(best[1])

    def _polyline(self, start_uv: FloatArray, goal_uv: FloatArray, cells: IntArray,
                  field: CostToGo, costs: CostGrid, *, forced_entry: bool
                  ) -> tuple[FloatArray, FloatArray]:
        """Exact start, the path's turning cells, exact goal (cell units), with each point's cost
        to go; the start's is inf when its first step (out of the lethal zone) is forced."""
        centres = cells.astype(np.float64) + 0.5
        to_go = field.cost[cells[:, 0] - field.offset[0],
                           cells[:, 1] - field.offset[1]].astype(np.float64)
        if forced_entry:
            start_to_go = math.inf
        else:
            start_to_go = to_go[0] + float(segment_costs(costs.cost, start_uv, centres[:1])[0])
        goal_to_go = -float(segment_costs(costs.cost, centres[-1], goal_uv[None, :])[0])
        points = np.vstack([start_uv, centres, goal_uv])
        return points, np.concatenate([[start_to_go], to_go, [goal_to_go]])

    def _to_world(self, points: FloatArray, start: Point, goal: Point) -> Plan:
        res, (ox, oy) = self.grid.resolution, self.grid.origin
        world = np.column_stack([ox + points[:, 1] * res, oy + points[:, 0] * res])
        world[0], world[-1] = start, goal   # exact, not rounded through cell units
        return Plan(waypoints=world)


def _straight_is_free(cost: FloatArray, start_uv: FloatArray, goal_uv: FloatArray) -> bool:
    """Whether the segment costs no more than its length: every cell it crosses is plain free
    floor (cost 1), outside every wall's lethal and comfort zones."""
    length = float(np.hypot(*(goal_uv - start_uv)))
    return float(segment_costs(cost, start_uv, goal_uv[None, :])[0]) <= length * (1.0 + 1e-12)


def _turns(cells: IntArray) -> IntArray:
    """The first, last and every cell where an 8-connected path changes direction."""
    if len(cells) < 3:
        return cells
    steps = np.diff(cells, axis=0)
    turning = np.any(steps[1:] != steps[:-1], axis=1)
    return cells[np.concatenate([[True], turning, [True]])]


def _shortcut(points: FloatArray, to_go: FloatArray, cost: FloatArray, first: int) -> list[int]:
    """Indices of the points kept when each is joined to the farthest one it can go straight to.

    Points before `first` are kept as they are (a forced step out of the lethal zone).
    """
    keep = list(range(first + 1))
    anchor = first
    while anchor < len(points) - 1:
        anchor = _farthest_shortcut(points, to_go, cost, anchor)
        keep.append(anchor)
    return keep


def _farthest_shortcut(points: FloatArray, to_go: FloatArray, cost: FloatArray,
                       anchor: int) -> int:
    """The farthest later point whose straight segment from `anchor` is no dearer than the path.

    Candidates are tested a batch at a time: the farthest that passes, then the gap between it
    and the next candidate (which failed) is searched again, until no gap is left.
    """
    best, limit = anchor + 1, len(points) - 1   # the next point is always reachable: it is a step
    while limit > best:
        count = min(limit - best, _BATCH)
        candidates = np.unique(np.linspace(best + 1, limit, count).round().astype(np.intp))
        segment = segment_costs(cost, points[anchor], points[candidates])
        path = to_go[anchor] - to_go[candidates]
        passes = segment <= path + _COST_SLACK * max(1.0, abs(to_go[anchor]))
        if passes.any():
            best = int(candidates[passes].max())
        beyond = candidates[candidates > best]
        limit = int(beyond[0]) - 1 if beyond.size else best
    return best


def plan_round_discs(grid: OccupancyGrid, centres: ArrayLike, radii: ArrayLike, start: Point,
                     goal: Point, *, body_radius: float, comfort_radius: float
                     ) -> FloatArray | None:
    """The waypoints of a plan from `start` to `goal` round discs (people or robots standing
    in the way, as obstacles) on the map, by a planner of their own; None when there is none.
    The map's own planners and their fields are left as they are."""
    try:
        return NavfnPlanner(grid.with_discs(centres, radii), NavfnParams()).plan(
            start, goal, body_radius=body_radius, comfort_radius=comfort_radius).waypoints
    except NoPath:
        return None


def reference_plan_length(grid: OccupancyGrid, start: Point, goal: Point,
                          body_radius: float) -> float | None:
    """The length of navfn's optimal plan (no corridor, no comfort margin) for a body from
    `start` to `goal`: the shortest way the metrics compare a path with (`plan_efficiency`).
    None when there is no such plan."""
    try:
        plan = NavfnPlanner(grid, NavfnParams(corridor=False)).plan(
            start, goal, body_radius=body_radius, comfort_radius=body_radius)
    except NoPath:
        return None
    return float(np.hypot(*np.diff(plan.waypoints, axis=0).T).sum())
