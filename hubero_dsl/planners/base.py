"""Planner plugins: the Protocols a global or local planner implements, and their registries.

Each planner declares its own parameters as a pydantic model (`Params`), so `social_force.A 2.1`
in a scenario is checked against what the planner really takes. Planners are found through
`hubero_dsl.planners.registry`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, ClassVar, Protocol, runtime_checkable

import numpy as np
import numpy.typing as npt
from pydantic import BaseModel, ConfigDict

from hubero_dsl.world.shapes import ShapeArrays

if TYPE_CHECKING:
    from hubero_dsl.world.grid import OccupancyGrid

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]
BoolArray = npt.NDArray[np.bool_]


class PlannerParams(BaseModel):
    """Base of every planner's parameter model: unknown fields are errors, values are frozen."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    @classmethod
    def inert_above(cls, step: float) -> dict[str, float]:
        """Parameters whose effect the time step caps: above the value given here (for a step
        of `step` seconds) a larger value changes nothing. `hubero check` warns about them."""
        return {}


class NoPath(Exception):  # noqa: N818 - reads as the outcome it is
    """The goal cannot be reached from the start; `reason` says why, for the task's status."""

    def __init__(self, reason: str) -> None:
        super().__init__(reason)
        self.reason = reason


@dataclass(frozen=True, slots=True)
class Plan:
    """A global path in world coordinates, start first, goal last."""

    waypoints: FloatArray  # (K, 2)

    @property
    def length(self) -> float:
        if len(self.waypoints) < 2:
            return 0.0
        return float(np.linalg.norm(np.diff(self.waypoints, axis=0), axis=1).sum())


@runtime_checkable
class GlobalPlanner(Protocol):
    """Plans a path over the static map. One instance serves every human of a run.

    A class may also offer `for_sharing(grid, params)`, a classmethod returning an instance
    whose plans do not depend on the queries it answered before; such an instance (and what
    it caches) then serves many runs of one program, as a gym environment's episodes and
    copies are (`hubero_dsl.sim.simulation.GlobalPlanners`). Without it, every run builds its
    own.
    """

    name: ClassVar[str]
    Params: ClassVar[type[PlannerParams]]

    def __init__(self, grid: OccupancyGrid, params: PlannerParams) -> None: ...

    def plan(self, start: tuple[float, float], goal: tuple[float, float], *,
             body_radius: float, comfort_radius: float) -> Plan:
        """A path the body fits along; cells closer to walls than `comfort_radius` cost more.

        Raises NoPath when the goal is unreachable (occupied, outside, or cut off).
        """
        ...


@dataclass(frozen=True, slots=True)
class Crowd:
    """Every moving body of a run at one tick: humans first, then robots.

    Planner inputs are read-only snapshots; planners return new arrays and never mutate these,
    so results do not depend on the order in which humans are processed.
    """

    position: FloatArray         # (N, 2) m
    velocity: FloatArray         # (N, 2) m/s
    heading: FloatArray          # (N,) rad
    radius: FloatArray           # (N,) body radius, m
    personal_space: ShapeArrays  # (N,) shapes in each body's frame
    is_robot: BoolArray          # (N,)
    # (N,) the simulation each row belongs to, when one call steers several (a vector
    # environment's copies); rows of different worlds never meet. None: one world.
    world: IntArray | None = None

    @property
    def count(self) -> int:
        return int(self.position.shape[0])


@dataclass(frozen=True, slots=True)
class Drive:
    """What the controlled humans want this tick, one row per controlled human."""

    index: IntArray              # (K,) rows of Crowd these humans are
    target: FloatArray           # (K, 2) point to steer towards (next waypoint or goal)
    desired_speed: FloatArray    # (K,) m/s; 0 means hold position
    max_speed: FloatArray        # (K,)
    relaxation_time: FloatArray  # (K,) s
    goal_strength: FloatArray    # (K,)
    avoidance_strength: FloatArray
    obstacle_strength: FloatArray
    interaction_range: FloatArray  # (K,) m
    field_of_view: FloatArray      # (K,) rad


@runtime_checkable
class LocalPlanner(Protocol):
    """Turns each controlled human's target into a velocity, reacting to others and walls."""

    name: ClassVar[str]
    Params: ClassVar[type[PlannerParams]]

    def __init__(self, grid: OccupancyGrid, params: list[PlannerParams]) -> None:
        """`params` holds one model per human of the run (index = Crowd row)."""
        ...

    def velocities(self, crowd: Crowd, drive: Drive, dt: float) -> FloatArray:
        """(K, 2) new velocities for the humans in `drive`, never faster than max_speed."""
        ...


def joined_planner(planners: list[LocalPlanner]) -> LocalPlanner | None:
    """One planner that steers the rows of `planners`' crowds stacked in order, each crowd a
    world of its own (`Crowd.world`), or None when their class cannot.

    A planner class offers this with a classmethod `joined(planners)`; by offering it, it
    promises to keep the worlds of a stacked Crowd apart. A vector environment steers all its
    copies with one call of the joined planner instead of one call per copy.
    """
    cls = type(planners[0])
    join = getattr(cls, "joined", None)
    if join is None or any(type(p) is not cls for p in planners):
        return None
    joined: LocalPlanner = join(planners)
    return joined
