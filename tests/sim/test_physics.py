"""The fast paths of a tick give exactly what the plain computations give.

`keep_out_of_walls` accepts bodies far from walls without interpolating clearances,
`BodySeparation` skips the k-d tree while nobody overlaps, and `PairFinder` takes every pair of a
small crowd without a tree. Each is compared bit for bit with the computation it stands for.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial import cKDTree

from hubero_dsl.errors import SimulationError
from hubero_dsl.planners.neighbours import PairFinder
from hubero_dsl.sim import physics
from hubero_dsl.sim.simulation import Simulation
from hubero_dsl.world.grid import OccupancyGrid
from tests.sim.conftest import ScenarioFactory


def furnished_room() -> OccupancyGrid:
    occupied = np.zeros((80, 120), dtype=bool)
    occupied[30:40, 20:60] = True      # a table
    occupied[60:64, 90:94] = True      # a pillar
    return OccupancyGrid(occupied, 0.05, (0.0, 0.0))


def kept_out_exactly(grid: OccupancyGrid, rng: np.random.Generator, count: int,
                     area: tuple[tuple[float, float], tuple[float, float]],
                     step: float, *, robots: bool = False) -> bool:
    """Random moves of `count` bodies from free places in `area`: `keep_out_of_walls` gives
    the exact test's answer, for people or for robots (half of them unicycles, which do not
    slide). Whether any move was stopped or slid."""
    old = rng.uniform(*area, size=(count, 2))
    old = old[grid.is_free(old)]
    new = old + rng.normal(0.0, step, size=old.shape)
    radius = rng.uniform(0.15, 0.3, size=len(old))
    keep = physics.ROBOT_WALL_KEEP if robots else physics.HUMAN_WALL_KEEP
    slides = rng.uniform(size=len(old)) < 0.5 if robots else None
    fast = physics.keep_out_of_walls(grid, old, new, radius, keep=keep, slides=slides)
    exact = physics._slide_along_walls(grid, old, new, keep[0] * radius + keep[1], slides)
    np.testing.assert_array_equal(fast, exact)
    return not np.array_equal(exact, new)


@pytest.mark.parametrize("seed", range(5))
def test_keep_out_of_walls_equals_the_exact_test_for_every_body(seed: int) -> None:
    rng = np.random.default_rng(seed)
    assert kept_out_exactly(furnished_room(), rng, 300, ((0.0, 0.0), (6.0, 4.0)), 0.15)


@pytest.mark.parametrize("robots", [False, True])
@pytest.mark.parametrize("count", [1, 3, physics.FEW_BODIES])
def test_a_few_bodies_are_kept_out_of_walls_as_many_are(count: int, robots: bool) -> None:
    # a few bodies are checked in floats, many in arrays: both give the exact test's answer
    grid, rng = furnished_room(), np.random.default_rng(count)
    about_the_table = ((0.5, 1.0), (3.5, 2.5))
    slid = sum(kept_out_exactly(grid, rng, count, about_the_table, 0.1, robots=robots)
               for _ in range(200))
    assert slid > 10   # walls were met, not only open floor
    if robots:
        assert kept_out_exactly(grid, rng, 300, ((0.0, 0.0), (6.0, 4.0)), 0.15, robots=True)


def test_the_float_test_of_a_point_is_the_array_test() -> None:
    grid = furnished_room()
    rng = np.random.default_rng(5)
    points = np.vstack([rng.uniform((-0.5, -0.5), (6.5, 4.5), size=(2000, 2)),
                        [[np.nan, 1.0], [np.inf, 1.0], [1.0, -np.inf]]])
    for distance in (0.05, 0.2, 0.6):
        expected = grid.surely_clear(points, distance)
        got = [grid.surely_clear_point(x, y, distance) for x, y in points.tolist()]
        np.testing.assert_array_equal(got, expected)
    assert expected.any() and not expected.all()


def test_keep_out_of_walls_returns_the_moves_when_all_are_clear() -> None:
    grid = OccupancyGrid(np.zeros((100, 100), dtype=bool), 0.1, (0.0, 0.0))
    old = np.array([[5.0, 5.0], [3.0, 6.0]])
    new = old + 0.05
    assert physics.keep_out_of_walls(grid, old, new, np.full(2, 0.2)) is new


def test_keep_out_of_walls_leaves_bodies_at_rest_where_they_are() -> None:
    grid = furnished_room()
    # at rest against the table and inside it (where a push may once have left a body): a
    # tick without motion stops nobody and moves nobody, without a clearance lookup
    old = np.array([[2.0, 1.47], [2.0, 1.75], [5.0, 1.0]])
    new = old.copy()
    assert physics.keep_out_of_walls(grid, old, new, np.full(3, 0.25)) is new
    exact = physics._slide_along_walls(grid, old, new, np.full(3, 0.125 + physics.WALL_MARGIN))
    np.testing.assert_array_equal(exact, new)


def test_body_separation_equals_separate_bodies_tick_after_tick() -> None:
    rng = np.random.default_rng(7)
    separation = physics.BodySeparation()
    rows, cols = np.mgrid[0:15, 0:15]
    position = np.column_stack([rows.ravel(), cols.ravel()]).astype(float)  # 1 m apart
    radius = rng.uniform(0.15, 0.3, size=len(position))
    movable = rng.uniform(size=len(position)) > 0.1
    stopped = 0
    for tick in range(60):
        position = position + np.array([0.03, 0.01]) + rng.normal(0.0, 0.005, position.shape)
        if tick % 10 == 5:   # now and then someone walks into someone else
            position[tick] = position[tick + 1] + np.array([0.1, 0.0])
        expected = physics.separate_bodies(position, radius, movable)
        got = separation(position, radius, movable)
        np.testing.assert_array_equal(got, expected)
        stopped += got is position
        position = got
    assert 0 < stopped < 60   # both the shortcut and the correction were exercised


@pytest.mark.parametrize("count", [2, 3, physics.FEW_BODIES])
def test_a_few_bodies_are_separated_as_many_are(count: int) -> None:
    rng = np.random.default_rng(count)
    separation = physics.BodySeparation()
    touched = 0
    for _ in range(200):
        position = rng.uniform(0.0, 0.6 * count, size=(count, 2))
        radius = rng.uniform(0.15, 0.3, size=count)
        movable = rng.uniform(size=count) > 0.2
        expected = physics.separate_bodies(position, radius, movable)
        got = separation(position, radius, movable)
        np.testing.assert_array_equal(got, expected)
        touched += got is not position
    assert 0 < touched < 200


def tree_pairs(position: np.ndarray, radius: float) -> np.ndarray:
    tree = cKDTree(position, balanced_tree=False, compact_nodes=False)
    return tree.query_pairs(radius, output_type="ndarray")


@pytest.mark.parametrize("count", [2, 3, 7, 16])
def test_small_crowds_get_the_pairs_of_the_tree_in_its_order(count: int) -> None:
    rng = np.random.default_rng(count)
    for _ in range(20):
        position = rng.uniform(0.0, 5.0, size=(count, 2))
        pairs = PairFinder().find(position, np.full(count, 3.0))
        found = np.column_stack([pairs.first, pairs.second])
        np.testing.assert_array_equal(found.reshape(-1, 2), tree_pairs(position, 3.0))


def as_set(first: np.ndarray, second: np.ndarray) -> set[tuple[int, int]]:
    return set(zip(first.tolist(), second.tolist(), strict=True))


@pytest.mark.parametrize("per_world", [3, 16, 40])
def test_worlds_stacked_meet_only_their_own(per_world: int) -> None:
    # four copies of one scene on top of each other: each finds the pairs it finds alone, in
    # the same order when it is small enough for one leaf of the tree
    rng = np.random.default_rng(per_world)
    alone = rng.uniform(0.0, 6.0, size=(per_world, 2))
    stacked = np.concatenate([alone + rng.normal(0.0, 0.01, alone.shape) * k for k in range(4)])
    world = np.repeat(np.arange(4), per_world)
    finder = PairFinder()
    for _ in range(3):  # the Verlet list's reuse keeps the worlds apart too
        pairs = finder.find(stacked, np.full(len(stacked), 2.0), world)
        assert (world[pairs.first] == world[pairs.second]).all()
        for k in range(4):
            mine = world[pairs.first] == k
            own = PairFinder().find(stacked[world == k], np.full(per_world, 2.0))
            first, second = pairs.first[mine] - k * per_world, pairs.second[mine] - k * per_world
            assert as_set(first, second) == as_set(own.first, own.second)
            if per_world <= 16:
                np.testing.assert_array_equal(first, own.first)
                np.testing.assert_array_equal(second, own.second)
                np.testing.assert_array_equal(pairs.distance[mine], own.distance)
        stacked = stacked + 0.05


def test_lengths_are_numpys_norms_bit_for_bit() -> None:
    rng = np.random.default_rng(3)
    vectors = rng.normal(size=(500, 2)) * rng.choice([1e-200, 1e-5, 1.0, 1e200], size=(500, 1))
    vectors[::7] = np.nan
    vectors[::11, 0] = np.inf
    vectors[::13] = 0.0
    with np.errstate(over="ignore"):
        np.testing.assert_array_equal(physics.lengths(vectors), np.linalg.norm(vectors, axis=1))
    assert physics.lengths(np.zeros((0, 2))).shape == (0,)


def test_a_position_that_is_not_a_number_ends_the_run(scenario: ScenarioFactory) -> None:
    """NaN or infinity is an error of the run, named with the human and the time, never a
    jump in the log."""
    sim = Simulation(scenario("human alice at (2, 2)\nhuman bob at (6, 2)\n"),
                     activities=False)
    sim.human("alice").teleop()
    sim.engine.humans.teleop_velocity[0] = (math.inf, 0.0)
    with pytest.raises(SimulationError, match=r"diverged at t = 0\.05 s: the position of alice"):
        sim.step()


def test_a_move_ending_inside_a_body_stops_where_it_first_touches_it() -> None:
    from hubero_dsl.sim.physics import contact_fractions

    bodies, body_radius = np.array([[2.0, 0.0], [2.0, 5.0]]), np.array([0.5, 0.5])
    old = np.array([[0.0, 0.0],     # into the first, ending 0.2 from its centre: back to 1.4
                    [0.0, 0.0],     # past it, ending clear of it: it goes (it has yielded)
                    [1.5, 0.0],     # already overlapping it (0.1 of 0.6), closing further
                    [1.6, 0.0],     # overlapping it, leaving
                    [0.0, 5.0]])    # into the second, which it is not set against
    new = old + np.array([[2.2, 0.0], [4.0, 0.0], [0.3, 0.0], [-1.0, 0.0], [2.2, 0.0]])
    radius = np.full(5, 0.1)
    pairs = (np.array([0, 1, 2, 3]), np.array([0, 0, 0, 0]))
    share = contact_fractions(old, new, radius, bodies, body_radius, pairs)
    assert share.tolist() == pytest.approx([1.4 / 2.2, 1.0, 0.0, 1.0, 1.0])
    assert contact_fractions(old[:1], old[:1], radius[:1], bodies, body_radius,
                             _every_pair(1, 2))[0] == 1.0


def _every_pair(moves: int, bodies: int) -> tuple[np.ndarray, np.ndarray]:
    return np.repeat(np.arange(moves), bodies), np.tile(np.arange(bodies), moves)


def test_a_few_moves_stop_at_bodies_as_the_arrays_stop_them() -> None:
    from hubero_dsl.sim.physics import contact_fractions, few_contact_fractions

    rng = np.random.default_rng(5)
    for _ in range(200):
        old = rng.uniform(0.0, 3.0, (3, 2))
        new = old + rng.normal(0.0, 0.4, (3, 2)) * rng.integers(0, 2, (3, 1))
        bodies = rng.uniform(0.0, 3.0, (4, 2))
        radius, body_radius = rng.uniform(0.1, 0.4, 3), rng.uniform(0.1, 0.4, 4)
        arrays = contact_fractions(old, new, radius, bodies, body_radius, _every_pair(3, 4))
        floats = few_contact_fractions(old.tolist(), new.tolist(), radius.tolist(),
                                       bodies.tolist(), body_radius.tolist())
        assert floats == arrays.tolist()  # bit for bit
