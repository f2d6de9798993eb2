"""The abstract syntax tree of a scenario file: frozen nodes, each carrying its source span.

Nodes say what was written, nothing more: names are unresolved, quantities keep the unit they were
written in (and their SI value), and nothing has been checked. The semantic passes in
`hubero_dsl.lang.checks` read these nodes and report problems at their spans.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import StrEnum
from typing import TypeAlias, TypeVar

from hubero_dsl.diagnostics import SourceFile, Span
from hubero_dsl.model.units import UNITS, Dimension

# ---- values ------------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class Number:
    """A bare number (`7`, `2.1`)."""

    value: float
    text: str
    span: Span

    @property
    def is_integer(self) -> bool:
        plain = "." not in self.text and "e" not in self.text.lower()
        return float(self.value).is_integer() and plain


@dataclass(frozen=True, slots=True)
class Quantity:
    """A number with a unit (`1.29 m/s`). `unit` may be unknown; the checker says so."""

    magnitude: float
    unit: str
    span: Span

    @property
    def known_unit(self) -> bool:
        return self.unit in UNITS

    @property
    def dimension(self) -> Dimension | None:
        entry = UNITS.get(self.unit)
        return entry[0] if entry else None

    @property
    def si(self) -> float:
        """The value in SI units (m, s, m/s, rad); NaN for an unknown unit, which the checker
        reports (a program is lowered for its other errors all the same)."""
        entry = UNITS.get(self.unit)
        return self.magnitude * entry[1] if entry else math.nan


@dataclass(frozen=True, slots=True)
class String:
    value: str
    span: Span


@dataclass(frozen=True, slots=True)
class NameRef:
    """A use of a name (a place, area, human, robot, label or planner)."""

    name: str
    span: Span


Coordinate: TypeAlias = Number | Quantity


@dataclass(frozen=True, slots=True)
class Point:
    x: Coordinate
    y: Coordinate
    span: Span


@dataclass(frozen=True, slots=True)
class NamedArg:
    name: str
    value: Value
    span: Span
    name_span: Span


@dataclass(frozen=True, slots=True)
class ShapeLit:
    """`circle(radius: 0.2 m)` and friends; arguments are checked against the kind later."""

    kind: str
    args: tuple[NamedArg, ...]
    span: Span

    def arg(self, name: str) -> NamedArg | None:
        return next((a for a in self.args if a.name == name), None)


@dataclass(frozen=True, slots=True)
class Distribution:
    """`normal(mean, sd)` or `uniform(low, high)`."""

    kind: str
    first: Value
    second: Value
    span: Span


@dataclass(frozen=True, slots=True)
class RectArea:
    corner_a: PointValue
    corner_b: PointValue
    span: Span


@dataclass(frozen=True, slots=True)
class PolygonArea:
    vertices: tuple[PointValue, ...]
    span: Span


PointValue: TypeAlias = Point | NameRef
AreaValue: TypeAlias = RectArea | PolygonArea | NameRef
Value: TypeAlias = Number | Quantity | String | NameRef | ShapeLit | Distribution | Point


def value_span(value: Value | RectArea | PolygonArea) -> Span:
    return value.span


# ---- parameters --------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class Param:
    """`speed 1.29 m/s`, `social_force.A 2.1`, or (in a variant) `actor1.speed 1.5 m/s`.

    `path` is the dotted name as written; the checker decides whether its first part names a
    human (a per-human setting) or a planner (a planner parameter).
    """

    path: tuple[str, ...]
    value: Value
    span: Span
    name_span: Span

    @property
    def dotted(self) -> str:
        return ".".join(self.path)


@dataclass(frozen=True, slots=True)
class RobotPath:
    waypoints: tuple[PointValue, ...]
    loop: bool
    span: Span


@dataclass(frozen=True, slots=True)
class RobotController:
    """`controller NAME`; a string here is an error the checker explains (files name no code)."""

    target: NameRef | String
    span: Span


# ---- conditions --------------------------------------------------------------------------


class LabelEvent(StrEnum):
    DONE = "done"
    STARTED = "started"
    FAILED = "failed"


@dataclass(frozen=True, slots=True)
class LabelCondition:
    label: NameRef
    event: LabelEvent
    span: Span


@dataclass(frozen=True, slots=True)
class ReachesCondition:
    subject: NameRef
    target: PointValue
    span: Span


@dataclass(frozen=True, slots=True)
class AllReach:
    """`all CROWD reach TARGET`."""

    group: NameRef
    target: PointValue
    span: Span


@dataclass(frozen=True, slots=True)
class AnyReaches:
    """`any CROWD reaches TARGET`."""

    group: NameRef
    target: PointValue
    span: Span


@dataclass(frozen=True, slots=True)
class CountIn:
    """`count(CROWD in AREA) OP N`."""

    group: NameRef
    area: AreaValue
    operator: str
    threshold: Value
    span: Span


@dataclass(frozen=True, slots=True)
class DistanceCondition:
    subject: NameRef
    target: PointValue
    operator: str
    threshold: Value
    span: Span


@dataclass(frozen=True, slots=True)
class InsideCondition:
    subject: NameRef
    area: AreaValue
    span: Span


@dataclass(frozen=True, slots=True)
class TimeCondition:
    operator: str
    threshold: Value
    span: Span


@dataclass(frozen=True, slots=True)
class NotCondition:
    operand: Condition
    span: Span


@dataclass(frozen=True, slots=True)
class AllOf:
    operands: tuple[Condition, ...]
    span: Span


@dataclass(frozen=True, slots=True)
class AnyOf:
    operands: tuple[Condition, ...]
    span: Span


Condition: TypeAlias = (LabelCondition | ReachesCondition | AllReach | AnyReaches | CountIn
                        | DistanceCondition | InsideCondition | TimeCondition | NotCondition
                        | AllOf | AnyOf)


# ---- tasks and steps ---------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class TaskOption:
    """One `keyword value` after a task: heading, speed, for, times, at, to, facing, in."""

    keyword: str
    value: Value | RectArea | PolygonArea
    span: Span


@dataclass(frozen=True, slots=True)
class Task:
    kind: str
    target: PointValue | None
    options: tuple[TaskOption, ...]
    span: Span
    kind_span: Span

    def option(self, keyword: str) -> TaskOption | None:
        return next((o for o in self.options if o.keyword == keyword), None)


@dataclass(frozen=True, slots=True)
class TaskStep:
    """`[label:] HUMAN TASK [until C] [within Q] [forever]`."""

    human: NameRef
    task: Task
    until: Condition | None
    within: Value | None
    forever: bool
    span: Span
    label: NameRef | None = None
    # a modifier written again (`within 8 s within 1 s`): the later ones, reported by checks
    repeated: tuple[tuple[str, Span], ...] = ()


@dataclass(frozen=True, slots=True)
class WaitStep:
    duration: Value
    span: Span
    label: NameRef | None = None


@dataclass(frozen=True, slots=True)
class WaitUntilStep:
    condition: Condition
    span: Span
    label: NameRef | None = None


@dataclass(frozen=True, slots=True)
class ParallelStep:
    branches: tuple[Step, ...]
    span: Span
    label: NameRef | None = None


@dataclass(frozen=True, slots=True)
class RaceStep:
    branches: tuple[Step, ...]
    span: Span
    label: NameRef | None = None


@dataclass(frozen=True, slots=True)
class RepeatStep:
    count: Number
    body: SequenceStep
    span: Span
    label: NameRef | None = None


@dataclass(frozen=True, slots=True)
class SequenceStep:
    steps: tuple[Step, ...]
    span: Span
    label: NameRef | None = None


Step: TypeAlias = (TaskStep | WaitStep | WaitUntilStep | ParallelStep | RaceStep | RepeatStep
                   | SequenceStep)


def child_steps(step: Step) -> tuple[Step, ...]:
    """The steps directly inside a composite step (none for tasks and waits)."""
    if isinstance(step, ParallelStep | RaceStep):
        return step.branches
    if isinstance(step, SequenceStep):
        return step.steps
    if isinstance(step, RepeatStep):
        return (step.body,)
    return ()


def walk_steps(steps: tuple[Step, ...]) -> list[Step]:
    """Every step, depth first, in source order."""
    found: list[Step] = []
    for step in steps:
        found.append(step)
        found.extend(walk_steps(child_steps(step)))
    return found


def walk_conditions(condition: Condition) -> list[Condition]:
    """Every sub-condition, the condition itself first."""
    found: list[Condition] = [condition]
    if isinstance(condition, NotCondition):
        found.extend(walk_conditions(condition.operand))
    elif isinstance(condition, AllOf | AnyOf):
        for operand in condition.operands:
            found.extend(walk_conditions(operand))
    return found


# ---- top-level statements ----------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class ScenarioDecl:
    title: String
    span: Span


@dataclass(frozen=True, slots=True)
class MapDecl:
    path: String
    span: Span


@dataclass(frozen=True, slots=True)
class SettingDecl:
    """`seed N`, `step Q`, `time_limit Q`, `on_failure MODE`, `bounds AREA`."""

    keyword: str
    value: Value | RectArea | PolygonArea
    span: Span


@dataclass(frozen=True, slots=True)
class PlaceDecl:
    name: NameRef
    point: PointValue
    heading: Value | None
    span: Span


@dataclass(frozen=True, slots=True)
class AreaDecl:
    name: NameRef
    area: AreaValue
    span: Span


@dataclass(frozen=True, slots=True)
class DefaultsDecl:
    params: tuple[Param, ...]
    span: Span


@dataclass(frozen=True, slots=True)
class HumanDecl:
    name: NameRef
    start: PointValue
    heading: Value | None
    params: tuple[Param, ...]
    span: Span


@dataclass(frozen=True, slots=True)
class CrowdDecl:
    """`crowd NAME N in AREA [heading A] [{ PARAM ... }]`: N humans NAME_1 ... NAME_N."""

    name: NameRef
    count: Number
    area: AreaValue
    heading: Value | None
    params: tuple[Param, ...]
    span: Span

    @property
    def members(self) -> tuple[str, ...]:
        size = int(self.count.value) if self.count.is_integer and 0 < self.count.value <= \
            MAX_CROWD else 0
        return tuple(f"{self.name.name}_{i}" for i in range(1, size + 1))


MAX_CROWD = 10_000  # people in one crowd


@dataclass(frozen=True, slots=True)
class FlowDecl:
    """`flow NAME from AREA to TARGET rate R [for Q | until C] [{ PARAM ... }]`: people who
    appear in AREA at random times, R on average, walk to TARGET and leave there."""

    name: NameRef
    area: AreaValue
    target: PointValue
    rate: Value
    duration: Value | None
    until: Condition | None
    params: tuple[Param, ...]
    span: Span


@dataclass(frozen=True, slots=True)
class GroupDecl:
    """`group NAME of (H, H, ...)`: people who walk and talk together."""

    name: NameRef
    members: tuple[NameRef, ...]
    span: Span


@dataclass(frozen=True, slots=True)
class RobotDecl:
    name: NameRef
    start: PointValue
    heading: Value | None
    params: tuple[Param, ...]
    path: RobotPath | None
    controller: RobotController | None
    span: Span
    extra_items: tuple[RobotPath | RobotController, ...] = ()  # repeats, reported by checks


@dataclass(frozen=True, slots=True)
class VariantDecl:
    name: NameRef
    params: tuple[Param, ...]
    span: Span


@dataclass(frozen=True, slots=True)
class SweepDecl:
    param: Param  # path and span of the swept parameter; value is the first listed value
    values: tuple[Value, ...]
    span: Span


@dataclass(frozen=True, slots=True)
class ActivityDecl:
    name: NameRef | None
    steps: tuple[Step, ...]
    span: Span


class ExpectMode(StrEnum):
    ALWAYS = "always"
    EVENTUALLY = "eventually"
    WITHIN = "within"
    AT_END = "at_end"   # a metric of the whole run: judged when it ends


@dataclass(frozen=True, slots=True)
class MetricCompare:
    """`METRIC(NAME [, OTHER]) OP Q` in an expectation."""

    metric: NameRef
    subject: NameRef
    other: NameRef | None
    operator: str
    threshold: Value
    span: Span


@dataclass(frozen=True, slots=True)
class ExpectDecl:
    condition: Condition | MetricCompare
    mode: ExpectMode
    deadline: Value | None
    span: Span


Statement: TypeAlias = (ScenarioDecl | MapDecl | SettingDecl | PlaceDecl | AreaDecl | DefaultsDecl
                        | HumanDecl | CrowdDecl | FlowDecl | GroupDecl | RobotDecl | VariantDecl
                        | SweepDecl
                        | ActivityDecl | ExpectDecl)


@dataclass(frozen=True, slots=True)
class Module:
    """A parsed scenario file: its statements in source order."""

    source: SourceFile
    statements: tuple[Statement, ...]

    def of_type(self, kind: type[StatementT]) -> list[StatementT]:
        return [s for s in self.statements if isinstance(s, kind)]


StatementT = TypeVar("StatementT")
