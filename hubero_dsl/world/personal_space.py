"""Vectorised geometry of personal-space shapes: extents along directions, outlines, containment.

A personal space is a `Shape` (see `shapes.py`) expressed in its owner's frame: x forward along
the heading, y to the left, origin at the owner's position. An ellipse's centre sits `offset`
behind the owner (along -heading); circles and rectangles are centred on the owner.

Everything here works on `ShapeArrays` (one shape per human) and broadcasts over query
directions or points, so planners can ask for every pair's extent in a handful of array
operations. `extent_in_body_frame` is the flat kernel the social force planner calls per pair.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from hubero_dsl.world.shapes import Shape, ShapeArrays, ShapeKind, shape_to_row

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]
KindArray = npt.NDArray[np.int8]

ShapeRow = tuple[int, float, float, float]

_TINY = 1e-12
_RECTANGLE = int(ShapeKind.RECTANGLE)  # a plain int compares with arrays faster than the enum


def extent_in_body_frame(kind: KindArray, a: FloatArray, b: FloatArray, offset: FloatArray,
                         forward: FloatArray, left: FloatArray) -> FloatArray:
    """Distance from the owner to its shape's boundary along body-frame directions.

    All arguments broadcast together; (`forward`, `left`) need not be unit vectors. Circles are
    ellipses with a = b and no offset, so only two formulas are evaluated. A direction that
    misses the shape (possible only when an ellipse's offset exceeds its semi-major axis, so
    the owner stands outside it) has extent 0.
    """
    norm = np.maximum(np.hypot(forward, left), _TINY)
    ux, uy = forward / norm, left / norm
    is_rectangle = np.asarray(kind == _RECTANGLE)
    if is_rectangle.all():  # only boxes: the ellipse formula would be computed for nothing
        return _box_extent(a, b, ux, uy)
    extent = _ellipse_extent(a, b, offset, ux, uy)
    if is_rectangle.any():
        extent = np.where(is_rectangle, _box_extent(a, b, ux, uy), extent)
    return np.asarray(extent, dtype=np.float64)


def _ellipse_extent(a: FloatArray, b: FloatArray, offset: FloatArray, ux: FloatArray,
                    uy: FloatArray) -> FloatArray:
    # Ray t*u from the owner against ((x + offset)/a)^2 + (y/b)^2 = 1: the far root of
    # p t^2 + 2 q t + c = 0 is the exit point, which is the boundary seen from inside.
    inv_a2 = 1.0 / (a * a)
    p = ux * ux * inv_a2 + uy * uy / (b * b)
    q = ux * offset * inv_a2
    c = offset * offset * inv_a2 - 1.0
    disc = np.maximum(q * q - p * c, 0.0)
    return np.asarray(np.maximum((np.sqrt(disc) - q) / p, 0.0), dtype=np.float64)


def _box_extent(half_length: FloatArray, half_width: FloatArray, ux: FloatArray,
                uy: FloatArray) -> FloatArray:
    along = half_length / np.maximum(np.abs(ux), _TINY)
    across = half_width / np.maximum(np.abs(uy), _TINY)
    return np.asarray(np.minimum(along, across), dtype=np.float64)


def _to_body_frame(heading: FloatArray, vectors: FloatArray) -> tuple[FloatArray, FloatArray]:
    """World vectors (N, 2) or (N, M, 2) -> forward and left components in each owner's frame."""
    cos_h, sin_h = np.cos(heading), np.sin(heading)
    if vectors.ndim == 3:
        cos_h, sin_h = cos_h[:, None], sin_h[:, None]
    x, y = vectors[..., 0], vectors[..., 1]
    return x * cos_h + y * sin_h, y * cos_h - x * sin_h


def _columns(shapes: ShapeArrays, ndim: int) -> tuple[KindArray, FloatArray, FloatArray,
                                                      FloatArray]:
    if ndim == 3:  # one shape per row, many queries per shape
        return shapes.kind[:, None], shapes.a[:, None], shapes.b[:, None], shapes.offset[:, None]
    return shapes.kind, shapes.a, shapes.b, shapes.offset


def extent_towards(shapes: ShapeArrays, heading: FloatArray,
                   direction_world: FloatArray) -> FloatArray:
    """Distance from each owner to the boundary of its personal space along world directions.

    `shapes` and `heading` have N rows; `direction_world` is (N, 2) (one direction per shape,
    result (N,)) or (N, M, 2) (M directions per shape, result (N, M)).
    """
    directions = np.asarray(direction_world, dtype=np.float64)
    forward, left = _to_body_frame(np.asarray(heading, dtype=np.float64), directions)
    kind, a, b, offset = _columns(shapes, directions.ndim)
    return extent_in_body_frame(kind, a, b, offset, forward, left)


def contains(shapes: ShapeArrays, heading: FloatArray, centre: FloatArray,
             points: FloatArray) -> BoolArray:
    """Whether points lie inside (or on) each owner's personal space.

    `centre` is each owner's position (N, 2); `points` is (N, 2) or (N, M, 2), giving a (N,)
    or (N, M) result.
    """
    points = np.asarray(points, dtype=np.float64)
    centre = np.asarray(centre, dtype=np.float64)
    relative = points - (centre[:, None, :] if points.ndim == 3 else centre)
    x, y = _to_body_frame(np.asarray(heading, dtype=np.float64), relative)
    kind, a, b, offset = _columns(shapes, points.ndim)
    inside_ellipse = ((x + offset) / a) ** 2 + (y / b) ** 2 <= 1.0 + 1e-12
    inside_box = (np.abs(x) <= a + 1e-12) & (np.abs(y) <= b + 1e-12)
    return np.asarray(np.where(kind == ShapeKind.RECTANGLE, inside_box, inside_ellipse),
                      dtype=np.bool_)


def outline(shape_row: Shape | ShapeRow, position: tuple[float, float] | FloatArray,
            heading: float, n: int = 32) -> FloatArray:
    """(n, 2) boundary points of one personal space in world coordinates, counter-clockwise.

    For plots and logs. Rectangles are sampled evenly along their perimeter starting at the
    front-right corner, so every corner is included when n is a multiple of 4 and the box is
    square.
    """
    kind, a, b, offset = (shape_to_row(shape_row) if not isinstance(shape_row, tuple)
                          else shape_row)
    if kind == ShapeKind.RECTANGLE:
        body = _box_outline(a, b, n)
    else:
        angle = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
        body = np.column_stack([a * np.cos(angle) - offset, b * np.sin(angle)])
    cos_h, sin_h = np.cos(heading), np.sin(heading)
    rotation = np.array([[cos_h, -sin_h], [sin_h, cos_h]])
    return np.asarray(body @ rotation.T + np.asarray(position, dtype=np.float64),
                      dtype=np.float64)


def _box_outline(half_length: float, half_width: float, n: int) -> FloatArray:
    """n points round the box, its four corners among them (points spread evenly round it
    cut three corners of a box that is not square): each side gets a share of the points by
    its length, starting at its corner."""
    corners = np.array([[half_length, -half_width], [half_length, half_width],
                        [-half_length, half_width], [-half_length, -half_width],
                        [half_length, -half_width]])
    sides = np.linalg.norm(np.diff(corners, axis=0), axis=1)
    if n < len(sides) or sides.sum() <= 0:
        arc = np.concatenate([[0.0], np.cumsum(sides)])
        samples = np.linspace(0.0, arc[-1], n, endpoint=False)
        return np.column_stack([np.interp(samples, arc, corners[:, 0]),
                                np.interp(samples, arc, corners[:, 1])])
    counts = np.maximum(1, np.floor(n * sides / sides.sum()).astype(int))
    counts[np.argmax(sides)] += n - int(counts.sum())  # the rounding's points to the longest
    return np.concatenate([
        corners[k] + np.linspace(0.0, 1.0, count, endpoint=False)[:, None]
        * (corners[k + 1] - corners[k]) for k, count in enumerate(counts)])
