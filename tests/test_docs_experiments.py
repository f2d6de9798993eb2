"""The pages of docs/ that quote runs of the shipped scenarios must quote them as they run now,
so that a change to the simulator cannot leave the pages' numbers behind: docs/experiments.md is
what scripts/experiments.py writes, and analysis.md's metrics example is the ellipse run's."""

from __future__ import annotations

from pathlib import Path

from tests.scripts import load_script

ROOT = Path(__file__).resolve().parents[1]


def test_the_experiments_page_is_what_its_script_writes(tmp_path: Path) -> None:
    module = load_script(ROOT / "scripts" / "experiments.py")
    assert module.main(["--out", str(tmp_path)]) == 0
    written = (tmp_path / "experiments.md").read_text(encoding="utf-8")
    committed = (ROOT / "docs" / "experiments.md").read_text(encoding="utf-8")
    assert written == committed, "regenerate it: .venv/bin/python scripts/experiments.py"
    pictures = sorted(path.name for path in (tmp_path / "images").glob("*.png"))
    assert pictures == sorted(f"{name}.png" for name in (
        "living_room_circle", "living_room_ellipse", "living_room_diff", "parking_square",
        "parking_circle", "parking_diff_actor1"))
    for name in pictures:
        assert (ROOT / "docs" / "images" / name).is_file()


def test_the_metrics_example_of_analysis_md_is_the_ellipse_runs(tmp_path: Path) -> None:
    import json

    from hubero_dsl.analysis.metrics import compute_metrics
    from hubero_dsl.log.reader import load_run
    from hubero_dsl.pipeline import compile_file
    from hubero_dsl.simulate import simulate

    page = (ROOT / "docs" / "analysis.md").read_text(encoding="utf-8")
    example = page.split("An example, actor2 in the living room's `ellipse` run:\n\n```json\n")[1]
    shown = json.loads(example.split("```")[0])
    log = tmp_path / "ellipse.mcap"
    simulate(compile_file(ROOT / "scenarios" / "living_room.hub"), variant="ellipse", log=log,
             writer_process=False)
    metrics = compute_metrics(load_run(log))
    assert metrics.to_dict()["humans"]["actor2"] == shown
    # and the Python example's comments above it
    closest = metrics.humans["actor2"].min_distance["actor1"]
    assert f'min_distance["actor1"]   # {closest:.6f}...' in page
    assert f'"actor1.duration": {metrics.flat()["actor1.duration"]:g}, ...' in page
