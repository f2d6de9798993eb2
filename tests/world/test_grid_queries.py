"""The grid's per-tick queries give exactly what their straightforward definitions give.

`clearance_at`, `is_free`, `contains` and `obstacle_direction_at` were rewritten to spare numpy
calls; the references below are the plain formulations (world_to_cell, clip, map_coordinates
over the fractional cells, cell_to_world of the nearest obstacle). Results must agree bit for
bit, including points on cell borders, on obstacle edges, inside walls, off the map and
non-finite ones. `surely_clear` must never claim more clearance than `clearance_at` reports.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from hubero_dsl.world.grid import OccupancyGrid


def reference_is_free(grid: OccupancyGrid, points: np.ndarray) -> np.ndarray:
    cells = grid.world_to_cell(points)
    row, col = grid._clipped(cells)
    return grid._inside(cells) & ~grid.occupied[row, col]


def reference_clearance_at(grid: OccupancyGrid, points: np.ndarray) -> np.ndarray:
    coords = np.nan_to_num(grid._fractional_cells(points) - 0.5, nan=0.0, posinf=0.0,
                           neginf=0.0)
    values = ndimage.map_coordinates(grid.clearance, coords.reshape(-1, 2).T, order=1,
                                     mode="nearest").reshape(points.shape[:-1])
    return np.where(reference_is_free(grid, points), values, 0.0)


def reference_direction(grid: OccupancyGrid, points: np.ndarray) -> np.ndarray:
    def squares(cells: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        lower = grid.cell_to_world(np.moveaxis(cells, 0, -1)) - 0.5 * grid.resolution
        return lower, lower + grid.resolution

    cells = grid.world_to_cell(points)
    row, col = grid._clipped(cells)
    centres = grid.cell_to_world(np.stack((row, col), axis=-1))
    lower, upper = squares(grid._obstacle_field[1][:, row, col])
    away = points - np.clip(points, lower, upper)
    on_edge = ~np.any(away != 0.0, axis=-1, keepdims=True)
    away = np.where(on_edge, centres - 0.5 * (lower + upper), away)
    towards_free = np.zeros_like(points)
    if grid._free_field is not None:
        lower, upper = squares(grid._free_field[:, row, col])
        towards_free = np.clip(points, lower, upper) - points
    xmin, ymin, xmax, ymax = grid.bounds
    towards_map = np.clip(points, (xmin, ymin), (xmax, ymax)) - points
    free = reference_is_free(grid, points)[..., None]
    inside = grid._inside(cells)[..., None]
    direction = np.where(free, away, np.where(inside, towards_free, towards_map))
    norms = np.linalg.norm(direction, axis=-1, keepdims=True)
    return np.divide(direction, norms, out=np.zeros_like(direction), where=norms > 0.0)


def furnished(seed: int, resolution: float = 0.05) -> OccupancyGrid:
    """A room with random boxes, pillars and unknown cells."""
    rng = np.random.default_rng(seed)
    occupied = np.zeros((60, 80), dtype=bool)
    for _ in range(8):
        r, c = rng.integers(0, 55), rng.integers(0, 75)
        occupied[r:r + rng.integers(1, 6), c:c + rng.integers(1, 6)] = True
    unknown = np.zeros_like(occupied)
    unknown[:3, :10] = True
    return OccupancyGrid(occupied, resolution, (-1.3, 0.7), unknown=unknown)


def awkward_points(grid: OccupancyGrid, seed: int) -> np.ndarray:
    """Random points, points on cell borders and corners, off the map, and non-finite ones."""
    rng = np.random.default_rng(seed)
    xmin, ymin, xmax, ymax = grid.bounds
    inside = rng.uniform((xmin - 0.5, ymin - 0.5), (xmax + 0.5, ymax + 0.5), size=(400, 2))
    rows, cols = grid.shape
    corners = grid.cell_to_world(np.column_stack([rng.integers(-1, rows + 1, 100),
                                                  rng.integers(-1, cols + 1, 100)]))
    corners -= 0.5 * grid.resolution
    borders = corners + np.column_stack([rng.uniform(0, grid.resolution, 100), np.zeros(100)])
    odd = np.array([[np.nan, 0.0], [0.0, np.nan], [np.inf, 1.0], [-np.inf, 1.0], [1.0, np.inf],
                    [1e12, -1e12], [xmin, ymin], [xmax, ymax]])
    return np.concatenate([inside, corners, borders, odd])


@pytest.mark.parametrize("seed", range(6))
def test_queries_equal_their_reference_formulations_bit_for_bit(seed: int) -> None:
    grid = furnished(seed)
    points = awkward_points(grid, seed)
    with np.errstate(invalid="ignore"):
        expected_direction = reference_direction(grid, points)
    np.testing.assert_array_equal(grid.is_free(points), reference_is_free(grid, points))
    np.testing.assert_array_equal(grid.contains(points), grid._inside(grid.world_to_cell(points)))
    np.testing.assert_array_equal(grid.clearance_at(points), reference_clearance_at(grid, points))
    with np.errstate(invalid="ignore"):
        direction = grid.obstacle_direction_at(points)
        both = grid.clearance_and_direction_at(points)
    np.testing.assert_array_equal(direction, expected_direction)
    np.testing.assert_array_equal(both[0], reference_clearance_at(grid, points))
    np.testing.assert_array_equal(both[1], expected_direction)


def test_queries_keep_the_shape_of_a_grid_of_points() -> None:
    grid = furnished(1)
    points = awkward_points(grid, 1)[:400].reshape(20, 20, 2)
    assert grid.clearance_at(points).shape == (20, 20)
    np.testing.assert_array_equal(grid.clearance_at(points),
                                  reference_clearance_at(grid, points))
    np.testing.assert_array_equal(grid.obstacle_direction_at(points),
                                  reference_direction(grid, points))


@pytest.mark.parametrize("resolution", [0.02, 0.05, 0.5])
def test_surely_clear_never_claims_more_than_the_interpolated_clearance(
        resolution: float) -> None:
    grid = furnished(3, resolution)
    points = awkward_points(grid, 3)
    finite = points[np.isfinite(points).all(axis=1)]
    clearance = grid.clearance_at(finite)
    for distance in (1e-9, 0.5 * resolution, 0.12, 0.3, 1.0, 2.5):
        sure = grid.surely_clear(finite, distance)
        assert np.all(clearance[sure] >= distance)
    # the bound is not idle: open space far from walls is recognised
    assert grid.surely_clear(finite, 1e-9).sum() > 0.3 * len(finite)
    assert not grid.surely_clear(points[~np.isfinite(points).all(axis=1)], 1e-9).any()


def test_off_map_points_are_never_surely_clear() -> None:
    grid = OccupancyGrid(np.zeros((40, 40), dtype=bool), 0.1, (0.0, 0.0))
    outside = np.array([[-0.05, 2.0], [4.2, 2.0], [2.0, -3.0], [2.0, 40.0]])
    assert not grid.surely_clear(outside, 1e-9).any()
    assert grid.surely_clear(np.array([[2.0, 2.0]]), 1.5).all()


def reference_obstacle_field(occupied: np.ndarray, resolution: float
                             ) -> tuple[np.ndarray, np.ndarray]:
    """scipy's transform of the whole grid padded with one occupied ring."""
    padded = np.pad(occupied, 1, constant_values=True)
    distances, nearest = ndimage.distance_transform_edt(~padded, sampling=resolution,
                                                        return_indices=True)
    return distances[1:-1, 1:-1], (nearest[:, 1:-1, 1:-1] - 1).astype(np.int32)


def random_cells(rng: np.random.Generator) -> np.ndarray:
    """Scattered obstacles, or a scattered free patch somewhere inside walls."""
    rows, cols = (int(n) for n in rng.integers(1, 30, size=2))
    occupied = rng.random((rows, cols)) < rng.random()
    if rng.random() < 0.5:
        occupied[:] = True
        top, left = int(rng.integers(0, rows)), int(rng.integers(0, cols))
        bottom, right = int(rng.integers(top, rows)) + 1, int(rng.integers(left, cols)) + 1
        occupied[top:bottom, left:right] = rng.random((bottom - top, right - left)) < 0.3
    return occupied


@pytest.mark.parametrize("resolution", [1.0, 0.05, 0.03])
def test_obstacle_field_of_the_free_cells_box_equals_the_whole_grids(resolution: float) -> None:
    # exact ties (resolution 1, small integer distances) are where a window could differ
    rng = np.random.default_rng(int(resolution * 100))
    for _ in range(300):
        occupied = random_cells(rng)
        distances, nearest = OccupancyGrid(occupied, resolution, (0.0, 0.0))._obstacle_field
        expected_distances, expected_nearest = reference_obstacle_field(occupied, resolution)
        np.testing.assert_array_equal(distances, expected_distances)
        np.testing.assert_array_equal(nearest, expected_nearest)
        assert nearest.dtype == np.int32


@pytest.mark.parametrize("resolution", [1.0, 0.05, 0.03])
def test_a_body_fits_where_the_free_mask_says_it_does(resolution: float) -> None:
    # found from the cells around it, without the map's field; ties at whole-cell radii
    rng = np.random.default_rng(int(resolution * 1000))
    for _ in range(200):
        occupied = random_cells(rng)
        rows, cols = occupied.shape
        points = rng.uniform((-1.0, -1.0), (cols + 1.0, rows + 1.0), size=(8, 2)) * resolution
        radii = np.concatenate([rng.integers(0, 6, size=4) * resolution,
                                rng.uniform(0.0, 6 * resolution, size=4)])
        for point, radius in zip(points, radii, strict=True):
            xy = (float(point[0]), float(point[1]))
            fresh = OccupancyGrid(occupied, resolution, (0.0, 0.0))
            fits = fresh.body_fits(xy, float(radius))
            assert "_obstacle_field" not in fresh.__dict__ or abs(
                fresh._nearest_obstacle_within(*(int(i) for i in fresh.world_to_cell(xy)),
                                               float(radius)) - radius) <= 1e-9
            cell = fresh.world_to_cell(xy)
            inside = bool(fresh._inside(cell))
            expected = inside and bool(fresh.free_mask(float(radius))[fresh._clipped(cell)])
            assert fits == expected, (xy, radius)


def test_grids_with_the_same_cells_share_one_obstacle_field() -> None:
    first, second = furnished(4), furnished(4)
    assert first._obstacle_field[0] is second._obstacle_field[0]
    assert furnished(5)._obstacle_field[0] is not first._obstacle_field[0]
    coarser = OccupancyGrid(first.occupied, 0.1, first.origin)
    assert coarser._obstacle_field[0] is not first._obstacle_field[0]
    np.testing.assert_array_equal(coarser.clearance, 2.0 * first.clearance)


# ---- a few points at a time: the same answers, computed in floats ----------------------------

def same_bits(a: np.ndarray, b: np.ndarray) -> bool:
    """Equal bit for bit (a zero's sign included)."""
    return a.shape == b.shape and np.array_equal(np.asarray(a, np.float64).view(np.uint64),
                                                 np.asarray(b, np.float64).view(np.uint64))


def few_at_a_time(points: np.ndarray, seed: int) -> list[np.ndarray]:
    """The finite points in chunks of 1 to FEW_POINTS."""
    from hubero_dsl.world.grid import FEW_POINTS

    points = points[np.isfinite(points).all(axis=1)]
    sizes = np.random.default_rng(seed).integers(1, FEW_POINTS + 1, len(points))
    return np.split(points, np.cumsum(sizes)[np.cumsum(sizes) < len(points)])


@pytest.mark.parametrize("seed", range(6))
def test_a_few_points_get_the_arrays_answers_bit_for_bit(seed: int) -> None:
    grid = furnished(seed)
    for chunk in few_at_a_time(awkward_points(grid, seed), seed):
        clearance, direction = grid.clearance_and_direction_at(chunk)
        assert same_bits(clearance, reference_clearance_at(grid, chunk))
        assert same_bits(direction, reference_direction(grid, chunk))
        assert same_bits(grid.clearance_at(chunk), clearance)
        reach = 0.4
        found, near_clearance, away = grid.walls_within(chunk, reach)
        floor = grid._clearance_floor
        rows, cols = grid._locate(chunk)[:2]
        np.testing.assert_array_equal(found, np.flatnonzero(floor[rows, cols] < reach))
        assert same_bits(near_clearance, clearance[found])
        assert same_bits(away, direction[found])


def test_a_few_points_on_a_map_without_free_cells_or_of_one_row() -> None:
    walls = OccupancyGrid(np.ones((4, 5), dtype=bool), 0.1, (0.0, 0.0))
    line = OccupancyGrid(np.array([[False, False, True, False]]), 0.5, (-1.0, 2.0))
    for grid, seed in ((walls, 1), (line, 2)):
        for chunk in few_at_a_time(awkward_points(grid, seed), seed):
            clearance, direction = grid.clearance_and_direction_at(chunk)
            assert same_bits(clearance, reference_clearance_at(grid, chunk))
            assert same_bits(direction, reference_direction(grid, chunk))


@pytest.mark.parametrize("seed", range(4))
def test_one_point_and_a_few_segments_get_the_arrays_answers(seed: int) -> None:
    grid, rng = furnished(seed), np.random.default_rng(seed)
    points = awkward_points(grid, seed)
    points = points[np.isfinite(points).all(axis=1)]
    for (x, y), free, clearance in zip(points.tolist(), grid.is_free(points).tolist(),
                                       grid.clearance_at(points).tolist(), strict=True):
        assert grid.is_free_point(x, y) == free
        assert same_bits(np.array(grid.clearance_at_point(x, y)), np.array(clearance))
    crossed_some = False
    for chunk in few_at_a_time(points, seed):
        ends = chunk + rng.normal(0.0, 0.3, chunk.shape)
        fractions = grid.segment_fractions(float(np.hypot(*(ends - chunk).T).max()))
        expected = grid.crosses_obstacle(chunk, ends).tolist()
        assert [grid.crosses_obstacle_point(a, b, c, d, fractions) for (a, b), (c, d)
                in zip(chunk.tolist(), ends.tolist(), strict=True)] == expected
        crossed_some |= any(expected) and not all(expected)
    assert crossed_some


def test_nearest_others_by_all_distances_and_by_a_tree_agree(
        monkeypatch: pytest.MonkeyPatch) -> None:
    from hubero_dsl.lang import placement

    rng = np.random.default_rng(5)
    centres = rng.uniform(0.0, 10.0, size=(300, 2))
    centres[7] = centres[3]  # two bodies on one spot
    pairwise = placement._nearest_others(centres)
    monkeypatch.setattr(placement, "PAIRWISE_AT_MOST", 0)
    tree = placement._nearest_others(centres)
    np.testing.assert_allclose(pairwise[0], tree[0], rtol=0, atol=1e-12)
    # the same other, or one as near (the bodies 3 and 7 share a spot: a tie for their
    # neighbours)
    to_others = np.hypot(*(centres - centres[tree[1]]).T)
    np.testing.assert_allclose(to_others, pairwise[0], rtol=0, atol=1e-12)
    assert pairwise[0][3] == pairwise[0][7] == 0.0 and pairwise[1][3] == 7
