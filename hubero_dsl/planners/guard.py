"""Planner plugins answered for: a third-party planner's failure is the user's error, not hubero's.

A planner that is not hubero's own is wrapped as it is built (`guarded_global`,
`guarded_local`). Whatever it raises (`sys.exit` too, but not a Ctrl-C) as it is set up, plans
or steers, and whatever it answers that is no plan or no velocities, becomes a `PlannerError`
naming the planner: the run ends with exit 1 and a message, as a robot controller's failure
does, never as an internal error. It is given read-only copies of the crowd and the drive, so
that it cannot move people by writing into them. Velocities faster than a human's `max_speed`
are capped at it, as the local planner's contract says they are.

hubero's own planners are not wrapped: their failures are hubero's, and cost nothing here.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import fields, is_dataclass, replace
from typing import TYPE_CHECKING, Any, ClassVar, TypeVar, cast

import numpy as np

from hubero_dsl.errors import OUTSIDE_STOPS, SimulationError, failure_of, shown
from hubero_dsl.planners.base import (
    Crowd,
    Drive,
    FloatArray,
    GlobalPlanner,
    LocalPlanner,
    NoPath,
    Plan,
    PlannerParams,
    joined_planner,
)
from hubero_dsl.planners.registry import OWN_PACKAGE

if TYPE_CHECKING:
    from hubero_dsl.world.grid import OccupancyGrid

T = TypeVar("T")

MAX_WAYPOINTS = 100_000  # a cell-by-cell plan 2 km long on a 2 cm map


class PlannerError(SimulationError):
    """A planner plugin raised, or answered something that is not a plan or velocities."""

    def at(self, time: float) -> PlannerError:
        """The same error, saying when in the run it happened (planners do not know)."""
        return PlannerError(f"at t = {time:g} s, {self.message}")


def is_plugin(cls: type) -> bool:
    """Whether a planner class is a third party's, not one of hubero's own."""
    return not cls.__module__.startswith(OWN_PACKAGE)


def built(kind: str, name: str, build: Callable[[], T]) -> T:
    """`build()`, a planner plugin's set-up; what it raises, a PlannerError."""
    try:
        return build()
    except OUTSIDE_STOPS:
        raise
    except BaseException as exc:  # user code: its failure is the user's error
        raise PlannerError(f"{kind} planner '{name}' failed as it was set up: "
                           f"{failure_of(exc)}") from None


def guarded_global(planner: GlobalPlanner, name: str, grid: OccupancyGrid) -> GlobalPlanner:
    if not is_plugin(type(planner)):
        return planner
    # its `name` is the plugin's, an instance's attribute where the protocol has a class's
    return cast(GlobalPlanner, GuardedGlobalPlanner(planner, name, grid))


def guarded_local(planner: LocalPlanner, name: str) -> LocalPlanner:
    if not is_plugin(type(planner)):
        return planner
    return cast(LocalPlanner, GuardedLocalPlanner(planner, name))


class GuardedGlobalPlanner:
    """A global planner plugin whose plans are checked: points of the map, finite."""

    Params: ClassVar[type[PlannerParams]] = PlannerParams

    def __init__(self, inner: GlobalPlanner, name: str, grid: OccupancyGrid) -> None:
        self.inner = inner
        self.name = name  # the plugin's, for messages and for whoever asks
        xmin, ymin, xmax, ymax = grid.bounds
        margin = grid.resolution
        self._bounds = (xmin - margin, ymin - margin, xmax + margin, ymax + margin)

    def plan(self, start: tuple[float, float], goal: tuple[float, float], *,
             body_radius: float, comfort_radius: float) -> Plan:
        asked = f"a plan from ({start[0]:g}, {start[1]:g}) to ({goal[0]:g}, {goal[1]:g})"
        try:
            answer = self.inner.plan(start, goal, body_radius=body_radius,
                                     comfort_radius=comfort_radius)
        except NoPath:
            raise
        except OUTSIDE_STOPS:
            raise
        except BaseException as exc:  # user code
            raise PlannerError(f"global planner '{self.name}', asked for {asked}, raised "
                               f"{failure_of(exc)}") from None
        return Plan(self._waypoints(answer, asked))

    def _waypoints(self, answer: object, asked: str) -> FloatArray:
        waypoints = _floats(answer.waypoints if isinstance(answer, Plan) else None)
        xmin, ymin, xmax, ymax = self._bounds
        if waypoints is None or waypoints.ndim != 2 or waypoints.shape[1:] != (2,) \
                or not len(waypoints) or not np.isfinite(waypoints).all():
            raise PlannerError(f"global planner '{self.name}', asked for {asked}, returned "
                               f"{shown(answer)}, not a Plan of (K, 2) finite waypoints")
        if len(waypoints) > MAX_WAYPOINTS:  # followed waypoint by waypoint, it would never end
            raise PlannerError(f"global planner '{self.name}', asked for {asked}, returned a "
                               f"plan of {len(waypoints):,} waypoints (at most "
                               f"{MAX_WAYPOINTS:,})")
        x, y = waypoints[:, 0], waypoints[:, 1]
        if ((x < xmin) | (x > xmax) | (y < ymin) | (y > ymax)).any():
            raise PlannerError(f"global planner '{self.name}', asked for {asked}, returned "
                               f"waypoints outside the map (x {xmin:g} .. {xmax:g}, y "
                               f"{ymin:g} .. {ymax:g} m)")
        return waypoints


class GuardedLocalPlanner:
    """A local planner plugin that reads the crowd without writing it, and whose velocities
    are checked: one finite pair per human steered, capped at the human's `max_speed`."""

    Params: ClassVar[type[PlannerParams]] = PlannerParams

    def __init__(self, inner: LocalPlanner, name: str) -> None:
        self.inner = inner
        self.name = name  # the plugin's, for messages and for whoever asks

    @classmethod
    def joined(cls, planners: list[GuardedLocalPlanner]) -> GuardedLocalPlanner | None:
        """The plugin's own joined planner, guarded, when its class offers one."""
        name = planners[0].name
        inner = built("local", name, lambda: joined_planner([p.inner for p in planners]))
        return None if inner is None else cls(inner, name)

    def velocities(self, crowd: Crowd, drive: Drive, dt: float) -> FloatArray:
        try:
            answer = self.inner.velocities(_read_only_copy(crowd), _read_only_copy(drive), dt)
        except OUTSIDE_STOPS:
            raise
        except BaseException as exc:  # user code
            raise PlannerError(f"local planner '{self.name}' raised "
                               f"{failure_of(exc)}") from None
        velocity = _floats(answer)
        steered = len(drive.index)
        if velocity is None or velocity.shape != (steered, 2) or \
                not np.isfinite(velocity).all():
            raise PlannerError(f"local planner '{self.name}' returned {shown(answer)}, "
                               f"not a ({steered}, 2) array of finite velocities")
        speed = np.hypot(velocity[:, 0], velocity[:, 1])
        over = speed > drive.max_speed
        if over.any():
            velocity = velocity.copy()
            velocity[over] *= (drive.max_speed[over] / speed[over])[:, None]
        return velocity


def _floats(value: object) -> FloatArray | None:
    """`value` as an array of floats, or None when it is none (a string, a mapping, ...)."""
    if isinstance(value, str | bytes) or value is None:
        return None
    try:
        array = np.array(value, dtype=np.float64)
    except Exception:  # whatever user code returned, it is no array of numbers
        return None
    return array


def _read_only_copy(snapshot: Any) -> Any:
    """A dataclass of arrays with read-only copies of the arrays: writing into one by mistake
    raises, and writing into one on purpose moves nobody."""
    def copied(value: Any) -> Any:
        if isinstance(value, np.ndarray):
            copy = value.copy()
            copy.flags.writeable = False
            return copy
        return _read_only_copy(value) if is_dataclass(value) and not isinstance(value, type) \
            else value

    return replace(snapshot, **{f.name: copied(getattr(snapshot, f.name))
                                for f in fields(snapshot)})
