"""A robot's collisions (who hit whom) and how its run ended, on hand-built runs whose answers
can be worked out by hand."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

import numpy as np
import pytest

from hubero_dsl.analysis.metrics import compute_metrics
from hubero_dsl.analysis.socialnav_log import (
    Collision,
    collided_with,
    robot_collisions,
    robot_social_metrics,
    robot_termination,
)
from hubero_dsl.log.reader import LoggedRun, RunOutcome
from hubero_dsl.sim.status import TaskStatus
from hubero_dsl.world.grid import OccupancyGrid

TIMES = [float(t) for t in range(7)]
WALK = [(float(x), 0.0) for x in range(-3, 4)]   # 1 m/s along y = 0, x = -3..3
STILL = [(0.0, 0.0)] * 7
INTO = [(-3.0, 0.0), (-2.0, 0.0), (-1.0, 0.0)] + [(-0.4, 0.0)] * 4  # up to 0.4 m of (0, 0)


def _result(state: str, time: float = 6.0, reason: str = "") -> RunOutcome:
    return RunOutcome(state=state, reason=reason, time=time, ticks=round(time * 20),
                      succeeded=state == "completed", expectations=[], humans=[])


def test_a_moving_robot_hits_a_standing_person(build_run: Callable, track: Callable,
                                               robot: Callable) -> None:
    # it drives up to 0.4 m of ann's centre, less than 0.3 + 0.2, and stays: one contact from
    # t = 3 s to the end; at its start the robot approaches at 0.8 m/s (central differences)
    run = build_run([track("ann", TIMES, STILL)], robots=[robot("cart", TIMES, INTO)],
                    params={"ann": {"radius": 0.2}})
    assert robot_collisions(run, "cart") == [Collision(3.0, 6.0, "ann", (0.0, 0.0), "cart")]


def test_a_walking_person_hits_a_standing_robot(build_run: Callable, track: Callable,
                                                robot: Callable) -> None:
    run = build_run([track("bob", TIMES, INTO)], robots=[robot("cart", TIMES, STILL)],
                    params={"bob": {"radius": 0.2}})
    (hit,) = robot_collisions(run, "cart")
    assert (hit.partner, hit.time, hit.point, hit.hit_by) == ("bob", 3.0, (-0.4, 0.0), "bob")


def _walled(run: LoggedRun) -> LoggedRun:
    """The run's 10 x 10 m map with everything from y = 1 m up occupied."""
    occupied = np.zeros((100, 100), dtype=bool)
    occupied[60:, :] = True   # rows of cells whose centres lie at y >= 1.05 m
    return replace(run, grid=OccupancyGrid(occupied, 0.1, (-5.0, -5.0)))


def test_collisions_name_each_partner_in_time_order_and_match_the_counts(
        build_run: Callable, track: Callable, robot: Callable) -> None:
    # the robot drives up to the wall and back, then through ann twice
    ys = [0.0, 0.3, 0.6, 0.8, 0.6, 0.3, 0.0]     # clearance below 0.3 m only at y = 0.8 (t = 3)
    path = [(0.0, y) for y in ys] + [(-1.0, -2.0), (0.0, -2.0), (1.0, -2.0), (0.0, -2.0)]
    times = [float(t) for t in range(len(path))]
    ann = track("ann", times, [(0.0, -2.0)] * len(path))
    run = _walled(build_run([ann], robots=[robot("cart", times, path)],
                            params={"ann": {"radius": 0.2}}))
    hits = robot_collisions(run, "cart")
    assert [(h.time, h.end, h.partner) for h in hits] == [
        (3.0, 3.0, "obstacle"), (8.0, 8.0, "ann"), (10.0, 10.0, "ann")]
    assert hits[0].point == pytest.approx((0.0, 1.05), abs=0.06)  # the wall it touched
    assert hits[0].hit_by == "cart"
    assert collided_with(hits) == {"ann": 2, "obstacle": 1}
    metrics = robot_social_metrics(run, "cart")
    assert (metrics["collisions"], metrics["obstacle_collisions"]) == (2.0, 1.0)


def _events(event: Callable, *finals: tuple[TaskStatus, float, str]) -> list:
    """A robot's move_to task started at 0 s and its later statuses, reasons attached."""
    events = [event("cart", 1, "move_to", TaskStatus.ACTIVE, 0.0, 5, 1)]
    for status, time, reason in finals:
        events.append(replace(event("cart", 1, "move_to", status, time, 5, 1), reason=reason))
    return events


@pytest.mark.parametrize(("finals", "result", "cause", "time", "detail"), [
    ([(TaskStatus.SUCCEEDED, 5.0, "")], "completed", "reached_goal", 5.0, ""),
    ([(TaskStatus.ABORTED, 4.0, "did not finish within 4 s")], "failed", "aborted", 4.0,
     "did not finish within 4 s"),
    ([], "timed_out", "timeout", 6.0, "time limit of 6 s reached"),
    ([], "failed", "stopped", 6.0, "time limit of 6 s reached"),
    ([], None, "unfinished", 6.0, "the log has no result: the run was cut off"),
])
def test_how_a_robots_tasks_ended(build_run: Callable, track: Callable, robot: Callable,
                                  event: Callable, finals: list, result: str | None,
                                  cause: str, time: float, detail: str) -> None:
    run = build_run([track("ann", TIMES, [(0.0, 3.0)] * 7)], robots=[robot("cart", TIMES, WALK)],
                    events=_events(event, *finals))
    if result is not None:
        run = replace(run, result=_result(result, reason="time limit of 6 s reached"
                                          if not finals else ""))
    ended = robot_termination(run, "cart")
    assert (ended.cause, ended.time, ended.detail) == (cause, time, detail)
    assert ended.success == (cause == "reached_goal")


@pytest.mark.parametrize(("reached_at", "cause", "time"), [
    (5.0, "collision", 3.0),       # it touched ann on the way: not a success
    (2.0, "reached_goal", 2.0),    # ann walked into it after it had arrived: its run had ended
])
def test_a_collision_before_the_goal_ends_the_run(build_run: Callable, track: Callable,
                                                  robot: Callable, event: Callable,
                                                  reached_at: float, cause: str,
                                                  time: float) -> None:
    run = build_run([track("ann", TIMES, [(0.0, 0.4)] * 7)], robots=[robot("cart", TIMES, WALK)],
                    params={"ann": {"radius": 0.2}},
                    events=_events(event, (TaskStatus.SUCCEEDED, reached_at, "")))
    run = replace(run, result=_result("completed"))
    ended = robot_termination(run, "cart")
    assert (ended.cause, ended.time) == (cause, time)
    assert ended.detail == ("with ann" if cause == "collision" else "")


def test_a_robot_without_tasks_or_with_a_stand_task(build_run: Callable, track: Callable,
                                                    robot: Callable, event: Callable) -> None:
    run = replace(build_run([track("ann", TIMES, [(0.0, 3.0)] * 7)],
                            robots=[robot("cart", TIMES, STILL)]), result=_result("completed"))
    assert robot_termination(run, "cart").cause == "no_task"
    stood = replace(run, events=[event("cart", 1, "stand", TaskStatus.ACTIVE, 0.0, 5, 1),
                                 event("cart", 1, "stand", TaskStatus.SUCCEEDED, 4.0, 5, 1)])
    assert (robot_termination(stood, "cart").cause, robot_termination(stood, "cart").success) == (
        "done", False)


def test_the_robots_metrics_carry_success_termination_and_partners(
        build_run: Callable, track: Callable, robot: Callable, event: Callable) -> None:
    run = build_run([track("ann", TIMES, [(0.0, 0.4)] * 7)], robots=[robot("cart", TIMES, WALK)],
                    params={"ann": {"radius": 0.2}},
                    events=_events(event, (TaskStatus.SUCCEEDED, 6.0, "")))
    flat = compute_metrics(replace(run, result=_result("completed"))).flat()
    assert flat["cart.termination"] == "collision"
    assert flat["cart.success"] is False
    assert flat["cart.collided_with.ann"] == 1
