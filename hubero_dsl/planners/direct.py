"""The direct local planner, and the goal-seeking term every local planner shares.

`DirectPlanner` steers each human straight at its target at the desired speed, ignoring
people and walls: a baseline, and a cheap planner for tests. `goal_acceleration` is the
relaxation towards the desired velocity with the arrival slow-down that lets humans stop at a
goal instead of orbiting it; the social force planner uses the same function.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, ClassVar, TypeVar

import numpy as np
import numpy.typing as npt
from pydantic import Field

from hubero_dsl.errors import SimulationError
from hubero_dsl.planners.base import Crowd, Drive, PlannerParams

if TYPE_CHECKING:
    from hubero_dsl.world.grid import OccupancyGrid

FloatArray = npt.NDArray[np.float64]
ModelT = TypeVar("ModelT", bound=PlannerParams)

# Planners cannot tell a path's last point from a waypoint on the way, so the slow-down must
# start closer than the distance at which the engine moves on to the next waypoint (0.6 m),
# or humans would slow at every corner.
ARRIVAL_RADIUS = 0.5
ARRIVAL_RADIUS_DOC = (
    "Distance from the target at which the desired speed starts to fall linearly to zero, m. "
    "Inside it the relaxation is made at least critically damped, so a human stops at its "
    "target without overshooting; it is widened to 4 * speed * dt when smaller, which keeps the "
    "discrete step from overshooting too. Keep it below the engine's waypoint look-ahead, or "
    "humans slow down at every waypoint.")


class DirectParams(PlannerParams):
    """Parameters of the direct planner."""

    arrival_radius: float = Field(default=ARRIVAL_RADIUS, gt=0.0, description=ARRIVAL_RADIUS_DOC,
                                  json_schema_extra={"dimension": "length"})


def goal_acceleration(position: FloatArray, velocity: FloatArray, drive: Drive,
                      arrival_radius: FloatArray | float, dt: float) -> FloatArray:
    """(K, 2) acceleration towards each human's desired velocity, with arrival slow-down.

    Far from the target the desired velocity is `desired_speed` along the line to the target
    and the relaxation rate is goal_strength / relaxation_time (Helbing & Molnar 1995). Within
    the arrival radius r the desired speed falls to speed * d / r, and the rate is raised to at
    least 4 * speed / r, the value that makes the approach x'' = rate * (speed * x / r - x')
    critically damped. The rate is capped at 1 / dt: a larger one would step past the desired
    velocity.
    """
    to_target = drive.target - position
    distance = np.hypot(to_target[:, 0], to_target[:, 1])
    heading_to_target = to_target / np.maximum(distance, 1e-9)[:, None]
    speed = drive.desired_speed
    ramp = np.maximum(arrival_radius, 4.0 * speed * dt)
    slowing = distance < ramp
    rate = drive.goal_strength / drive.relaxation_time
    if slowing.any():
        desired_speed = np.where(slowing, speed * distance / ramp, speed)
        rate = np.where(slowing, np.maximum(rate, 4.0 * speed / ramp), rate)
    else:
        desired_speed = speed
    rate = np.minimum(rate, 1.0 / dt)
    desired = heading_to_target * desired_speed[:, None]
    return np.asarray((desired - velocity) * rate[:, None], dtype=np.float64)


def clip_speed(velocity: FloatArray, max_speed: FloatArray) -> FloatArray:
    """Scale down every row faster than its max_speed to exactly max_speed."""
    speed = np.hypot(velocity[:, 0], velocity[:, 1])
    scale = np.minimum(1.0, max_speed / np.maximum(speed, 1e-12))
    return np.asarray(velocity * scale[:, None], dtype=np.float64)


def params_as(model: type[ModelT], params: list[PlannerParams], planner: str) -> list[ModelT]:
    """Each entry as a `model`; a bare `PlannerParams()` (e.g. for a robot) means the defaults."""
    converted: list[ModelT] = []
    for row, entry in enumerate(params):
        if isinstance(entry, model):
            converted.append(entry)
        elif type(entry) is PlannerParams:
            converted.append(model())
        else:
            raise SimulationError(f"the {planner} planner got parameters of type "
                                  f"{type(entry).__name__} for body {row}; it takes "
                                  f"{model.__name__}")
    return converted


def check_drive(crowd: Crowd, drive: Drive, rows_with_params: int) -> None:
    """Raise SimulationError when the drive names rows the crowd or the parameters lack."""
    if not drive.index.size:
        return
    lowest, highest = int(drive.index.min()), int(drive.index.max())
    if lowest < 0 or highest >= crowd.count:
        raise SimulationError(f"a drive names crowd rows outside 0..{crowd.count - 1}")
    if highest >= rows_with_params:
        raise SimulationError(f"a drive names crowd row {highest} but the planner "
                              f"was given parameters for {rows_with_params} bodies")


class DirectPlanner:
    """Steers straight at the target; people and obstacles are ignored."""

    name: ClassVar[str] = "direct"
    Params: ClassVar[type[PlannerParams]] = DirectParams

    def __init__(self, grid: OccupancyGrid, params: list[PlannerParams]) -> None:
        self.grid = grid
        models = params_as(DirectParams, params, self.name)
        self._arrival_radius = np.array([m.arrival_radius for m in models], dtype=np.float64)

    @classmethod
    def joined(cls, planners: list[DirectPlanner]) -> DirectPlanner:
        """One planner for the stacked crowds of `planners` (nobody meets anyone here)."""
        joined = cls(planners[0].grid, [])
        joined._arrival_radius = np.concatenate([p._arrival_radius for p in planners])
        return joined

    def velocities(self, crowd: Crowd, drive: Drive, dt: float) -> FloatArray:
        """(K, 2) new velocities: relax towards the target, slow down on arrival, clip."""
        check_drive(crowd, drive, self._arrival_radius.shape[0])
        rows = drive.index
        velocity = crowd.velocity[rows]
        acceleration = goal_acceleration(crowd.position[rows], velocity, drive,
                                         self._arrival_radius[rows], dt)
        new_velocity = clip_speed(velocity + acceleration * dt, drive.max_speed)
        # robots are driven by their scripts, never by a local planner
        robots = crowd.is_robot[rows]
        new_velocity[robots] = velocity[robots]
        return new_velocity
