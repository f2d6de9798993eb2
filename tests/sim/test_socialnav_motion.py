"""The metrics of motion, time to collision, social force, groups and obstacles, against hand
computations, and in expectations."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from hubero_dsl.pipeline import check_source, compile_source
from hubero_dsl.sim.loop import run_program
from hubero_dsl.sim.simulation import Simulation
from hubero_dsl.socialnav import Track, group_space, member_indices, social_metrics


def _track(points: list[tuple[float, float]], dt: float = 1.0, radius: float = 0.25) -> Track:
    return Track(np.arange(len(points)) * dt, np.asarray(points, dtype=float), radius)


def test_speed_acceleration_and_energy() -> None:
    # segments of 1, 2 and 3 m, one second each
    m = social_metrics(_track([(0, 0), (1, 0), (3, 0), (6, 0)]), [])
    assert m["avg_speed"] == pytest.approx(2.0)
    assert m["max_speed"] == pytest.approx(3.0)
    assert m["motion_energy"] == pytest.approx(1 + 4 + 9)
    # the speed grows by 1 m/s between segments whose midpoints are 1 s apart
    assert m["avg_acceleration"] == pytest.approx(1.0)
    assert m["max_acceleration"] == pytest.approx(1.0)


def test_a_turn_is_an_acceleration() -> None:
    # 1 m east then 1 m north: the velocity changes by (-1, 1) over 1 s
    m = social_metrics(_track([(0, 0), (1, 0), (1, 1)]), [])
    assert m["max_acceleration"] == pytest.approx(math.sqrt(2))


def test_time_to_collision_with_a_standing_person() -> None:
    # 1 m/s towards a person 10 m ahead; contact at 0.5 m between centres
    subject = _track([(x, 0.0) for x in range(4)])
    ahead = _track([(10.0, 0.0)] * 4)
    assert social_metrics(subject, [ahead])["min_time_to_collision"] == pytest.approx(7 - 0.5)
    beside = _track([(10.0, 1.0)] * 4)  # passes 1 m from its centre: never in contact
    assert social_metrics(subject, [beside])["min_time_to_collision"] == math.inf
    behind = _track([(-5.0, 0.0)] * 4)  # moving away
    assert social_metrics(subject, [behind])["min_time_to_collision"] == math.inf


def test_time_to_collision_head_on_and_in_contact() -> None:
    subject = _track([(0.0, 0.0), (1.0, 0.0), (2.0, 0.0)])
    other = _track([(6.0, 0.0), (5.0, 0.0), (4.0, 0.0)])
    # closing at 2 m/s; at the last sample 2 m apart: (2 - 0.5) / 2
    assert social_metrics(subject, [other])["min_time_to_collision"] == pytest.approx(0.75)
    touching = _track([(0.3, 0.0), (1.3, 0.0), (2.3, 0.0)])
    assert social_metrics(subject, [touching])["min_time_to_collision"] == 0.0


def test_social_force_on_the_subject() -> None:
    still = _track([(0.0, 0.0)] * 3)
    right = _track([(1.0, 0.0)] * 3)
    left = _track([(-1.0, 0.0)] * 3)
    # gap 1 - 0.25 - 0.25 = 0.5 m
    assert social_metrics(still, [right])["social_force"] == pytest.approx(
        2.1 * math.exp(-0.5 / 0.3))
    assert social_metrics(still, [right, left])["social_force"] == pytest.approx(0.0, abs=1e-12)


def test_distances_to_the_nearest_person() -> None:
    subject = _track([(0.0, 0.0), (1.0, 0.0), (2.0, 0.0)])
    person = _track([(0.0, 2.0)] * 3)
    m = social_metrics(subject, [person])
    # centres 2, sqrt(5), sqrt(8); the last sample weighs nothing in the average
    assert m["max_centre_distance"] == pytest.approx(math.sqrt(8))
    assert m["max_distance"] == pytest.approx(math.sqrt(8) - 0.5)
    assert m["avg_centre_distance"] == pytest.approx((2 + math.sqrt(5)) / 2)


def test_group_space_intrusions() -> None:
    # two members at (0, +-1): the group's space is the circle of radius 1 + 0.25 about (0, 0)
    members = [_track([(0.0, 1.0)] * 7), _track([(0.0, -1.0)] * 7)]
    centre, radius = group_space(np.stack([m.position for m in members]), np.array([0.25, 0.25]))
    assert centre[0] == pytest.approx([0.0, 0.0]) and radius[0] == pytest.approx(1.25)
    # walking x = -3..3 at y = 0: the body overlaps it at x = -1, 0, 1 (3 s of 6)
    subject = _track([(x, 0.0) for x in range(-3, 4)])
    assert social_metrics(subject, members, groups=[[0, 1]])["group_intrusions"] == \
        pytest.approx(0.5)
    assert social_metrics(subject, members)["group_intrusions"] == 0.0


def test_member_indices_leave_out_the_subjects_own_group() -> None:
    groups = [("mum", "dad"), ("ann", "bob")]
    assert member_indices(groups, ["dad", "ann", "bob", "mum"], "mum") == [[1, 2]]
    assert member_indices(groups, ["ann", "bob"], "cart") == [[], [0, 1]]


def test_obstacle_collision_episodes() -> None:
    # a wall at x = 2: clearance 2, 1, 0.2, 1, 0.2 -> two contacts of a 0.25 m body
    subject = _track([(0.0, 0.0), (1.0, 0.0), (1.8, 0.0), (1.0, 0.0), (1.8, 0.0)])
    m = social_metrics(subject, [], clearance=lambda p: 2.0 - p[:, 0])
    assert m["obstacle_collisions"] == 2.0
    assert social_metrics(subject, [])["obstacle_collisions"] == 0.0


def _scenario(room_map: Path, expectations: str) -> str:
    return (f'scenario "m"\nmap "{room_map}"\nhuman bob at (5, 5)\n'
            "robot cart at (1, 2) { controller navigator; goal (8, 2); speed 1 m/s }\n"
            "activity { bob stand for 1 s }\nactivity { cart move_to (8, 2) }\n" + expectations)


def test_new_metrics_in_expectations(room_map: Path) -> None:
    program = compile_source(_scenario(room_map, """
    expect max_speed(cart) <= 1.5 m/s
    expect obstacle_collisions(cart) <= 0
    expect min_time_to_collision(cart, bob) >= 1 s
    expect group_intrusions(cart) <= 0 %
    """), "t.hub")
    result = run_program(Simulation(program))
    assert all(v.held for v in result.expectations), [(v.text, v.value)
                                                      for v in result.expectations]
    assert result.robot_metrics["cart"]["avg_speed"] > 0.3


def test_speed_metrics_take_speeds(room_map: Path) -> None:
    result = check_source(_scenario(room_map, "expect max_speed(cart) <= 1 m\n"), "t.hub")
    assert "E201" in {d.code for d in result.errors}
