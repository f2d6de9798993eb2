"""The task registry: every task kind of the language declared once, and a task as lowered.

A `TaskKind` says what a task takes (a bare target, and which options with which values), whether
it ends by itself, how it is described and how plots mark where it ended. The checker validates
scenario files against it, the graph verification asks it how tasks end, the human API and the
scheduler build tasks from it, and plots read it. The behaviour that carries a kind out is
registered beside the behaviours (`hubero_dsl.sim.behaviours.BEHAVIOURS`), so adding a task
kind is one entry here and one behaviour there.

A `Task` is one task as the compiler lowered it (or as the API was asked for it): its kind, its
target (a point in metres or the name of a human or robot) and its options in SI units, keyed by
the API's argument names.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from enum import StrEnum
from typing import TYPE_CHECKING, Any

from hubero_dsl.model.units import Dimension

if TYPE_CHECKING:
    from hubero_dsl.diagnostics import Span

Point = tuple[float, float]
Target = Point | str   # a point in metres, or the name of a human or robot (where it is then)


class ValueKind(StrEnum):
    """What an option's value is, for the checker and the lowering."""

    TIME = "time"
    LENGTH = "length"
    SPEED = "speed"
    ANGLE = "angle"
    COUNT = "count"      # a whole number of at least 1
    TARGET = "target"    # a point, a place, a human or a robot
    AREA = "area"

    @property
    def dimension(self) -> Dimension | None:
        return _DIMENSIONS.get(self)


_DIMENSIONS = {ValueKind.TIME: Dimension.TIME, ValueKind.LENGTH: Dimension.LENGTH,
               ValueKind.SPEED: Dimension.SPEED, ValueKind.ANGLE: Dimension.ANGLE}


class TargetRule(StrEnum):
    """What a task's bare target may be (`alice move_to sofa`)."""

    NONE = "none"        # no bare target; `hint_keyword` says which option to use instead
    POINT = "point"      # required: a point, place, human or robot
    BODY = "body"        # required: a human or robot


@dataclass(frozen=True, slots=True)
class OptionSpec:
    keyword: str                    # as written: `for`, `heading`, `to`, ...
    argument: str                   # the API's keyword argument: duration, heading, to, ...
    value: ValueKind
    default: float | None = None    # what the task uses when the option is not written


@dataclass(frozen=True, slots=True)
class TaskKind:
    name: str
    summary: str
    target: TargetRule
    options: tuple[OptionSpec, ...]
    ends_by_itself: bool = False     # ends without `for`, `times` or `until` (reaches its goal)
    hint_keyword: str = "at"         # for TargetRule.NONE: the option a bare target should use
    described_option: str | None = None  # an option the description names (`stand facing x`)
    marks_goal: bool = False         # plots mark where it ended as a goal reached
    keeps_posture: bool = False      # starting it does not make a sitting human stand up
    robot_options: tuple[str, ...] | None = None  # robots take it, with these options

    def option(self, keyword: str) -> OptionSpec | None:
        return next((o for o in self.options if o.keyword == keyword), None)

    def argument(self, argument: str) -> OptionSpec | None:
        return next((o for o in self.options if o.argument == argument), None)

    @property
    def robots(self) -> bool:
        """Whether robots take this kind (humans take every kind)."""
        return self.robot_options is not None

    def for_robots(self) -> TaskKind:
        """The kind as a robot takes it: only the options a controller's goal can carry."""
        keep = self.robot_options or ()
        return replace(self, options=tuple(o for o in self.options if o.keyword in keep))

    @property
    def keywords(self) -> tuple[str, ...]:
        return tuple(o.keyword for o in self.options)

    def ends(self, arguments: Mapping[str, Any]) -> bool:
        """Whether a task with these options ends by itself (its goal, `for` or `times`)."""
        return self.ends_by_itself or "duration" in arguments or "times" in arguments

    def describe(self, target: Any, arguments: Mapping[str, Any]) -> str:
        """`move_to (2, 3)`, `stand facing alice`: how events and the log name a task."""
        words = [self.name]
        if target is not None:
            words.append(describe_target(target))
        described = self.option(self.described_option) if self.described_option else None
        if described is not None and arguments.get(described.argument) is not None:
            words += [described.keyword, describe_target(arguments[described.argument])]
        return " ".join(words)


def _duration() -> OptionSpec:
    return OptionSpec("for", "duration", ValueKind.TIME)


def _heading() -> OptionSpec:
    return OptionSpec("heading", "heading", ValueKind.ANGLE)


TASKS: dict[str, TaskKind] = {kind.name: kind for kind in (
    TaskKind("stand", "stand still, optionally facing a target", TargetRule.NONE,
             (OptionSpec("facing", "facing", ValueKind.TARGET), _duration()),
             hint_keyword="facing", described_option="facing", robot_options=("for",)),
    TaskKind("move_to", "walk to a target along a global plan", TargetRule.POINT,
             (_heading(), OptionSpec("speed", "speed", ValueKind.SPEED)),
             ends_by_itself=True, marks_goal=True, robot_options=("speed",)),
    TaskKind("run_to", "run to a target at run_speed", TargetRule.POINT, (_heading(),),
             ends_by_itself=True, marks_goal=True),
    TaskKind("move_around", "wander to random reachable goals", TargetRule.NONE,
             (OptionSpec("in", "area", ValueKind.AREA), _duration(),
              OptionSpec("times", "times", ValueKind.COUNT))),
    TaskKind("follow", "follow a human or robot at a distance", TargetRule.BODY,
             (OptionSpec("at", "distance", ValueKind.LENGTH, default=1.0), _duration()),
             robot_options=("at", "for")),
    TaskKind("talk", "stand and face the person spoken to", TargetRule.NONE,
             (OptionSpec("to", "to", ValueKind.TARGET), _duration()),
             hint_keyword="to", described_option="to"),
    TaskKind("sit_down", "go there, sit for the time", TargetRule.NONE,
             (OptionSpec("at", "at", ValueKind.TARGET), _duration(), _heading()),
             marks_goal=True, keeps_posture=True),
    TaskKind("lie_down", "go there, lie for the time", TargetRule.NONE,
             (OptionSpec("at", "at", ValueKind.TARGET), _duration(), _heading()),
             marks_goal=True, keeps_posture=True),
    TaskKind("teleop", "velocity comes from the Python API", TargetRule.NONE, (_duration(),)),
)}


@dataclass(frozen=True, slots=True)
class Task:
    """One task: a registered kind, a resolved target and SI options by argument name."""

    kind: str
    target: Target | None = None
    arguments: Mapping[str, Any] = field(default_factory=dict)
    span: Span | None = None
    group: str | None = None  # the group whose task this is, given to each of its members
    # given to a crowd or group: its members go there together (`reaches` counts where a
    # member's walk there succeeded, `Engine.arrived_together`)
    together: bool = False

    @property
    def spec(self) -> TaskKind:
        return TASKS[self.kind]

    def get(self, argument: str) -> Any:
        """The option's value, or the kind's default for it (None when it has none)."""
        if argument in self.arguments:
            return self.arguments[argument]
        option = self.spec.argument(argument)
        return option.default if option is not None else None

    @property
    def ends_by_itself(self) -> bool:
        return self.spec.ends(self.arguments)


def describe_target(target: Any) -> str:
    if isinstance(target, str):
        return target
    x, y = target
    return f"({x:g}, {y:g})"
