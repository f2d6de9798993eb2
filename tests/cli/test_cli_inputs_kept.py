"""No command writes its output over one of its inputs: a scenario, its map file, the map's
image, or a log it reads."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
from PIL import Image

from tests.cli.conftest import Outcome


def _png_map(folder: Path) -> Path:
    """A 4 m x 4 m room whose image is a PNG named like the map (`room.png` beside
    `room.yaml`): the name `map show` would give its picture."""
    pixels = np.full((80, 80), 254, dtype=np.uint8)
    pixels[[0, -1], :] = 0
    pixels[:, [0, -1]] = 0
    Image.fromarray(pixels).save(folder / "room.png")
    (folder / "room.yaml").write_text(
        "image: room.png\nresolution: 0.05\norigin: [0.0, 0.0, 0.0]\nnegate: 0\n"
        "occupied_thresh: 0.65\nfree_thresh: 0.196\n", encoding="utf-8")
    (folder / "room.hub").write_text(
        'scenario "room"\nmap "room.yaml"\nhuman a at (1, 1)\n'
        "activity { a move_to (3, 1) }\n", encoding="utf-8")
    return folder / "room.hub"


def _unchanged(folder: Path) -> Callable[[], bool]:
    before = {p.name: p.read_bytes() for p in folder.iterdir() if p.is_file()}
    return lambda: all((folder / name).read_bytes() == data for name, data in before.items())


def test_map_show_never_draws_over_the_maps_own_image(cli: Callable[..., Outcome],
                                                    tmp_path: Path) -> None:
    _png_map(tmp_path)
    kept = _unchanged(tmp_path)
    for argv in (("map", "show", str(tmp_path / "room.yaml")),
                 ("map", "show", str(tmp_path / "room.yaml"), "-o", str(tmp_path / "room.png"))):
        outcome = cli(*argv)
        assert outcome.status == 2 and "it is an input of this command" in outcome.err
    assert kept()


def test_run_and_graph_never_write_over_the_maps_image(cli: Callable[..., Outcome],
                                                      tmp_path: Path) -> None:
    scenario = _png_map(tmp_path)
    kept = _unchanged(tmp_path)
    image = str(tmp_path / "room.png")
    assert cli("run", str(scenario), "-o", image, "-q").status == 2
    graph = cli("graph", str(scenario), "-o", image)
    assert graph.status == 2 and "it is an input of this command" in graph.err
    assert kept()


def test_diff_never_draws_over_a_log_it_compares(cli: Callable[..., Outcome],
                                                 tmp_path: Path) -> None:
    scenario = _png_map(tmp_path)
    log = tmp_path / "run.mcap"
    assert cli("run", str(scenario), "-o", str(log), "-q").status == 0
    picture = tmp_path / "run.png"  # a log named like a picture: still an input
    log.rename(picture)
    kept = _unchanged(tmp_path)
    outcome = cli("diff", str(picture), str(picture), "--plot", str(picture))
    assert outcome.status == 2 and "it is an input of this command" in outcome.err
    assert kept()


def test_bench_never_writes_over_a_scenarios_map_image(cli: Callable[..., Outcome],
                                                       tmp_path: Path) -> None:
    # the suite's scenario `room.hub` draws on `../out/room.yaml`, whose image `room.png` is
    # the name of the picture `bench -o out` would draw of it
    out = tmp_path / "out"
    out.mkdir()
    _png_map(out)
    (out / "room.hub").unlink()
    suite = tmp_path / "suite"
    suite.mkdir()
    (suite / "room.hub").write_text(
        'scenario "room"\nmap "../out/room.yaml"\n'
        "robot r at (1, 1) { controller navigator; goal (3, 1) }\n"
        "activity { r move_to (3, 1) }\n", encoding="utf-8")
    kept = _unchanged(out)
    outcome = cli("bench", str(suite), "-o", str(out), "--seeds", "1")
    assert outcome.status == 2 and "room.png: cannot be written" in outcome.err
    assert kept()


def test_plot_and_diff_never_draw_over_the_map_image_the_run_was_made_from(
        cli: Callable[..., Outcome], tmp_path: Path) -> None:
    # the log `room.mcap` beside `room.png`: `plot` alone would name its picture room.png
    scenario = _png_map(tmp_path)
    log = tmp_path / "room.mcap"
    assert cli("run", str(scenario), "-o", str(log), "-q").status == 0
    kept = _unchanged(tmp_path)
    image = str(tmp_path / "room.png")
    for argv in (("plot", str(log)), ("plot", str(log), "-o", image),
                 ("diff", str(log), str(log), "--plot", image)):
        outcome = cli(*argv)
        assert outcome.status == 2 and "room.png: cannot be written" in outcome.err, argv
        assert "holds the scenario or map" in outcome.err or "input of" in outcome.err
    assert kept()
    assert cli("plot", str(log), "-o", str(tmp_path / "picture.png")).status == 0
