"""Robots under test: bodies driven by controllers, with kinematics, limits and tasks.

Every tick each robot's controller is asked for a velocity command given what its sensors
report (`hubero_dsl.controllers.base.Observation`); the command is shaped by the robot's
kinematics and limits (speed, acceleration, turn rate) and the robot moves, never through a
wall. A velocity set through the API overrides the controller and the kinematics until it is
cleared (a unicycle moves sideways at it too, facing where it goes); a command given through
the API (`drive`, as the Gym environment does each step) takes the controller's place and goes
through the kinematics like the controller's answer would.

Robots take tasks from activities like humans (`move_to`, `stand`, `follow`): a task sets the
goal the controller is given and ends as a human's would (arrived, time up, stuck, the target
gone), with the same statuses and events. An exception or a wrong answer from a controller
is the controller's error: `ControllerError`, naming the robot, the time and the cause.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from hubero_dsl.controllers.base import Neighbour, Observation, RobotBody, RobotController
from hubero_dsl.errors import OUTSIDE_STOPS, SimulationError, failure_of, shown
from hubero_dsl.model.tasks import Target, Task
from hubero_dsl.model.units import finite_pair
from hubero_dsl.sim import physics
from hubero_dsl.sim.arrays import BoolArray, FloatArray, HumanArrays, IntArray
from hubero_dsl.sim.status import TaskHandle, TaskStatus, stuck_reason
from hubero_dsl.world.shapes import Circle, ShapeArrays

if TYPE_CHECKING:
    from hubero_dsl.model.program import RobotSpec
    from hubero_dsl.world.grid import OccupancyGrid

PROGRESS = 0.5   # m a robot with a goal must make within the stuck time
StatusSetter = Callable[[TaskHandle, TaskStatus, str], None]


class ControllerError(SimulationError):
    """A robot's controller raised, or answered something that is not a velocity."""


@dataclass
class RobotTask:
    """What a robot's current task asks of it."""

    handle: TaskHandle
    task: Task
    deadline: int | None          # tick at which a timed task succeeds
    stop_distance: float
    speed: float


class Robots:
    """All robots: their state as arrays, their controllers and their tasks."""

    def __init__(self, specs: tuple[RobotSpec, ...], grid: OccupancyGrid, dt: float,
                 controllers: Mapping[str, RobotController] | None = None) -> None:
        self.specs = specs
        self.names = [s.name for s in specs]
        self.grid = grid
        count = len(specs)
        self.position: FloatArray = np.array([s.start.xy for s in specs], float).reshape(count, 2)
        self.moved_from: FloatArray = self.position  # where each robot's last move began
        self.velocity: FloatArray = np.zeros((count, 2))
        self.heading: FloatArray = np.array([s.start.heading or 0.0 for s in specs], float)
        self.radius: FloatArray = np.array([s.radius for s in specs], float)
        self.speed: FloatArray = np.array([s.speed for s in specs], float)
        self.path_length: FloatArray = np.zeros(count)
        self.personal_space = ShapeArrays.from_shapes([Circle(s.radius) for s in specs])
        self.commanded: dict[int, tuple[float, float]] = {}
        self.driven: dict[int, tuple[float, float]] = {}
        # which may slide along a wall that stops them: a unicycle cannot move sideways
        self.slides: BoolArray = np.array([s.kinematics == "holonomic" for s in specs], bool)
        self._holonomic = np.flatnonzero(self.slides).tolist()
        self.controllers: list[RobotController] = [
            (controllers or {})[s.name] for s in specs] if count else []
        self.tasks: list[RobotTask | None] = [None] * count
        self._anchor = self.position.copy()
        self._anchor_tick = np.zeros(count, dtype=np.int64)

    @property
    def count(self) -> int:
        return len(self.specs)

    def controller_names(self) -> list[str]:
        """Who drives each robot: the registered controller its declaration names, or
        `MODULE:CLASS` of a controller handed over in its place."""
        from hubero_dsl.controllers.registry import controller_class

        names = []
        for spec, controller in zip(self.specs, self.controllers, strict=True):
            cls = type(controller)
            registered = spec.controller and controller_class(spec.controller) is cls
            names.append(spec.controller if registered else f"{cls.__module__}:{cls.__qualname__}")
        return names

    def index_of(self, name: str) -> int:
        return self.names.index(name)

    def position_of(self, name: str) -> tuple[float, float] | None:
        if name not in self.names:
            return None
        x, y = self.position[self.names.index(name)]
        return (float(x), float(y))

    def radius_of(self, name: str) -> float:
        return float(self.radius[self.names.index(name)]) if name in self.names else 0.0

    def set_velocity(self, name: str, velocity: tuple[float, float] | None) -> None:
        """Move the robot at `velocity` from now on, whatever its kinematics, facing where it
        goes (None: back to its controller)."""
        _override(self.commanded, self.names.index(name), velocity)

    def drive(self, name: str, command: tuple[float, float] | None) -> None:
        """Answer for the robot's controller from now on: `command` is what a controller would
        return, (vx, vy) or (v, omega) by the robot's kinematics (None: ask the controller
        again). The controller is not asked, so no observation is built for it."""
        _override(self.driven, self.names.index(name), command)

    # ---- one tick ----------------------------------------------------------------------------

    def wanted(self, dt: float, tick: int, humans: HumanArrays,
               position_of: Callable[[Target], tuple[float, float] | None]
               ) -> list[tuple[float, float]]:
        """The velocity each robot is to move at this tick: its command (the controller
        asked, unless the API gave one) shaped by its kinematics and limits."""
        time = tick * dt
        wanted = []
        for i in range(self.count):
            if i in self.commanded:
                vx, vy = self.commanded[i]
                wanted.append(self._limited(i, vx, vy, dt))
            else:
                command = self.driven.get(i)
                if command is None:
                    command = self._ask(i, self._observe(i, time, humans, position_of), time)
                wanted.append(self._move(i, command, dt))
        return wanted

    def _face(self, velocity: Sequence[Sequence[float]]) -> None:
        """A holonomic robot faces where it goes, and so does any robot moved by a velocity set
        through the API, which takes no heading (numpy's arctan2 on floats: the values its
        arrays would give)."""
        facing = sorted({*self._holonomic, *self.commanded}) if self.commanded \
            else self._holonomic
        for i in facing:
            vx, vy = velocity[i]
            if math.hypot(vx, vy) > 1e-6:
                self.heading[i] = np.arctan2(vy, vx)

    def _moved_few(self, wanted: list[tuple[float, float]], dt: float
                   ) -> Sequence[Sequence[float]] | None:
        """`move_fleets` for a few robots, in floats with the arrays' arithmetic (numpy's
        calls on arrays of one row cost more than the arithmetic); None when a coordinate is
        not finite, which the arrays handle."""
        old = self.position.tolist()
        proposed = [(x + vx * dt, y + vy * dt)
                    for (x, y), (vx, vy) in zip(old, wanted, strict=True)]
        stops = physics.wall_stops(self.grid, old, proposed, self.radius.tolist(),
                                   keep=physics.ROBOT_WALL_KEEP, slides=self.slides.tolist())
        if stops is None:
            return None
        moved = [stops.get(i, p) for i, p in enumerate(proposed)]
        step = [(mx - x, my - y) for (mx, my), (x, y) in zip(moved, old, strict=True)]
        if any(stops[i] != proposed[i] for i in stops):
            wanted = [(sx / dt, sy / dt) for sx, sy in step]  # as `move_fleets`: every row
        self.velocity = np.array(wanted, dtype=np.float64).reshape(self.count, 2)
        self.position = np.array(moved, dtype=np.float64).reshape(self.count, 2)
        for i, (sx, sy) in enumerate(step):
            self.path_length[i] += np.hypot(sx, sy)
        return wanted

    def _observe(self, i: int, time: float, humans: HumanArrays,
                 position_of: Callable[[Target], tuple[float, float] | None]) -> Observation:
        spec = self.specs[i]
        here = self.position[i]
        goal, stop, speed = None, spec.goal_tolerance, float(self.speed[i])
        task = self.tasks[i]
        if task is not None:
            stop, speed = task.stop_distance, task.speed
            if task.task.kind != "stand" and task.task.target is not None:
                goal = position_of(task.task.target)
        return Observation(
            time=time, position=(float(here[0]), float(here[1])),
            velocity=(float(self.velocity[i, 0]), float(self.velocity[i, 1])),
            heading=float(self.heading[i]), goal=goal, stop_distance=stop, speed=speed,
            people=self.seen_by(i, humans.names, humans.position, humans.velocity,
                              humans.radius),
            robots=self.seen_by(i, self.names, self.position, self.velocity, self.radius))

    def seen_by(self, i: int, names: list[str], position: FloatArray, velocity: FloatArray,
              radius: FloatArray) -> tuple[Neighbour, ...]:
        """Bodies within the robot's sensor range and field of view, nearest first."""
        if not len(names):
            return ()
        rows = self.seen_rows(i, position, radius)
        return tuple(Neighbour(names[r], (float(position[r, 0]), float(position[r, 1])),
                               (float(velocity[r, 0]), float(velocity[r, 1])), float(radius[r]))
                     for r in rows)

    def seen_rows(self, i: int, position: FloatArray, radius: FloatArray) -> IntArray:
        """The rows of the bodies at `position` that robot `i` sees, nearest first."""
        offset, distance = self.offsets_from(i, position)
        visible = in_view(self.specs[i], offset, distance - radius, float(self.heading[i]))
        if position is self.position:
            visible[i] = False
        rows = visible.nonzero()[0]
        return rows[np.argsort(distance[rows], kind="stable")]

    def offsets_from(self, i: int, position: FloatArray) -> tuple[FloatArray, FloatArray]:
        """The offset of each body at `position` from robot `i`'s centre, and its length."""
        offset = position - self.position[i]
        return offset, np.hypot(offset[:, 0], offset[:, 1])

    def _ask(self, i: int, observation: Observation, time: float) -> tuple[float, float]:
        controller = self.controllers[i]
        try:
            command = controller.command(observation)
        except OUTSIDE_STOPS:
            raise
        except BaseException as exc:  # user code: its failure is the user's error
            raise ControllerError(
                f"robot '{self.names[i]}' at t = {time:g} s: its controller "
                f"{type(controller).__name__} raised {failure_of(exc)}") from None
        return _velocity_command(command, self.names[i], type(controller).__name__, time)

    # A robot's command is two numbers: shaped with math on floats, which costs a fraction of
    # what numpy's calls on arrays of two would, every tick of every episode.

    def _move(self, i: int, command: tuple[float, float], dt: float) -> tuple[float, float]:
        """The velocity a command gives this tick, under the robot's kinematics and limits."""
        spec = self.specs[i]
        if spec.kinematics == "holonomic":
            return self._limited(i, command[0], command[1], dt)
        forward, turn = command
        limit = spec.max_angular_speed
        turn = max(-limit, min(limit, turn))
        old_heading = float(self.heading[i])
        heading = physics.wrap_angle(old_heading + turn * dt)
        self.heading[i] = heading
        # a unicycle's speed is along its heading: its limits bound the forward speed, which
        # then turns with the heading (no velocity lagging sideways behind it)
        now = (float(self.velocity[i, 0]) * math.cos(old_heading)
               + float(self.velocity[i, 1]) * math.sin(old_heading))
        forward = max(-spec.max_speed, min(spec.max_speed, forward))
        most = spec.max_acceleration * dt
        forward = max(now - most, min(now + most, forward))
        return (math.cos(heading) * forward, math.sin(heading) * forward)

    def _limited(self, i: int, vx: float, vy: float, dt: float) -> tuple[float, float]:
        """(vx, vy) within the robot's speed limit, reached from its current velocity within
        its acceleration limit."""
        spec = self.specs[i]
        speed = math.hypot(vx, vy)
        if speed > spec.max_speed:
            vx, vy = vx * (spec.max_speed / speed), vy * (spec.max_speed / speed)
        now_x, now_y = float(self.velocity[i, 0]), float(self.velocity[i, 1])
        change_x, change_y = vx - now_x, vy - now_y
        most = spec.max_acceleration * dt
        size = math.hypot(change_x, change_y)
        if size > most:
            vx, vy = now_x + change_x * (most / size), now_y + change_y * (most / size)
        return (vx, vy)

    # ---- tasks -------------------------------------------------------------------------------

    def start(self, name: str, task: Task, handle: TaskHandle, tick: int, dt: float,
              radius_of: Callable[[str], float]) -> None:
        """Give the robot `task` (the caller has preempted the one it had)."""
        i = self.index_of(name)
        spec = self.specs[i]
        duration = task.get("duration")
        deadline = tick + max(1, round(duration / dt)) if duration is not None else None
        stop = spec.goal_tolerance
        if task.kind == "follow":
            stop = float(task.get("distance"))
        if isinstance(task.target, str):  # a body: stop beside it, not on it
            stop += radius_of(task.target) + spec.radius
        speed = float(task.get("speed") or spec.speed)
        self.tasks[i] = RobotTask(handle, task, deadline, stop, speed)
        self._anchor[i] = self.position[i]
        self._anchor_tick[i] = tick

    def current(self, name: str) -> RobotTask | None:
        return self.tasks[self.index_of(name)]

    def clear(self, name: str) -> None:
        self.tasks[self.index_of(name)] = None

    def settle(self, tick: int, dt: float, stuck_ticks: int,
               position_of: Callable[[Target], tuple[float, float] | None],
               finish: Callable[[str, TaskStatus, str], None],
               standing_at: Callable[[tuple[float, float], FloatArray, float], str | None]
               ) -> None:
        """End the tasks whose end has come: arrived, time up, stuck, or the target gone. A
        robot stuck near a goal someone stands on is told so in the reason; unlike a person,
        it does not count that as arriving (its success is what a benchmark measures)."""
        for i, task in enumerate(self.tasks):
            if task is None:
                continue
            name, kind = self.names[i], task.task.kind
            goal = position_of(task.task.target) if task.task.target is not None else None
            if task.task.target is not None and goal is None:
                finish(name, TaskStatus.ABORTED, f"target '{task.task.target}' disappeared")
            elif self._done(i, task, goal, tick):
                finish(name, TaskStatus.SUCCEEDED, "")
            elif kind == "move_to" and (problem := self._problem(i)) is not None:
                finish(name, TaskStatus.ABORTED, problem)  # its controller cannot get there
            elif kind == "move_to" and self._stuck(i, tick, stuck_ticks):
                taker = None if goal is None else standing_at(goal, self.position[i],
                                                              task.stop_distance)
                finish(name, TaskStatus.ABORTED, stuck_reason(stuck_ticks * dt, taker))

    def _problem(self, i: int) -> str | None:
        """Why the controller cannot reach the goal, if it says (the navigator's `problem`)."""
        problem = getattr(self.controllers[i], "problem", None)
        return problem if isinstance(problem, str) else None

    def _done(self, i: int, task: RobotTask, goal: tuple[float, float] | None,
              tick: int) -> bool:
        if task.deadline is not None and tick >= task.deadline:
            return True
        return task.task.kind == "move_to" and goal is not None and \
            math.dist(goal, self.position[i]) <= task.stop_distance

    def _stuck(self, i: int, tick: int, stuck_ticks: int) -> bool:
        if math.dist(self.position[i], self._anchor[i]) > PROGRESS:
            self._anchor[i] = self.position[i]
            self._anchor_tick[i] = tick
        return tick - int(self._anchor_tick[i]) > stuck_ticks


def in_view(spec: RobotSpec, offset: FloatArray, surface: FloatArray,
            heading: float | FloatArray) -> BoolArray:
    """Which bodies a robot of `spec` facing `heading` (per body, or one for all) sees: those
    within its sensor range, surface to surface (`surface`: each body's surface distance from
    the robot's centre), and its field of view (`offset`: each body's centre from the
    robot's)."""
    visible = surface - spec.radius <= spec.sensor_range
    if spec.field_of_view < 2 * math.pi:
        bearing = np.arctan2(offset[:, 1], offset[:, 0]) - heading
        visible &= np.abs(physics.wrap_angle(bearing)) <= spec.field_of_view / 2
    return visible


def move_fleets(fleets: Sequence[Robots], wanted: Sequence[list[tuple[float, float]]],
                dt: float) -> None:
    """Move the robots of one simulation, or of many at once (a vector environment's copies,
    on one map), at the velocities `wanted` (`Robots.wanted`), never through a wall. Each
    robot moves as it would alone: the walls are kept out for all rows in one call, and a
    fleet in which a wall stopped or bent someone's move takes the velocities of its steps
    (every row's, as alone). Where each moved from is kept for `stop_at_people`."""
    for fleet in fleets:
        fleet.moved_from = fleet.position  # replaced by the move, never written into
    _move_fleets(fleets, wanted, dt)


_FEW_PAIRS = 64  # robots x people up to which a robot's stop at people is found in floats


def stop_at_people(fleets: Sequence[Robots], people: Sequence[HumanArrays], dt: float) -> None:
    """At a tick's end, once people have moved and been pushed off the robots: a robot still
    inside someone, who could not yield (seated, lying, pressed against a wall or a crowd),
    is taken back along its move to where their bodies touch (a collision, as the metrics
    count it), rather than drive through them. Whoever could yield did, and stops no robot."""
    olds = [fleet.moved_from for fleet in fleets]
    humans = [h.position for h in people]
    count = sum(len(h) for h in humans)
    if not count:
        return
    if len(fleets) == 1 and fleets[0].count * count <= _FEW_PAIRS:
        share = np.array(physics.few_contact_fractions(
            olds[0].tolist(), fleets[0].position.tolist(), fleets[0].radius.tolist(),
            humans[0].tolist(), people[0].radius.tolist()))
    else:
        share = physics.contact_fractions(
            np.concatenate(olds), np.concatenate([fleet.position for fleet in fleets]),
            np.concatenate([fleet.radius for fleet in fleets]), np.concatenate(humans),
            np.concatenate([h.radius for h in people]),
            _pairs_within([fleet.count for fleet in fleets], [len(h) for h in humans]))
    if (share >= 1.0).all():
        return
    start = 0
    for fleet, before in zip(fleets, olds, strict=True):
        part = share[start:start + fleet.count]
        start += fleet.count
        for i in np.flatnonzero(part < 1.0).tolist():
            whole = fleet.position[i] - before[i]
            step = whole * part[i]
            # the part of the move not made is taken back off the length walked (np.hypot, as
            # the moves counted it)
            fleet.path_length[i] += np.hypot(*step) - np.hypot(*whole)
            fleet.position[i] = before[i] + step
            fleet.velocity[i] = step / dt


def _pairs_within(robots: list[int], people: list[int]) -> tuple[IntArray, IntArray]:
    """Every (robot row, person row) of the same simulation, simulations' rows stacked one
    after another (`robots[k]` and `people[k]` rows of simulation k)."""
    per_robot = np.repeat(people, robots)               # each robot's simulation's people
    first_person = np.repeat(np.cumsum([0, *people[:-1]]), robots)
    robot = np.repeat(np.arange(len(per_robot)), per_robot)
    before = np.repeat(np.cumsum(per_robot) - per_robot, per_robot)  # pairs of earlier robots
    return robot, np.repeat(first_person, per_robot) + np.arange(len(robot)) - before


def _move_fleets(fleets: Sequence[Robots], wanted: Sequence[list[tuple[float, float]]],
                 dt: float) -> None:
    if len(fleets) == 1 and fleets[0].count <= physics.FEW_BODIES:
        few = fleets[0]._moved_few(list(wanted[0]), dt)
        if few is not None:
            fleets[0]._face(few)
            return
    velocity = np.array([v for fleet in wanted for v in fleet], dtype=np.float64).reshape(-1, 2)
    if not len(velocity):
        return
    old = np.concatenate([fleet.position for fleet in fleets])
    proposed = old + velocity * dt
    moved = physics.keep_out_of_walls(fleets[0].grid, old, proposed,
                                      np.concatenate([fleet.radius for fleet in fleets]),
                                      keep=physics.ROBOT_WALL_KEEP,
                                      slides=np.concatenate([fleet.slides for fleet in fleets]))
    step = moved - old
    starts = list(itertools.accumulate((fleet.count for fleet in fleets), initial=0))
    if moved is not proposed:
        stopped = (moved != proposed).any(axis=1)
        for start, end in itertools.pairwise(starts):
            if stopped[start:end].any():
                velocity[start:end] = step[start:end] / dt
    walked = np.concatenate([fleet.path_length for fleet in fleets]) + np.hypot(step[:, 0],
                                                                                 step[:, 1])
    rows = velocity.tolist()
    for fleet, (start, end) in zip(fleets, itertools.pairwise(starts), strict=True):
        fleet.velocity, fleet.position = velocity[start:end], moved[start:end]
        fleet.path_length = walked[start:end]
        fleet._face(rows[start:end])


def _override(table: dict[int, tuple[float, float]], index: int,
              value: tuple[float, float] | None) -> None:
    """Set robot `index`'s entry of an override table, or clear it with None."""
    if value is None:
        table.pop(index, None)
    else:
        table[index] = value


def _velocity_command(command: Any, robot: str, controller: str,
                      time: float) -> tuple[float, float]:
    """Two finite real numbers (a pair, a list, an array of two), or the controller's error:
    not a mapping (its keys are no velocity), an iterator or a pair of truth values."""
    try:
        first, second = command if isinstance(command, Sequence | np.ndarray) \
            and not isinstance(command, str | bytes) else (None, None)
        velocity = finite_pair(first, second)
        if velocity is not None:
            return velocity
    except Exception:  # whatever reading the answer raises, the answer is not a velocity
        pass
    raise ControllerError(f"robot '{robot}' at t = {time:g} s: its controller {controller} "
                          f"returned {shown(command)}, not a velocity (two finite numbers)")


def robot_body(spec: RobotSpec, grid: OccupancyGrid, dt: float) -> RobotBody:
    return RobotBody(name=spec.name, radius=spec.radius, kinematics=spec.kinematics,
                     speed=spec.speed, max_speed=spec.max_speed,
                     max_acceleration=spec.max_acceleration,
                     max_angular_speed=spec.max_angular_speed,
                     goal_tolerance=spec.goal_tolerance, path=spec.path, loop=spec.loop,
                     grid=grid, dt=dt)
