"""Ticking many simulations at once (`Lockstep`) gives each what it gets alone, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

from hubero_dsl.sim.lockstep import Lockstep
from hubero_dsl.sim.simulation import Simulation
from tests.sim.conftest import ScenarioFactory

# a crowd larger than the few-body shortcuts: people bumping into each other (the separation),
# walking into walls, turning on arrival, talking and standing for a time, a flow coming and
# going (people absent off the map), and a robot taking a task among them
CROWD = "\n".join(
    ["seed 3", "time_limit 40 s"]
    + [f"human p{i} at ({1 + 0.45 * (i % 9):.2f}, {1.2 + 0.5 * (i // 9):.2f})"
       for i in range(18)]
    + ["flow visitors from rect((7.5, 6), (9.5, 7.5)) to (1, 7) rate 1 /s for 20 s",
       "robot r at (8, 2) { radius 0.3 m; speed 0.6 m/s }",
       "activity { parallel {",
       *[f"    p{i} move_around in rect((0.5, 0.5), (9.5, 7.5)) for 30 s" for i in range(0, 18, 2)],
       *[f"    p{i} move_to (9, {1 + 0.3 * i:.1f}) heading 90 deg" for i in range(1, 14, 2)],
       "    p15 talk to p17 for 6 s",
       "    p17 stand facing (5, 7) for 3 s",
       "    r move_to (1, 4)",
       "} }"])


def _state(sim: Simulation) -> list[np.ndarray]:
    h, e, r = sim.engine.humans, sim.engine, sim.engine.robots
    return [h.position, h.velocity, h.heading, h.path_length, e.anchor, e.anchor_tick,
            r.position, r.velocity, r.heading]


def _tick_alike(together: list[Simulation], alone: list[Simulation], ticks: int) -> None:
    """Tick `together` in lockstep and `alone` one by one, `ticks` times; after every tick
    each copy's state and events are those of its twin, bit for bit."""
    lockstep = Lockstep()
    for _ in range(ticks):
        steerings = Simulation.begin_steps(together, lockstep)
        steered = [sim.engine.steer(steering) for sim, steering in zip(together, steerings,
                                                                           strict=True)]
        Simulation.end_steps(together, steerings, steered, lockstep)
        for sim in alone:
            sim.step()
        for mine, theirs in zip(together, alone, strict=True):
            assert mine.tick == theirs.tick
            for got, expected in zip(_state(mine), _state(theirs), strict=True):
                np.testing.assert_array_equal(got, expected)
            assert mine.events == theirs.events


def test_simulations_ticked_together_tick_as_each_alone(scenario: ScenarioFactory) -> None:
    program = scenario(CROWD)
    together = [Simulation(program, seed=seed) for seed in (1, 2, 3)]
    alone = [Simulation(program, seed=seed) for seed in (1, 2, 3)]
    for sim in (together[2], alone[2]):  # copies at different ticks: their own clocks
        for _ in range(37):
            sim.step()
    _tick_alike(together, alone, 400)
    events = sum(len(sim.events) for sim in together)
    assert events > 100  # tasks started, ended, people came and left, in every copy
    assert all(sim.engine.humans.present is not None and sim.engine.humans.present.any()
               for sim in together)


def test_robots_stopped_at_people_stop_alike_together_and_alone(
        scenario: ScenarioFactory) -> None:
    # alone, a robot's stop at people is found in floats; together, in arrays
    program = scenario("human a at (5, 4)\nhuman b at (5, 6)\n"
                       "robot r at (2, 4.1) { radius 0.3 m; max_speed 1.0 m/s }\n")
    together = [Simulation(program, seed=seed) for seed in (1, 2)]
    alone = [Simulation(program, seed=seed) for seed in (1, 2)]
    for sim in (*together, *alone):
        sim.human("a").sit_down(duration=30.0)
        sim.set_robot_velocity("r", 1.0, 0.0)
    _tick_alike(together, alone, 80)
    robot, seated = together[0].robot("r").position, together[0].human("a").position
    assert np.hypot(*(np.asarray(robot) - seated)) == pytest.approx(0.5, abs=1e-6)  # touching
