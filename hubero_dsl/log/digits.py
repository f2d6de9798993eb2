"""Fixed-width decimal text for whole arrays of numbers, written by table lookups.

A log of 1000 humans writes about 15,000 numbers per frame. Formatting them one by one with
`%` costs about 0.15 us each, which is more than a tick of the simulation; here a whole column
of numbers becomes text in a few numpy operations. The digits are looked up four at a time in
a table of the 10,000 four-character groups ("0000" to "9999", and the right-aligned forms
with spaces and a minus sign for the leading group), so no Python code runs per number.

The text is right-aligned in a field of fixed width (spaces in front, as printf pads), which
JSON allows around any value: every record of a frame then keeps its length from frame to frame,
and numbers can be written into a byte template at fixed columns. A `FixedFormat` has one or two
leading groups of four characters (sign and integer digits) and 4 or 8 decimals:

    FixedFormat(head_groups=2, decimals=4)  ->  "      -12.3456"  (13 characters, |x| < 1e7)
    FixedFormat(head_groups=1, decimals=8)  ->  "  -0.70710678"  (13 characters, |x| < 1000)

Values beyond the format's range are clipped to it, and so is NaN (as the largest positive
value; the frames written to logs hold no NaN). Rounding is to the nearest multiple of the
last decimal place.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cache

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]
ByteArray = npt.NDArray[np.uint8]
GroupArray = npt.NDArray[np.uint32]

_GROUP = 10_000  # four decimal digits


def _groups(texts: list[str]) -> GroupArray:
    """Four-character ASCII strings as uint32 words (a view of their bytes, any endianness)."""
    return np.frombuffer("".join(texts).encode("ascii"), dtype=np.uint32).copy()


@cache
def _tables() -> tuple[GroupArray, GroupArray, GroupArray, GroupArray]:
    """(zero-padded, leading group, leading group after an empty one, blank and minus)."""
    padded = _groups([f"{n:04d}" for n in range(_GROUP)])
    # a leading group of up to three digits with its sign: index n, or n + 1000 when negative
    leading = _groups([f"{n:>4d}" for n in range(1000)] + [f"{'-' + str(n):>4}"
                                                             for n in range(1000)])
    # the second group when the first is empty: up to three digits carry their own sign; four
    # digits leave the sign to the first group (index n, or n + 10,000 when negative)
    second = _groups([f"{n:>4d}" for n in range(_GROUP)]
                     + [f"{'-' + str(n):>4}" if n < 1000 else f"{n:04d}" for n in range(_GROUP)])
    blank_minus = _groups(["    ", "   -"])
    return padded, leading, second, blank_minus


@dataclass(frozen=True)
class FixedFormat:
    """Right-aligned numbers with `4 * head_groups` characters before the point."""

    head_groups: int  # 1: |x| < 1000; 2: |x| < 10,000,000
    decimals: int     # 4 or 8

    def __post_init__(self) -> None:
        if self.head_groups not in (1, 2) or self.decimals not in (4, 8):
            raise ValueError(f"unsupported fixed format {self}")

    @property
    def width(self) -> int:
        return 4 * self.head_groups + 1 + self.decimals

    @property
    def limit(self) -> float:
        """The largest magnitude written as it is (larger ones are clipped to it)."""
        whole = 999 if self.head_groups == 1 else 9_999_999
        return whole + 1.0 - 10.0 ** -self.decimals

    def text(self, values: FloatArray) -> ByteArray:
        """The text of each value, one row of `width` ASCII bytes per value."""
        values = np.asarray(values, dtype=np.float64).ravel()
        scaled = np.rint(np.fmin(np.abs(values), self.limit) * 10.0 ** self.decimals)
        whole, fraction = np.divmod(scaled.astype(np.int64), 10 ** self.decimals)
        negative = (values < 0) & (scaled > 0)
        head = self._head(whole, negative)
        chars = np.empty((len(values), self.width), dtype=np.uint8)
        point = 4 * self.head_groups
        chars[:, :point] = head.view(np.uint8).reshape(len(values), point)
        chars[:, point] = ord(".")
        chars[:, point + 1:] = self._fraction(fraction).view(np.uint8).reshape(
            len(values), self.decimals)
        return chars

    def _head(self, whole: npt.NDArray[np.int64], negative: npt.NDArray[np.bool_]
              ) -> GroupArray:
        padded, leading, second, blank_minus = _tables()
        sign = negative.astype(np.int64)
        if self.head_groups == 1:
            return leading[whole + 1000 * sign]
        high, low = np.divmod(whole, _GROUP)
        empty = high == 0
        first = np.where(empty, blank_minus[sign & (low >= 1000)], leading[high + 1000 * sign])
        rest = np.where(empty, second[low + _GROUP * sign], padded[low])
        return np.column_stack([first, rest])

    def _fraction(self, fraction: npt.NDArray[np.int64]) -> GroupArray:
        padded = _tables()[0]
        if self.decimals == 4:
            return padded[fraction]
        high, low = np.divmod(fraction, _GROUP)
        return np.column_stack([padded[high], padded[low]])


METRES = FixedFormat(head_groups=2, decimals=4)     # positions, speeds: 0.1 mm, up to 10,000 km
UNIT = FixedFormat(head_groups=1, decimals=8)       # quaternion components
RADIANS = FixedFormat(head_groups=1, decimals=4)    # headings
