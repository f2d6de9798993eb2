"""Social force planner: passing, personal space, walls, arrival, limits, order, params, robots.

Runs are simulated with a tiny loop (position += velocity * dt) over a stand-in grid made of
straight walls, so the planner is tested on its own.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import cast

import numpy as np
import pytest
from pydantic import ValidationError

from hubero_dsl.errors import SimulationError
from hubero_dsl.model.params import HUMAN_PARAMS
from hubero_dsl.planners.base import Crowd, Drive, LocalPlanner, PlannerParams
from hubero_dsl.planners.registry import local_planner, planner_params
from hubero_dsl.planners.social_force import SocialForceParams, SocialForcePlanner
from hubero_dsl.world.grid import OccupancyGrid
from hubero_dsl.world.shapes import Circle, Ellipse, Rectangle, Shape, ShapeArrays

DT = 0.05
SPEED = cast(float, HUMAN_PARAMS["speed"].default)
MAX_SPEED = cast(float, HUMAN_PARAMS["max_speed"].default)
FIELD_OF_VIEW = cast(float, HUMAN_PARAMS["field_of_view"].default)


def make_grid(blocked: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None,
              half_size: float = 12.0, resolution: float = 0.05) -> OccupancyGrid:
    """A square map centred on the origin; `blocked(x, y)` marks walls at cell centres."""
    cells = round(2 * half_size / resolution)
    centres = -half_size + (np.arange(cells) + 0.5) * resolution
    x, y = np.meshgrid(centres, centres)  # rows along y, row 0 lowest
    occupied = blocked(x, y) if blocked else np.zeros((cells, cells), dtype=bool)
    return OccupancyGrid(occupied, resolution, (-half_size, -half_size))


def corridor(half_width: float) -> OccupancyGrid:
    return make_grid(lambda x, y: np.abs(y) > half_width)


OPEN = make_grid()


@dataclass
class Scene:
    """Bodies of a small run: humans first, robots last, and where the humans walk."""

    position: np.ndarray
    target: np.ndarray
    shapes: list[Shape]
    radius: np.ndarray
    robots: int = 0
    velocity: np.ndarray | None = None
    speed: np.ndarray | None = None
    heading: np.ndarray | None = None
    params: list[PlannerParams] = field(default_factory=list)

    def __post_init__(self) -> None:
        count = len(self.position)
        self.position = np.asarray(self.position, dtype=np.float64)
        self.target = np.asarray(self.target, dtype=np.float64)
        if self.velocity is None:
            self.velocity = np.zeros((count, 2))
        if self.speed is None:
            self.speed = np.full(count - self.robots, SPEED)
        if self.heading is None:
            to_target = np.zeros((count, 2))
            to_target[: count - self.robots] = self.target - self.position[: count - self.robots]
            self.heading = np.arctan2(to_target[:, 1], to_target[:, 0])
        if not self.params:
            self.params = [SocialForceParams() for _ in range(count)]

    @property
    def humans(self) -> int:
        return len(self.position) - self.robots

    def crowd(self) -> Crowd:
        is_robot = np.arange(len(self.position)) >= self.humans
        assert self.velocity is not None and self.heading is not None
        return Crowd(self.position.copy(), self.velocity.copy(), self.heading.copy(),
                     np.asarray(self.radius, dtype=np.float64),
                     ShapeArrays.from_shapes(self.shapes), is_robot)

    def drive(self) -> Drive:
        k = self.humans
        assert self.speed is not None
        ones = np.ones(k)
        return Drive(index=np.arange(k), target=self.target, desired_speed=self.speed,
                     max_speed=np.full(k, MAX_SPEED), relaxation_time=np.full(k, 0.54),
                     goal_strength=ones, avoidance_strength=ones, obstacle_strength=ones,
                     interaction_range=np.full(k, 3.0), field_of_view=np.full(k, FIELD_OF_VIEW))


def simulate(scene: Scene, grid: OccupancyGrid, seconds: float) -> tuple[np.ndarray, np.ndarray]:
    """(T, N, 2) positions and (T, K, 2) human velocities, stepping the humans only."""
    planner = SocialForcePlanner(grid, scene.params)
    positions, velocities = [scene.position.copy()], []
    assert scene.velocity is not None and scene.heading is not None
    for _ in range(round(seconds / DT)):
        new = planner.velocities(scene.crowd(), scene.drive(), DT)
        humans = slice(0, scene.humans)
        scene.velocity[humans] = new
        scene.position = scene.position + scene.velocity * DT
        moving = np.hypot(new[:, 0], new[:, 1]) > 0.05
        scene.heading[humans] = np.where(moving, np.arctan2(new[:, 1], new[:, 0]),
                                         scene.heading[humans])
        positions.append(scene.position.copy())
        velocities.append(new)
    return np.array(positions), np.array(velocities)


def head_on(space: Shape, lateral_offset: float = 0.0) -> Scene:
    y = lateral_offset / 2.0
    return Scene(position=[[-5.0, y], [5.0, -y]], target=[[6.0, y], [-6.0, -y]],
                 shapes=[space, space], radius=np.array([0.2, 0.2]))


def pair_distance(positions: np.ndarray) -> np.ndarray:
    return np.linalg.norm(positions[:, 0] - positions[:, 1], axis=1)


def test_is_a_registered_local_planner() -> None:
    assert local_planner("social_force") is SocialForcePlanner
    assert planner_params("social_force") is SocialForceParams
    assert isinstance(SocialForcePlanner(OPEN, []), LocalPlanner)


@pytest.mark.parametrize("lateral_offset", [0.0, 0.1, -0.3])
def test_head_on_walkers_pass_without_touching(lateral_offset: float) -> None:
    positions, velocities = simulate(head_on(Circle(0.5), lateral_offset), corridor(1.5),
                                     seconds=14.0)
    assert pair_distance(positions).min() > 0.4  # the two body radii
    assert positions[-1, 0, 0] > 5.5 and positions[-1, 1, 0] < -5.5  # both got through
    assert np.abs(positions[:, :, 1]).max() < 1.5 - 0.2  # and stayed inside the corridor
    jerk = np.linalg.norm(np.diff(velocities, axis=0), axis=-1) / DT
    assert jerk.max() < 4.0  # a smooth swerve, no kicks


def lateral_gap_when_level(scene: Scene) -> float:
    """How far apart across the corridor two walkers heading at each other along x are when
    they draw level (the one heading east is on the south side when positive)."""
    positions, _ = simulate(scene, corridor(1.5), seconds=10.0)
    level = int(np.argmin(np.abs(positions[:, 0, 0] - positions[:, 1, 0])))
    return float(positions[level, 1, 1] - positions[level, 0, 1])


@pytest.mark.parametrize("lateral_offset", [0.0, 0.1, -0.1, 0.3])
def test_people_coming_the_other_way_keep_to_their_right(lateral_offset: float) -> None:
    # east-bound to the south, west-bound to the north, whichever side they started on
    keep_right = [SocialForceParams(oncoming_side_preference=1.0)] * 2
    assert lateral_gap_when_level(replace(head_on(Circle(0.5), lateral_offset),
                                          params=keep_right)) > 0.7
    keep_left = [SocialForceParams(oncoming_side_preference=-1.0)] * 2
    assert lateral_gap_when_level(replace(head_on(Circle(0.5), -lateral_offset),
                                          params=keep_left)) < -0.7


def test_without_keeping_to_the_side_people_pass_on_the_side_they_started() -> None:
    assert lateral_gap_when_level(head_on(Circle(0.5), 0.3)) < -0.7


def test_keeping_to_the_side_leaves_people_walking_the_same_way_alone() -> None:
    """Someone ahead going one's own way, or standing, is not oncoming: the velocities are
    those without the preference, to the last bit."""
    def velocities(target: list[list[float]], keep_side: float) -> np.ndarray:
        scene = Scene(position=[[0.0, 0.0], [2.0, 0.1]], target=target,
                      shapes=[Circle(0.5)] * 2, radius=np.array([0.2, 0.2]),
                      params=[SocialForceParams(oncoming_side_preference=keep_side)] * 2)
        return SocialForcePlanner(OPEN, scene.params).velocities(scene.crowd(), scene.drive(),
                                                                 DT)

    for target in ([[6.0, 0.0], [6.0, 0.1]], [[6.0, 0.0], [2.0, 0.1]]):  # same way; standing
        assert np.array_equal(velocities(target, 0.0), velocities(target, 1.0))
    coming = [[6.0, 0.0], [-6.0, 0.1]]
    assert not np.array_equal(velocities(coming, 0.0), velocities(coming, 1.0))


def test_a_larger_personal_space_keeps_people_further_apart() -> None:
    small, _ = simulate(head_on(Circle(0.2)), corridor(2.5), seconds=14.0)
    large, _ = simulate(head_on(Circle(1.0)), corridor(2.5), seconds=14.0)
    assert pair_distance(large).min() > pair_distance(small).min() + 0.2
    assert pair_distance(small).min() > 0.4


def stop_distance_behind(space: Shape, space_at_rest: float = 1.0) -> float:
    """How far from a standing person someone stops whose target lies just beyond them."""
    no_sidestep = [SocialForceParams(side_preference=0.0,  # stay on the line of centres
                                     space_at_rest=space_at_rest)] * 2
    scene = Scene(position=[[0.0, 0.0], [4.0, 0.0]], target=[[4.5, 0.0], [4.0, 0.0]],
                  shapes=[space, Circle(0.2)], radius=np.array([0.2, 0.2]),
                  speed=np.array([SPEED, 0.0]), params=no_sidestep)
    positions, _ = simulate(scene, OPEN, seconds=12.0)
    return float(pair_distance(positions)[-1])


def test_an_ellipse_keeps_people_further_away_in_front_than_beside() -> None:
    ellipse, circle = Ellipse(1.2, 0.4), Circle(0.4)
    assert stop_distance_behind(ellipse) > stop_distance_behind(circle) + 0.4
    # at rest, a neighbour 1 m ahead pushes harder than one 1 m beside; beside, the ellipse
    # and the circle of its semi-minor axis push the same
    pushes = {}
    for name, space in (("ellipse", ellipse), ("circle", circle)):
        for where, spot in (("ahead", [1.0, 0.0]), ("beside", [0.0, 1.0])):
            scene = Scene(position=[[0.0, 0.0], spot], target=[[0.0, 0.0], spot],
                          shapes=[space, Circle(0.2)], radius=np.array([0.2, 0.2]),
                          speed=np.zeros(2), heading=np.zeros(2))
            velocity = SocialForcePlanner(OPEN, scene.params).velocities(
                scene.crowd(), scene.drive(), DT)
            pushes[name, where] = float(np.linalg.norm(velocity[0]))
    assert pushes["ellipse", "ahead"] > 3.0 * pushes["ellipse", "beside"]
    assert pushes["ellipse", "beside"] == pytest.approx(pushes["circle", "beside"], rel=0.25)
    assert pushes["ellipse", "ahead"] > 3.0 * pushes["circle", "ahead"]


def test_a_personal_space_that_shrinks_at_rest_lets_people_close_up() -> None:
    whole = stop_distance_behind(Circle(0.6))
    shrunk = stop_distance_behind(Circle(0.6), space_at_rest=0.2)
    assert shrunk < whole - 0.1
    assert shrunk > 0.4  # bodies still do not touch


def test_at_the_desired_speed_the_whole_personal_space_counts() -> None:
    def first_velocities(space_at_rest: float) -> np.ndarray:
        scene = head_on(Circle(0.6))
        scene.position = np.array([[-0.6, 0.0], [0.6, 0.0]])
        scene.velocity = np.array([[SPEED, 0.0], [-SPEED, 0.0]])
        scene.params = [SocialForceParams(space_at_rest=space_at_rest)] * 2
        return SocialForcePlanner(OPEN, scene.params).velocities(scene.crowd(), scene.drive(),
                                                                 DT)

    np.testing.assert_array_equal(first_velocities(0.0), first_velocities(1.0))


def follow_slow_leader(time_gap: float, beside: float = 0.0,
                       lane: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """A walker (desired 1.3 m/s) starting 3 m behind a leader who walks at 0.5 m/s, `beside`
    metres to the side of the walker's line, with no social push: only the time gap acts."""
    params = [SocialForceParams(A=0.0, side_preference=0.0, time_gap=time_gap,
                                time_gap_lane=lane)] * 2
    scene = Scene(position=[[-3.0, 0.0], [0.0, beside]], target=[[20.0, 0.0], [20.0, beside]],
                  shapes=[Circle(0.3)] * 2, radius=np.array([0.2, 0.2]),
                  speed=np.array([1.3, 0.5]), params=params)
    return simulate(scene, OPEN, seconds=12.0)


def test_a_time_gap_makes_a_walker_follow_at_the_leaders_speed_one_gap_behind() -> None:
    positions, velocities = follow_slow_leader(time_gap=1.0)
    free = pair_distance(positions) - 0.4  # between the bodies
    # the speed-headway rule v = free / T settles at the leader's speed, 0.5 m behind at T = 1
    assert velocities[-40:, 0, 0] == pytest.approx(0.5, abs=0.02)
    assert free[-40:] == pytest.approx(0.5, abs=0.05)
    assert free.min() > 0.3  # it never closed in on the leader
    # a longer gap keeps it further behind
    longer, _ = follow_slow_leader(time_gap=2.0)
    assert pair_distance(longer)[-1] - 0.4 == pytest.approx(1.0, abs=0.1)


def test_a_time_gap_leaves_people_off_ones_path_alone() -> None:
    # the leader walks 0.5 m beside the line: further than the two bodies' radii, so the walker
    # passes it at its own speed, as it does with no time gap at all
    with_gap, fast = follow_slow_leader(time_gap=1.0, beside=0.5)
    without, _ = follow_slow_leader(time_gap=0.0, beside=0.5)
    np.testing.assert_array_equal(with_gap, without)
    passing = slice(100, 160)  # 5-8 s, as it overtakes (later the map's edge slows it)
    assert fast[passing, 0, 0] == pytest.approx(1.3, abs=0.01)
    # touching distance across the line is the limit: 0.35 m to the side still blocks
    _, blocked = follow_slow_leader(time_gap=1.0, beside=0.35)
    assert blocked[passing, 0, 0].max() < 0.7


def test_a_narrower_lane_leaves_the_next_lane_alone() -> None:
    # 0.3 m to the side: within the two radii (0.4 m), so the full lane blocks (above), but
    # outside half of them, a lane of its own as in a bottleneck's staggered lanes
    next_lane, fast = follow_slow_leader(time_gap=1.0, beside=0.3, lane=0.5)
    without, _ = follow_slow_leader(time_gap=0.0, beside=0.3)
    np.testing.assert_array_equal(next_lane, without)
    assert fast[40:75, 0, 0].min() > 1.2   # 2-3.75 s: walking up at its own speed
    # someone within half of the radii, 0.15 m to the side, is still followed
    _, blocked = follow_slow_leader(time_gap=1.0, beside=0.15, lane=0.5)
    assert blocked[100:160, 0, 0].max() < 0.7


def test_no_time_gap_is_the_plain_model_bit_for_bit() -> None:
    plain, _ = follow_slow_leader(time_gap=0.0)
    params = [SocialForceParams(A=0.0, side_preference=0.0)] * 2
    scene = Scene(position=[[-3.0, 0.0], [0.0, 0.0]], target=[[20.0, 0.0], [20.0, 0.0]],
                  shapes=[Circle(0.3)] * 2, radius=np.array([0.2, 0.2]),
                  speed=np.array([1.3, 0.5]), params=params)
    np.testing.assert_array_equal(plain, simulate(scene, OPEN, seconds=12.0)[0])


def test_a_human_walking_at_a_wall_does_not_enter_it() -> None:
    wall = make_grid(lambda x, y: x >= 3.0)
    scene = Scene(position=[[0.0, 0.0]], target=[[8.0, 0.3]], shapes=[Circle(0.5)],
                  radius=np.array([0.2]), speed=np.array([3.0]))
    positions, _ = simulate(scene, wall, seconds=10.0)
    assert positions[:, 0, 0].max() + 0.2 <= 3.0 + 1e-3  # within the grid's interpolation
    assert positions[-1, 0, 0] > 2.0  # it did walk up to the wall


def test_body_contact_keeps_a_pressed_human_out_of_the_wall() -> None:
    wall = make_grid(lambda x, y: x >= 3.0)
    params = [SocialForceParams(A_wall=0.0)]  # no social push: only the body contact is left
    scene = Scene(position=[[0.0, 0.0]], target=[[8.0, 0.0]], shapes=[Circle(0.5)],
                  radius=np.array([0.2]), params=params)
    positions, velocities = simulate(scene, wall, seconds=10.0)
    overlap = positions[:, 0, 0] + 0.2 - 3.0
    assert overlap.max() < 0.05
    assert np.abs(velocities[-20:]).max() < 0.05  # pressed against it, at rest, no jitter


def test_a_single_human_stops_at_its_target_without_oscillating() -> None:
    scene = Scene(position=[[0.0, 0.0]], target=[[6.0, 2.0]], shapes=[Circle(0.5)],
                  radius=np.array([0.2]))
    positions, velocities = simulate(scene, OPEN, seconds=12.0)
    distance = np.linalg.norm(positions[:, 0] - scene.target[0], axis=1)
    assert distance[-1] < 0.2
    assert np.all(np.diff(distance) <= 1e-9)  # closes in monotonically: no overshoot, no orbit
    assert np.linalg.norm(velocities[-1, 0]) < 0.05
    arrived = np.argmax(distance < 0.2)
    assert np.all(distance[arrived:] < 0.2)


def random_scene(rng: np.random.Generator, humans: int, robots: int) -> Scene:
    count = humans + robots
    shapes: list[Shape] = [Circle(0.5), Ellipse(1.0, 0.5, 0.3), Rectangle(1.2, 0.8)] * count
    return Scene(position=rng.uniform(-3.0, 3.0, size=(count, 2)),
                 target=rng.uniform(-4.0, 4.0, size=(humans, 2)), shapes=shapes[:count],
                 radius=rng.uniform(0.15, 0.3, size=count), robots=robots,
                 velocity=rng.uniform(-1.0, 1.0, size=(count, 2)),
                 speed=rng.uniform(0.0, 1.6, size=humans),
                 params=[SocialForceParams(A=float(a), lambda_=float(lam), anticipation=float(t))
                         for a, lam, t in rng.uniform([1.0, 0.1, 0.0], [4.0, 1.0, 1.0],
                                                      size=(count, 3))])


def test_speeds_never_exceed_max_speed_even_in_a_crush() -> None:
    scene = random_scene(np.random.default_rng(3), humans=60, robots=3)
    _, velocities = simulate(scene, corridor(3.0), seconds=3.0)
    speeds = np.linalg.norm(velocities, axis=-1)
    assert np.all(np.isfinite(velocities))
    assert speeds.max() <= MAX_SPEED + 1e-9


def test_results_do_not_depend_on_row_order() -> None:
    scene = random_scene(np.random.default_rng(5), humans=40, robots=4)
    planner = SocialForcePlanner(corridor(3.0), scene.params)
    crowd, drive = scene.crowd(), scene.drive()
    expected = planner.velocities(crowd, drive, DT)
    # shuffle the humans' rows, keep the robots last, and steer them in another order too
    rng = np.random.default_rng(6)
    human_order = rng.permutation(scene.humans)
    order = np.concatenate([human_order, np.arange(scene.humans, len(scene.position))])
    shapes = ShapeArrays.from_shapes([scene.shapes[i] for i in order])
    permuted = Crowd(crowd.position[order], crowd.velocity[order], crowd.heading[order],
                     crowd.radius[order], shapes, crowd.is_robot[order])
    new_row = np.argsort(order)
    steer = rng.permutation(scene.humans)
    permuted_drive = Drive(new_row[steer], *(getattr(drive, name)[steer] for name in (
        "target", "desired_speed", "max_speed", "relaxation_time", "goal_strength",
        "avoidance_strength", "obstacle_strength", "interaction_range", "field_of_view")))
    permuted_planner = SocialForcePlanner(corridor(3.0),
                                          [scene.params[i] for i in order])
    got = permuted_planner.velocities(permuted, permuted_drive, DT)
    np.testing.assert_allclose(got, expected[steer], rtol=1e-12, atol=1e-12)


def test_a_planner_kept_across_ticks_matches_a_fresh_one_each_tick() -> None:
    # the planner remembers candidate neighbours between ticks; that must not change results
    scene = random_scene(np.random.default_rng(8), humans=50, robots=2)
    kept = SocialForcePlanner(OPEN, scene.params)
    assert scene.velocity is not None
    for _ in range(60):
        crowd, drive = scene.crowd(), scene.drive()
        got = kept.velocities(crowd, drive, DT)
        fresh = SocialForcePlanner(OPEN, scene.params).velocities(crowd, drive, DT)
        np.testing.assert_allclose(got, fresh, rtol=1e-12, atol=1e-12)
        scene.velocity[: scene.humans] = got
        scene.position = scene.position + scene.velocity * 2 * DT  # refresh every few ticks


def test_people_beyond_ones_interaction_range_are_ignored() -> None:
    scene = Scene(position=[[0.0, 0.0], [2.0, 0.0]], target=[[0.0, 0.0], [2.0, 0.0]],
                  shapes=[Circle(0.5)] * 2, radius=np.array([0.2, 0.2]), speed=np.zeros(2),
                  heading=np.array([0.0, np.pi]))
    drive = scene.drive()
    short_sighted = Drive(drive.index, drive.target, drive.desired_speed, drive.max_speed,
                          drive.relaxation_time, drive.goal_strength, drive.avoidance_strength,
                          drive.obstacle_strength, np.array([1.5, 3.0]), drive.field_of_view)
    velocity = SocialForcePlanner(OPEN, scene.params).velocities(scene.crowd(), short_sighted,
                                                                 DT)
    np.testing.assert_array_equal(velocity[0], [0.0, 0.0])
    assert velocity[1, 0] > 0.0  # pushed away from the first, along +x


def test_parameters_are_validated() -> None:
    with pytest.raises(ValidationError):
        SocialForceParams.model_validate({"C": 1.0})
    with pytest.raises(ValidationError):
        SocialForceParams(B=-0.3)
    with pytest.raises(ValidationError):
        SocialForceParams.model_validate({"lambda": 1.5})
    assert SocialForceParams.model_validate({"lambda": 0.6}).lambda_ == 0.6
    assert SocialForceParams(lambda_=0.1).lambda_ == 0.1
    for name, info in SocialForceParams.model_fields.items():
        assert info.description, name


def test_parameters_of_another_planner_are_refused() -> None:
    class Other(PlannerParams):
        speedup: float = 1.0

    with pytest.raises(SimulationError, match="social_force"):
        SocialForcePlanner(OPEN, [Other()])


def test_robots_are_not_steered_and_repel() -> None:
    # a human walking dead-on at a robot that drives straight at it
    scene = Scene(position=[[-5.0, 0.0], [3.0, 0.0]], target=[[6.0, 0.0]],
                  shapes=[Circle(0.5), Circle(0.3)], radius=np.array([0.2, 0.3]), robots=1,
                  velocity=np.array([[0.0, 0.0], [-0.5, 0.0]]))
    positions, _ = simulate(scene, OPEN, seconds=14.0)
    robot_path = positions[:, 1]
    np.testing.assert_allclose(robot_path[:, 1], 0.0)  # the robot kept its course
    np.testing.assert_allclose(np.diff(robot_path[:, 0]), -0.5 * DT)
    assert pair_distance(positions).min() > 0.5  # the human stepped out of its way
    assert np.abs(positions[:, 0, 1]).max() > 0.3
    assert positions[-1, 0, 0] > 5.5
    # a drive that names a robot row leaves the robot's velocity as it is
    crowd = scene.crowd()
    drive = Drive(np.array([1]), np.array([[5.0, 5.0]]), *(np.full(1, v) for v in (
        1.0, 1.8, 0.54, 1.0, 1.0, 1.0, 3.0, FIELD_OF_VIEW)))
    planner = SocialForcePlanner(OPEN, scene.params)
    np.testing.assert_array_equal(planner.velocities(crowd, drive, DT), crowd.velocity[[1]])


def test_a_drive_outside_the_crowd_is_an_error() -> None:
    scene = Scene(position=[[0.0, 0.0]], target=[[1.0, 0.0]], shapes=[Circle(0.5)],
                  radius=np.array([0.2]))
    drive = scene.drive()
    bad = Drive(np.array([3]), *(getattr(drive, name) for name in (
        "target", "desired_speed", "max_speed", "relaxation_time", "goal_strength",
        "avoidance_strength", "obstacle_strength", "interaction_range", "field_of_view")))
    with pytest.raises(SimulationError):
        SocialForcePlanner(OPEN, scene.params).velocities(
            scene.crowd(), bad, DT)
