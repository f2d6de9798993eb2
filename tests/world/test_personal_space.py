"""Personal-space geometry checked against shapely on random shapes, headings and directions."""

from __future__ import annotations

import numpy as np
import pytest
import shapely
from shapely import affinity
from shapely.geometry import LineString, Point, Polygon, box

from hubero_dsl.world.personal_space import contains, extent_towards, outline
from hubero_dsl.world.shapes import Circle, Ellipse, Rectangle, Shape, ShapeArrays, Square

CASES = 60


def random_shapes(rng: np.random.Generator, count: int) -> list[Shape]:
    shapes: list[Shape] = []
    for index in range(count):
        major, minor = rng.uniform(0.2, 2.0, size=2)
        if index % 3 == 0:
            shapes.append(Circle(float(major)))
        elif index % 3 == 1:
            shapes.append(Ellipse(float(major), float(minor), float(rng.uniform(0.0, 0.9) * major)))
        else:
            shapes.append(Rectangle(float(2 * major), float(2 * minor)))
    return shapes


def shapely_shape(shape: Shape, position: np.ndarray, heading: float) -> Polygon:
    if isinstance(shape, Circle):
        body = Point(0.0, 0.0).buffer(shape.radius, quad_segs=1024)
    elif isinstance(shape, Ellipse):
        unit = Point(0.0, 0.0).buffer(1.0, quad_segs=1024)
        body = affinity.translate(affinity.scale(unit, shape.semi_major, shape.semi_minor,
                                                 origin=(0.0, 0.0)), -shape.offset, 0.0)
    else:
        body = box(-shape.length / 2, -shape.width / 2, shape.length / 2, shape.width / 2)
    turned = affinity.rotate(body, heading, origin=(0.0, 0.0), use_radians=True)
    return affinity.translate(turned, float(position[0]), float(position[1]))


Scene = tuple[list[Shape], ShapeArrays, np.ndarray, np.ndarray]


@pytest.fixture
def scene() -> Scene:
    rng = np.random.default_rng(11)
    shapes = random_shapes(rng, CASES)
    positions = rng.uniform(-5.0, 5.0, size=(CASES, 2))
    headings = rng.uniform(-np.pi, np.pi, size=CASES)
    return shapes, ShapeArrays.from_shapes(shapes), positions, headings


def test_extent_matches_ray_intersection_with_shapely(scene: Scene) -> None:
    shapes, arrays, positions, headings = scene
    rng = np.random.default_rng(12)
    angles = rng.uniform(-np.pi, np.pi, size=(CASES, 5))
    directions = np.stack([np.cos(angles), np.sin(angles)], axis=-1) * rng.uniform(0.1, 3.0,
                                                                                   (CASES, 5, 1))
    got = extent_towards(arrays, headings, directions)
    assert got.shape == (CASES, 5)
    for row, shape in enumerate(shapes):
        polygon = shapely_shape(shape, positions[row], headings[row])
        for column in range(5):
            unit = directions[row, column] / np.linalg.norm(directions[row, column])
            ray = LineString([positions[row], positions[row] + 10.0 * unit])
            expected = polygon.intersection(ray).length
            assert got[row, column] == pytest.approx(expected, abs=2e-4), (shape, row, column)


def test_extent_with_one_direction_per_shape(scene: Scene) -> None:
    _, arrays, _, headings = scene
    forward = np.column_stack([np.cos(headings), np.sin(headings)])
    left = np.column_stack([-np.sin(headings), np.cos(headings)])
    ahead = extent_towards(arrays, headings, forward)
    behind = extent_towards(arrays, headings, -forward)
    beside = extent_towards(arrays, headings, left)
    assert ahead.shape == (CASES,)
    np.testing.assert_allclose(ahead, arrays.a - arrays.offset)
    np.testing.assert_allclose(behind, arrays.a + arrays.offset)
    # beside the owner an offset ellipse is narrower than its semi-minor axis
    expected_beside = arrays.b * np.sqrt(1.0 - (arrays.offset / arrays.a) ** 2)
    np.testing.assert_allclose(beside, expected_beside)


def test_offset_ellipse_reaches_further_behind_than_ahead() -> None:
    arrays = ShapeArrays.from_shapes([Ellipse(1.0, 0.5, 0.4)])
    heading = np.array([np.pi / 2])  # facing +y
    ahead = extent_towards(arrays, heading, np.array([[0.0, 1.0]]))
    behind = extent_towards(arrays, heading, np.array([[0.0, -1.0]]))
    assert ahead[0] == pytest.approx(0.6)
    assert behind[0] == pytest.approx(1.4)


def test_contains_agrees_with_shapely(scene: Scene) -> None:
    shapes, arrays, positions, headings = scene
    rng = np.random.default_rng(13)
    points = positions[:, None, :] + rng.uniform(-2.5, 2.5, size=(CASES, 40, 2))
    got = contains(arrays, headings, positions, points)
    assert got.shape == (CASES, 40)
    for row, shape in enumerate(shapes):
        polygon = shapely_shape(shape, positions[row], headings[row])
        expected = shapely.contains_xy(polygon, points[row, :, 0], points[row, :, 1])
        # points within polygon-approximation error of the boundary may legitimately differ
        margin = shapely.distance(polygon.exterior, shapely.points(points[row]))
        decided = margin > 1e-3
        np.testing.assert_array_equal(got[row][decided], expected[decided])
    assert got.any() and not got.all()


def test_contains_one_point_per_shape() -> None:
    arrays = ShapeArrays.from_shapes([Circle(0.5), Square(1.0)])
    heading = np.array([0.0, np.pi / 4])
    centre = np.array([[0.0, 0.0], [3.0, 0.0]])
    points = np.array([[0.4, 0.0], [3.0 + 0.6, 0.0]])  # the square's corner is turned 45 deg
    np.testing.assert_array_equal(contains(arrays, heading, centre, points), [True, True])
    np.testing.assert_array_equal(contains(arrays, heading, centre, points * 1.3), [False, False])


@pytest.mark.parametrize("shape", [Circle(0.7), Ellipse(1.2, 0.5, 0.3), Rectangle(1.0, 0.4)])
def test_outline_traces_the_shapely_boundary(shape: Shape) -> None:
    position, heading = np.array([2.0, -1.0]), 0.7
    points = outline(shape, position, heading, n=64)
    assert points.shape == (64, 2)
    polygon = shapely_shape(shape, position, heading)
    distances = shapely.distance(polygon.exterior, shapely.points(points))
    assert distances.max() < 1e-3
    assert Polygon(points).is_valid
    assert Polygon(points).exterior.is_ccw


@pytest.mark.parametrize("n", [4, 32, 48])
def test_a_rectangles_outline_keeps_its_corners(n: int) -> None:
    # points spread evenly round a 1.2 x 0.8 m box cut three of its corners by 5 cm
    points = outline(Rectangle(1.2, 0.8), (0.0, 0.0), 0.0, n=n)
    assert points.shape == (n, 2)
    for corner in ((0.6, 0.4), (-0.6, 0.4), (-0.6, -0.4), (0.6, -0.4)):
        assert np.min(np.hypot(*(points - corner).T)) < 1e-12
    assert Polygon(points).area == pytest.approx(1.2 * 0.8)


def test_outline_accepts_a_shape_row() -> None:
    points = outline((0, 1.0, 1.0, 0.0), (0.0, 0.0), 0.0, n=4)
    np.testing.assert_allclose(points, [[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0]],
                               atol=1e-12)
