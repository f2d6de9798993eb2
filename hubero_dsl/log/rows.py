"""Byte templates of equal-length rows whose numbers sit at fixed columns.

A frame of a log repeats one record per human (its pose, its state, its transform) with the
same layout and new numbers. A `RowTemplate` keeps those records as the rows of one uint8 array:
each row is literal text cut by slots, and filling a frame writes each slot as one column block
(`digits.FixedFormat` text, or the same bytes in every row, like the frame's time) without
touching the text around it.

Rows are made the same length by padding each literal piece with spaces at its end, up to the
longest piece of that position in any row. Every piece ends just before a slot (a JSON value) or
at the end of the record, where JSON allows whitespace, so the padding keeps the text valid. A
piece may change later (a human's task starts): it is written in place when it fits its padded
width, and the layout grows (never shrinks) when it does not, so widths only depend on what was
written before, and the same run gives the same bytes.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from hubero_dsl.log.digits import FixedFormat

ByteArray = npt.NDArray[np.uint8]
FloatArray = npt.NDArray[np.float64]


@dataclass(frozen=True)
class Stamp:
    """A slot that holds the same `width` bytes in every row of a fill (a frame's time)."""

    width: int


Slot = FixedFormat | Stamp
SlotValue = FloatArray | ByteArray | bytes  # numbers, their text (rows, width), a Stamp's bytes
Pieces = Sequence[bytes]  # the literal text of a row: one piece before each slot, one after


class RowTemplate:
    """Rows of equal length: literal pieces (padded) with `slots` between them."""

    def __init__(self, slots: Sequence[Slot], rows: Sequence[Pieces]) -> None:
        self.slots = tuple(slots)
        self._pieces = [self._checked(pieces) for pieces in rows]
        self._widths = [0] * (len(self.slots) + 1)
        self.columns: list[int] = []
        self.buffer: ByteArray = np.empty((0, 0), dtype=np.uint8)
        self._layout()

    @property
    def row_length(self) -> int:
        return int(self.buffer.shape[1])

    def set_rows(self, rows: dict[int, Pieces]) -> None:
        """Replace the literal text of some rows; their slots are blank until the next fill."""
        for row, pieces in rows.items():
            self._pieces[row] = self._checked(pieces)
        grown = any(len(piece) > width for pieces in rows.values()
                    for piece, width in zip(pieces, self._widths, strict=True))
        if grown:
            self._layout()
            return
        for row in rows:
            self.buffer[row] = np.frombuffer(self._row_text(row), dtype=np.uint8)

    def fill(self, values: Sequence[SlotValue]) -> ByteArray:
        """Write every slot: numbers as their format's text (one per row, or pre-formatted
        `(rows, width)` bytes), a Stamp's bytes in every row. Returns the rows."""
        for slot, column, value in zip(self.slots, self.columns, values, strict=True):
            block = self.buffer[:, column:column + slot.width]
            if isinstance(value, bytes):
                block[:] = np.frombuffer(value, dtype=np.uint8)
            elif value.dtype == np.uint8:
                block[:] = value
            else:
                assert isinstance(slot, FixedFormat)
                block[:] = slot.text(np.asarray(value, dtype=np.float64))
        return self.buffer

    # ---- layout -----------------------------------------------------------------------------

    def _checked(self, pieces: Pieces) -> list[bytes]:
        if len(pieces) != len(self.slots) + 1:
            raise ValueError(f"a row needs {len(self.slots) + 1} pieces, got {len(pieces)}")
        return list(pieces)

    def _layout(self) -> None:
        """Widen the pieces to fit every row and write all rows (slots blank), column by
        column: a few joins per piece position, not one per row."""
        by_position = list(zip(*self._pieces, strict=True)) if self._pieces else [
            () for _ in self._widths]
        self._widths = [max(width, *map(len, pieces)) if pieces else width
                        for width, pieces in zip(self._widths, by_position, strict=True)]
        rows, blocks = len(self._pieces), []
        self.columns, column = [], 0
        for index, (width, pieces) in enumerate(zip(self._widths, by_position, strict=True)):
            text = b"".join([piece.ljust(width) for piece in pieces])
            blocks.append(np.frombuffer(text, dtype=np.uint8).reshape(rows, width))
            column += width
            if index < len(self.slots):
                blocks.append(np.full((rows, self.slots[index].width), ord(" "), np.uint8))
                self.columns.append(column)
                column += self.slots[index].width
        self.buffer = np.ascontiguousarray(np.hstack(blocks))

    def _row_text(self, row: int) -> bytes:
        """The row's literal pieces, each padded to its width, with blank slots between."""
        pieces = self._pieces[row]
        return b"".join([piece.ljust(width) + b" " * slot.width for piece, width, slot
                         in zip(pieces, self._widths, self.slots, strict=False)]
                        + [pieces[-1].ljust(self._widths[-1])])
