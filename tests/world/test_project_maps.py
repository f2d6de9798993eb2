"""The project's own maps (maps/): the paper's points fit, the routes exist, the narrow aisle works,
and the committed files are exactly what maps/draw_maps.py draws from the shape descriptions."""

from __future__ import annotations

from pathlib import Path
from types import ModuleType

import numpy as np
import pytest
from skimage.graph import MCP_Geometric

from hubero_dsl.world.grid import BoolArray, OccupancyGrid
from hubero_dsl.world.mapfile import load_map
from tests.scripts import load_script

MAPS = Path(__file__).resolve().parents[2] / "maps"

LIVING_ROOM_POINTS = [(6.30, 2.50), (3.80, -5.30), (5.5, 1.0), (2.0, -2.8), (0.6, -2.0)]
ACTOR1_START, DUMPSTER = (-5.0, -6.0), (1.2, -5.7)
PARKING_POINTS = [ACTOR1_START, (-4, -1.8), (-2, 0), (1.5, 2), (0.5, 6.6), (0.3, 18.8),
                  (7.0, 2.9), DUMPSTER, (-3.5, 10.5), (-0.5, 14.8)]
# The aisle runs east-west between the south fence (y = -8.0) and a parked car's side (y = -7.0).
AISLE_CENTRE = (-1.85, -7.5)
AISLE_X, AISLE_Y = (-4.1, 0.4), (-8.0, -7.0)
SMALL_BODY, LARGE_COMFORT = 0.25, 0.70


@pytest.fixture(scope="module")
def living_room() -> OccupancyGrid:
    return load_map(MAPS / "living_room.yaml")


@pytest.fixture(scope="module")
def parking() -> OccupancyGrid:
    return load_map(MAPS / "parking.yaml")


def cells_of(grid: OccupancyGrid, points: list[tuple[float, float]]) -> tuple[np.ndarray, ...]:
    return tuple(grid.world_to_cell(points).T)


def connected(mask: BoolArray, grid: OccupancyGrid, a: tuple[float, float],
              b: tuple[float, float]) -> bool:
    from scipy import ndimage

    labels, _ = ndimage.label(mask, structure=np.ones((3, 3)))
    label_a, label_b = labels[cells_of(grid, [a, b])]
    return bool(label_a and label_a == label_b)


def route_length(grid: OccupancyGrid, radius: float, a: tuple[float, float],
                 b: tuple[float, float]) -> float:
    """Shortest 8-connected path length, in metres, over the cells a body of `radius` fits."""
    costs = np.where(grid.free_mask(radius), 1.0, np.inf)
    start, end = (tuple(int(v) for v in cell) for cell in grid.world_to_cell([a, b]))
    cumulative, _ = MCP_Geometric(costs).find_costs([start], [end])
    return float(cumulative[end]) * grid.resolution


# --- the living room --------------------------------------------------------------------------


def test_living_room_frame(living_room: OccupancyGrid) -> None:
    assert living_room.shape == (650, 712)
    assert living_room.resolution == 0.02
    assert living_room.origin == (-5.75, -6.5)


def test_living_room_points_have_room_around_them(living_room: OccupancyGrid) -> None:
    assert (living_room.clearance_at(LIVING_ROOM_POINTS) >= 0.45).all()


def test_living_room_points_are_mutually_reachable(living_room: OccupancyGrid) -> None:
    for start in LIVING_ROOM_POINTS:
        reachable = living_room.reachable_mask(start, SMALL_BODY)
        assert reachable[cells_of(living_room, LIVING_ROOM_POINTS)].all()


def test_living_room_is_closed_and_furnished(living_room: OccupancyGrid) -> None:
    # walls all round: the free floor never touches the map border or the unknown outside
    assert living_room.unknown is not None and living_room.unknown[0, 0]
    floor = living_room.reachable_mask(LIVING_ROOM_POINTS[0], 0.0)
    assert not (floor[0].any() or floor[-1].any() or floor[:, 0].any() or floor[:, -1].any())
    # the sofa lies behind the talking point, the table and chairs next to the table points
    assert not living_room.is_free([(5.5, 0.0), (1.0, -3.8), (1.2, -2.9)]).any()
    assert living_room.clearance_at((5.5, 1.0)) < 0.8
    assert living_room.clearance_at((2.0, -2.8)) < 0.6


# --- the parking lot ----------------------------------------------------------------------


def test_parking_frame(parking: OccupancyGrid) -> None:
    assert parking.shape == (920, 940)
    assert parking.resolution == 0.05
    assert parking.origin == (-18.0, -15.0)


def test_parking_points_have_room_around_them(parking: OccupancyGrid) -> None:
    assert (parking.clearance_at(PARKING_POINTS) >= 0.45).all()


@pytest.mark.parametrize("radius", [0.2, SMALL_BODY, LARGE_COMFORT])
def test_parking_points_are_mutually_reachable(parking: OccupancyGrid, radius: float) -> None:
    reachable = parking.reachable_mask(PARKING_POINTS[0], radius)
    assert reachable[cells_of(parking, PARKING_POINTS)].all()


def test_dumpster_is_next_to_actor1s_goal(parking: OccupancyGrid) -> None:
    assert parking.clearance_at(DUMPSTER) < 1.0
    assert not parking.is_free((2.8, -7.0))


def test_aisle_is_narrower_than_the_large_personal_space(parking: OccupancyGrid) -> None:
    centre = float(parking.clearance_at(AISLE_CENTRE))
    assert SMALL_BODY < centre < LARGE_COMFORT
    x = AISLE_CENTRE[0]
    assert not parking.is_free([(x, AISLE_Y[0] - 0.03), (x, AISLE_Y[1] + 0.03)]).any()  # sides
    across = [(x, y) for y in np.linspace(AISLE_Y[0] + 0.05, AISLE_Y[1] - 0.05, 19)]
    assert parking.is_free(across).all()
    along = [(x, AISLE_CENTRE[1]) for x in np.linspace(AISLE_X[0] + 0.1, AISLE_X[1] - 0.1, 41)]
    clearance = parking.clearance_at(along)
    assert ((clearance > SMALL_BODY) & (clearance < LARGE_COMFORT)).all()  # 4.3 m of it


def centres(grid: OccupancyGrid) -> tuple[np.ndarray, np.ndarray]:
    rows, cols = np.indices(grid.shape)
    x, y = np.moveaxis(grid.cell_to_world(np.stack((rows, cols), axis=-1)), -1, 0)
    return x, y


def test_aisle_is_the_only_short_way_into_the_yard(parking: OccupancyGrid) -> None:
    x, y = centres(parking)
    # Close the yard's other ways in: its north fence line (with the gate) and its east side.
    north = (y > -2.35) & (y < -2.05) & (x > -2.5) & (x < 10.1)
    east = (x > 9.0) & (x < 10.1) & (y < -2.05)
    closed = ~(north | east)
    # The small body still gets from actor1's start to the dumpster, through the aisle ...
    assert connected(parking.free_mask(SMALL_BODY) & closed, parking, ACTOR1_START, DUMPSTER)
    # ... the large personal space does not ...
    assert not connected(parking.free_mask(LARGE_COMFORT) & closed, parking,
                         ACTOR1_START, DUMPSTER)
    # ... but it does the long way round ...
    assert connected(parking.free_mask(LARGE_COMFORT), parking, ACTOR1_START, DUMPSTER)
    # ... and nothing but the aisle leads in: closing it too shuts the small body out.
    aisle = (x > AISLE_X[0]) & (x < AISLE_X[1]) & (y > AISLE_Y[0]) & (y < AISLE_Y[1])
    assert not connected(parking.free_mask(SMALL_BODY) & closed & ~aisle, parking,
                         ACTOR1_START, DUMPSTER)


def test_large_personal_space_takes_a_longer_way_round(parking: OccupancyGrid) -> None:
    through_aisle = route_length(parking, SMALL_BODY, ACTOR1_START, DUMPSTER)
    round_the_yard = route_length(parking, LARGE_COMFORT, ACTOR1_START, DUMPSTER)
    assert 7.0 < through_aisle < 9.5
    assert round_the_yard > through_aisle + 3.5


# --- the drawing script -------------------------------------------------------------------


@pytest.fixture(scope="module")
def draw_maps() -> ModuleType:
    return load_script(MAPS / "draw_maps.py")


@pytest.mark.parametrize("name", ["living_room", "parking", "station", "halls", "corridor_halls",
                                  "benchmark/corridor", "benchmark/crossing", "benchmark/doorway",
                                  "benchmark/long_corridor", "benchmark/narrow_corridor",
                                  "benchmark/hall", "benchmark/lounge"])
def test_committed_maps_are_what_the_script_draws(draw_maps: ModuleType, name: str,
                                                  tmp_path: Path) -> None:
    written = draw_maps.draw(MAPS / f"{name}.shapes.yaml", tmp_path)
    assert written.read_bytes() == (MAPS / f"{name}.yaml").read_bytes()
    assert written.with_suffix(".pgm").read_bytes() == (MAPS / f"{name}.pgm").read_bytes()


def test_script_draws_every_description_including_the_benchmark_maps(
        draw_maps: ModuleType, tmp_path: Path) -> None:
    assert draw_maps.main(["--out", str(tmp_path)]) == 0
    assert {"corridor.yaml", "crossing.yaml", "doorway.yaml", "long_corridor.yaml",
            "narrow_corridor.yaml", "hall.yaml", "lounge.yaml",
            "living_room.yaml"} <= {p.name for p in tmp_path.glob("*.yaml")}


def test_parked_cars_have_the_size_of_cars(draw_maps: ModuleType) -> None:
    drawing = draw_maps.load_drawing(MAPS / "parking.shapes.yaml")
    cars = [o for o in drawing.obstacles if o.name.startswith("car")]
    assert len(cars) >= 15
    for car in cars:
        xmin, ymin, xmax, ymax = car.geometry.bounds
        assert sorted((xmax - xmin, ymax - ymin)) == pytest.approx([1.9, 4.5]), car.name


def test_bad_shape_descriptions_are_map_errors(draw_maps: ModuleType, tmp_path: Path) -> None:
    from hubero_dsl.errors import MapError

    path = tmp_path / "bad.shapes.yaml"
    path.write_text("resolution: 0.05\norigin: [0, 0]\nsize: [1.03, 1.0]\n")
    with pytest.raises(MapError, match="whole number"):
        draw_maps.load_drawing(path)
    path.write_text("resolution: 0.05\norigin: [0, 0]\nsize: [1, 1]\n"
                    "obstacles: [{name: x, circle: [0, 0]}]\n")
    with pytest.raises(MapError, match="radius"):
        draw_maps.load_drawing(path)


def test_script_draws_named_maps_and_reports_bad_names(draw_maps: ModuleType, tmp_path: Path,
                                                      capsys: pytest.CaptureFixture[str]) -> None:
    assert draw_maps.main(["living_room", "--out", str(tmp_path)]) == 0
    assert (tmp_path / "living_room.yaml").is_file() and (tmp_path / "living_room.pgm").is_file()
    assert draw_maps.main(["no_such_map", "--out", str(tmp_path)]) == 2
    assert "no_such_map.shapes.yaml" in capsys.readouterr().err
