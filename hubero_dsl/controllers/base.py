"""The robot controller interface: what a controller is told, sees, and answers each tick.

A controller is built once per run with its robot (`RobotBody`: size, kinematics, limits, the
map) and its parameters (a pydantic model, `Params`, checked like a planner's), and is asked
every tick for a velocity command given what the robot's sensors would report (`Observation`):
its own state and goal, and the people and robots within its sensor range and field of view.

A command is two numbers: `(vx, vy)` in m/s in the map frame for a holonomic robot, `(v, omega)`
(forward speed in m/s, turn rate in rad/s, counter-clockwise) for a unicycle. The engine then
applies the robot's limits (speed, acceleration, turn rate) and keeps it out of walls, so a
controller cannot drive a robot faster than declared or through an obstacle.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar, Literal, Protocol, runtime_checkable

from pydantic import BaseModel, ConfigDict

if TYPE_CHECKING:
    from hubero_dsl.world.grid import OccupancyGrid

Point = tuple[float, float]
Kinematics = Literal["holonomic", "unicycle"]


class ControllerParams(BaseModel):
    """Base of every controller's parameter model: unknown fields are errors, values frozen."""

    model_config = ConfigDict(extra="forbid", frozen=True)


def params_of(controller: type) -> Any:
    """A controller class's parameter model: its `Params`, or none (`ControllerParams`
    itself, which takes no field) when it declares none."""
    return getattr(controller, "Params", ControllerParams)


@dataclass(frozen=True, slots=True)
class RobotBody:
    """A robot as its controller knows it from the start."""

    name: str
    radius: float
    kinematics: Kinematics
    speed: float                 # cruise speed, m/s
    max_speed: float             # inf when not limited
    max_acceleration: float      # m/s^2, inf when not limited
    max_angular_speed: float     # rad/s, inf when not limited
    goal_tolerance: float
    path: tuple[Point, ...]      # the declared route (for the `path` controller)
    loop: bool
    grid: OccupancyGrid
    dt: float                    # s per tick

    @property
    def cruise_speed(self) -> float:
        return min(self.speed, self.max_speed)


@dataclass(frozen=True, slots=True)
class Neighbour:
    """A person or robot the sensors report: where, how fast, how big."""

    name: str
    position: Point
    velocity: Point
    radius: float

    def gap(self, point: Point, radius: float) -> float:
        """Surface-to-surface distance from a disc of `radius` at `point`."""
        return math.hypot(self.position[0] - point[0],
                          self.position[1] - point[1]) - self.radius - radius


@dataclass(frozen=True, slots=True)
class Observation:
    """What a robot knows at one tick."""

    time: float                  # s since the start
    position: Point
    velocity: Point
    heading: float               # rad, map frame
    goal: Point | None           # where its task sends it now; None: stay where it is
    stop_distance: float         # how close to the goal counts as there
    speed: float                 # the speed its task asks for (m/s)
    people: tuple[Neighbour, ...]   # humans within sensor range and field of view, nearest first
    robots: tuple[Neighbour, ...]   # other robots likewise


@runtime_checkable
class RobotController(Protocol):
    """Drives one robot. Built as `Controller(body, params)`; `command` is called every tick."""

    Params: ClassVar[type[ControllerParams]]

    def command(self, observation: Observation) -> tuple[float, float]: ...
