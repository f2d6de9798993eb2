"""Personal-space shapes, in the human's frame (x forward along the heading, y to the left).

These are the run-time values (SI floats) that the language's `circle(...)`, `ellipse(...)`,
`rectangle(...)` and `square(...)` compile to. `ShapeArrays` packs one shape per human into
numpy arrays so planners can evaluate every human's personal space at once.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]


class ShapeKind(IntEnum):
    CIRCLE = 0
    ELLIPSE = 1
    RECTANGLE = 2


@dataclass(frozen=True, slots=True)
class Circle:
    radius: float


@dataclass(frozen=True, slots=True)
class Ellipse:
    """Semi-axes along (major) and across (minor) the heading; the centre sits `offset` behind."""

    semi_major: float
    semi_minor: float
    offset: float = 0.0


@dataclass(frozen=True, slots=True)
class Rectangle:
    """`length` along the heading, `width` across it, centred on the human."""

    length: float
    width: float


def Square(side: float) -> Rectangle:  # noqa: N802 - reads like the language's `square(side: L)`
    return Rectangle(side, side)


Shape = Circle | Ellipse | Rectangle


def shape_to_row(shape: Shape) -> tuple[int, float, float, float]:
    """(kind, a, b, offset): a, b are the half-extents along and across the heading."""
    if isinstance(shape, Circle):
        return (ShapeKind.CIRCLE, shape.radius, shape.radius, 0.0)
    if isinstance(shape, Ellipse):
        return (ShapeKind.ELLIPSE, shape.semi_major, shape.semi_minor, shape.offset)
    return (ShapeKind.RECTANGLE, shape.length / 2.0, shape.width / 2.0, 0.0)


def lateral_extent(shape: Shape) -> float:
    """Half-width across the heading: how much room the shape asks for in a passage."""
    _, _, half_width, _ = shape_to_row(shape)
    return half_width


def describe_shape(shape: Shape) -> str:
    if isinstance(shape, Circle):
        return f"circle(radius: {shape.radius:g} m)"
    if isinstance(shape, Ellipse):
        text = f"ellipse(semi_major: {shape.semi_major:g} m, semi_minor: {shape.semi_minor:g} m"
        return text + (f", offset: {shape.offset:g} m)" if shape.offset else ")")
    if shape.length == shape.width:
        return f"square(side: {shape.length:g} m)"
    return f"rectangle(length: {shape.length:g} m, width: {shape.width:g} m)"


@dataclass(frozen=True, slots=True)
class ShapeArrays:
    """One shape per human as arrays: kind (N,), a (N,), b (N,), offset (N,)."""

    kind: npt.NDArray[np.int8]
    a: FloatArray
    b: FloatArray
    offset: FloatArray

    @staticmethod
    def stacked(parts: list[ShapeArrays]) -> ShapeArrays:
        """The rows of `parts`, one after another."""
        return ShapeArrays(np.concatenate([p.kind for p in parts]),
                           np.concatenate([p.a for p in parts]),
                           np.concatenate([p.b for p in parts]),
                           np.concatenate([p.offset for p in parts]))

    @staticmethod
    def from_shapes(shapes: list[Shape]) -> ShapeArrays:
        rows = np.array([shape_to_row(s) for s in shapes], dtype=np.float64).reshape(-1, 4)
        return ShapeArrays(rows[:, 0].astype(np.int8), rows[:, 1].copy(), rows[:, 2].copy(),
                           rows[:, 3].copy())
