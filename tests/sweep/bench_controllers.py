"""Controllers of a user's own for the benchmark's tests, handed over with --controller."""

from __future__ import annotations

from hubero_dsl.controllers.base import Observation
from hubero_dsl.controllers.navigator import Navigator


class SlowNavigator(Navigator):
    """The reference navigator at half its speed: a controller that differs measurably."""

    def command(self, observation: Observation) -> tuple[float, float]:
        speed, turn = super().command(observation)
        return speed / 2, turn


class Raising(Navigator):
    """A controller with a bug: it raises on its first command."""

    def command(self, observation: Observation) -> tuple[float, float]:
        raise RuntimeError("bug in the controller")
