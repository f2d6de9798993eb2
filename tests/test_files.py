"""`write_replacing`: an output appears under its name only whole, and a failure leaves no file
behind, neither under the name nor beside it."""

from __future__ import annotations

from pathlib import Path

import pytest

from hubero_dsl.errors import InputError
from hubero_dsl.files import write_replacing


def test_the_output_replaces_the_old_file_whole(tmp_path: Path) -> None:
    out = tmp_path / "table.md"
    out.write_text("old")
    suffixes: list[str] = []

    def write(temp: Path) -> None:
        suffixes.append(temp.suffix)
        assert out.read_text() == "old"  # the name still holds the old file while writing
        temp.write_text("new")

    assert write_replacing(out, write) == out
    assert out.read_text() == "new" and suffixes == [".md"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["table.md"]


def test_a_failed_write_leaves_nothing(tmp_path: Path) -> None:
    out = tmp_path / "plot.png"

    def write(temp: Path) -> None:
        temp.write_bytes(b"half")
        raise OSError(28, "No space left on device")

    with pytest.raises(InputError, match=r"plot\.png: cannot be written"):
        write_replacing(out, write)
    assert list(tmp_path.iterdir()) == []
