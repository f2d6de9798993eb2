"""The `straight` global planner: the segment from start to goal, nothing else.

A baseline for open spaces and for the `direct` local planner. It only checks that the body fits
at the goal; the segment itself is not checked against the map, so in a cluttered map the local
planner is what keeps the body off the walls.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, ClassVar

import numpy as np

from hubero_dsl.errors import SimulationError
from hubero_dsl.planners.base import NoPath, Plan, PlannerParams
from hubero_dsl.planners.costfield import goal_obstruction

if TYPE_CHECKING:
    from hubero_dsl.world.grid import OccupancyGrid


class StraightLineParams(PlannerParams):
    """The `straight` planner takes no parameters."""


class StraightLinePlanner:
    """Plans the straight segment start -> goal."""

    name: ClassVar[str] = "straight"
    Params: ClassVar[type[PlannerParams]] = StraightLineParams

    def __init__(self, grid: OccupancyGrid, params: PlannerParams) -> None:
        self.grid = grid
        self.params = params

    @classmethod
    def for_sharing(cls, grid: OccupancyGrid, params: PlannerParams) -> StraightLinePlanner:
        """The planner itself: it keeps nothing between plans, so runs can share it."""
        return cls(grid, params)

    def plan(self, start: tuple[float, float], goal: tuple[float, float], *,
             body_radius: float, comfort_radius: float) -> Plan:
        """[start, goal]; raises NoPath when the goal is off the map or the body does not fit
        there. `comfort_radius` is accepted for the protocol and ignored."""
        if not (math.isfinite(body_radius) and body_radius >= 0.0):
            raise SimulationError(f"body radius must be a finite number >= 0 m, not {body_radius}")
        reason = goal_obstruction(self.grid, goal, body_radius)
        if reason is not None:
            raise NoPath(reason)
        return Plan(waypoints=np.array([start, goal], dtype=np.float64))
