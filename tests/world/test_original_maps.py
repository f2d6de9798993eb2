"""The HuBeRo paper's original maps (ASCII PGM, from the shared data) load with the right frame."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from hubero_dsl.world.grid import OccupancyGrid
from hubero_dsl.world.mapfile import load_map

ORIGINAL = Path(__file__).resolve().parents[2] / ".." / "shared" / "maps" / "hubero-original"

pytestmark = pytest.mark.skipif(not ORIGINAL.is_dir(), reason=f"{ORIGINAL} is not available")

LIVING_ROOM_POINTS = [(6.30, 2.50), (3.80, -5.30), (5.5, 1.0), (2.0, -2.8), (0.6, -2.0)]
PARKING_POINTS = [(-5, -6), (-4, -1.8), (-2, 0), (1.5, 2), (0.5, 6.6), (0.3, 18.8), (7.0, 2.9),
                  (1.2, -5.7), (-3.5, 10.5), (-0.5, 14.8)]


@pytest.fixture(scope="module")
def living_room() -> OccupancyGrid:
    return load_map(ORIGINAL / "living_room.yaml")


@pytest.fixture(scope="module")
def parking() -> OccupancyGrid:
    return load_map(ORIGINAL / "parking.yaml")


def test_living_room_frame(living_room: OccupancyGrid) -> None:
    assert living_room.shape == (650, 712)
    assert living_room.resolution == 0.02
    assert living_room.origin == (-5.75, -6.5)
    assert living_room.bounds == pytest.approx((-5.75, -6.5, 8.49, 6.5))


def test_parking_frame(parking: OccupancyGrid) -> None:
    assert parking.shape == (920, 940)
    assert parking.resolution == 0.05
    assert parking.origin == (-18.0, -15.0)
    assert parking.bounds == pytest.approx((-18.0, -15.0, 29.0, 31.0))


def test_living_room_rows_are_flipped(living_room: OccupancyGrid) -> None:
    # The dining table is in the south of the room; its mirror image in the north is empty.
    assert not living_room.is_free((1.5, -4.0))
    assert living_room.is_free((1.5, 4.0))
    # The south wall runs at y = -5.93, just inside it is floor.
    assert not living_room.is_free((2.0, -5.93))
    assert living_room.is_free((2.0, -5.7))


def test_parking_rows_are_flipped(parking: OccupancyGrid) -> None:
    # The two long vehicles stand in the north-east (y 9.5 .. 21.5), not mirrored in the south.
    assert not parking.is_free((12.0, 15.0))
    assert parking.is_free((12.0, 1.0))
    assert not parking.is_free((0.0, -8.0))  # the south fence
    assert parking.is_free((0.0, -7.5))


@pytest.mark.parametrize(("name", "points"), [("living_room", LIVING_ROOM_POINTS),
                                              ("parking", PARKING_POINTS)])
def test_paper_points_are_free_and_mutually_reachable(name: str, points: list[tuple[float, float]],
                                                      request: pytest.FixtureRequest) -> None:
    grid: OccupancyGrid = request.getfixturevalue(name)
    assert grid.is_free(points).all()
    assert (grid.clearance_at(points) > 0.25).all()
    reachable = grid.reachable_mask(points[0], 0.25)
    assert reachable[tuple(grid.world_to_cell(points).T)].all()


def test_original_maps_are_trinary_black_and_white(living_room: OccupancyGrid,
                                                   parking: OccupancyGrid) -> None:
    for grid in (living_room, parking):
        assert grid.unknown is not None and not grid.unknown.any()
        assert 0.05 < np.mean(grid.occupied) < 0.25
