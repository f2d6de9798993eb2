"""OccupancyGrid: coordinates, free space, clearance, wall directions, reachability, caching."""

from __future__ import annotations

import pickle

import numpy as np
import pytest

from hubero_dsl.errors import MapError
from hubero_dsl.world.grid import OccupancyGrid

RES = 0.1


def room(rows: int = 20, cols: int = 30, origin: tuple[float, float] = (1.0, -2.0),
         **blocks: tuple[slice, slice]) -> OccupancyGrid:
    occupied = np.zeros((rows, cols), dtype=bool)
    for rs, cs in blocks.values():
        occupied[rs, cs] = True
    return OccupancyGrid(occupied, RES, origin)


def brute_force_clearance(occupied: np.ndarray, resolution: float) -> np.ndarray:
    """Distance from every cell centre to the nearest occupied cell or border-ring cell."""
    padded = np.pad(occupied, 1, constant_values=True)
    obstacles = np.argwhere(padded) - 1
    cells = np.argwhere(np.ones_like(occupied))
    distances = np.linalg.norm(cells[:, None, :] - obstacles[None, :, :], axis=-1).min(axis=1)
    return distances.reshape(occupied.shape) * resolution


# --- geometry ---------------------------------------------------------------------------------


def test_shape_and_bounds() -> None:
    grid = room(rows=20, cols=30, origin=(1.0, -2.0))
    assert grid.shape == (20, 30)
    assert grid.bounds == pytest.approx((1.0, -2.0, 4.0, 0.0))


def test_world_to_cell_puts_row_zero_at_the_lowest_y() -> None:
    grid = room(origin=(1.0, -2.0))
    cells = grid.world_to_cell([(1.05, -1.95), (1.05, -0.05), (3.95, -1.95), (2.55, -1.25)])
    assert cells.tolist() == [[0, 0], [19, 0], [0, 29], [7, 15]]


def test_cell_to_world_gives_centres_and_round_trips() -> None:
    grid = room(origin=(1.0, -2.0))
    rc = np.array([[0, 0], [7, 15], [19, 29]])
    centres = grid.cell_to_world(rc)
    assert centres[0] == pytest.approx((1.05, -1.95))
    assert centres[1] == pytest.approx((2.55, -1.25))
    assert (grid.world_to_cell(centres) == rc).all()


def test_queries_keep_the_shape_of_their_input() -> None:
    grid = room()
    points = np.zeros((3, 4, 2))
    assert grid.world_to_cell(points).shape == (3, 4, 2)
    assert grid.cell_to_world(np.zeros((5, 2), dtype=int)).shape == (5, 2)
    assert grid.contains(points).shape == (3, 4)
    assert grid.is_free(points).shape == (3, 4)
    assert grid.clearance_at(points).shape == (3, 4)
    assert grid.obstacle_direction_at(points).shape == (3, 4, 2)
    assert grid.world_to_cell((2.0, -1.0)).shape == (2,)
    assert grid.clearance_at((2.0, -1.0)).shape == ()


def test_points_must_have_two_coordinates() -> None:
    with pytest.raises(ValueError, match="shape"):
        room().is_free([1.0, 2.0, 3.0])


def test_contains_and_is_free() -> None:
    grid = room(origin=(0.0, 0.0), block=(slice(5, 10), slice(5, 10)))
    points = [(0.75, 0.75), (-0.01, 1.0), (3.0, 1.0), (1.0, 2.0), (np.nan, 1.0), (np.inf, 0.5)]
    assert grid.contains(points).tolist() == [True, False, False, False, False, False]
    assert grid.is_free(points).tolist() == [False, False, False, False, False, False]
    assert grid.is_free((0.25, 0.25))
    assert grid.contains((2.999, 1.999))
    with np.errstate(all="raise"):  # a point written as 1e308 is outside, and says no more
        assert not grid.contains((1e308, -1e308))


# --- clearance ----------------------------------------------------------------------------


def test_clearance_is_the_exact_distance_to_the_nearest_obstacle_or_border() -> None:
    rng = np.random.default_rng(3)
    occupied = rng.random((17, 23)) < 0.08
    grid = OccupancyGrid(occupied, RES, (0.0, 0.0))
    assert grid.clearance == pytest.approx(brute_force_clearance(occupied, RES))
    assert (grid.clearance[occupied] == 0.0).all()


def test_border_counts_as_an_obstacle() -> None:
    grid = room(rows=11, cols=11, origin=(0.0, 0.0))
    assert grid.clearance[0, 5] == pytest.approx(RES)
    assert grid.clearance[5, 5] == pytest.approx(6 * RES)


def test_clearance_at_interpolates_between_cell_centres() -> None:
    grid = room(origin=(0.0, 0.0), wall=(slice(0, 20), slice(0, 1)))
    centres = grid.cell_to_world(np.array([[10, 3], [10, 4]]))
    at_centres = grid.clearance_at(centres)
    assert at_centres == pytest.approx(grid.clearance[10, 3:5])
    halfway = grid.clearance_at(centres.mean(axis=0))
    assert halfway == pytest.approx(at_centres.mean())


def test_clearance_at_is_zero_off_free_cells() -> None:
    grid = room(origin=(0.0, 0.0), wall=(slice(0, 20), slice(0, 1)))
    assert grid.clearance_at([(0.05, 1.0), (-1.0, 1.0), (1.0, 5.0), (np.nan, 0.0)]).tolist() == [
        0.0, 0.0, 0.0, 0.0]


# --- wall directions ----------------------------------------------------------------------


def test_obstacle_direction_points_away_from_the_wall() -> None:
    grid = room(rows=40, cols=40, origin=(0.0, 0.0), floor=(slice(0, 3), slice(0, 40)))
    directions = grid.obstacle_direction_at([(2.0, 0.6), (2.0, 0.9), (1.5, 1.2)])
    assert directions == pytest.approx(np.array([[0.0, 1.0]] * 3), abs=0.05)
    assert np.linalg.norm(directions, axis=-1) == pytest.approx(1.0)


def test_obstacle_direction_near_the_border_points_into_the_map() -> None:
    grid = room(rows=40, cols=40, origin=(0.0, 0.0))
    assert grid.obstacle_direction_at((0.12, 2.0)) == pytest.approx((1.0, 0.0), abs=1e-9)
    assert grid.obstacle_direction_at((3.97, 2.0)) == pytest.approx((-1.0, 0.0), abs=1e-9)


def test_obstacle_direction_inside_a_wall_points_out_of_it() -> None:
    grid = room(rows=40, cols=40, origin=(0.0, 0.0), floor=(slice(0, 3), slice(0, 40)))
    inside = grid.obstacle_direction_at((2.0, 0.1))
    assert inside == pytest.approx((0.0, 1.0), abs=0.05)


def test_obstacle_direction_outside_the_map_points_at_it() -> None:
    grid = room(rows=40, cols=40, origin=(0.0, 0.0))
    outside = grid.obstacle_direction_at([(-1.0, 2.0), (2.0, 9.0)])
    assert outside == pytest.approx(np.array([[1.0, 0.0], [0.0, -1.0]]))


def test_obstacle_direction_is_zero_on_a_fully_occupied_map() -> None:
    grid = OccupancyGrid(np.ones((4, 4), dtype=bool), RES, (0.0, 0.0))
    assert grid.obstacle_direction_at((0.2, 0.2)) == pytest.approx((0.0, 0.0))


# --- where a body fits --------------------------------------------------------------------


def two_rooms(door_cells: int) -> OccupancyGrid:
    """Two rooms side by side; the dividing wall has a door `door_cells` wide in its middle."""
    occupied = np.zeros((41, 61), dtype=bool)
    occupied[:, 30] = True
    first = 20 - door_cells // 2
    occupied[first:first + door_cells, 30] = False
    return OccupancyGrid(occupied, RES, (0.0, 0.0))


def test_free_mask_is_clearance_above_the_radius_and_cached() -> None:
    grid = two_rooms(door_cells=5)
    mask = grid.free_mask(0.3)
    assert (mask == (grid.clearance > 0.3)).all()
    assert grid.free_mask(0.3) is mask
    assert not mask.flags.writeable
    assert grid.free_mask(0.5).sum() < mask.sum()


def test_reachable_mask_goes_through_a_door_only_when_the_body_fits() -> None:
    grid = two_rooms(door_cells=7)  # 0.7 m: the door's centre has 0.4 m clearance
    left, right = (1.0, 2.0), (5.0, 2.0)
    right_cell = tuple(grid.world_to_cell(right))
    assert grid.reachable_mask(left, 0.3)[right_cell]
    assert not grid.reachable_mask(left, 0.45)[right_cell]
    assert grid.reachable_mask(left, 0.45)[tuple(grid.world_to_cell(left))]


def test_reachable_mask_is_empty_from_an_occupied_or_outside_start() -> None:
    grid = two_rooms(door_cells=7)
    assert not grid.reachable_mask((3.05, 0.5), 0.1).any()
    assert not grid.reachable_mask((-5.0, 0.5), 0.1).any()
    assert not grid.reachable_mask((0.02, 2.0), 0.2).any()  # the body does not fit there


def test_reachable_mask_is_shared_within_a_component() -> None:
    grid = two_rooms(door_cells=9)
    first = grid.reachable_mask((1.0, 2.0), 0.2)
    assert grid.reachable_mask((5.0, 3.0), 0.2) is first
    assert not first.flags.writeable


def test_nearest_free_of_a_free_point_is_the_point_itself() -> None:
    grid = two_rooms(door_cells=7)
    assert grid.nearest_free((1.23, 2.34)) == ((1.23, 2.34), 0.0)


def test_nearest_free_leaves_an_obstacle_for_the_closest_cell_that_fits() -> None:
    grid = two_rooms(door_cells=7)
    (x, y), distance = grid.nearest_free((3.05, 0.52), body_radius=0.0)
    assert (x, y) == pytest.approx((2.95, 0.55))  # ties go to the lowest (row, col)
    assert distance == pytest.approx(np.hypot(0.1, 0.03))
    (x, y), distance = grid.nearest_free((3.05, 0.5), body_radius=0.3)
    assert grid.clearance_at((x, y)) > 0.3
    assert distance == pytest.approx(np.hypot(x - 3.05, y - 0.5))


def test_nearest_free_outside_the_map() -> None:
    grid = room(rows=10, cols=10, origin=(0.0, 0.0))
    (x, y), distance = grid.nearest_free((-1.0, 0.55))
    assert (x, y) == pytest.approx((0.05, 0.55))
    assert distance == pytest.approx(1.05)


@pytest.mark.parametrize("radius", [0.0, 0.1, 0.15])
def test_nearest_free_is_the_nearest_of_every_cell_that_fits(radius: float) -> None:
    # the search goes by the distance transform's nearest cell; it must find what comparing
    # with every cell that fits finds, ties to the lowest (row, col) included
    rng = np.random.default_rng(7)
    occupied = rng.random((60, 80)) < 0.1
    grid = OccupancyGrid(occupied, 0.1, (-2.0, 1.0), "random")
    rows, cols = np.nonzero(grid.free_mask(radius))
    centres = grid.cell_to_world(np.stack((rows, cols), axis=-1))
    for x, y in rng.uniform((-4.0, -1.0), (8.0, 9.0), size=(300, 2)):
        (fx, fy), distance = grid.nearest_free((float(x), float(y)), radius)
        if distance == 0.0:
            continue
        every = np.hypot(centres[:, 0] - x, centres[:, 1] - y)
        best = int(np.argmin(every))
        assert ((fx, fy), distance) == ((float(centres[best, 0]), float(centres[best, 1])),
                                        float(every[best]))


def test_nearest_free_fails_when_the_body_fits_nowhere() -> None:
    grid = room(rows=10, cols=10)
    with pytest.raises(MapError, match="radius 2 m"):
        grid.nearest_free((1.5, -1.5), body_radius=2.0)


def test_negative_radius_is_rejected() -> None:
    with pytest.raises(ValueError, match="radius"):
        room().free_mask(-0.1)


# --- construction -------------------------------------------------------------------------


def test_unknown_cells_count_as_occupied() -> None:
    occupied = np.zeros((5, 5), dtype=bool)
    unknown = np.zeros((5, 5), dtype=bool)
    unknown[2, 2] = True
    grid = OccupancyGrid(occupied, RES, (0.0, 0.0), unknown=unknown)
    assert grid.occupied[2, 2]
    assert grid.unknown is not None and grid.unknown[2, 2]
    assert not grid.is_free((0.25, 0.25))


def test_the_grid_owns_read_only_copies_of_its_cells() -> None:
    occupied = np.zeros((5, 5), dtype=bool)
    grid = OccupancyGrid(occupied, RES, (0, 0))
    occupied[0, 0] = True
    assert not grid.occupied[0, 0]
    assert not grid.occupied.flags.writeable
    assert not grid.clearance.flags.writeable
    assert grid.origin == (0.0, 0.0) and isinstance(grid.origin[0], float)


@pytest.mark.parametrize(("occupied", "resolution", "unknown", "message"), [
    (np.zeros(5, dtype=bool), RES, None, "2-D"),
    (np.zeros((0, 3), dtype=bool), RES, None, "non-empty"),
    (np.zeros((3, 3), dtype=bool), 0.0, None, "resolution"),
    (np.zeros((3, 3), dtype=bool), -0.1, None, "resolution"),
    (np.zeros((3, 3), dtype=bool), float("nan"), None, "resolution"),
    (np.zeros((3, 3), dtype=bool), RES, np.zeros((3, 4), dtype=bool), "unknown"),
])
def test_invalid_grids_are_map_errors(occupied: np.ndarray, resolution: float,
                                      unknown: np.ndarray | None, message: str) -> None:
    with pytest.raises(MapError, match=message):
        OccupancyGrid(occupied, resolution, (0.0, 0.0), source="test.yaml", unknown=unknown)


def test_pickling_keeps_the_map_and_drops_the_caches() -> None:
    grid = two_rooms(door_cells=5)
    grid.free_mask(0.2)
    copy = pickle.loads(pickle.dumps(grid))
    assert (copy.occupied == grid.occupied).all()
    assert copy.resolution == grid.resolution and copy.origin == grid.origin
    assert copy._cache == {}
    assert "_obstacle_field" not in copy.__dict__
    assert not copy.occupied.flags.writeable
    assert (copy.free_mask(0.2) == grid.free_mask(0.2)).all()


def test_repr_is_short() -> None:
    text = repr(room(rows=20, cols=30))
    assert text == "OccupancyGrid(30x20 cells, 0.1 m, origin (1, -2), source='<memory>')"


def test_obstacle_direction_around_a_pillar_is_radial() -> None:
    grid = room(rows=41, cols=41, origin=(0.0, 0.0), pillar=(slice(20, 21), slice(20, 21)))
    angles = np.linspace(0.0, 2 * np.pi, 16, endpoint=False)
    radial = np.stack((np.cos(angles), np.sin(angles)), axis=-1)
    points = np.array([2.05, 2.05]) + 0.5 * radial
    directions = grid.obstacle_direction_at(points)
    assert (np.einsum("ij,ij->i", directions, radial) > 0.97).all()


def test_caches_stay_bounded_and_keep_what_was_used_last() -> None:
    grid = two_rooms(door_cells=5)
    kept = grid.free_mask(0.1)
    for radius in np.linspace(0.2, 1.0, 100):
        grid.free_mask(float(radius))
        assert grid.free_mask(0.1) is kept  # used again, so never the oldest
    assert len(grid._cache) <= 48
