"""Task statuses, postures and the task handle: what a caller holds after commanding a human."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from enum import IntEnum, StrEnum
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from hubero_dsl.diagnostics import Span


class TaskStatus(StrEnum):
    PENDING = "PENDING"
    ACTIVE = "ACTIVE"
    SUCCEEDED = "SUCCEEDED"
    PREEMPTED = "PREEMPTED"
    ABORTED = "ABORTED"

    @property
    def is_final(self) -> bool:
        return self in (TaskStatus.SUCCEEDED, TaskStatus.PREEMPTED, TaskStatus.ABORTED)


class Posture(IntEnum):
    STANDING = 0
    SITTING = 1
    LYING = 2


@dataclass(frozen=True, slots=True)
class TaskEvent:
    """One status change of one task, as the log records it."""

    tick: int
    time: float
    task_id: int
    human: str
    kind: str
    status: TaskStatus
    reason: str
    span: Span | None


@dataclass(eq=False)
class TaskHandle:
    """A command given to one human. Its status moves PENDING -> ACTIVE -> a final status.

    `cancel()` preempts it. The simulation owns the transitions; callers only read them.
    """

    task_id: int
    human: str
    kind: str
    description: str
    span: Span | None = None
    status: TaskStatus = TaskStatus.PENDING
    reason: str = ""
    started_at: float | None = None
    ended_at: float | None = None
    _cancel: Callable[[TaskHandle, str], None] | None = field(default=None, repr=False)
    _listeners: list[Callable[[TaskHandle], None]] = field(default_factory=list, repr=False)

    @property
    def done(self) -> bool:
        return self.status.is_final

    def cancel(self, reason: str = "cancelled") -> None:
        """Preempt the task if it has not finished, for `reason`; a finished task stays as it
        is."""
        if not self.done and self._cancel is not None:
            self._cancel(self, reason)

    def on_change(self, listener: Callable[[TaskHandle], None]) -> None:
        self._listeners.append(listener)

    def _notify(self) -> None:
        for listener in list(self._listeners):
            listener(self)


def describe_target(target: Any) -> str:
    if isinstance(target, str):
        return target
    x, y = target
    return f"({x:g}, {y:g})"


def stuck_reason(seconds: float, taken_by: str | None = None) -> str:
    """Why a walk was given up: no progress for `seconds`, and who stands on its goal, if
    someone does (a human's or a robot's task alike)."""
    taken = f", its goal taken by {taken_by}" if taken_by is not None else ""
    return f"stuck: no progress for {seconds:g} s{taken}"
