"""Evaluating the language's conditions against the running world.

Used by `wait until`, `until`, and `expect`. Conditions come lowered (`hubero_dsl.model`): places
are points, areas polygons, thresholds SI. Labels come from the scheduler's `LabelBook`,
positions and goal tolerances from the engine; areas are tested with `shapely.contains_xy`.
"""

from __future__ import annotations

import math
import operator
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
import shapely

from hubero_dsl.model import conditions as c
from hubero_dsl.model.tasks import Target

if TYPE_CHECKING:
    from hubero_dsl.sim.engine import Engine

COMPARE: dict[str, Callable[[float, float], bool]] = {
    "<": operator.lt, "<=": operator.le, ">": operator.gt, ">=": operator.ge}


@dataclass
class LabelBook:
    """Which labelled steps have started, finished, or had an action aborted."""

    started: set[str] = field(default_factory=set)
    done: set[str] = field(default_factory=set)
    failed: set[str] = field(default_factory=set)

    def holds(self, label: str, event: c.LabelEvent) -> bool:
        book = {c.LabelEvent.STARTED: self.started, c.LabelEvent.DONE: self.done,
                c.LabelEvent.FAILED: self.failed}[event]
        return label in book


class Conditions:
    """Judges conditions now: the engine's positions and time, the scheduler's labels."""

    def __init__(self, engine: Engine, labels: LabelBook) -> None:
        self.engine = engine
        self.labels = labels

    def holds(self, condition: c.Condition) -> bool:
        match condition:
            case c.LabelCondition(label=label, event=event):
                return self.labels.holds(label.name, event)
            case c.Reaches(subject=subject, target=target):
                gap = self._distance(subject, target)
                return gap is not None and gap <= self._tolerance(subject)
            case c.DistanceTo(subject=subject, target=target, operator=op, threshold=threshold):
                gap = self._distance(subject, target)
                return gap is not None and COMPARE[op](gap, threshold)
            case c.Inside(subject=subject, area=area):
                where = self.engine.position_of(subject)
                return where is not None and bool(shapely.contains_xy(area, *where))
            case c.CountInside(members=members, area=area, operator=op, threshold=threshold):
                return COMPARE[op](self._count_inside(members, area), threshold)
            case c.TimeCompare(operator=op, threshold=threshold):
                # `time >= 2 s` holds at the tick that reaches 2 s despite rounding
                return COMPARE[op](self.engine.time, threshold - 1e-9
                                   if op in (">=", "<") else threshold)
            case c.Not(operand=operand):
                return not self.holds(operand)
            case c.AllOf(operands=operands):
                return all(self.holds(o) for o in operands)
            case c.AnyOf(operands=operands):
                return any(self.holds(o) for o in operands)
        raise TypeError(f"unknown condition {condition!r}")

    def _count_inside(self, members: tuple[str, ...], area: object) -> int:
        where = [p for p in (self.engine.position_of(m) for m in members) if p is not None]
        if not where:
            return 0
        points = np.asarray(where)
        return int(np.count_nonzero(shapely.contains_xy(area, points[:, 0], points[:, 1])))

    def _distance(self, subject: str, target: Target) -> float | None:
        here = self.engine.position_of(subject)
        there = self.engine.position_of(target)
        if here is None or there is None:
            return None
        return math.hypot(there[0] - here[0], there[1] - here[1])

    def _tolerance(self, subject: str) -> float:
        return self.engine.goal_tolerance_of(subject)
