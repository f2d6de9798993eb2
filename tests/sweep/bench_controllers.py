"""A controller of a user's own for the benchmark's tests, handed over with --controller (the
working one is the plugin package of tests/plugin_controller.py)."""

from __future__ import annotations

from hubero_dsl.controllers.base import Observation
from hubero_dsl.controllers.navigator import Navigator


class Raising(Navigator):
    """A controller with a bug: it raises on its first command."""

    def command(self, observation: Observation) -> tuple[float, float]:
        raise RuntimeError("bug in the controller")
