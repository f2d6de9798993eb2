"""Lowering: from the checked syntax tree to the model the rest of hubero reads.

Places become points, areas polygons, quantities SI floats, task options the API's arguments
(`for 5 s` -> `duration=5.0`), labels `Label`s; every step and condition keeps its span and its
text in the scenario's words. Lowering is total: in a file with errors, what cannot be resolved
becomes a neutral value (an empty polygon, NaN), so the activity graph can still be built and
verified for more diagnostics; no program is built from such a file.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import replace
from typing import TYPE_CHECKING, Any

from hubero_dsl.lang import ast
from hubero_dsl.lang.text import format_condition, format_task_step, format_value
from hubero_dsl.model import activities as m
from hubero_dsl.model import conditions as c
from hubero_dsl.model.program import Pose
from hubero_dsl.model.tasks import TASKS, Target, Task, ValueKind

if TYPE_CHECKING:
    from shapely.geometry import Polygon

    from hubero_dsl.diagnostics import SourceFile, Span


def coordinate(value: ast.Coordinate) -> float:
    return value.value if isinstance(value, ast.Number) else value.si


def fixed_point(value: ast.PointValue, places: Mapping[str, Pose]) -> tuple[float, float] | None:
    """The coordinates of a literal point or a place; None for bodies and unknown names."""
    if isinstance(value, ast.Point):
        return (coordinate(value.x), coordinate(value.y))
    pose = places.get(value.name)
    return pose.xy if pose else None


def area_polygon(value: ast.RectArea | ast.PolygonArea, places: Mapping[str, Pose]) -> Polygon:
    """The polygon of a literal area (names inside must be places; checked before)."""
    from shapely.geometry import Polygon

    corners = (value.corner_a, value.corner_b) if isinstance(value, ast.RectArea) \
        else value.vertices
    points = [fixed_point(v, places) or (0.0, 0.0) for v in corners]
    if not all(math.isfinite(x) and math.isfinite(y) for x, y in points):
        return Polygon()  # a coordinate of an unknown unit: the checker's error
    if isinstance(value, ast.RectArea):
        (x0, x1), (y0, y1) = sorted(x for x, _ in points), sorted(y for _, y in points)
        return Polygon([(x0, y0), (x1, y0), (x1, y1), (x0, y1)])
    return Polygon(points) if len(points) >= 3 else Polygon()  # fewer: the checker's error


def named_areas(module: ast.Module, places: Mapping[str, Pose]) -> dict[str, Polygon]:
    """Every `area NAME ...` as a polygon, names of other areas followed to the end."""
    areas: dict[str, Polygon] = {}
    aliases: dict[str, str] = {}
    for decl in module.of_type(ast.AreaDecl):
        if isinstance(decl.area, ast.NameRef):  # an area may be another area's name
            aliases[decl.name.name] = decl.area.name
        else:
            areas[decl.name.name] = area_polygon(decl.area, places)
    for name in aliases:  # follow chains of names (the checker rejected cycles)
        target, hops = aliases[name], 0
        while target in aliases and hops < len(aliases):
            target, hops = aliases[target], hops + 1
        if target in areas:
            areas[name] = areas[target]
    return areas


def seconds(value: ast.Value) -> float:
    """A checked value's SI magnitude (NaN where the checker has reported it)."""
    if isinstance(value, ast.Quantity):
        return value.si
    if isinstance(value, ast.Number):
        return value.value
    return math.nan


class Lowering:
    """Lowers one module's activities and expectations against its places and areas."""

    def __init__(self, source: SourceFile, places: Mapping[str, Pose],
                 areas: Mapping[str, Polygon], bounds: Polygon | None,
                 groups: Mapping[str, tuple[str, ...]] | None = None,
                 walking_groups: frozenset[str] = frozenset(),
                 flows: frozenset[str] = frozenset()) -> None:
        self.source = source
        self.places = places
        self.areas = areas
        self.bounds = bounds
        self.groups = groups or {}   # a crowd's or group's name -> its members
        # the `group`s among them: their members walk together, and talk facing each other
        self.walking_groups = walking_groups
        # the flows among them: their people come and go, so `all` and `any` count where
        # each one left the scene too (`c.FlowReaches`)
        self.flows = flows

    # ---- activities ------------------------------------------------------------------------

    def activities(self, decls: Sequence[ast.ActivityDecl]) -> tuple[m.Activity, ...]:
        return tuple(m.Activity(decl.name.name if decl.name is not None else None,
                                tuple(self.step(s) for s in decl.steps), decl.span,
                                _head_span(decl)) for decl in decls)

    def step(self, step: ast.Step) -> m.Step:
        label = _label(step.label)
        match step:
            case ast.TaskStep() if step.human.name in self.groups:
                # a task given to a crowd or group is given to every member; it ends when all
                # have
                members = self.groups[step.human.name]
                return m.ParallelStep(tuple(self._member_step(step, member)
                                            for member in members), step.span, label,
                                      crowd=step.human.name)
            case ast.TaskStep():
                return m.TaskStep(step.human.name, self.task(step.task),
                                  self.condition(step.until) if step.until else None,
                                  seconds(step.within) if step.within is not None else None,
                                  step.forever, step.span, format_task_step(step), label)
            case ast.WaitStep():
                return m.WaitStep(seconds(step.duration), format_value(step.duration),
                                  step.span, label)
            case ast.WaitUntilStep():
                return m.WaitUntilStep(self.condition(step.condition), step.span, label)
            case ast.ParallelStep():
                return m.ParallelStep(tuple(self.step(b) for b in step.branches), step.span,
                                      label)
            case ast.RaceStep():
                return m.RaceStep(tuple(self.step(b) for b in step.branches), step.span, label)
            case ast.RepeatStep():
                return m.RepeatStep(step.count.value, step.count.text, step.count.is_integer,
                                    step.count.span,
                                    tuple(self.step(s) for s in step.body.steps), step.span,
                                    label)
            case ast.SequenceStep():
                return m.SequenceStep(tuple(self.step(s) for s in step.steps), step.span, label)
        raise TypeError(f"not a step: {step!r}")

    def _member_step(self, step: ast.TaskStep, member: str) -> m.Step:
        lowered = self.step(replace(step, human=ast.NameRef(member, step.human.span),
                                    label=None))
        group = step.human.name
        if not isinstance(lowered, m.TaskStep):
            return lowered
        task = lowered.task
        walking = group in self.walking_groups
        if task.kind in ("move_to", "run_to"):  # side by side: `behaviours._place_abreast`
            task = replace(task, group=group if walking else None, together=True)
        elif walking and task.kind == "move_around":  # a stroll: shared goals, abreast
            task = replace(task, group=group)
        elif walking and task.kind == "talk" and "to" not in task.arguments:
            task = replace(task, arguments={**task.arguments, "to": group})  # face its centre
        return replace(lowered, task=task)

    def task(self, task: ast.Task) -> Task:
        kind = TASKS.get(task.kind)
        arguments: dict[str, Any] = {}
        for option in task.options:
            spec = kind.option(option.keyword) if kind is not None else None
            if spec is not None:
                arguments[spec.argument] = self.option_value(option.value, spec.value)
        if kind is not None:
            for spec in kind.options:  # an area not written is the scenario's bounds
                if spec.value is ValueKind.AREA and spec.argument not in arguments \
                        and self.bounds is not None:
                    arguments[spec.argument] = self.bounds
        target = self.target(task.target) if task.target is not None else None
        return Task(task.kind, target, arguments, task.span)

    def option_value(self, value: Any, kind: ValueKind) -> Any:
        if kind is ValueKind.TARGET:
            return self.target(value)
        if kind is ValueKind.AREA:
            return self.area(value)
        if kind is ValueKind.COUNT:
            number = value.value if isinstance(value, ast.Number) else math.nan
            return int(number) if math.isfinite(number) else 0
        return seconds(value)

    def target(self, value: ast.PointValue) -> Target:
        """A fixed point, or the name of the human/robot whose position it means at the time."""
        if isinstance(value, ast.Point):
            return (coordinate(value.x), coordinate(value.y))
        if not isinstance(value, ast.NameRef):  # not a point at all: reported by the checker
            return (math.nan, math.nan)
        if value.name in self.places:
            return self.places[value.name].xy
        return value.name

    def area(self, value: ast.AreaValue) -> Polygon:
        if isinstance(value, ast.NameRef):
            from shapely.geometry import Polygon

            return self.areas.get(value.name, Polygon())
        return area_polygon(value, self.places)

    # ---- conditions ------------------------------------------------------------------------

    def condition(self, condition: ast.Condition) -> c.Condition:
        text, span = format_condition(condition), condition.span
        match condition:
            case ast.LabelCondition():
                return c.LabelCondition(c.Label(condition.label.name, condition.label.span),
                                        c.LabelEvent(condition.event.value), span, text)
            case ast.ReachesCondition():
                return c.Reaches(condition.subject.name, self.target(condition.target), span,
                                 text)
            case ast.DistanceCondition():
                return c.DistanceTo(condition.subject.name, self.target(condition.target),
                                    condition.operator, seconds(condition.threshold), span, text)
            case ast.AllReach() | ast.AnyReaches() if condition.group.name in self.flows:
                return c.FlowReaches(condition.group.name, self.target(condition.target),
                                     isinstance(condition, ast.AllReach), span, text)
            case ast.AllReach():
                target = self.target(condition.target)
                return c.AllOf(tuple(c.Reaches(member, target, span, text) for member in
                                     self.groups.get(condition.group.name, ())), span, text)
            case ast.AnyReaches():
                target = self.target(condition.target)
                return c.AnyOf(tuple(c.Reaches(member, target, span, text) for member in
                                     self.groups.get(condition.group.name, ())), span, text)
            case ast.CountIn():
                return c.CountInside(self.groups.get(condition.group.name, ()),
                                     self.area(condition.area), condition.operator,
                                     seconds(condition.threshold), span, text)
            case ast.InsideCondition():
                return c.Inside(condition.subject.name, self.area(condition.area), span, text)
            case ast.TimeCondition():
                return c.TimeCompare(condition.operator, seconds(condition.threshold), span,
                                     text)
            case ast.NotCondition():
                return c.Not(self.condition(condition.operand), span, text)
            case ast.AllOf():
                return c.AllOf(tuple(self.condition(o) for o in condition.operands), span, text)
            case ast.AnyOf():
                return c.AnyOf(tuple(self.condition(o) for o in condition.operands), span, text)
        raise TypeError(f"not a condition: {condition!r}")

    # ---- expectations ----------------------------------------------------------------------

    def expectations(self, decls: Sequence[ast.ExpectDecl]) -> tuple[m.Expectation, ...]:
        return tuple(m.Expectation(self._expected(decl.condition), m.ExpectMode(decl.mode.value),
                                   seconds(decl.deadline) if decl.deadline is not None else None,
                                   self._expect_text(decl), decl.span) for decl in decls)

    def _expected(self, condition: ast.Condition | ast.MetricCompare
                  ) -> c.Condition | c.MetricCompare:
        if not isinstance(condition, ast.MetricCompare):
            return self.condition(condition)
        other = condition.other.name if condition.other is not None else None
        text = (f"{condition.metric.name}({condition.subject.name}"
                f"{', ' + other if other else ''}) {condition.operator} "
                f"{format_value(condition.threshold)}")
        return c.MetricCompare(condition.metric.name, condition.subject.name, other,
                               condition.operator, seconds(condition.threshold),
                               condition.span, text)

    def _expect_text(self, decl: ast.ExpectDecl) -> str:
        span = decl.span
        line = self.source.line(span.line)
        end = span.end_column - 1 if span.end_line == span.line else len(line)
        return line[span.column - 1:end].strip().removeprefix("expect").strip()


def _label(ref: ast.NameRef | None) -> c.Label | None:
    return c.Label(ref.name, ref.span) if ref is not None else None


def _head_span(decl: ast.ActivityDecl) -> Span:
    """`activity NAME` (or just `activity`): where the activity's start is shown."""
    from hubero_dsl.diagnostics import Span

    span = decl.span
    if decl.name is not None:
        return Span(span.file, span.line, span.column, decl.name.span.end_line,
                    decl.name.span.end_column)
    return Span(span.file, span.line, span.column, span.line, span.column + len("activity"))
