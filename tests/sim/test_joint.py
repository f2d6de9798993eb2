"""Steering many simulations in one call gives each what it gets alone."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from hubero_dsl.planners.base import Crowd, Drive
from hubero_dsl.sim.arrays import FloatArray
from hubero_dsl.sim.joint import JointSteering
from hubero_dsl.sim.lockstep import Lockstep
from hubero_dsl.sim.simulation import Simulation
from tests.sim.conftest import ScenarioFactory

# people walking at each other and past the walls, with a planner per human's choice
BODY = """
seed 4
human a at (2, 2)
human b at (8, 2.2)
human c at (5, 6) { local_planner direct }
human d at (1.0, 6.5)
activity { parallel {
    a move_to (8, 2)
    b move_to (2, 2)
    c move_to (5, 1)
    d move_around in rect((0.5, 4), (9.5, 7.5)) for 30 s
} }
"""


class Opaque:
    """A local planner that steers as the one it wraps but cannot be joined."""

    def __init__(self, inner: Any) -> None:
        self.inner = inner

    def velocities(self, crowd: Crowd, drive: Drive, dt: float) -> FloatArray:
        assert crowd.world is None  # steered alone: a crowd of one simulation
        velocity: FloatArray = self.inner.velocities(crowd, drive, dt)
        return velocity


def copies(scenario: ScenarioFactory, count: int) -> list[Simulation]:
    program = scenario(BODY)
    return [Simulation(program, seed=seed) for seed in range(1, count + 1)]


@pytest.mark.parametrize("joinable", [True, False])
def test_copies_steered_together_move_as_each_alone(scenario: ScenarioFactory,
                                                    joinable: bool) -> None:
    together, alone = copies(scenario, 3), copies(scenario, 3)
    if not joinable:
        for sim in together:
            planners = sim.engine._local
            planners["social_force"] = Opaque(planners["social_force"])
    joint, lockstep, walked = JointSteering(), Lockstep(), 0
    for _ in range(300):
        steerings = Simulation.begin_steps(together, lockstep)
        steered = joint.steer([s.engine for s in together], steerings)
        Simulation.end_steps(together, steerings, steered, lockstep)
        for sim in alone:
            sim.step()
        for mine, theirs in zip(together, alone, strict=True):
            np.testing.assert_array_equal(mine.engine.humans.position,
                                          theirs.engine.humans.position)
        walked += sum(int(sim.engine.humans.moving.sum()) for sim in together)
    assert walked > 1000  # both planners steered people of every copy, tick after tick
    assert {e.human for sim in together for e in sim.events if e.status.value == "SUCCEEDED"} \
        >= {"a", "b", "c"}
