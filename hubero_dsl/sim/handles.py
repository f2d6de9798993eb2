"""The control API (the paper's requirement a): command each human, and each robot, on its own.

`HumanHandle` is what `Simulation.human(name)` returns, `RobotHandle` what `Simulation.robot(name)`
returns. Every command returns a `TaskHandle`
whose status goes PENDING -> ACTIVE -> SUCCEEDED / PREEMPTED / ABORTED (with a reason); a new
command preempts the current one. Targets are `(x, y)` points in metres, or the name of a place,
a human or a robot (that body's position when the task starts or re-plans). Angles are radians,
durations seconds, speeds m/s.

`do(kind, target, **arguments)` gives a task of any kind in the task registry
(`hubero_dsl.model.tasks.TASKS`), with the registry's argument names; the named methods
(`move_to`, `talk`, ...) are the same calls spelt out. The scheduler gives scenario tasks through
`give`, so scenario files and Python callers command humans the same way. Robots take the kinds
the registry marks for robots (`move_to`, `stand`, `follow`); their controller drives them
towards the goal a task gives.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import replace
from typing import TYPE_CHECKING, Any

import numpy as np
from shapely.geometry import Polygon

from hubero_dsl.errors import SimulationError
from hubero_dsl.model.tasks import TASKS, Target, TargetRule, Task, TaskKind, ValueKind
from hubero_dsl.model.units import LARGEST, Dimension, finite_pair, real_number
from hubero_dsl.sim.behaviours import BEHAVIOURS, Behaviour
from hubero_dsl.sim.status import Posture, TaskHandle

if TYPE_CHECKING:
    from hubero_dsl.diagnostics import Span
    from hubero_dsl.sim.engine import Engine

# the units the API takes values in (SI: an angle in radians)
SI_UNIT = {Dimension.TIME: "s", Dimension.LENGTH: "m", Dimension.SPEED: "m/s",
           Dimension.ANGLE: "rad"}


class _Actor:
    """What humans and robots share: tasks given by kind, checked against the registry."""

    def __init__(self, engine: Engine, name: str, places: dict[str, tuple[float, float]],
                 ids: itertools.count[int]) -> None:
        self._engine = engine
        self.name = name
        self._places = places
        self._ids = ids

    def do(self, kind: str, target: Target | None = None, *, span: Span | None = None,
           **arguments: Any) -> TaskHandle:
        """Give a task of any registered kind: `do("move_to", (2, 3), speed=1.0)`.
        Arguments left None are not given (the kind's default applies)."""
        given = {name: value for name, value in arguments.items() if value is not None}
        return self.give(Task(kind, target, given, span))

    def give(self, task: Task) -> TaskHandle:
        """Give `task` (checked against the registry), preempting the current one."""
        if self.name in self._engine.removed:
            raise SimulationError(f"{self.name} was removed: it takes no more tasks")
        kind = self._kind(task.kind)
        target = self._task_target(kind, task.target)
        arguments = {name: self._argument(kind, name, value)
                     for name, value in task.arguments.items()}
        resolved = replace(task, kind=kind.name, target=target, arguments=arguments)
        # named as given (a place by its name), numbers as read (a Fraction as a float)
        described = kind.describe(
            _as_given(task.target, target),
            {n: _as_given(task.arguments[n], value) for n, value in arguments.items()})
        handle = TaskHandle(next(self._ids), self.name, kind.name, described, task.span)
        handle._cancel = self._engine.cancel
        self._start(resolved, handle)
        return handle

    def _kind(self, name: str) -> TaskKind:
        kind = TASKS.get(name)
        if kind is None:
            raise SimulationError(f"unknown task '{name}' (tasks: {', '.join(TASKS)})")
        return kind

    def _start(self, task: Task, handle: TaskHandle) -> None:
        raise NotImplementedError

    def _task_target(self, kind: TaskKind, target: Target | None) -> Target | None:
        if kind.target is TargetRule.NONE:
            if target is not None:
                raise SimulationError(f"{kind.name} takes no target (use "
                                      f"{kind.hint_keyword}=...)")
            return None
        if target is None:
            raise SimulationError(f"{kind.name} needs a target")
        if kind.target is TargetRule.BODY:
            if not isinstance(target, str) or target in self._places:
                what = "a place" if isinstance(target, str) else "a point"
                raise SimulationError(f"{kind.name} needs a human or robot, not {what}")
            if target == self.name:
                raise SimulationError(f"{self.name} cannot {kind.name} itself")
            self._required_target(target)
            return target  # the body itself, wherever it goes
        return self._required_target(target)

    def _argument(self, kind: TaskKind, name: str, value: Any) -> Any:
        """An option's value checked as a scenario file's is: of its kind, finite, within the
        language's bounds (`units.LARGEST`); SimulationError, when given, where it is not."""
        spec = kind.argument(name)
        if spec is None:
            takes = ", ".join(o.argument for o in kind.options) or "nothing"
            raise SimulationError(f"{kind.name} takes no '{name}' (it takes {takes})")
        if spec.value is ValueKind.TARGET:
            if value == self.name:  # as a file's checker says (E203): not at oneself
                raise SimulationError(f"{self.name} cannot {kind.name} {name} itself")
            return self._required_target(value)
        if spec.value is ValueKind.AREA:
            if not isinstance(value, Polygon):
                raise SimulationError(f"{kind.name}: {name} must be a shapely Polygon, not "
                                      f"{value!r:.60}")
            return value
        if spec.value is ValueKind.COUNT:
            if not isinstance(value, int | np.integer) or isinstance(value, bool) or value < 1:
                raise SimulationError(f"{kind.name}: {name} must be a whole number of at least "
                                      f"1, not {value!r:.60}")
            return int(value)
        dimension = spec.value.dimension
        assert dimension is not None  # what is left is a time, a length, a speed or an angle
        number, largest = real_number(value), LARGEST[dimension]
        if number is None or not math.isfinite(number) or abs(number) > largest:
            raise SimulationError(f"{kind.name}: {name} must be a finite number of at most "
                                  f"{largest:g} {SI_UNIT[dimension]}, not {value!r:.60}")
        if spec.value is not ValueKind.ANGLE and number <= 0:
            raise SimulationError(f"{name} must be greater than zero")
        return number

    def _required_target(self, target: Target) -> Target:
        if not isinstance(target, str):
            point = _point(target)
            if point is None:
                raise SimulationError(f"{self.name}: a target is a place, human or robot name "
                                      f"or a point (x, y) of finite numbers within "
                                      f"{LARGEST[Dimension.LENGTH]:g} m, not {target!r:.60}")
            return point
        if target in self._places:
            return self._places[target]
        if self._engine.position_of(target) is None:
            raise SimulationError(f"unknown target '{target}': not a place, human or robot")
        return target



class HumanHandle(_Actor):
    """One human of a running simulation."""

    def __init__(self, engine: Engine, name: str, places: dict[str, tuple[float, float]],
                 ids: itertools.count[int]) -> None:
        super().__init__(engine, name, places, ids)
        self._index = engine.index_of(name)

    # ---- state ---------------------------------------------------------------------------

    @property
    def position(self) -> tuple[float, float]:
        x, y = self._engine.humans.position[self._index]
        return (float(x), float(y))

    @property
    def velocity(self) -> tuple[float, float]:
        vx, vy = self._engine.humans.velocity[self._index]
        return (float(vx), float(vy))

    @property
    def heading(self) -> float:
        return float(self._engine.humans.heading[self._index])

    @property
    def posture(self) -> Posture:
        return Posture(int(self._engine.humans.posture[self._index]))

    @property
    def task(self) -> TaskHandle | None:
        """The task the human is doing now, if any."""
        return self._engine.handle[self._index]

    @property
    def state(self) -> str:
        """The behaviour's FSM state ('walking', 'aligning', 'talking', ... or 'idle';
        'giving_way' while waiting for its turn in a jam)."""
        return self._engine.fsm_state(self._index)

    # ---- commands ------------------------------------------------------------------------

    def stand(self, *, facing: Target | None = None, duration: float | None = None,
              span: Span | None = None) -> TaskHandle:
        return self.do("stand", facing=facing, duration=duration, span=span)

    def move_to(self, target: Target, *, heading: float | None = None,
                speed: float | None = None, span: Span | None = None) -> TaskHandle:
        return self.do("move_to", target, heading=heading, speed=speed, span=span)

    def run_to(self, target: Target, *, heading: float | None = None,
               span: Span | None = None) -> TaskHandle:
        return self.do("run_to", target, heading=heading, span=span)

    def move_around(self, *, area: Polygon | None = None, duration: float | None = None,
                    times: int | None = None, span: Span | None = None) -> TaskHandle:
        return self.do("move_around", area=area, duration=duration, times=times, span=span)

    def follow(self, target: str, *, distance: float = 1.0, duration: float | None = None,
               span: Span | None = None) -> TaskHandle:
        return self.do("follow", target, distance=distance, duration=duration, span=span)

    def talk(self, *, to: Target | None = None, duration: float | None = None,
             span: Span | None = None) -> TaskHandle:
        return self.do("talk", to=to, duration=duration, span=span)

    def sit_down(self, *, at: Target | None = None, duration: float | None = None,
                 heading: float | None = None, span: Span | None = None) -> TaskHandle:
        return self.do("sit_down", at=at, duration=duration, heading=heading, span=span)

    def lie_down(self, *, at: Target | None = None, duration: float | None = None,
                 heading: float | None = None, span: Span | None = None) -> TaskHandle:
        return self.do("lie_down", at=at, duration=duration, heading=heading, span=span)

    def teleop(self, *, duration: float | None = None, span: Span | None = None) -> TaskHandle:
        return self.do("teleop", duration=duration, span=span)

    def set_velocity(self, vx: float, vy: float) -> None:
        """The velocity a `teleop` task applies (walls still stop the human)."""
        vx, vy = _pair(self.name, "a velocity", vx, vy)
        speed = float(np.hypot(vx, vy))
        limit = float(self._engine.humans.run_speed[self._index])
        scale = 1.0 if speed <= limit else limit / speed
        self._engine.humans.teleop_velocity[self._index] = (vx * scale, vy * scale)

    # ---- internals -----------------------------------------------------------------------

    def _start(self, task: Task, handle: TaskHandle) -> None:
        behaviour: Behaviour = BEHAVIOURS[task.kind](task)
        self._engine.command(self._index, behaviour, handle)



class RobotHandle(_Actor):
    """One robot of a running simulation: its state, its tasks, and a velocity override."""

    def __init__(self, engine: Engine, name: str, places: dict[str, tuple[float, float]],
                 ids: itertools.count[int]) -> None:
        super().__init__(engine, name, places, ids)
        self._index = engine.robots.index_of(name)

    @property
    def position(self) -> tuple[float, float]:
        x, y = self._engine.robots.position[self._index]
        return (float(x), float(y))

    @property
    def velocity(self) -> tuple[float, float]:
        vx, vy = self._engine.robots.velocity[self._index]
        return (float(vx), float(vy))

    @property
    def heading(self) -> float:
        return float(self._engine.robots.heading[self._index])

    @property
    def task(self) -> TaskHandle | None:
        current = self._engine.robots.tasks[self._index]
        return current.handle if current is not None else None

    def move_to(self, target: Target, *, speed: float | None = None,
                span: Span | None = None) -> TaskHandle:
        return self.do("move_to", target, speed=speed, span=span)

    def stand(self, *, duration: float | None = None, span: Span | None = None) -> TaskHandle:
        return self.do("stand", duration=duration, span=span)

    def follow(self, target: str, *, distance: float = 1.0, duration: float | None = None,
               span: Span | None = None) -> TaskHandle:
        return self.do("follow", target, distance=distance, duration=duration, span=span)

    def set_velocity(self, vx: float, vy: float) -> None:
        """Move the robot at (vx, vy) m/s in the map frame from now on, whatever its
        controller says and whatever its kinematics: an override (teleoperation, tests). A
        unicycle moves as given too, sideways if need be, and faces where it goes, as a
        holonomic robot does; its speed and acceleration limits and the walls still apply, its
        turn rate does not. `drive()` commands the robot within its kinematics instead;
        `release()` hands it back to its controller."""
        self._engine.robots.set_velocity(self.name, _pair(self.name, "a velocity", vx, vy))

    def drive(self, first: float, second: float) -> None:
        """Give the robot the command its controller would give, from now on: (vx, vy) m/s
        for a holonomic robot, (v m/s, omega rad/s) for a unicycle. Its kinematics, limits and
        the walls apply as to a controller's command; `release()` hands it back."""
        self._engine.robots.drive(self.name, _pair(self.name, "a command", first, second))

    def release(self) -> None:
        """Back to the robot's controller: undo `set_velocity` and `drive`."""
        self._engine.robots.set_velocity(self.name, None)
        self._engine.robots.drive(self.name, None)

    def _kind(self, name: str) -> TaskKind:
        kind = super()._kind(name)
        if not kind.robots:
            robot_kinds = ", ".join(k.name for k in TASKS.values() if k.robots)
            raise SimulationError(f"robots take {robot_kinds}, not {name}")
        return kind.for_robots()

    def _start(self, task: Task, handle: TaskHandle) -> None:
        self._engine.command_robot(self._index, task, handle)


def _as_given(given: Any, read: Any) -> Any:
    """A name as it was given (a place's, not its point), anything else as it was read."""
    return given if isinstance(given, str) else read


def _point(value: object) -> tuple[float, float] | None:
    """`value` as a point: two real numbers, finite and within the language's lengths."""
    if not isinstance(value, tuple | list | np.ndarray) or len(value) != 2:
        return None
    point = finite_pair(*value)
    largest = LARGEST[Dimension.LENGTH]
    if point is None or not all(abs(v) <= largest for v in point):
        return None
    return point


def _pair(actor: str, what: str, first: object, second: object) -> tuple[float, float]:
    """Two finite real numbers (a velocity, a command), or SimulationError naming `actor`."""
    pair = finite_pair(first, second)
    if pair is None:
        raise SimulationError(f"{actor}: {what} must be two finite numbers, got "
                              f"({first!r:.30}, {second!r:.30})")
    return pair
