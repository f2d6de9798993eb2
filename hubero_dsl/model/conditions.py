"""Conditions as lowered: `wait until`, `until` and `expect` read these, never the syntax.

Names are resolved (a place is its point, an area its polygon), thresholds are SI floats, and
every condition keeps its span and its text as the scenario's words (`invite done`) for messages
and diagrams.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from enum import StrEnum
from typing import TYPE_CHECKING, TypeAlias

from hubero_dsl.model.tasks import Target

if TYPE_CHECKING:
    from shapely.geometry import Polygon

    from hubero_dsl.diagnostics import Span


class LabelEvent(StrEnum):
    DONE = "done"
    STARTED = "started"
    FAILED = "failed"


@dataclass(frozen=True, slots=True)
class Label:
    """A label as written: its name and where (a definition, or a reference in a condition)."""

    name: str
    span: Span


@dataclass(frozen=True, slots=True)
class LabelCondition:
    label: Label
    event: LabelEvent
    span: Span
    text: str


@dataclass(frozen=True, slots=True)
class Reaches:
    """`NAME reaches TARGET`: within the subject's goal tolerance of it."""

    subject: str
    target: Target
    span: Span
    text: str


@dataclass(frozen=True, slots=True)
class FlowReaches:
    """`all FLOW reach TARGET` (`every`) or `any FLOW reaches TARGET`, over the people the flow
    has brought: each where they are, or where they left the scene. `all` holds once the flow
    brings nobody more, at least one came, and every one who came is within their goal
    tolerance of the target."""

    flow: str
    target: Target
    every: bool
    span: Span
    text: str


@dataclass(frozen=True, slots=True)
class DistanceTo:
    """`distance(NAME, TARGET) OP Q`, centre to centre, in metres."""

    subject: str
    target: Target
    operator: str
    threshold: float
    span: Span
    text: str


@dataclass(frozen=True, slots=True)
class Inside:
    subject: str
    area: Polygon
    span: Span
    text: str


@dataclass(frozen=True, slots=True)
class CountInside:
    """`count(CROWD in AREA) OP N`: how many of `members` are inside the area."""

    members: tuple[str, ...]
    area: Polygon
    operator: str
    threshold: float
    span: Span
    text: str


@dataclass(frozen=True, slots=True)
class TimeCompare:
    operator: str
    threshold: float   # s
    span: Span
    text: str


@dataclass(frozen=True, slots=True)
class Not:
    operand: Condition
    span: Span
    text: str


@dataclass(frozen=True, slots=True)
class AllOf:
    operands: tuple[Condition, ...]
    span: Span
    text: str


@dataclass(frozen=True, slots=True)
class AnyOf:
    operands: tuple[Condition, ...]
    span: Span
    text: str


@dataclass(frozen=True, slots=True)
class MetricCompare:
    """`METRIC(SUBJECT [, OTHER]) OP THRESHOLD`: judged on the whole run, when it ends."""

    metric: str
    subject: str
    other: str | None
    operator: str
    threshold: float   # SI (a ratio as a fraction: 10 % is 0.1)
    span: Span
    text: str


Condition: TypeAlias = (LabelCondition | Reaches | FlowReaches | DistanceTo | Inside
                        | CountInside | TimeCompare | Not | AllOf | AnyOf)


def walk_conditions(condition: Condition) -> list[Condition]:
    """The condition and every condition inside it, depth first."""
    found: list[Condition] = [condition]
    if isinstance(condition, Not):
        found += walk_conditions(condition.operand)
    elif isinstance(condition, AllOf | AnyOf):
        for operand in condition.operands:
            found += walk_conditions(operand)
    return found


def required_labels(condition: Condition) -> list[LabelCondition]:
    """The label events that must have happened for the condition to hold: every `and`
    operand's; those every `or` operand needs (`y done or y failed` needs `y started`: a
    label is done or failed only once started); under `not not`, the operand's."""
    match condition:
        case LabelCondition():
            return [condition]
        case AllOf(operands=operands):
            return [part for operand in operands for part in required_labels(operand)]
        case AnyOf(operands=operands):
            return _needed_by_each(condition, operands)
        case Not(operand=Not(operand=inner)):
            return required_labels(inner)
    return []


def _needed_by_each(either: AnyOf, operands: tuple[Condition, ...]) -> list[LabelCondition]:
    """The label events every operand of `either` needs, each worded as `either` itself."""
    each = [_implied(operand) for operand in operands]
    common = [key for key in each[0] if all(key in implied for implied in each[1:])]
    return [replace(each[0][key], event=key[1], span=either.span, text=either.text)
            for key in common]


def _implied(condition: Condition) -> dict[tuple[str, LabelEvent], LabelCondition]:
    """The label events a condition needs, by (label, event), a label's start included
    wherever its end or failure is needed."""
    found: dict[tuple[str, LabelEvent], LabelCondition] = {}
    for needed in required_labels(condition):
        found.setdefault((needed.label.name, needed.event), needed)
        found.setdefault((needed.label.name, LabelEvent.STARTED), needed)
    return found
