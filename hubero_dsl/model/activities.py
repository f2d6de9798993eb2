"""Activities and expectations as lowered: the steps the activity graph is built from.

Each step keeps its span and label for diagnostics, and its text in the scenario's own words for
messages and diagrams; values are SI and names are resolved (a task's target is a point or a
body's name, an area a polygon). Lowering never fails: in a file with errors, what cannot be
resolved is lowered to a neutral value so that the graph can still be verified, and no program
is built from it.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum
from typing import TYPE_CHECKING, TypeAlias

from hubero_dsl.model.conditions import Condition, Label, MetricCompare
from hubero_dsl.model.tasks import Task

if TYPE_CHECKING:
    from hubero_dsl.diagnostics import Span


@dataclass(frozen=True, slots=True)
class TaskStep:
    """`[LABEL:] ACTOR TASK [until C] [within Q] [forever]`."""

    actor: str
    task: Task
    until: Condition | None
    within: float | None       # s
    forever: bool
    span: Span
    text: str                  # the step without its label, as the scenario's words
    label: Label | None = None


@dataclass(frozen=True, slots=True)
class WaitStep:
    duration: float            # s
    duration_text: str         # `2 s`, as written
    span: Span
    label: Label | None = None


@dataclass(frozen=True, slots=True)
class WaitUntilStep:
    condition: Condition
    span: Span
    label: Label | None = None


@dataclass(frozen=True, slots=True)
class ParallelStep:
    branches: tuple[Step, ...]
    span: Span
    label: Label | None = None
    crowd: str | None = None   # a task given to a crowd: one branch per member


@dataclass(frozen=True, slots=True)
class RaceStep:
    branches: tuple[Step, ...]
    span: Span
    label: Label | None = None


@dataclass(frozen=True, slots=True)
class RepeatStep:
    count: float               # as written; `rounds` is what runs
    count_text: str
    count_is_whole: bool       # written as a whole number (`3`, not `3.0` or `1e1`)
    count_span: Span
    body: tuple[Step, ...]
    span: Span
    label: Label | None = None

    @property
    def rounds(self) -> int:
        """The number of rounds, or 0 when the count is not a whole number of at least one."""
        return int(self.count) if self.count_is_whole and self.count >= 1 else 0


@dataclass(frozen=True, slots=True)
class SequenceStep:
    steps: tuple[Step, ...]
    span: Span
    label: Label | None = None


Step: TypeAlias = (TaskStep | WaitStep | WaitUntilStep | ParallelStep | RaceStep | RepeatStep
                   | SequenceStep)


@dataclass(frozen=True, slots=True)
class Activity:
    name: str | None
    steps: tuple[Step, ...]
    span: Span
    head_span: Span            # `activity NAME`: where its start is shown


def child_steps(step: Step) -> tuple[Step, ...]:
    """The steps directly inside a composite step (none for tasks and waits)."""
    if isinstance(step, ParallelStep | RaceStep):
        return step.branches
    if isinstance(step, SequenceStep):
        return step.steps
    if isinstance(step, RepeatStep):
        return step.body
    return ()


def walk_steps(steps: tuple[Step, ...]) -> list[Step]:
    """Every step, depth first, in source order."""
    found: list[Step] = []
    for step in steps:
        found.append(step)
        found.extend(walk_steps(child_steps(step)))
    return found


class ExpectMode(StrEnum):
    ALWAYS = "always"
    EVENTUALLY = "eventually"
    WITHIN = "within"
    AT_END = "at_end"   # a metric of the whole run


@dataclass(frozen=True, slots=True)
class Expectation:
    """`expect CONDITION always | eventually | within Q`."""

    condition: Condition | MetricCompare
    mode: ExpectMode
    deadline: float | None     # s, for `within`
    text: str                  # as the summary shows it: the line without `expect`
    span: Span
