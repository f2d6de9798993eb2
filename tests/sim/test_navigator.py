"""The reference navigator among people who do not give way: it steps out of the way of someone
walking at it, goes round people standing in its way, and keeps off walls."""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import numpy as np
import pytest

from hubero_dsl.pipeline import compile_file
from hubero_dsl.sim.loop import RunState, run_program
from hubero_dsl.sim.simulation import Simulation
from tests.sim.conftest import ScenarioFactory

REPO_ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("seed", range(1, 9))
def test_among_the_guests_the_cart_never_touches_anyone_and_always_arrives(seed: int) -> None:
    # with seed 5 a wandering guest used to walk into the stopped cart and pin it there
    sim = Simulation(compile_file(REPO_ROOT / "scenarios" / "robot_among_guests.hub"),
                     seed=seed)
    gaps: list[float] = []
    radius = float(sim.engine.robots.radius[0])

    def observe(s: Simulation) -> None:
        cart = s.robot("cart").position
        gaps.append(min(math.dist(cart, s.human(n).position) - radius
                        - float(s.engine.humans.radius[s.engine.index_of(n)])
                        for n in s.engine.humans.names))

    result = run_program(sim, [observe])
    assert result.state is RunState.COMPLETED, result.reason
    assert result.robots[0].tasks_done == 3
    assert min(gaps) > 0.05


def test_it_steps_aside_for_someone_walking_at_it(scenario: ScenarioFactory) -> None:
    """bob ignores robots and walks the cart's line head-on: standing would end in contact."""
    program = scenario("""
    human bob at (8, 4) heading 180 deg { robot_reaction impassive }
    robot cart at (2, 4) { controller navigator; speed 0.6 m/s }
    activity { bob move_to (1, 4) }
    activity { cart move_to (9, 4) within 40 s }
    """)
    sim = Simulation(program)
    gaps: list[float] = []
    result = run_program(sim, [lambda s: gaps.append(
        math.dist(s.robot("cart").position, s.human("bob").position) - 0.3 - 0.2)])
    assert result.state is RunState.COMPLETED, result.reason
    assert min(gaps) > 0.0


def test_it_goes_round_someone_standing_in_its_way(scenario: ScenarioFactory) -> None:
    program = scenario("""
    human bob at (5, 4) heading 90 deg
    robot cart at (1, 4) { controller navigator; speed 0.8 m/s; navigator.detour_after 2 s }
    activity { bob stand for 60 s }
    activity { cart move_to (9, 4) within 40 s }
    """)
    sim = Simulation(program)
    gaps: list[float] = []
    result = run_program(sim, [lambda s: gaps.append(
        math.dist(s.robot("cart").position, s.human("bob").position) - 0.3 - 0.2)])
    cart_task = [e for e in result.events if e.human == "cart"]
    assert cart_task[-1].status.value == "SUCCEEDED", result.reason
    assert min(gaps) >= 0.3 - 0.05   # round him at its safety margin


def test_it_goes_round_a_robot_standing_in_its_way(scenario: ScenarioFactory) -> None:
    # an external robot left at rest is an obstacle like a person standing: it waited there
    # until it was given up as stuck
    program = scenario("""
    robot cart at (1, 4) heading 0 deg { controller navigator; speed 0.8 m/s }
    robot parked at (4, 4) { controller external }
    activity { cart move_to (8, 4) within 40 s }
    """)
    sim = Simulation(program)
    gaps: list[float] = []
    result = run_program(sim, [lambda s: gaps.append(
        math.dist(s.robot("cart").position, s.robot("parked").position) - 0.3 - 0.3)])
    assert result.succeeded, result.reason
    assert min(gaps) >= 0.3 - 0.05   # round it at its safety margin


def test_it_keeps_off_the_walls_of_a_corridor(scenario: ScenarioFactory, tmp_path: Path) -> None:
    from hubero_dsl.world.mapfile import save_map
    from tests.sim.conftest import room_grid

    corridor = tmp_path / "corridor.yaml"  # 1.2 m wide, with a bend
    save_map(room_grid(walls=((0.0, 0.0, 10.0, 3.4), (0.0, 4.6, 6.0, 8.0),
                              (7.2, 4.6, 10.0, 8.0))), corridor)
    program = scenario("""
    human bob at (9.3, 4)
    robot cart at (0.5, 4) heading 0 deg {
        controller navigator; kinematics unicycle; speed 0.8 m/s; max_angular_speed 2.0
    }
    activity { bob stand for 1 s }
    activity { cart move_to (6.6, 7.5) within 40 s }
    """, map_path=corridor)
    sim = Simulation(program)
    clearance: list[float] = []
    result = run_program(sim, [lambda s: clearance.append(
        float(s.engine.grid.clearance_at([s.robot("cart").position])[0]))])
    assert result.robots[0].last_status == "SUCCEEDED", result.reason
    assert min(clearance) >= 0.3 - 0.03   # it may brush a corner by a few centimetres


def test_stepping_out_of_a_crowds_way_it_does_not_flip_from_side_to_side() -> None:
    # re-choosing its step every tick among near-equal ways, it reversed 12 times and changed
    # its velocity faster than 5 m/s^2 in 64 ticks of this run
    from hubero_dsl.pipeline import compile_source

    hall = REPO_ROOT / "maps" / "benchmark" / "hall.yaml"
    sim = Simulation(compile_source(f"""\
scenario "a crowd walking at the cart"
map "{hall}"
seed 2
time_limit 60 s
on_failure continue
crowd people 10 in rect((9.0, 2.5), (12.5, 7.5)) heading 180 deg {{
    speed normal(1.2 m/s, 0.15 m/s)
}}
human solo at (11.0, 5.0) heading 180 deg
robot cart at (1.0, 5.0) heading 0 deg {{
    controller navigator; radius 0.3 m; speed 0.8 m/s; max_speed 1.0 m/s; goal (13.0, 5.0)
}}
activity {{ parallel {{ people move_to (1.5, 5.0); solo move_to (1.0, 5.0)
                        cart move_to (13.0, 5.0) within 50 s }} }}
""", str(REPO_ROOT / "t.hub")))
    velocities = []
    while sim.time < 30.0:
        sim.step()
        velocities.append(sim.robot("cart").velocity)
    jolts = reversals = 0
    for (ax, ay), (bx, by) in itertools.pairwise(velocities):
        jolts += math.hypot(bx - ax, by - ay) / sim.dt > 5.0
        moving = math.hypot(ax, ay) > 0.05 and math.hypot(bx, by) > 0.05
        reversals += moving and ax * bx + ay * by < -0.5 * math.hypot(ax, ay) * math.hypot(bx, by)
    assert jolts <= 35 and reversals <= 10


def test_steps_aside_for_one_goal_are_forgotten_at_the_next(scenario: ScenarioFactory) -> None:
    # kept while it waited, the place its steps aside began limited those for a next goal
    sim = Simulation(scenario("human bob at (3.2, 4)\n"
                              "robot r at (2, 4) { controller navigator; radius 0.3 m }\n"),
                     activities=False)
    sim.human("bob").stand(duration=60.0)     # in its way to either goal: it waits
    navigator = sim.engine.robots.controllers[0]
    sim.robot("r").move_to((6.0, 4.0))
    while navigator.blocked_for == 0.0 and sim.time < 10.0:  # it closes in, then stops
        sim.step()
    assert navigator.blocked_for > 0.0
    navigator.escape_origin, navigator.escape_way = np.array([1.0, 4.0]), 3  # as if aside
    sim.robot("r").move_to((6.0, 4.5))
    sim.step()
    assert navigator.blocked_for > 0.0        # still waiting, for the new goal
    assert navigator.escape_origin is None and navigator.escape_way is None
