"""The human control API (the paper's requirement a): command each human on its own.

`HumanHandle` is what `Simulation.human(name)` returns. Every command returns a `TaskHandle`
whose status goes PENDING -> ACTIVE -> SUCCEEDED / PREEMPTED / ABORTED (with a reason); a new
command preempts the current one. Targets are `(x, y)` points in metres, or the name of a place,
a human or a robot (that body's position when the task starts or re-plans). Angles are radians,
durations seconds, speeds m/s. The scheduler drives humans through exactly these methods.
"""

from __future__ import annotations

import itertools
from typing import TYPE_CHECKING

import numpy as np

from hubero_dsl.errors import SimulationError
from hubero_dsl.sim.behaviours import (
    Behaviour,
    Follow,
    MoveAround,
    MoveTo,
    Posed,
    Stand,
    Talk,
    Target,
    Teleop,
    Timing,
)
from hubero_dsl.sim.status import Posture, TaskHandle, describe_target

if TYPE_CHECKING:
    from shapely.geometry import Polygon

    from hubero_dsl.diagnostics import Span
    from hubero_dsl.sim.engine import Engine



class HumanHandle:
    """One human of a running simulation."""

    def __init__(self, engine: Engine, name: str, places: dict[str, tuple[float, float]],
                 ids: itertools.count[int]) -> None:
        self._engine = engine
        self.name = name
        self._index = engine.index_of(name)
        self._places = places
        self._ids = ids

    # ---- state ---------------------------------------------------------------------------

    @property
    def position(self) -> tuple[float, float]:
        x, y = self._engine.humans.position[self._index]
        return (float(x), float(y))

    @property
    def velocity(self) -> tuple[float, float]:
        vx, vy = self._engine.humans.velocity[self._index]
        return (float(vx), float(vy))

    @property
    def heading(self) -> float:
        return float(self._engine.humans.heading[self._index])

    @property
    def posture(self) -> Posture:
        return Posture(int(self._engine.humans.posture[self._index]))

    @property
    def task(self) -> TaskHandle | None:
        """The task the human is doing now, if any."""
        return self._engine.handle[self._index]

    @property
    def state(self) -> str:
        """The behaviour's FSM state ('walking', 'aligning', 'talking', ... or 'idle')."""
        behaviour = self._engine.behaviour[self._index]
        return behaviour.state if behaviour is not None else "idle"

    # ---- commands ------------------------------------------------------------------------

    def stand(self, *, facing: Target | None = None, duration: float | None = None,
              span: Span | None = None) -> TaskHandle:
        words = f"stand facing {describe_target(facing)}" if facing is not None else "stand"
        return self._give(Stand(Timing(duration), self._target(facing)), words, span)

    def move_to(self, target: Target, *, heading: float | None = None,
                speed: float | None = None, span: Span | None = None) -> TaskHandle:
        _positive(speed, "speed")
        behaviour = MoveTo(self._required_target(target), heading, speed)
        return self._give(behaviour, f"move_to {describe_target(target)}", span)

    def run_to(self, target: Target, *, heading: float | None = None,
               span: Span | None = None) -> TaskHandle:
        behaviour = MoveTo(self._required_target(target), heading, running=True)
        behaviour.kind = "run_to"
        return self._give(behaviour, f"run_to {describe_target(target)}", span)

    def move_around(self, *, area: Polygon | None = None, duration: float | None = None,
                    times: int | None = None, span: Span | None = None) -> TaskHandle:
        if times is not None and times < 1:
            raise SimulationError("move_around: times must be at least 1")
        return self._give(MoveAround(Timing(duration), area, times), "move_around", span)

    def follow(self, target: str, *, distance: float = 1.0, duration: float | None = None,
               span: Span | None = None) -> TaskHandle:
        if target == self.name:
            raise SimulationError(f"{self.name} cannot follow itself")
        self._required_target(target)
        _positive(distance, "distance")
        return self._give(Follow(Timing(duration), target, distance), f"follow {target}", span)

    def talk(self, *, to: Target | None = None, duration: float | None = None,
             span: Span | None = None) -> TaskHandle:
        words = f"talk to {describe_target(to)}" if to is not None else "talk"
        return self._give(Talk(Timing(duration), self._target(to)), words, span)

    def sit_down(self, *, at: Target | None = None, duration: float | None = None,
                 heading: float | None = None, span: Span | None = None) -> TaskHandle:
        return self._give(Posed(Posture.SITTING, Timing(duration), self._target(at), heading),
                          "sit_down", span)

    def lie_down(self, *, at: Target | None = None, duration: float | None = None,
                 heading: float | None = None, span: Span | None = None) -> TaskHandle:
        return self._give(Posed(Posture.LYING, Timing(duration), self._target(at), heading),
                          "lie_down", span)

    def teleop(self, *, duration: float | None = None, span: Span | None = None) -> TaskHandle:
        return self._give(Teleop(Timing(duration)), "teleop", span)

    def set_velocity(self, vx: float, vy: float) -> None:
        """The velocity a `teleop` task applies (walls still stop the human)."""
        speed = float(np.hypot(vx, vy))
        limit = float(self._engine.humans.run_speed[self._index])
        scale = 1.0 if speed <= limit else limit / speed
        self._engine.humans.teleop_velocity[self._index] = (vx * scale, vy * scale)

    # ---- internals -----------------------------------------------------------------------

    def _target(self, target: Target | None) -> Target | None:
        if target is None:
            return None
        return self._required_target(target)

    def _required_target(self, target: Target) -> Target:
        if not isinstance(target, str):
            x, y = target
            return (float(x), float(y))
        if target in self._places:
            return self._places[target]
        if self._engine.position_of(target) is None:
            raise SimulationError(f"unknown target '{target}': not a place, human or robot")
        return target

    def _give(self, behaviour: Behaviour, description: str, span: Span | None) -> TaskHandle:
        handle = TaskHandle(next(self._ids), self.name, behaviour.kind, description, span)
        handle._cancel = self._engine.cancel
        self._engine.command(self._index, behaviour, handle)
        return handle


def _positive(value: float | None, what: str) -> None:
    if value is not None and not value > 0:
        raise SimulationError(f"{what} must be greater than zero")
