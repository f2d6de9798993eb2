"""Units and dimensions of the language. Every quantity is stored in SI: m, s, m/s, m/s^2,
rad, rad/s, /s."""

from __future__ import annotations

import math
import numbers
from decimal import Decimal
from enum import StrEnum


class Dimension(StrEnum):
    LENGTH = "length"
    TIME = "time"
    SPEED = "speed"
    ACCELERATION = "acceleration"
    ANGLE = "angle"
    ANGULAR_SPEED = "angular speed"
    RATIO = "ratio"      # a share: `10 %` is 0.1
    RATE = "rate"        # events per second: `30 /min` is 0.5
    NUMBER = "number"


# The largest magnitude a value of these dimensions may have in a scenario: beyond it a number
# describes nothing physical, and would overflow tick counts and floating-point arithmetic.
LARGEST: dict[Dimension, float] = {Dimension.TIME: 1e6, Dimension.LENGTH: 1e5,
                                   Dimension.SPEED: 100.0, Dimension.RATE: 1000.0,
                                   Dimension.ANGLE: 1e4}  # rad: some 1,600 turns

# unit -> (dimension, factor to SI)
UNITS: dict[str, tuple[Dimension, float]] = {
    "m": (Dimension.LENGTH, 1.0),
    "cm": (Dimension.LENGTH, 0.01),
    "mm": (Dimension.LENGTH, 0.001),
    "s": (Dimension.TIME, 1.0),
    "ms": (Dimension.TIME, 0.001),
    "min": (Dimension.TIME, 60.0),
    "h": (Dimension.TIME, 3600.0),
    "m/s": (Dimension.SPEED, 1.0),
    "km/h": (Dimension.SPEED, 1000.0 / 3600.0),
    "m/s^2": (Dimension.ACCELERATION, 1.0),
    "deg": (Dimension.ANGLE, math.pi / 180.0),
    "rad": (Dimension.ANGLE, 1.0),
    "rad/s": (Dimension.ANGULAR_SPEED, 1.0),
    "deg/s": (Dimension.ANGULAR_SPEED, math.pi / 180.0),
    "%": (Dimension.RATIO, 0.01),
    "/s": (Dimension.RATE, 1.0),
    "/min": (Dimension.RATE, 1.0 / 60.0),
    "/h": (Dimension.RATE, 1.0 / 3600.0),
}

# Dimensions whose values were written as bare numbers before they had units (a robot's limits,
# the metrics of acceleration): a bare number still reads as SI, m/s^2 or rad/s.
BARE_IS_SI = frozenset({Dimension.ACCELERATION, Dimension.ANGULAR_SPEED})

# How each dimension reads in a message, with a unit to suggest.
EXAMPLE_UNIT: dict[Dimension, str] = {
    Dimension.LENGTH: "m",
    Dimension.TIME: "s",
    Dimension.SPEED: "m/s",
    Dimension.ACCELERATION: "m/s^2",
    Dimension.ANGLE: "deg",
    Dimension.ANGULAR_SPEED: "deg/s",
    Dimension.RATIO: "%",
    Dimension.RATE: "/min",
    Dimension.NUMBER: "",
}


def dimension_named(word: object) -> Dimension:
    """The dimension a planner's field or a metric names by its word (`"length"`); a plain
    number for none, or a word that is no dimension (a metric's `"count"`)."""
    return next((d for d in Dimension if d.value == word), Dimension.NUMBER)


def units_of(dimension: Dimension) -> list[str]:
    return [unit for unit, (dim, _) in UNITS.items() if dim is dimension]


def describe(dimension: Dimension) -> str:
    """'a length (m, cm, mm)' — for messages that say what was expected."""
    if dimension is Dimension.NUMBER:
        return "a plain number"
    article = "an" if dimension.value[0] in "aeiou" else "a"
    return f"{article} {dimension.value} ({', '.join(units_of(dimension))})"


def real_number(value: object) -> float | None:
    """`value` as a float when Python code gave a real number: any `numbers.Real` (an int, a
    float, a Fraction, numpy's numbers) or a Decimal. None for anything else (a bool, a
    complex, a string) and for a number no float holds (a whole number or a fraction beyond
    1.8e308, a signalling NaN); a NaN or an infinity stays one, for the caller to refuse."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real | Decimal):
        return None
    try:
        return float(value)
    except (OverflowError, ValueError):
        return None


def finite_pair(first: object, second: object) -> tuple[float, float] | None:
    """Two finite real numbers (`real_number`, neither a NaN nor an infinity) as floats: a
    velocity, a command, a point; None for anything else."""
    a, b = real_number(first), real_number(second)
    if a is None or b is None or not (math.isfinite(a) and math.isfinite(b)):
        return None
    return (a, b)
