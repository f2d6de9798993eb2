"""The tick at rest (nobody walks or is teleoperated) gives what moving at zero would."""

from __future__ import annotations

import copy

import numpy as np
import pytest

from hubero_dsl.sim.lockstep import Lockstep, _Rows
from hubero_dsl.sim.simulation import Simulation
from hubero_dsl.sim.status import Posture
from tests.sim.conftest import ScenarioFactory


def moved_both_ways(sim: Simulation) -> tuple[Simulation, Simulation]:
    """The engine's move of this tick at rest (`None`) and at an explicit zero velocity."""
    at_rest, at_zero = copy.deepcopy(sim), copy.deepcopy(sim)
    at_rest_rows, at_zero_rows = _Rows([at_rest.engine]), _Rows([at_zero.engine])
    Lockstep()._move(at_rest_rows, None)
    Lockstep()._move(at_zero_rows, np.zeros(sim.engine.humans.position.shape))
    return at_rest, at_zero


def assert_same_state(first: Simulation, second: Simulation) -> None:
    for name in ("position", "velocity", "path_length"):
        got, expected = getattr(first.engine.humans, name), getattr(second.engine.humans, name)
        np.testing.assert_array_equal(got, expected)
        # -0.0 and 0.0 are equal to numpy but not in a log
        assert np.signbit(got).tolist() == np.signbit(expected).tolist()


@pytest.mark.parametrize("robot", ["", "robot r at (6, 4) { radius 0.4 m }"])
def test_a_tick_at_rest_is_a_move_at_zero(scenario: ScenarioFactory, robot: str) -> None:
    # standing apart, one sitting, one at -0.0 (which a move at zero turns into 0.0)
    sim = Simulation(scenario(f"human a at (2, 2)\nhuman b at (4, 3)\n{robot}\n"),
                     activities=False)
    sim.step()
    sim.engine.humans.position[0, 1] = -0.0
    sim.engine.humans.posture[1] = Posture.SITTING  # never moved
    at_rest, at_zero = moved_both_ways(sim)
    assert_same_state(at_rest, at_zero)


def test_people_overlapping_at_rest_are_still_separated(scenario: ScenarioFactory) -> None:
    sim = Simulation(scenario("human a at (2, 2)\nhuman b at (2.3, 2)\n"
                              "robot r at (2.6, 2.1) { radius 0.4 m }\n"), activities=False)
    at_rest, at_zero = moved_both_ways(sim)
    assert_same_state(at_rest, at_zero)
    assert not np.array_equal(at_rest.engine.humans.position, sim.engine.humans.position)
