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
from hubero_dsl.socialnav import GOAL_SLACK

if TYPE_CHECKING:
    from hubero_dsl.sim.engine import Engine
    from hubero_dsl.sim.flows import Flows

COMPARE: dict[str, Callable[[float, float], bool]] = {
    "<": operator.lt, "<=": operator.le, ">": operator.gt, ">=": operator.ge}
TIME_SLACK = 1e-9  # s: a tick's time (tick x step) is the time it stands for within this


@dataclass
class LabelBook:
    """Which labelled steps have started, finished, or had an action aborted."""

    started: set[str] = field(default_factory=set)
    done: set[str] = field(default_factory=set)
    failed: set[str] = field(default_factory=set)

    def book(self, event: c.LabelEvent) -> set[str]:
        """The labels of which `event` has happened (the set itself, which grows)."""
        if event is c.LabelEvent.STARTED:
            return self.started
        return self.done if event is c.LabelEvent.DONE else self.failed


class Conditions:
    """Judges conditions now: the engine's positions and time, the scheduler's labels.

    A condition that is asked again and again (an `expect` every tick, a `wait until`) is
    turned once into a function of the world: names resolved to the engine's rows, the
    comparison chosen, so that each tick only reads positions and compares.
    """

    def __init__(self, engine: Engine, labels: LabelBook) -> None:
        self.engine = engine
        self.labels = labels
        self.flows: Flows | None = None   # the run's flows, set when it has any
        # by the condition's identity; the condition is kept, so its id is never reused
        self._tests: dict[int, tuple[c.Condition, Callable[[], bool]]] = {}

    def holds(self, condition: c.Condition) -> bool:
        return self.test(condition)()

    def test(self, condition: c.Condition) -> Callable[[], bool]:
        """A function telling whether `condition` holds at the time it is called (made once
        per condition)."""
        kept = self._tests.get(id(condition))
        if kept is None:
            kept = self._tests[id(condition)] = (condition, self._test(condition))
        return kept[1]

    def _test(self, condition: c.Condition) -> Callable[[], bool]:
        """A function telling whether `condition` holds now."""
        match condition:
            case c.LabelCondition(label=label, event=event):
                name, book = label.name, self.labels.book(event)
                return lambda: name in book
            case c.Reaches(subject=subject, target=target):
                near = self._within(subject, target, operator.le,
                                    self.engine.goal_tolerance_of(subject) + GOAL_SLACK)
                return self._or_arrived_together(subject, target, near)
            case c.FlowReaches(flow=flow, target=target, every=every):
                return self._flow_reaches(flow, target, every)
            case c.DistanceTo(subject=subject, target=target, operator=op, threshold=threshold):
                return self._within(subject, target, COMPARE[op], threshold)
            case c.Inside(subject=subject, area=area):
                def inside() -> bool:
                    where = self.engine.position_of(subject)
                    return where is not None and bool(shapely.contains_xy(area, *where))
                return inside
            case c.CountInside(members=members, area=area, operator=op, threshold=threshold):
                compare = COMPARE[op]
                return lambda: compare(self._count_inside(members, area), threshold)
            case c.TimeCompare(operator=op, threshold=threshold):
                # the tick that reaches 2 s is at 2 s despite rounding (56 x 0.05 s is
                # 2.8000000000000003): `time >= 2 s` and `time <= 2 s` both hold at it
                compare = COMPARE[op]
                bound = threshold - TIME_SLACK if op in (">=", "<") else threshold + TIME_SLACK
                return lambda: compare(self.engine.time, bound)
            case c.Not(operand=operand):
                test = self._test(operand)
                return lambda: not test()
            case c.AllOf(operands=operands):
                tests = [self._test(o) for o in operands]
                return lambda: all(t() for t in tests)
            case c.AnyOf(operands=operands):
                tests = [self._test(o) for o in operands]
                return lambda: any(t() for t in tests)
        raise TypeError(f"unknown condition {condition!r}")

    def _within(self, subject: str, target: Target, compare: Callable[[float, float], bool],
                bound: float) -> Callable[[], bool]:
        """Whether the distance between `subject` and `target` compares with `bound` (never
        when either is gone)."""
        here, there = self.engine.locator(subject), self.engine.locator(target)

        def holds() -> bool:
            a, b = here(), there()
            return a is not None and b is not None and compare(
                math.hypot(b[0] - a[0], b[1] - a[1]), bound)
        return holds

    def _or_arrived_together(self, subject: str, target: Target,
                             near: Callable[[], bool]) -> Callable[[], bool]:
        """`near`, or: `subject` was sent to the point `target` with its crowd or group and
        its walk there succeeded (`Engine.arrived_together`): many cannot all stand on one
        point."""
        engine = self.engine
        if isinstance(target, str) or subject not in engine.humans.names:
            return near
        row = engine.index_of(subject)
        return lambda: near() or engine.together_at.get(row) == target

    def _flow_reaches(self, flow: str, target: Target, every: bool) -> Callable[[], bool]:
        """Whether all (`every`) or any of the people `flow` has brought are, or left the
        scene, within their goal tolerance of `target`; `all` only once nobody more will come
        and someone came."""
        there, tolerance = self.engine.locator(target), self.engine.humans.goal_tolerance

        def holds() -> bool:
            assert self.flows is not None  # a program with a flow builds its flows
            rows, where, more = self.flows.whereabouts(flow)
            at = there()
            if at is None or not len(rows) or (every and more):
                return False
            within = (np.hypot(where[:, 0] - at[0], where[:, 1] - at[1])
                      <= tolerance[rows] + GOAL_SLACK)
            return bool(within.all() if every else within.any())
        return holds

    def _count_inside(self, members: tuple[str, ...], area: object) -> int:
        where = [p for p in (self.engine.position_of(m) for m in members) if p is not None]
        if not where:
            return 0
        points = np.asarray(where)
        return int(np.count_nonzero(shapely.contains_xy(area, points[:, 0], points[:, 1])))
