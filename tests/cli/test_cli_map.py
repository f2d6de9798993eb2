"""`hubero map draw` and `hubero map show`, and the worked example of docs/maps.md run as written
in a folder outside the repository."""

from __future__ import annotations

import re
import shlex
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from PIL import Image

from hubero_dsl.world.mapfile import load_map

ROOT = Path(__file__).resolve().parents[2]
DOCS = ROOT / "docs" / "maps.md"
UNKNOWN_GREY = (158, 158, 158)  # mapview's 0.62 grey


def _worked_example() -> tuple[dict[str, str], list[str]]:
    """The files (named by their first comment line) and the commands of 'Your own map'."""
    section = DOCS.read_text(encoding="utf-8").split("## Your own map")[1].split("\n## ")[0]
    files, commands = {}, []
    for language, body in re.findall(r"```(\w+)\n(.*?)```", section, flags=re.S):
        if language == "bash":
            commands += [line for line in body.splitlines() if line.startswith("hubero ")]
        else:
            name = body.splitlines()[0].removeprefix("# ").strip()
            files[name] = body
    return files, commands


def test_the_worked_example_of_the_docs_runs(tmp_path: Path, cli: Any,
                                             monkeypatch: pytest.MonkeyPatch) -> None:
    files, commands = _worked_example()
    assert set(files) == {"office.shapes.yaml", "office.hub"} and len(commands) == 4
    for name, text in files.items():
        (tmp_path / name).write_text(text, encoding="utf-8")
    monkeypatch.chdir(tmp_path)
    for command in commands:
        outcome = cli(*shlex.split(command)[1:])
        assert outcome.status == 0, (command, outcome.err)
    grid = load_map(tmp_path / "office.yaml")
    assert grid.shape == (120, 160) and grid.unknown is not None
    desk = grid.world_to_cell((4.0, 2.9))
    assert grid.occupied[desk[0], desk[1]] and not grid.unknown[desk[0], desk[1]]
    assert (tmp_path / "office.mcap").stat().st_size > 0
    picture = np.asarray(Image.open(tmp_path / "office.png").convert("RGB")).reshape(-1, 3)
    colours = {tuple(c) for c in np.unique(picture, axis=0).tolist()}
    assert {(255, 255, 255), (0, 0, 0), UNKNOWN_GREY} <= colours
    assert (148, 103, 189) in colours  # the places, in tab:purple


def test_show_draws_any_map_next_to_it(tmp_path: Path, cli: Any) -> None:
    nav2 = Path(__file__).resolve().parents[1] / "world" / "nav2_maps"
    for name in ("tb3_sandbox.yaml", "tb3_sandbox.pgm"):
        (tmp_path / name).write_bytes((nav2 / name).read_bytes())
    outcome = cli("map", "show", str(tmp_path / "tb3_sandbox.yaml"))
    assert outcome.status == 0, outcome.err
    with Image.open(tmp_path / "tb3_sandbox.png") as picture:
        assert picture.format == "PNG" and picture.width > 300


@pytest.mark.parametrize(("text", "message", "line"), [
    ("resolution: 0.05\norigin: [0, 0]\nsize: [1, 1\n", "not valid YAML", 4),
    ("resolution: 0.05\norigin: [0, 0]\nsize: [1.03, 1.0]\n", "whole number", 3),
    ("resolution: 0.05\norigin: [0, 0]\nsize: [1, 1]\nobstacles:\n"
     "  - {name: x, circle: [0, 0], radius: -1}\n", "radius", 5),
    ("resolution: 0.05\norigin: [0, 0]\nsize: [1, 1]\nobstacles:\n"
     "  - {name: x, hexagon: [0, 0]}\n", "unknown key `hexagon`", 5),
    ("resolution: 0.05\norigin: [0, 0]\nsize: [1, 1]\nobstacles:\n"
     "  - {name: x}\n", "exactly one of", 5),
    # a misspelt key drew a map with no obstacles at all
    ("resolution: 0.05\norigin: [0, 0]\nsize: [1, 1]\nobstacels:\n"
     "  - {name: x, rect: [[0, 0], [1, 1]]}\n", "unknown key `obstacels` (did you mean "
     "`obstacles`?)", 4),
    ("resolution: 0.001\norigin: [0, 0]\nsize: [100, 100]\n", "the most a map may have", 3),
    ("resolution: 0.05\norigin: &o [0, 0]\nsize: *o\n", "anchors and aliases", 2),
    # twenty obstacles as large as a fine-celled map: hours of drawing, refused at once
    ("resolution: 0.002\norigin: [0, 0]\nsize: [8, 8]\nobstacles:\n"
     + "".join(f"  - {{name: c{i}, circle: [4, 4], radius: 3.9}}\n" for i in range(20)),
     "more than 200,000,000: use fewer or smaller obstacles, or larger cells", 5),
])
def test_bad_descriptions_are_errors_at_their_line(tmp_path: Path, cli: Any, text: str,
                                                   message: str, line: int) -> None:
    shapes = tmp_path / "bad.shapes.yaml"
    shapes.write_text(text, encoding="utf-8")
    outcome = cli("map", "draw", str(shapes), "-o", str(tmp_path / "bad.yaml"))
    assert outcome.status == 2
    assert message in outcome.err and f"bad.shapes.yaml:{line}:" in outcome.err, outcome.err
    assert "Traceback" not in outcome.err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.shapes.yaml"]


def test_draw_writes_over_a_map_but_never_over_other_files(tmp_path: Path, cli: Any) -> None:
    shapes = tmp_path / "room.shapes.yaml"
    shapes.write_text("resolution: 0.1\norigin: [0, 0]\nsize: [2, 2]\n", encoding="utf-8")
    drawn = tmp_path / "room.yaml"
    assert cli("map", "draw", str(shapes), "-o", str(drawn)).status == 0
    assert cli("map", "draw", str(shapes), "-o", str(drawn)).status == 0  # drawn again
    notes = tmp_path / "notes.yaml"
    notes.write_text("todo: buy milk\n", encoding="utf-8")
    refused = cli("map", "draw", str(shapes), "-o", str(notes))
    assert refused.status == 2 and "exists and is not a map file" in refused.err
    assert notes.read_text() == "todo: buy milk\n" and not (tmp_path / "notes.pgm").exists()
    picture = tmp_path / "photo.pgm"
    picture.write_bytes(b"P2\n1 1\n255\n0\n")  # another PGM: text, not what a map draws
    refused = cli("map", "draw", str(shapes), "-o", str(tmp_path / "photo.yaml"))
    assert refused.status == 2 and "photo.pgm exists and is not a map's image" in refused.err
    assert not (tmp_path / "photo.yaml").exists()


def test_draw_refuses_to_write_over_its_input_or_into_nowhere(tmp_path: Path, cli: Any) -> None:
    shapes = tmp_path / "room.yaml"
    shapes.write_text("resolution: 0.1\norigin: [0, 0]\nsize: [2, 2]\n", encoding="utf-8")
    over = cli("map", "draw", str(shapes), "-o", str(shapes))
    assert over.status == 2 and shapes.read_text().startswith("resolution")
    nowhere = cli("map", "draw", str(shapes), "-o", str(tmp_path / "no" / "room_map.yaml"))
    assert nowhere.status == 2
    missing = cli("map", "show", str(tmp_path / "missing.yaml"))
    assert missing.status == 2 and "Traceback" not in missing.err


def test_a_scenarios_legend_lists_what_the_picture_shows() -> None:
    # a party without robots or flows had "robot start" and "flow target" in its legend
    from matplotlib.figure import Figure

    from hubero_dsl.analysis import mapview
    from hubero_dsl.pipeline import compile_file

    root = Path(__file__).resolve().parents[2]
    labels = [h.get_label() for h in mapview._scenario(
        Figure().add_subplot(), compile_file(root / "scenarios" / "house_party.hub"))]
    assert "robot start" in labels and "flow target (area dashed)" not in labels
    labels = [h.get_label() for h in mapview._scenario(
        Figure().add_subplot(), compile_file(root / "scenarios" / "living_room.hub"))]
    assert "robot start" not in labels and "place" in labels


def test_a_crowds_starts_are_named_once_with_its_size() -> None:
    # eight unnamed dots: the reader had to guess whose starts they were
    from matplotlib.figure import Figure

    from hubero_dsl.analysis import mapview
    from hubero_dsl.pipeline import compile_file

    root = Path(__file__).resolve().parents[2]
    axes = Figure().add_subplot()
    mapview._scenario(axes, compile_file(root / "scenarios" / "lounge_crowd.hub"))
    texts = [t.get_text() for t in axes.texts]
    assert texts.count("visitors (8)") == 1 and not any("visitors_" in t for t in texts)
    assert {"mum", "dad", "kid", "cart", "lounge"} <= set(texts)


def test_a_scenario_written_for_another_map_is_drawn_with_a_warning(tmp_path: Path,
                                                                    cli: Any) -> None:
    # the living room's people were drawn on the car park without a word
    out = tmp_path / "x.png"
    shown = cli("map", "show", str(ROOT / "maps" / "parking.yaml"), "-o", str(out),
                "--scenario", str(ROOT / "scenarios" / "living_room.hub"))
    assert shown.status == 0 and out.is_file()
    assert "is written for the map" in shown.err and "not " in shown.err
    own = cli("map", "show", str(ROOT / "maps" / "living_room.yaml"), "-o", str(out),
              "--scenario", str(ROOT / "scenarios" / "living_room.hub"))
    assert own.status == 0 and "warning" not in own.err
