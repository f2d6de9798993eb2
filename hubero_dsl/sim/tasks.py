"""From a task as written (`actor2 talk to actor1 for 5 s`) to a call of the human API.

The scheduler uses this, so scenario files and Python callers command humans the same way.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from hubero_dsl.lang import ast
from hubero_dsl.lang.program import Pose
from hubero_dsl.lang.units import Dimension
from hubero_dsl.sim.conditions import si
from hubero_dsl.sim.status import TaskHandle

if TYPE_CHECKING:
    from hubero_dsl.diagnostics import Span
    from hubero_dsl.sim.simulation import Simulation

DEFAULT_FOLLOW_DISTANCE = 1.0  # m


def _target(sim: Simulation, value: ast.PointValue) -> tuple[float, float] | str:
    resolved = sim.program.point(value)
    return resolved.xy if isinstance(resolved, Pose) else resolved


def _options(sim: Simulation, task: ast.Task) -> dict[str, Any]:
    """The task's options as API keyword values (SI units, resolved names)."""
    found: dict[str, Any] = {}
    for option in task.options:
        value = option.value
        keyword = option.keyword
        if keyword in ("facing", "to") or (keyword == "at" and task.kind != "follow"):
            found[keyword] = _target(sim, value)  # type: ignore[arg-type]
        elif keyword == "in":
            found[keyword] = sim.program.area(value)  # type: ignore[arg-type]
        elif keyword == "times":
            found[keyword] = int(value.value)  # type: ignore[union-attr]
        else:
            dimension = {"heading": Dimension.ANGLE, "speed": Dimension.SPEED,
                         "for": Dimension.TIME, "at": Dimension.LENGTH}[keyword]
            found[keyword] = si(value, dimension)  # type: ignore[arg-type]
    return found


def give_task(sim: Simulation, human: str, task: ast.Task, span: Span) -> TaskHandle:
    """Command `human` to do `task`; returns the task's handle."""
    handle = sim.human(human)
    o = _options(sim, task)
    target = _target(sim, task.target) if task.target is not None else None
    kind = task.kind
    if kind == "stand":
        return handle.stand(facing=o.get("facing"), duration=o.get("for"), span=span)
    if kind == "move_to":
        assert target is not None
        return handle.move_to(target, heading=o.get("heading"), speed=o.get("speed"), span=span)
    if kind == "run_to":
        assert target is not None
        return handle.run_to(target, heading=o.get("heading"), span=span)
    if kind == "move_around":
        area = o.get("in", sim.program.bounds)
        return handle.move_around(area=area, duration=o.get("for"), times=o.get("times"),
                                  span=span)
    if kind == "follow":
        assert isinstance(target, str)
        return handle.follow(target, distance=o.get("at", DEFAULT_FOLLOW_DISTANCE),
                             duration=o.get("for"), span=span)
    if kind == "talk":
        return handle.talk(to=o.get("to"), duration=o.get("for"), span=span)
    if kind == "sit_down":
        return handle.sit_down(at=o.get("at"), duration=o.get("for"), heading=o.get("heading"),
                               span=span)
    if kind == "lie_down":
        return handle.lie_down(at=o.get("at"), duration=o.get("for"), heading=o.get("heading"),
                               span=span)
    return handle.teleop(duration=o.get("for"), span=span)
