"""Social-navigation metrics from a log: per robot and human, shapes, groups, the index row."""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import pytest

from hubero_dsl.analysis.metrics import compute_metrics
from hubero_dsl.analysis.socialnav_log import (
    human_social_metrics,
    log_social_metrics,
    robot_social_metrics,
)
from hubero_dsl.log.reader import load_run
from hubero_dsl.pipeline import compile_file
from hubero_dsl.sim.status import TaskStatus
from hubero_dsl.simulate import simulate
from hubero_dsl.socialnav import METRICS
from hubero_dsl.world.shapes import Ellipse, Rectangle

REPO_ROOT = Path(__file__).resolve().parents[2]
TIMES = [float(t) for t in range(7)]
WALK = [(float(x), 0.0) for x in range(-3, 4)]   # 1 m/s along y = 0, x = -3..3


@pytest.mark.parametrize(("shape", "heading", "share"), [
    (Ellipse(1.0, 0.5), 0.0, 3 / 6),            # along the walk: inside at x = -1, 0, 1
    (Ellipse(1.0, 0.5), math.pi / 2, 1 / 6),    # across it: only at x = 0
    (Rectangle(4.0, 1.0), 0.0, 5 / 6),          # 2 m either side: x = -2..2
])
def test_a_robot_in_a_persons_own_shape(build_run: Callable, track: Callable, robot: Callable,
                                        shape: object, heading: float, share: float) -> None:
    ann = track("ann", TIMES, [(0.0, 0.0)] * 7, heading=heading)
    run = build_run([ann], robots=[robot("cart", TIMES, WALK)],
                    params={"ann": {"personal_space": shape, "radius": 0.2}})
    metrics = robot_social_metrics(run, "cart")
    assert metrics["shape_intrusions"] == pytest.approx(share)
    assert set(metrics) == {*METRICS, "shape_intrusions"}


def test_a_flows_member_counts_only_while_it_is_there(build_run: Callable, track: Callable,
                                                      robot: Callable) -> None:
    # a visitor logged from t = 1 to 2 at x = 3, beside where the robot will be at t = 6: it
    # left long before; held at its last position it would be a ghost the robot runs into
    visitor = track("visitor_1", [1.0, 1.5, 2.0], [(3.0, 0.5)] * 3)
    ann = track("ann", TIMES, [(-3.0, 5.0)] * 7)
    run = build_run([visitor, ann], robots=[robot("cart", TIMES, WALK)])
    metrics = robot_social_metrics(run, "cart")
    # while the visitor was there the robot was at x = -2 .. -1: 4.06 m from it, surfaces
    assert metrics["min_distance"] == pytest.approx(math.hypot(4.0, 0.5) - 0.5)
    assert metrics["collisions"] == 0.0 and metrics["shape_intrusions"] == 0.0
    assert metrics["min_time_to_collision"] > 1.0    # no jump from or to nowhere


def test_a_robot_alone_has_no_distances(build_run: Callable, robot: Callable) -> None:
    metrics = robot_social_metrics(build_run([], robots=[robot("cart", TIMES, WALK)]), "cart")
    assert all(metrics[key] == math.inf for key in (
        "min_distance", "avg_distance", "max_distance", "avg_centre_distance"))


def test_group_spaces_come_from_the_logs_sets(build_run: Callable, track: Callable,
                                              robot: Callable) -> None:
    mum = track("mum", TIMES, [(0.0, 1.0)] * 7)
    dad = track("dad", TIMES, [(0.0, -1.0)] * 7)
    run = build_run([mum, dad], robots=[robot("cart", TIMES, WALK)],
                    params={"mum": {"radius": 0.25}, "dad": {"radius": 0.25}})
    run = replace(run, metadata=replace(run.metadata, sets={"family": ("group", ("mum", "dad"))}))
    # the group's circle has radius 1.25 about (0, 0); the robot's body (0.3 m) overlaps it
    # while |x| < 1.55: at x = -1, 0, 1
    assert robot_social_metrics(run, "cart")["group_intrusions"] == pytest.approx(3 / 6)
    # a member is not intruding on its own group
    assert human_social_metrics(run, "mum")["group_intrusions"] == 0.0


def test_humans_among_their_neighbours_equal_everyone(build_run: Callable,
                                                      track: Callable) -> None:
    near = [track(f"p{i}", TIMES, [(i * 0.8, t * 0.3) for t in TIMES]) for i in range(4)]
    far = track("far", TIMES, [(40.0, 40.0)] * 7)
    run = build_run([*near, far])
    pruned = log_social_metrics(run)["humans"]
    for name in run.humans:
        full = human_social_metrics(run, name)
        for metric, value in full.items():
            assert pruned[name][metric] == pytest.approx(value, rel=1e-6, abs=1e-9), metric
    assert pruned["far"]["min_centre_distance"] == pytest.approx(math.hypot(40 - 2.4, 40 - 1.8))


def test_robots_metrics_reach_the_flat_row(build_run: Callable, track: Callable,
                                           robot: Callable) -> None:
    run = build_run([track("ann", TIMES, [(0.0, 2.0)] * 7)],
                    robots=[robot("cart", TIMES, WALK)])
    flat = compute_metrics(run).flat()
    assert flat["cart.social.avg_speed"] == pytest.approx(1.0)
    assert flat["cart.social.min_centre_distance"] == pytest.approx(2.0)
    assert "cart.social.time_to_goal" in flat  # infinite: no goal is logged


def test_a_robots_logged_goal_gives_its_time_to_goal(build_run: Callable, track: Callable,
                                                     robot: Callable) -> None:
    run = build_run([track("ann", TIMES, [(0.0, 2.0)] * 7)],
                    robots=[robot("cart", TIMES, WALK)])
    metadata = replace(run.metadata, robot_params={
        "cart": {"goal": (1.0, 0.0), "goal_tolerance": 0.2}})
    metrics = robot_social_metrics(replace(run, metadata=metadata), "cart")
    assert metrics["time_to_goal"] == pytest.approx(4.0)   # at x = 1 after 4 s
    assert metrics["path_efficiency"] == pytest.approx(1.0)  # 4 m straight to it
    assert math.isinf(robot_social_metrics(run, "cart")["time_to_goal"])


@pytest.mark.parametrize("case", ["no humans", "robot without frames", "robot with one frame",
                                  "human without frames", "one human", "repeated times",
                                  "late arrival"])
def test_thin_logs_are_measured_without_warnings(build_run: Callable, track: Callable,
                                                 robot: Callable, case: str) -> None:
    walk = track("a", [0, 1], [(0, 0), (1, 0)])
    runs = {
        "no humans": lambda: build_run([], robots=[robot("r", [0, 1], [(0, 0), (1, 0)])]),
        "robot without frames": lambda: build_run([walk], robots=[robot("r", [], [])]),
        "robot with one frame": lambda: build_run([walk], robots=[robot("r", [0], [(2, 2)])]),
        "human without frames": lambda: build_run([track("b", [], []), walk],
                                                  robots=[robot("r", [0, 1], [(2, 2), (2, 3)])]),
        "one human": lambda: build_run([walk]),
        "repeated times": lambda: build_run(
            [track("a", [0, 1, 1, 2], [(0, 0), (1, 0), (1, 0), (2, 0)]),
             track("b", [0, 1, 1, 2], [(3, 0)] * 4)],
            robots=[robot("r", [0, 1, 1, 2], [(0, 1), (1, 1), (1, 1), (2, 1)])]),
        "late arrival": lambda: build_run([track("a", [0, 1, 2, 3], [(x, 0) for x in range(4)]),
                                           track("b", [2, 3], [(3, 0), (3, 1)])]),
    }
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        run = runs[case]()
        metrics = log_social_metrics(run)
        compute_metrics(run).flat()
    assert set(metrics["robots"]) == set(run.robots)
    assert set(metrics["humans"]) == set(run.humans)


def test_a_logged_robot_reaches_its_goal_when_its_task_does(tmp_path: Path) -> None:
    log = tmp_path / "lounge.mcap"
    simulate(compile_file(REPO_ROOT / "scenarios" / "lounge_crowd.hub"), log=log)
    run = load_run(log)
    assert run.metadata.robot_goal("cart") == ((3.5, 0.5), 0.2)
    reached = next(e.time for e in run.events
                   if e.human == "cart" and e.status is TaskStatus.SUCCEEDED)
    # the log samples every 0.1 s: the first frame at the goal is at most a frame later
    assert reached <= robot_social_metrics(run, "cart")["time_to_goal"] <= reached + 0.1 + 1e-9


def test_plan_efficiency_measures_the_path_against_the_way_round_a_wall(tmp_path: Path) -> None:
    from hubero_dsl.planners.navfn import reference_plan_length
    from hubero_dsl.world.mapfile import save_map
    from tests.sim.conftest import room_grid

    walled = tmp_path / "wall.yaml"  # a wall at x = 5 with a gap at the top
    grid = room_grid(walls=((4.9, 0.0, 5.1, 6.0),))
    save_map(grid, walled)
    shortest = reference_plan_length(grid, (2.0, 2.0), (8.0, 2.0), 0.3)
    assert shortest is not None and shortest > 2 * math.hypot(2.9, 4.0)  # up round the wall
    text = f"""scenario "round a wall"
map "{walled}"
human alice at (1, 1)
robot cart at (2, 2) {{ controller navigator; speed 0.8 m/s; goal (8.0, 2.0) }}
activity {{ alice stand for 1 s }}
activity {{ cart move_to (8, 2) within 60 s }}
expect plan_efficiency(cart) >= 80 %
"""
    scenario = tmp_path / "wall.hub"
    scenario.write_text(text, encoding="utf-8")
    log = tmp_path / "wall.mcap"
    result = simulate(compile_file(scenario), log=log)
    assert result.succeeded
    metrics = robot_social_metrics(load_run(log), "cart")
    assert metrics["plan_efficiency"] == pytest.approx(
        shortest / metrics["path_length"], rel=0.05)
    assert metrics["path_efficiency"] < 0.6 < metrics["plan_efficiency"] <= 1.0
