"""`hubero plot`: a PNG of a run, a GIF replay, and exit 2 for bad logs and unwritable outputs."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from PIL import Image, ImageSequence

from hubero_dsl.cli.run import run_one
from hubero_dsl.pipeline import compile_file
from tests.cli.conftest import REPO_ROOT, Outcome

MAP = REPO_ROOT / "maps" / "living_room.yaml"

WALK = f"""\
scenario "walk"
map "{MAP}"
time_limit 10 s
human a at (1, 1) heading 0 deg {{ personal_space ellipse(semi_major: 1.1 m, semi_minor: 0.8 m) }}
human b at (2, -1) heading 90 deg {{ personal_space square(side: 0.5 m) }}
activity {{
    parallel {{
        a move_to (4, 1)
        b move_to (2, 0.5)
    }}
}}
"""

Cli = Callable[..., Outcome]


@pytest.fixture(scope="module")
def log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("plot")
    (folder / "walk.hub").write_text(WALK, encoding="utf-8")
    out = folder / "walk.mcap"
    run_one(compile_file(folder / "walk.hub"), None, None, out, 10.0, quiet=True)
    return out


def test_png(cli: Cli, log: Path, tmp_path: Path) -> None:
    out = tmp_path / "walk.png"
    outcome = cli("plot", str(log), "-o", str(out))
    assert outcome.status == 0, outcome.err
    assert outcome.out == "" and outcome.err == ""
    with Image.open(out) as image:
        assert image.format == "PNG"
        assert image.width > 600 and image.height > 300
        pixels = np.asarray(image.convert("RGB"))
    assert (pixels < 245).any(axis=2).mean() > 0.1


def test_gif_and_png_together(cli: Cli, log: Path, tmp_path: Path) -> None:
    png, gif = tmp_path / "walk.png", tmp_path / "walk.gif"
    outcome = cli("plot", str(log), "-o", str(png), "--animate", str(gif), "--frames", "4",
                  "--fps", "4", "--spacing", "0.5", "--whole-map")
    assert outcome.status == 0, outcome.err
    assert png.stat().st_size > 0
    with Image.open(gif) as image:
        assert image.format == "GIF"
        assert sum(1 for _ in ImageSequence.Iterator(image)) == 4


def test_without_an_output_the_picture_goes_beside_the_log(cli: Cli, log: Path,
                                                           tmp_path: Path) -> None:
    copy = tmp_path / "copy.mcap"
    copy.write_bytes(log.read_bytes())
    outcome = cli("plot", str(copy))
    assert outcome.status == 0, outcome.err
    picture = tmp_path / "copy.png"
    assert f"picture written to {picture}" in outcome.out
    with Image.open(picture) as image:
        assert image.format == "PNG"
    assert cli("plot", str(copy)).status == 0  # its own picture is drawn again
    picture.write_text("my notes")  # a file that is not a picture is never written over
    refused = cli("plot", str(copy))
    assert refused.status == 2 and "is not a PNG" in refused.err
    assert picture.read_text() == "my notes"


@pytest.mark.parametrize(("command", "name", "kind"), [
    (("plot", "{log}", "-o"), "notes.png", "a PNG"),
    (("plot", "{log}", "--animate"), "notes.gif", "a GIF"),
    (("diff", "{log}", "{log}", "--plot"), "notes.png", "a PNG"),
    (("map", "show", "{map}", "-o"), "notes.png", "a PNG"),
])
def test_no_picture_is_written_over_a_users_other_file(cli: Cli, log: Path, tmp_path: Path,
                                                       command: tuple[str, ...], name: str,
                                                       kind: str) -> None:
    notes = tmp_path / name
    notes.write_text("my notes", encoding="utf-8")
    argv = [part.format(log=log, map=REPO_ROOT / "maps" / "living_room.yaml") for part in command]
    refused = cli(*argv, str(notes))
    assert refused.status == 2 and f"is not {kind}" in refused.err, refused.err
    assert notes.read_text(encoding="utf-8") == "my notes"


@pytest.mark.parametrize(("argv", "message"), [
    (("-o", "{tmp}/missing/x.png"), "cannot be written"),
    (("-o", "{tmp}"), "give a name ending in .png"),
    (("-o", "{tmp}/folder.png"), "cannot be written (it is a directory)"),
    (("--animate", "{tmp}/missing/x.gif"), "cannot be written"),
    (("-o", "{tmp}/x.png", "--spacing", "0"), "--spacing must be a positive"),
    (("--animate", "{tmp}/x.gif", "--frames", "0"), "--frames and --fps"),
    (("-o", "{tmp}/x.png", "--fps", "4"), "shape the GIF of --animate OUT.gif: give it too"),
    (("-o", "{tmp}/x.txt"), "give a name ending in .png"),
    (("--animate", "{tmp}/x.pgm"), "give a name ending in .gif"),
])
def test_usage_errors(cli: Cli, log: Path, tmp_path: Path, argv: tuple[str, ...],
                      message: str) -> None:
    (tmp_path / "folder.png").mkdir(exist_ok=True)
    outcome = cli("plot", str(log), *(a.format(tmp=tmp_path) for a in argv))
    assert outcome.status == 2
    assert message in outcome.err
    assert not (tmp_path / "x.png").exists()


@pytest.mark.parametrize(("content", "message"), [
    (b"", "the file is empty"),
    (b"plain text", "not a readable hubero run log"),
])
def test_bad_log(cli: Cli, tmp_path: Path, content: bytes, message: str) -> None:
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(content)
    outcome = cli("plot", str(bad), "-o", str(tmp_path / "x.png"))
    assert outcome.status == 2
    assert message in outcome.err
    assert not (tmp_path / "x.png").exists()


def test_truncated_log(cli: Cli, log: Path, tmp_path: Path) -> None:
    bad = tmp_path / "half.mcap"
    bad.write_bytes(log.read_bytes()[: log.stat().st_size // 2])
    outcome = cli("plot", str(bad), "-o", str(tmp_path / "x.png"))
    assert outcome.status == 2
    assert "half.mcap" in outcome.err
