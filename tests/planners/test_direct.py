"""Direct planner: straight at the target, people ignored, a clean stop, limits and params."""

from __future__ import annotations

import numpy as np
import pytest
from pydantic import ValidationError

from hubero_dsl.planners.base import Crowd, Drive, LocalPlanner, PlannerParams
from hubero_dsl.planners.direct import DirectParams, DirectPlanner
from hubero_dsl.planners.registry import local_planner
from hubero_dsl.world.grid import OccupancyGrid
from hubero_dsl.world.shapes import Circle, ShapeArrays

DT = 0.05
GRID = OccupancyGrid(np.zeros((200, 200), dtype=bool), 0.1, (-10.0, -10.0))


def crowd(position: np.ndarray, velocity: np.ndarray, robots: int = 0) -> Crowd:
    count = len(position)
    return Crowd(position, velocity, np.zeros(count), np.full(count, 0.2),
                 ShapeArrays.from_shapes([Circle(0.5)] * count),
                 np.arange(count) >= count - robots)


def drive(index: np.ndarray, target: np.ndarray, speed: float = 1.29,
          max_speed: float = 1.8) -> Drive:
    k = len(index)
    ones = np.ones(k)
    return Drive(index, target, np.full(k, speed), np.full(k, max_speed), np.full(k, 0.54),
                 ones, ones, ones, np.full(k, 3.0), np.full(k, np.radians(200.0)))


def run(position: np.ndarray, target: np.ndarray, seconds: float,
        speed: float = 1.29) -> tuple[np.ndarray, np.ndarray]:
    planner = DirectPlanner(GRID, [DirectParams()] * len(position))
    velocity = np.zeros_like(position)
    positions, velocities = [position], []
    for _ in range(round(seconds / DT)):
        velocity = planner.velocities(crowd(position, velocity),
                                      drive(np.arange(len(position)), target, speed), DT)
        position = position + velocity * DT
        positions.append(position)
        velocities.append(velocity)
    return np.array(positions), np.array(velocities)


def test_is_a_registered_local_planner() -> None:
    assert local_planner("direct") is DirectPlanner
    assert isinstance(DirectPlanner(GRID, []), LocalPlanner)


def test_walks_straight_through_people() -> None:
    start = np.array([[-4.0, 0.0], [4.0, 0.0]])
    positions, _ = run(start, start[::-1].copy(), seconds=10.0)
    np.testing.assert_allclose(positions[:, :, 1], 0.0)  # never swerves
    assert positions[-1, 0, 0] == pytest.approx(4.0, abs=0.2)
    assert positions[-1, 1, 0] == pytest.approx(-4.0, abs=0.2)


def test_stops_at_the_target_without_overshooting() -> None:
    target = np.array([[3.0, -4.0]])
    positions, velocities = run(np.zeros((1, 2)), target, seconds=10.0)
    distance = np.linalg.norm(positions[:, 0] - target[0], axis=1)
    assert np.all(np.diff(distance) <= 1e-9)
    assert distance[-1] < 0.2
    assert np.linalg.norm(velocities[-1]) < 0.05


@pytest.mark.parametrize("speed", [0.5, 1.29, 3.0])
@pytest.mark.parametrize("relaxation_time", [0.2, 1.5])
@pytest.mark.parametrize("goal_strength", [0.5, 2.0])
def test_the_stop_is_clean_for_any_speed_and_relaxation(speed: float, relaxation_time: float,
                                                         goal_strength: float) -> None:
    planner = DirectPlanner(GRID, [DirectParams()])
    target = np.array([[4.0, 1.0]])
    k = np.ones(1)
    steer = Drive(np.array([0]), target, k * speed, k * 3.0, k * relaxation_time,
                  k * goal_strength, k, k, k * 3.0, k * np.pi)
    position, velocity = np.zeros((1, 2)), np.zeros((1, 2))
    distance = []
    for _ in range(300):
        velocity = planner.velocities(crowd(position, velocity), steer, DT)
        position = position + velocity * DT
        distance.append(float(np.linalg.norm(position[0] - target[0])))
    assert np.all(np.diff(distance) <= 1e-9)
    assert distance[-1] < 0.01


def test_never_faster_than_max_speed() -> None:
    _, velocities = run(np.zeros((1, 2)), np.array([[9.0, 0.0]]), seconds=5.0, speed=3.0)
    speeds = np.linalg.norm(velocities, axis=-1)
    assert speeds.max() == pytest.approx(1.8)


def test_robots_are_left_alone() -> None:
    bodies = crowd(np.array([[0.0, 0.0], [1.0, 0.0]]), np.array([[0.0, 0.0], [0.3, 0.1]]),
                   robots=1)
    planner = DirectPlanner(GRID, [DirectParams(), PlannerParams()])
    new = planner.velocities(bodies, drive(np.array([1, 0]), np.array([[5.0, 5.0]] * 2)), DT)
    np.testing.assert_array_equal(new[0], [0.3, 0.1])
    assert new[1, 0] > 0.0 and new[1, 1] > 0.0


def test_parameters_are_validated() -> None:
    with pytest.raises(ValidationError):
        DirectParams.model_validate({"A": 2.0})
    with pytest.raises(ValidationError):
        DirectParams(arrival_radius=0.0)
