"""Command-line options that name an output file: checked for the kind of file written there
before any work is done (a picture is a PNG, a replay a GIF, a map a YAML file)."""

from __future__ import annotations

import argparse
import os
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from hubero_dsl.log.reader import LoggedRun


def output_file(*suffixes: str) -> Callable[[str], Path]:
    """An argparse type: a path whose name ends in one of `suffixes` (any case)."""
    def parse(text: str) -> Path:
        path = Path(text)
        if path.name in ("", ".", "..") or path.suffix.lower() not in suffixes:
            raise argparse.ArgumentTypeError(
                f"'{text}': hubero writes a {suffixes[0][1:].upper()} file here; give a name "
                f"ending in {' or '.join(suffixes)}")
        return path
    return parse


def named_file(text: str) -> Path:
    """An argparse type: a path that names a file (`-o ""` named the current folder)."""
    path = Path(text)
    if path.name in ("", ".", "..") or text.endswith(("/", os.sep)):  # `out/` is a folder
        raise argparse.ArgumentTypeError(f"'{text}' names no file: give a file name")
    return path


PNG = output_file(".png")
GIF = output_file(".gif")
YAML = output_file(".yaml", ".yml")


def refuse_run_inputs(path: Path, *runs: LoggedRun) -> None:
    """Refuse (InputError) to write over a file that holds the same bytes as one a run was
    made from (its scenario, its map's YAML or image): a log names them but not where they
    lie, so a picture named like the map's image (`room.png` beside `room.mcap`) is caught
    by what it holds."""
    import hashlib

    from hubero_dsl.errors import InputError

    digests = frozenset().union(*(run.metadata.input_sha256 for run in runs))
    try:
        held = hashlib.sha256(path.read_bytes()).hexdigest() if path.is_file() else None
    except OSError:
        return  # unreadable: writing it fails with its own message
    if held in digests:
        raise InputError(f"{path}: cannot be written (it holds the scenario or map a run "
                         "it draws was made from)")


def check_picture(path: Path, reads: tuple[Path, ...] = ()) -> None:
    """Fail before any work when a picture cannot be written at `path` (see
    `hubero_dsl.files.check_output`), or when a file there is not a picture of its kind: a
    PNG or GIF is written over one, never over a user's other file."""
    from hubero_dsl.files import GIF_MAGIC, PNG_MAGIC, check_output, refuse_other_kind

    check_output(path, reads)
    gif = path.suffix.lower() == ".gif"
    refuse_other_kind(path, GIF_MAGIC if gif else PNG_MAGIC, "a GIF" if gif else "a PNG",
                      "give another name")
