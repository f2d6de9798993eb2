"""Evaluating the language's conditions against the running world.

Used by `wait until`, `until`, and `expect`. Labels come from the scheduler's `LabelBook`;
positions from the engine; areas are shapely polygons (point-in-polygon via `contains_xy`).
"""

from __future__ import annotations

import math
import operator
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import shapely

from hubero_dsl.lang import ast
from hubero_dsl.lang.program import Pose
from hubero_dsl.lang.units import Dimension

if TYPE_CHECKING:
    from hubero_dsl.sim.simulation import Simulation

COMPARE: dict[str, Callable[[float, float], bool]] = {
    "<": operator.lt, "<=": operator.le, ">": operator.gt, ">=": operator.ge}


@dataclass
class LabelBook:
    """Which labelled steps have started, finished, or had an action aborted."""

    started: set[str] = field(default_factory=set)
    done: set[str] = field(default_factory=set)
    failed: set[str] = field(default_factory=set)

    def holds(self, label: str, event: ast.LabelEvent) -> bool:
        book = {ast.LabelEvent.STARTED: self.started, ast.LabelEvent.DONE: self.done,
                ast.LabelEvent.FAILED: self.failed}[event]
        return label in book


def si(value: ast.Value, dimension: Dimension) -> float:
    """A checked value's SI magnitude (the checker guaranteed its dimension)."""
    if isinstance(value, ast.Quantity):
        return value.si
    if isinstance(value, ast.Number):
        return value.value
    raise TypeError(f"not a {dimension.value}: {value!r}")


class Conditions:
    def __init__(self, sim: Simulation, labels: LabelBook) -> None:
        self.sim = sim
        self.labels = labels

    def holds(self, condition: ast.Condition) -> bool:
        match condition:
            case ast.LabelCondition(label=label, event=event):
                return self.labels.holds(label.name, event)
            case ast.ReachesCondition(subject=subject, target=target):
                gap = self._distance(subject.name, target)
                return gap is not None and gap <= self._tolerance(subject.name)
            case ast.DistanceCondition(subject=subject, target=target, operator=op):
                gap = self._distance(subject.name, target)
                threshold = si(condition.threshold, Dimension.LENGTH)
                return gap is not None and COMPARE[op](gap, threshold)
            case ast.InsideCondition(subject=subject, area=area):
                where = self.sim.engine.position_of(subject.name)
                polygon = self.sim.program.area(area)
                return where is not None and bool(shapely.contains_xy(polygon, *where))
            case ast.TimeCondition(operator=op, threshold=threshold):
                return COMPARE[op](self.sim.time, si(threshold, Dimension.TIME) - 1e-9
                                   if op in (">=", "<") else si(threshold, Dimension.TIME))
            case ast.NotCondition(operand=operand):
                return not self.holds(operand)
            case ast.AllOf(operands=operands):
                return all(self.holds(o) for o in operands)
            case ast.AnyOf(operands=operands):
                return any(self.holds(o) for o in operands)
        raise TypeError(f"unknown condition {condition!r}")

    def _distance(self, subject: str, target: ast.PointValue) -> float | None:
        here = self.sim.engine.position_of(subject)
        resolved = self.sim.program.point(target)
        there = resolved.xy if isinstance(resolved, Pose) else self.sim.engine.position_of(
            resolved)
        if here is None or there is None:
            return None
        return math.hypot(there[0] - here[0], there[1] - here[1])

    def _tolerance(self, subject: str) -> float:
        if subject in self.sim.engine.humans.names:
            index = self.sim.engine.index_of(subject)
            return float(self.sim.engine.humans.goal_tolerance[index])
        return 0.2
