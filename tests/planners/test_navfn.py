"""The navfn planner: valid paths, exact ends, NoPath reasons, caching, comfort, determinism."""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import numpy as np
import pytest
from pydantic import ValidationError

from hubero_dsl.errors import SimulationError
from hubero_dsl.planners.base import GlobalPlanner, NoPath, PlannerParams
from hubero_dsl.planners.navfn import NavfnParams, NavfnPlanner
from hubero_dsl.planners.registry import global_planner
from hubero_dsl.world.grid import OccupancyGrid

RES = 0.05
BODY = 0.2
SHARED_MAPS = Path(__file__).resolve().parents[2] / ".." / "shared" / "maps" / "hubero-original"


def grid_of(width: float, height: float, *blocks: tuple[float, float, float, float]
            ) -> OccupancyGrid:
    """An empty room (its border is a wall) with rectangular obstacles (x0, y0, x1, y1) in m."""
    occupied = np.zeros((round(height / RES), round(width / RES)), dtype=bool)
    for x0, y0, x1, y1 in blocks:
        occupied[round(y0 / RES):round(y1 / RES), round(x0 / RES):round(x1 / RES)] = True
    return OccupancyGrid(occupied=occupied, resolution=RES, origin=(0.0, 0.0))


def assert_body_fits(grid: OccupancyGrid, waypoints: np.ndarray, radius: float, *,
                     skip_first_segment: bool = False) -> None:
    """Every point along every segment lies on a cell where the body fits."""
    segments = list(itertools.pairwise(waypoints))
    for a, b in segments[1:] if skip_first_segment else segments:
        count = max(2, math.ceil(np.linalg.norm(b - a) / (grid.resolution / 8)))
        # Offset samples so none falls exactly on a cell corner a segment only touches.
        t = (np.arange(count) + 0.37) / count
        cells = grid.world_to_cell(a + t[:, None] * (b - a))
        clearance = grid.clearance[cells[:, 0], cells[:, 1]]
        assert clearance.min() > radius, f"segment {a} -> {b} leaves the free space"


@pytest.fixture(scope="module")
def pillar_room() -> OccupancyGrid:
    """10 m x 6 m with a 2 m x 4 m pillar in the middle, rising from the floor."""
    return grid_of(10.0, 6.0, (4.0, 0.0, 6.0, 4.0))


def navfn(grid: OccupancyGrid, **params: object) -> NavfnPlanner:
    return NavfnPlanner(grid, NavfnParams.model_validate(params))


def test_registered_under_its_name(pillar_room: OccupancyGrid) -> None:
    assert global_planner("navfn") is NavfnPlanner
    assert NavfnPlanner.Params is NavfnParams
    assert isinstance(navfn(pillar_room), GlobalPlanner)


def test_open_space_plan_is_the_straight_segment() -> None:
    planner = navfn(grid_of(8.0, 6.0))
    plan = planner.plan((1.03, 1.21), (6.52, 4.87), body_radius=BODY, comfort_radius=0.5)
    np.testing.assert_array_equal(plan.waypoints, [[1.03, 1.21], [6.52, 4.87]])


def test_path_goes_round_an_obstacle_with_exact_ends(pillar_room: OccupancyGrid) -> None:
    start, goal = (1.37, 1.12), (8.61, 1.43)
    plan = navfn(pillar_room).plan(start, goal, body_radius=BODY, comfort_radius=0.1)
    assert tuple(plan.waypoints[0]) == start
    assert tuple(plan.waypoints[-1]) == goal
    assert_body_fits(pillar_room, plan.waypoints, BODY)
    # Over the pillar's top (y = 4) with the body's radius to spare, and not much further.
    assert plan.waypoints[:, 1].max() > 4.0 + BODY
    assert plan.length < 1.05 * (math.dist(start, (4.0, 4.2)) + 2.0 + math.dist((6.0, 4.2), goal))


def test_unsmoothed_path_is_valid_and_has_more_turns(pillar_room: OccupancyGrid) -> None:
    start, goal = (1.37, 1.12), (8.61, 1.43)
    smooth = navfn(pillar_room).plan(start, goal, body_radius=BODY, comfort_radius=0.1)
    raw = navfn(pillar_room, smooth=False).plan(start, goal, body_radius=BODY, comfort_radius=0.1)
    assert len(raw.waypoints) > len(smooth.waypoints)
    assert raw.length >= smooth.length
    assert_body_fits(pillar_room, raw.waypoints, BODY)


def test_goal_outside_the_map(pillar_room: OccupancyGrid) -> None:
    with pytest.raises(NoPath, match=r"goal \(12\.00, 3\.00\) is outside the map"):
        navfn(pillar_room).plan((1.0, 1.0), (12.0, 3.0), body_radius=BODY, comfort_radius=0.5)


def test_goal_inside_an_obstacle(pillar_room: OccupancyGrid) -> None:
    with pytest.raises(NoPath, match=r"goal \(5\.00, 2\.00\) is inside an obstacle; "
                                     r"a body of radius 0\.20 m does not fit"):
        navfn(pillar_room).plan((1.0, 1.0), (5.0, 2.0), body_radius=BODY, comfort_radius=0.5)


def test_goal_too_close_to_an_obstacle(pillar_room: OccupancyGrid) -> None:
    # The goal's cell centre is 0.125 m from the pillar's face at x = 4.
    with pytest.raises(NoPath, match=r"goal \(3\.88, 2\.00\) is 0\.15 m from an obstacle; "
                                     r"a body of radius 0\.20 m does not fit"):
        navfn(pillar_room).plan((1.0, 1.0), (3.88, 2.0), body_radius=BODY, comfort_radius=0.5)


def test_lethal_margin_widens_the_body(pillar_room: OccupancyGrid) -> None:
    goal = (3.77, 2.0)   # its cell is 0.25 m from the pillar: fits 0.2, not 0.2 + 0.1
    navfn(pillar_room).plan((1.0, 1.0), goal, body_radius=BODY, comfort_radius=0.5)
    with pytest.raises(NoPath, match=r"with a 0\.10 m margin\) does not fit"):
        navfn(pillar_room, lethal_margin=0.1).plan((1.0, 1.0), goal, body_radius=BODY,
                                                   comfort_radius=0.5)


def test_goal_cut_off_by_a_wall() -> None:
    walled = grid_of(10.0, 6.0, (4.9, 0.0, 5.1, 6.0))
    with pytest.raises(NoPath, match=r"goal \(8\.00, 3\.00\) cannot be reached from \(2\.00, "
                                     r"3\.00\): no free path for a body of radius 0\.20 m"):
        navfn(walled).plan((2.0, 3.0), (8.0, 3.0), body_radius=BODY, comfort_radius=0.5)


def test_a_gap_narrower_than_the_body_does_not_connect() -> None:
    gap = grid_of(10.0, 6.0, (4.9, 0.0, 5.1, 2.8), (4.9, 3.2, 5.1, 6.0))   # 0.4 m wide
    planner = navfn(gap)
    plan = planner.plan((2.0, 3.0), (8.0, 3.0), body_radius=0.1, comfort_radius=0.1)
    assert_body_fits(gap, plan.waypoints, 0.1)
    with pytest.raises(NoPath, match="cannot be reached"):
        planner.plan((2.0, 3.0), (8.0, 3.0), body_radius=BODY, comfort_radius=0.1)


def test_start_pushed_into_the_lethal_zone_still_plans(pillar_room: OccupancyGrid) -> None:
    start = (3.9, 2.0)   # 0.1 m from the pillar, closer than the body's radius
    plan = navfn(pillar_room).plan(start, (1.0, 5.0), body_radius=BODY, comfort_radius=0.5)
    assert tuple(plan.waypoints[0]) == start
    first_step = plan.waypoints[1]
    assert math.dist(start, first_step) < 0.2          # straight out to the nearest place it fits
    assert first_step[0] < 3.9                         # away from the pillar, not through it
    assert_body_fits(pillar_room, plan.waypoints, BODY, skip_first_segment=True)


def test_start_off_the_map_or_inside_an_obstacle(pillar_room: OccupancyGrid) -> None:
    planner = navfn(pillar_room)
    with pytest.raises(NoPath, match=r"start \(-1\.00, 2\.00\) is outside the map"):
        planner.plan((-1.0, 2.0), (1.0, 5.0), body_radius=BODY, comfort_radius=0.5)
    with pytest.raises(NoPath, match=r"start \(5\.00, 2\.00\) is inside an obstacle"):
        planner.plan((5.0, 2.0), (1.0, 5.0), body_radius=BODY, comfort_radius=0.5)


def test_bad_radii_are_refused(pillar_room: OccupancyGrid) -> None:
    with pytest.raises(SimulationError, match="body radius"):
        navfn(pillar_room).plan((1.0, 1.0), (2.0, 2.0), body_radius=-0.1, comfort_radius=0.5)
    with pytest.raises(SimulationError, match="comfort radius"):
        navfn(pillar_room).plan((1.0, 1.0), (2.0, 2.0), body_radius=BODY,
                                comfort_radius=math.nan)


def test_field_is_built_once_per_goal_and_reused(pillar_room: OccupancyGrid) -> None:
    planner = navfn(pillar_room)
    goal = (8.5, 1.0)
    planner.plan((1.0, 1.0), goal, body_radius=BODY, comfort_radius=0.5)
    # 7.5 m away, the first plan searched a corridor; a start outside it widens the field
    # to the whole component, which every later plan to the goal reuses
    planner.plan((2.0, 5.0), goal, body_radius=BODY, comfort_radius=0.5)
    planner.plan((1.0, 1.0), goal, body_radius=BODY, comfort_radius=0.5)
    planner.plan((3.0, 4.0), goal, body_radius=BODY, comfort_radius=0.5)
    stats = planner.cache_stats
    assert (stats.grid_builds, stats.field_builds, stats.field_hits) == (1, 2, 2)
    # Another comfort radius is another cost grid and field; a goal in the same cell is not.
    planner.plan((1.0, 1.0), goal, body_radius=BODY, comfort_radius=0.7)
    planner.plan((1.0, 1.0), (8.51, 1.01), body_radius=BODY, comfort_radius=0.7)
    stats = planner.cache_stats
    assert (stats.grid_builds, stats.field_builds, stats.field_hits) == (2, 3, 3)


def test_whole_fields_are_cached_objects(pillar_room: OccupancyGrid) -> None:
    planner = navfn(pillar_room)
    field = planner.cost_to_go((8.5, 1.0), body_radius=BODY, comfort_radius=0.5)
    assert field.complete
    assert field is planner.cost_to_go((8.5, 1.0), body_radius=BODY, comfort_radius=0.5)
    assert field.value((20, 170)) == 0.0
    assert field.value((20, 20)) > field.value((20, 160)) > 0.0


def test_comfort_radii_inside_the_body_share_one_cost_grid(pillar_room: OccupancyGrid) -> None:
    planner = navfn(pillar_room)
    for comfort in (0.0, 0.1, 0.2):
        planner.plan((1.0, 1.0), (8.5, 1.0), body_radius=BODY, comfort_radius=comfort)
    assert planner.cache_stats.grid_builds == 1
    assert planner.cache_stats.field_builds == 1


def test_a_free_straight_segment_needs_no_search(pillar_room: OccupancyGrid) -> None:
    planner = navfn(pillar_room)
    plan = planner.plan((7.5, 5.0), (8.5, 1.0), body_radius=BODY, comfort_radius=0.5)
    np.testing.assert_array_equal(plan.waypoints, [(7.5, 5.0), (8.5, 1.0)])
    assert planner.straight_plans == 1 and planner.cache_stats.field_builds == 0
    # round the pillar: a search, and the same straight plan as before from a warm cache
    planner.plan((1.0, 1.0), (8.5, 1.0), body_radius=BODY, comfort_radius=0.5)
    assert planner.straight_plans == 1 and planner.cache_stats.field_builds == 1


def test_field_cache_is_bounded(pillar_room: OccupancyGrid) -> None:
    planner = navfn(pillar_room, cache_size=2)
    goals = [(8.5, 1.0), (8.5, 3.0), (8.5, 5.0), (8.5, 1.0)]
    for goal in goals:
        planner.plan((1.0, 1.0), goal, body_radius=BODY, comfort_radius=0.5)
    assert planner.cache_stats.field_builds == 4   # the first goal had been dropped


def test_a_partial_field_is_widened_and_gives_the_same_paths(pillar_room: OccupancyGrid) -> None:
    # `near` passes the pillar's corner within the comfort zone: a search, stopped early
    goal, near, far = (8.5, 1.0), (6.3, 4.3), (1.0, 1.0)
    warm = navfn(pillar_room)
    warm.plan(near, goal, body_radius=BODY, comfort_radius=0.5)
    far_plan = warm.plan(far, goal, body_radius=BODY, comfort_radius=0.5)
    assert warm.cache_stats.field_builds == 2 and warm.straight_plans == 0
    fresh = navfn(pillar_room).plan(far, goal, body_radius=BODY, comfort_radius=0.5)
    np.testing.assert_array_equal(far_plan.waypoints, fresh.waypoints)


def test_plans_are_deterministic(pillar_room: OccupancyGrid) -> None:
    runs = [navfn(pillar_room).plan((1.37, 1.12), (8.61, 1.43), body_radius=BODY,
                                    comfort_radius=0.6).waypoints for _ in range(2)]
    np.testing.assert_array_equal(runs[0], runs[1])


def aisle_world(detour: bool) -> OccupancyGrid:
    """A 4 m-deep row of parked cars across a 24 m hall, with a 1 m aisle through it.

    With `detour`, the row stops 4 m short of the right wall: going round is ~11 m longer.
    """
    row_end = 20.0 if detour else 24.0
    return grid_of(24.0, 14.0, (0.0, 5.0, 12.8, 9.0), (13.8, 5.0, row_end, 9.0))


@pytest.mark.parametrize(("comfort", "through_aisle"), [(0.70, False), (0.125, True)])
def test_big_personal_space_takes_the_detour(comfort: float, through_aisle: bool) -> None:
    grid = aisle_world(detour=True)
    plan = navfn(grid).plan((13.3, 2.5), (13.3, 11.5), body_radius=BODY, comfort_radius=comfort)
    assert_body_fits(grid, plan.waypoints, BODY)
    went_round = plan.waypoints[:, 0].max() > 20.0
    assert went_round is not through_aisle
    assert plan.length == pytest.approx(9.0 if through_aisle else 20.0, rel=0.05)


def test_big_personal_space_squeezes_through_when_there_is_no_other_way() -> None:
    grid = aisle_world(detour=False)
    plan = navfn(grid).plan((13.3, 2.5), (13.3, 11.5), body_radius=BODY, comfort_radius=0.70)
    assert plan.length == pytest.approx(9.0, rel=0.01)


def test_comfort_zone_keeps_a_big_personal_space_off_walls() -> None:
    grid = grid_of(10.0, 4.0)
    start, goal = (1.0, 0.5), (9.0, 0.5)   # both near the bottom wall
    hugging = navfn(grid).plan(start, goal, body_radius=BODY, comfort_radius=0.1)
    roomy = navfn(grid).plan(start, goal, body_radius=BODY, comfort_radius=1.0)
    assert hugging.waypoints[:, 1].max() == pytest.approx(0.5)
    assert roomy.waypoints[:, 1].max() > 0.8


def test_params_are_validated() -> None:
    for bad in ({"comfort_weight": -1.0}, {"lethal_margin": -0.1}, {"cache_size": 0},
                {"comfort_weight": math.inf}, {"unknown": 1}):
        with pytest.raises(ValidationError):
            NavfnParams.model_validate(bad)
    assert all(f.description for f in NavfnParams.model_fields.values())


def test_base_params_mean_defaults(pillar_room: OccupancyGrid) -> None:
    assert NavfnPlanner(pillar_room, PlannerParams()).params == NavfnParams()


@pytest.mark.skipif(not SHARED_MAPS.is_dir(), reason="shared maps are absent")
def test_paper_routes_on_the_parking_map() -> None:
    from hubero_dsl.world.mapfile import load_map

    grid = load_map(SHARED_MAPS / "parking.yaml")
    planner = navfn(grid)
    starts = [(-5.0, -6.0), (-4.0, -1.8), (-2.0, 0.0), (1.5, 2.0)]
    goals = [(0.5, 6.6), (0.3, 18.8), (7.0, 2.9), (1.2, -5.7), (-3.5, 10.5), (-0.5, 14.8)]
    for comfort in (0.125, 0.70):
        for start, goal in zip(starts * 2, goals, strict=False):
            plan = planner.plan(start, goal, body_radius=BODY, comfort_radius=comfort)
            assert tuple(plan.waypoints[0]) == start and tuple(plan.waypoints[-1]) == goal
            assert plan.length >= math.dist(start, goal) - 1e-9
            assert_body_fits(grid, plan.waypoints, BODY)


@pytest.mark.skipif(not SHARED_MAPS.is_dir(), reason="shared maps are absent")
def test_paper_routes_on_the_living_room_map() -> None:
    from hubero_dsl.world.mapfile import load_map

    grid = load_map(SHARED_MAPS / "living_room.yaml")
    planner = navfn(grid)
    for start, goal in [((3.8, -5.3), (5.5, 1.0)), ((5.5, 1.0), (2.0, -2.8)),
                        ((6.3, 2.5), (0.6, -2.0))]:
        plan = planner.plan(start, goal, body_radius=BODY, comfort_radius=0.8)
        assert_body_fits(grid, plan.waypoints, BODY)
        assert plan.length >= math.dist(start, goal) - 1e-9
