"""Social-navigation metrics against hand computations, and in expectations."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from hubero_dsl.pipeline import check_source, compile_source
from hubero_dsl.sim.loop import run_program
from hubero_dsl.sim.simulation import Simulation
from hubero_dsl.socialnav import CONTACT, METRICS, Track, social_metrics


def _track(points: list[tuple[float, float]], dt: float = 1.0, radius: float = 0.25) -> Track:
    return Track(np.arange(len(points)) * dt, np.asarray(points, dtype=float), radius)


def test_a_straight_walk_past_a_standing_person() -> None:
    # the subject walks x = 0..4 at y = 0, one metre a second; a person stands at (2, 1)
    subject = _track([(x, 0.0) for x in range(5)])
    person = _track([(2.0, 1.0)] * 5)
    m = social_metrics(subject, [person], goal=(4.0, 0.0))
    assert m["path_length"] == pytest.approx(4.0)
    assert m["path_efficiency"] == pytest.approx(1.0)
    assert m["path_irregularity"] == 0.0
    assert m["time_to_goal"] == pytest.approx(4.0)
    # centre distances sqrt(5), sqrt(2), 1, sqrt(2), sqrt(5); radii 0.25 + 0.25
    assert m["min_centre_distance"] == pytest.approx(1.0)
    assert m["min_distance"] == pytest.approx(0.5)
    # samples weigh 1 s each but the last: gaps 1.736, 0.914, 0.5, 0.914 -> personal 3 s of 4
    assert m["personal_intrusions"] == pytest.approx(0.75)
    assert m["social_intrusions"] == pytest.approx(0.25)
    assert m["intimate_intrusions"] == 0.0
    assert m["avg_distance"] == pytest.approx((math.sqrt(5) + 2 * math.sqrt(2) + 1) / 4 - 0.5)
    assert m["collisions"] == 0.0 and m["time_not_moving"] == 0.0 and m["jerk"] == 0.0
    gaps = np.array([math.sqrt(5), math.sqrt(2), 1.0, math.sqrt(2)]) - 0.5
    assert m["social_work"] == pytest.approx(float((2.1 * np.exp(-gaps / 0.3)).sum()))


@pytest.mark.parametrize("rounding", [0.0, 4e-16, -4e-16])
def test_bodies_that_just_touch_have_collided_whatever_the_rounding(rounding: float) -> None:
    # the engine pushes overlapping bodies apart until they touch: a gap of 0, give or take a
    # float's rounding, is a contact
    subject = _track([(0.0, 0.0), (0.5 + rounding, 0.0), (3.0, 0.0)])
    person = _track([(1.0, 0.0)] * 3)
    metrics = social_metrics(subject, [person])
    assert metrics["collisions"] == 1.0 and metrics["min_time_to_collision"] == 0.0


def test_bodies_that_just_touch_have_collided_as_a_log_keeps_them() -> None:
    # touching on a diagonal, each position rounded to the log's 0.1 mm: the logged distance
    # is 0.05 mm more than the radii's sum (a run's verdict saw the contact, its log did not)
    side = round(0.5 / math.sqrt(2), 4)
    assert math.hypot(side, side) - 0.5 > 4e-5
    subject = _track([(-1.0, -1.0), (0.0, 0.0), (-1.0, -1.0)])
    person = _track([(side, side)] * 3)
    assert social_metrics(subject, [person])["collisions"] == 1.0


def test_a_gap_above_the_contact_is_no_contact() -> None:
    subject = _track([(0.0, 0.0), (0.5 - 2 * CONTACT, 0.0), (3.0, 0.0)])
    person = _track([(1.0, 0.0)] * 3)
    assert social_metrics(subject, [person])["collisions"] == 0.0


def test_a_zigzag_turns_and_is_inefficient() -> None:
    subject = _track([(0, 0), (1, 1), (2, 0), (3, 1), (4, 0)])
    m = social_metrics(subject, [])
    diagonal = 4 * math.sqrt(2)
    assert m["path_length"] == pytest.approx(diagonal)
    assert m["path_efficiency"] == pytest.approx(4.0 / diagonal)
    assert m["path_irregularity"] == pytest.approx(3 * (math.pi / 2) / diagonal)
    assert m["min_distance"] == math.inf and m["time_to_goal"] == math.inf


def test_bumping_into_someone_twice_is_two_collisions() -> None:
    subject = _track([(0, 0), (0.3, 0), (2, 0), (0.3, 0), (0, 0), (0, 0)])
    person = _track([(0.0, 0.0)] * 6, radius=0.2)
    m = social_metrics(subject, [person])
    assert m["collisions"] == 2.0
    assert m["min_distance"] == pytest.approx(-0.45)
    assert m["intimate_intrusions"] == pytest.approx(4 / 5)
    assert m["time_not_moving"] == pytest.approx(1.0)  # the last second, standing


def test_jerk_of_a_cubic_motion() -> None:
    times = np.arange(8) * 0.5
    subject = Track(times, np.stack([times ** 3, np.zeros(8)], axis=1), 0.2)
    assert social_metrics(subject, [])["jerk"] == pytest.approx(6.0)


def test_jerk_takes_a_last_shorter_step_as_short() -> None:
    # a run's log ends with a frame at the end time, half a step after the one before: the
    # third difference over the usual step cubed made 4 of this cubic's jerk of 1
    times = np.append(np.arange(11) * 0.1, 1.05)
    subject = Track(times, np.stack([times ** 3 / 6, np.zeros(12)], axis=1), 0.2)
    assert social_metrics(subject, [])["jerk"] == pytest.approx(1.0, abs=0.01)


def test_every_metric_is_computed() -> None:
    m = social_metrics(_track([(0, 0), (1, 0)]), [_track([(5, 5), (5, 5)])])
    assert set(m) == set(METRICS)


def _scenario(room_map: Path, expectations: str) -> str:
    return (f'scenario "m"\nmap "{room_map}"\nhuman bob at (5, 5)\n'
            "robot cart at (1, 2) { controller navigator; goal (8, 2); speed 1 m/s }\n"
            "activity { bob stand for 1 s }\nactivity { cart move_to (8, 2) }\n" + expectations)


@pytest.mark.parametrize("creep", [4.4e-16, 1e-4])
def test_two_bodies_standing_still_are_on_no_collision_course(creep: float) -> None:
    # a float's last place, or a log's 0.1 mm, per sample: rounding, no approach (the first
    # gave a time to contact of 10^14 s)
    subject = _track([(0.0, 0.0)] * 3, dt=0.1)
    person = _track([(2.0 - k * creep, 0.0) for k in range(3)], dt=0.1)
    assert social_metrics(subject, [person])["min_time_to_collision"] == math.inf


def test_a_robot_at_its_own_limits_meets_expectations_of_them(room_map: Path) -> None:
    # the navigator drives at its top speed and accelerates at its limit: the metrics come out
    # a few units in the last place over them, which an expectation of the limit must forgive
    program = compile_source(_scenario(room_map, """
    expect max_speed(cart) <= 1 m/s
    """).replace("speed 1 m/s }", "speed 1 m/s; max_speed 1 m/s; max_acceleration 0.5 }"),
        "t.hub")
    result = run_program(Simulation(program))
    assert [(v.text, v.held) for v in result.expectations] == [
        ("max_speed(cart) <= 1 m/s", True)]


def test_metrics_in_expectations(room_map: Path) -> None:
    program = compile_source(_scenario(room_map, """
    expect min_distance(cart) >= 1 m
    expect min_distance(cart, bob) >= 1 m
    expect path_efficiency(cart) >= 90 %
    expect time_to_goal(cart) <= 10 s
    expect personal_intrusions(cart) > 50 %
    """), "t.hub")
    result = run_program(Simulation(program))
    verdicts = {v.text: v.held for v in result.expectations}
    assert verdicts == {"min_distance(cart) >= 1 m": True, "min_distance(cart, bob) >= 1 m": True,
                        "path_efficiency(cart) >= 90 %": True,
                        "time_to_goal(cart) <= 10 s": True,
                        "personal_intrusions(cart) > 50 %": False}
    assert result.robot_metrics["cart"]["path_length"] == pytest.approx(7.0, abs=0.3)


@pytest.mark.parametrize(("expectation", "code"), [
    ("expect min_distanse(cart) >= 1 m", "E111"),
    ("expect min_distance(cart) >= 1 s", "E201"),
    ("expect personal_intrusions(cart) <= 10 m", "E201"),
    ("expect min_distance(nobody) >= 1 m", "E101"),
])
def test_metric_mistakes_are_reported(room_map: Path, expectation: str, code: str) -> None:
    result = check_source(_scenario(room_map, expectation + "\n"), "t.hub")
    assert code in {d.code for d in result.errors}


def test_efficiency_is_not_a_number_when_the_goal_was_never_reached() -> None:
    time = np.arange(0.0, 5.0, 0.1)
    straight = Track(time, np.column_stack([time, np.zeros_like(time)]), 0.3)
    short = social_metrics(straight, [], goal=(20.0, 0.0), plan_length=20.0)
    assert math.isnan(short["path_efficiency"]) and math.isnan(short["plan_efficiency"])
    assert short["time_to_goal"] == math.inf
    reached = social_metrics(straight, [], goal=(4.5, 0.0))
    assert reached["path_efficiency"] == pytest.approx(1.0)


class _Straight:
    """Drives east at 1 m/s: 4.3 m to the goal with a tolerance of 0.2 m, 4.1 s exactly."""

    def __init__(self, body: object, params: object) -> None:
        pass

    def command(self, observation: object) -> tuple[float, float]:
        return (1.0, 0.0)


def test_reaching_the_goal_is_one_instant_for_the_condition_and_the_metric(
        room_map: Path) -> None:
    # the approach ends at the tolerance, give or take a float's rounding: the metric counted
    # it as reached and the condition a tick later
    text = (f'scenario "t"\nmap "{room_map}"\ntime_limit 20 s\n'
            "robot cart at (1.0, 2.0) { controller external; goal (5.3, 2.0); "
            "goal_tolerance 0.2 m; max_acceleration 100 }\n"
            "human h at (1, 6)\nactivity { h stand for 8 s }\n"
            "expect cart reaches (5.3, 2.0) within 8 s\n")
    result = run_program(Simulation(compile_source(text, "t.hub"),
                                    controllers={"cart": _Straight}))
    (reached,) = result.expectations
    assert reached.held and reached.decided_at == pytest.approx(4.1)
    assert result.robot_metrics["cart"]["time_to_goal"] == pytest.approx(4.1)
