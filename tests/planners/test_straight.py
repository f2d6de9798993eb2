"""The straight-line baseline: [start, goal], refusing only goals the body cannot stand at."""

from __future__ import annotations

import numpy as np
import pytest

from hubero_dsl.errors import SimulationError
from hubero_dsl.planners.base import NoPath
from hubero_dsl.planners.registry import global_planner
from hubero_dsl.planners.straight import StraightLineParams, StraightLinePlanner
from hubero_dsl.world.grid import OccupancyGrid


@pytest.fixture(scope="module")
def pillar_room() -> OccupancyGrid:
    """10 m x 6 m at 0.05 m with a 2 m x 4 m pillar in the middle, rising from the floor."""
    occupied = np.zeros((120, 200), dtype=bool)
    occupied[0:80, 80:120] = True
    return OccupancyGrid(occupied=occupied, resolution=0.05, origin=(0.0, 0.0))


@pytest.fixture(scope="module")
def planner(pillar_room: OccupancyGrid) -> StraightLinePlanner:
    return StraightLinePlanner(pillar_room, StraightLineParams())


def test_registered_under_its_name() -> None:
    assert global_planner("straight") is StraightLinePlanner


def test_plan_is_the_segment_even_through_an_obstacle(planner: StraightLinePlanner) -> None:
    plan = planner.plan((1.3, 1.2), (8.7, 1.4), body_radius=0.2, comfort_radius=0.5)
    np.testing.assert_array_equal(plan.waypoints, [[1.3, 1.2], [8.7, 1.4]])
    assert plan.length == pytest.approx(np.hypot(7.4, 0.2))


@pytest.mark.parametrize(("goal", "reason"), [
    ((11.0, 3.0), r"goal \(11\.00, 3\.00\) is outside the map"),
    ((5.0, 2.0), r"goal \(5\.00, 2\.00\) is inside an obstacle; a body of radius 0\.20 m does "
                 r"not fit"),
    ((3.88, 2.0), r"goal \(3\.88, 2\.00\) is 0\.15 m from an obstacle; a body of radius 0\.20 m "
                  r"does not fit"),
])
def test_goal_where_the_body_does_not_fit(planner: StraightLinePlanner, goal: tuple[float, float],
                                          reason: str) -> None:
    with pytest.raises(NoPath, match=reason):
        planner.plan((1.0, 1.0), goal, body_radius=0.2, comfort_radius=0.5)


def test_a_smaller_body_fits_where_a_larger_does_not(planner: StraightLinePlanner) -> None:
    plan = planner.plan((1.0, 1.0), (3.88, 2.0), body_radius=0.1, comfort_radius=0.5)
    assert tuple(plan.waypoints[-1]) == (3.88, 2.0)


def test_bad_radius_is_refused(planner: StraightLinePlanner) -> None:
    with pytest.raises(SimulationError, match="body radius"):
        planner.plan((1.0, 1.0), (2.0, 2.0), body_radius=float("inf"), comfort_radius=0.5)


def test_takes_no_parameters() -> None:
    with pytest.raises(ValueError, match="extra"):
        StraightLineParams.model_validate({"smooth": True})
