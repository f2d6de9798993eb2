"""`hubero bench`: the suite with the reference and a controller of the user's own, the tables
read back with csv, the plots opened with Pillow, and bad input refused with exit 2."""

from __future__ import annotations

import csv
import json
import math
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from PIL import Image

from hubero_dsl.cli.main import main
from hubero_dsl.sweep.bench import COLUMNS
from tests.plugin_controller import install_straight_drive

ROOT = Path(__file__).resolve().parents[2]
RIMEA = ROOT / "scenarios" / "rimea"
SUITE = ROOT / "scenarios" / "benchmark"
HERE = "tests.sweep.bench_controllers"


@pytest.fixture
def small_suite(tmp_path: Path) -> Path:
    """Two scenarios of the suite (they name their maps relative to the repository)."""
    folder = ROOT / "scenarios" / "benchmark"
    suite = tmp_path / "scenarios" / "benchmark"
    suite.mkdir(parents=True)
    for name in ("crossing.hub", "doorway.hub"):
        shutil.copy(folder / name, suite / name)
    shutil.copytree(ROOT / "maps" / "benchmark", tmp_path / "maps" / "benchmark")
    return suite


def _rows(path: Path) -> list[dict[str, str]]:
    with open(path, newline="", encoding="utf-8") as stream:
        return list(csv.DictReader(stream))


def test_bench_with_a_controller_of_your_own(small_suite: Path, tmp_path: Path,
                                             monkeypatch: pytest.MonkeyPatch) -> None:
    """The plugin package of the plugin tests, `straight_drive` (straight at the goal, blind to
    people), beside the reference navigator: both columns, and they differ where they must."""
    site = install_straight_drive(tmp_path / "site")
    monkeypatch.syspath_prepend(str(site))  # worker processes inherit sys.path
    out = tmp_path / "out"
    code = main(["bench", str(small_suite), "-o", str(out), "--jobs", "2",
                 "--controller", "cart=straight_drive:StraightDrive"])
    assert code == 1  # the straight drive fails the doorway's expectations
    runs = {}
    for name in ("crossing", "doorway"):
        rows = _rows(out / f"{name}.csv")
        assert tuple(rows[0]) == COLUMNS
        assert [(r["variant"], r["controller"]) for r in rows] == [
            (v, side) for side in ("reference", "yours")
            for v in ("robot_reaction=regular", "robot_reaction=surprised",
                      *(("robot_reaction=impassive",) if name == "crossing" else
                        ("robot_reaction=curious", "robot_reaction=impassive")))]
        assert all(math.isfinite(float(r["min_distance"])) for r in rows)
        for row in rows:
            runs[name, row["variant"], row["controller"]] = row
        assert (out / f"{name}.md").read_text().startswith("| scenario |")
        with Image.open(out / f"{name}.png") as image:
            assert image.format == "PNG" and image.size[0] > 100
    for (name, variant, side), row in runs.items():
        if side == "reference":
            assert (row["succeeded"], row["success"], row["termination"], row["collided_with"]
                    ) == ("true", "true", "reached_goal", ""), (name, variant)
        elif name == "doorway":  # it drives into the person in the door, unless they dodge
            # a regular walker steps out of its way, a surprised one stops short of it
            dodges = variant in ("robot_reaction=regular", "robot_reaction=surprised")
            assert row["succeeded"] == "false"
            assert row["collided_with"].startswith("walker:") != dodges, (variant, dict(row))
            assert float(row["min_distance"]) < float(
                runs[name, variant, "reference"]["min_distance"])
    # an impassive person walks on through the junction: the navigator keeps away, the
    # straight drive not
    impassive = ("crossing", "robot_reaction=impassive")
    assert float(runs[(*impassive, "yours")]["min_distance"]) < 0.5 * float(
        runs[(*impassive, "reference")]["min_distance"])
    summary = _rows(out / "summary.csv")
    assert [(r["scenario"], r["controller"]) for r in summary] == [
        ("crossing", "reference"), ("crossing", "yours"),
        ("doorway", "reference"), ("doorway", "yours")]
    assert summary[2]["success"] == "4/4" and summary[3]["collided_with"].startswith("walker:")


def test_a_controller_that_raises_is_a_row_and_exit_1(small_suite: Path, tmp_path: Path,
                                                       monkeypatch: pytest.MonkeyPatch,
                                                       capsys: pytest.CaptureFixture[str]
                                                       ) -> None:
    monkeypatch.syspath_prepend(str(ROOT))
    (small_suite / "doorway.hub").unlink()
    out = tmp_path / "out"
    assert main(["bench", str(small_suite), "-o", str(out), "--jobs", "1",
                 "--controller", f"cart={HERE}:Raising"]) == 1
    rows = _rows(out / "crossing.csv")
    mine = [r for r in rows if r["controller"] == "yours"]
    assert len(mine) == 3 and all(r["status"] == "error" for r in mine)
    assert all("bug in the controller" in r["reason"] for r in mine)
    assert all((r["success"], r["termination"]) == ("false", "error") for r in mine)
    (_, yours) = _rows(out / "summary.csv")
    assert (yours["success"], yours["termination"]) == ("0/3", "error:3")
    assert "bug in the controller" in capsys.readouterr().out


@pytest.mark.parametrize(("args", "message"), [
    (["bench", "{empty}"], "no scenarios"),
    (["bench", "{suite}", "--controller", "robot9=tests.sweep.bench_controllers:Raising"],
     "no robot named 'robot9'"),
    (["bench", "{suite}", "--controller", "cart=no_such_module_x:Planner"], "cannot be imported"),
    (["bench", "{suite}", "--controller", "cart"], "ROBOT=MODULE:CLASS"),
    (["bench", "{suite}", "--seeds", "3..1"], "the range 3..1 is empty"),
    (["bench", "{rimea}"], "no robot under test"),   # it ran them, "5 runs; 5 ok"
])
def test_bad_input_is_exit_2_with_a_message(args: list[str], message: str, small_suite: Path,
                                            tmp_path: Path, capsys: pytest.CaptureFixture[str]
                                            ) -> None:
    empty = tmp_path / "empty"
    empty.mkdir()
    argv = [a.format(empty=empty, suite=small_suite, rimea=RIMEA) for a in args]
    assert main([*argv, "-o", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err


def test_seeds_run_every_variant_with_each(small_suite: Path, tmp_path: Path) -> None:
    (small_suite / "doorway.hub").unlink()
    out = tmp_path / "out"
    assert main(["bench", str(small_suite), "-o", str(out), "--jobs", "2",
                 "--seeds", "1,4"]) == 0
    rows = _rows(out / "crossing.csv")
    assert [(r["variant"], r["seed"]) for r in rows] == [
        (f"robot_reaction={v}", s) for v in ("regular", "surprised", "impassive")
        for s in ("1", "4")]
    (summary,) = _rows(out / "summary.csv")
    assert (summary["variant"], summary["seed"]) == ("6/6 ok", "")


def test_the_documented_reference_table_is_what_the_command_writes(tmp_path: Path) -> None:
    out = tmp_path / "out"
    assert main(["bench", str(SUITE), "-o", str(out), "--jobs", "2"]) == 0
    doc = (ROOT / "docs" / "benchmark.md").read_text(encoding="utf-8")
    committed = doc.split("<!-- bench-summary:start -->\n")[1].split("<!-- bench-summary:end")[0]
    assert committed == (out / "summary.md").read_text(encoding="utf-8")


def test_a_failed_run_of_a_scenario_without_variants_is_named_as_written(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    suite = tmp_path / "suite"
    suite.mkdir()
    (suite / "tiny.hub").write_text(
        f'scenario "tiny"\nmap "{ROOT / "maps" / "living_room.yaml"}"\ntime_limit 3 s\n'
        "robot cart at (-4.4, 4.8) { controller navigator; goal (3.5, 0.5) }\n"
        "human g at (1.0, 1.0)\nactivity { g stand for 3 s }\n"
        "expect cart reaches (3.5, 0.5) within 2 s\n", encoding="utf-8")
    assert main(["bench", str(suite), "-o", str(tmp_path / "out"), "--jobs", "1"]) == 1
    out = capsys.readouterr().out
    assert "tiny [(as written)] seed" in out and "[None]" not in out


@pytest.mark.parametrize("name", ["summary.md", "crossing.csv", "doorway.png"])
def test_the_tables_are_written_over_the_benchs_own_only(name: str, small_suite: Path,
                                                         tmp_path: Path,
                                                         capsys: pytest.CaptureFixture[str]
                                                         ) -> None:
    # a user's notes called summary.md, or a picture of theirs, were silently replaced
    out = tmp_path / "out"
    out.mkdir()
    (out / name).write_text("my notes\n", encoding="utf-8")
    assert main(["bench", str(small_suite), "-o", str(out), "--jobs", "1"]) == 2
    err = capsys.readouterr().err
    assert f"{out / name} exists and is not a table or picture of hubero bench" in err
    assert (out / name).read_text(encoding="utf-8") == "my notes\n"
    assert not (out / "runs").exists()


def test_the_tables_do_not_go_into_the_suites_folder_or_onto_a_file(
        small_suite: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["bench", str(small_suite), "-o", str(small_suite)]) == 2
    assert "is the suite's own folder" in capsys.readouterr().err
    assert not (small_suite / "runs").exists()
    a_file = tmp_path / "notes.txt"
    a_file.write_text("x", encoding="utf-8")
    assert main(["bench", str(small_suite), "-o", str(a_file)]) == 2
    assert f"cannot write the tables into {a_file}: {a_file} is a file, not a directory" \
        in capsys.readouterr().err


def test_a_bench_is_written_over_its_own_earlier_tables(small_suite: Path,
                                                         tmp_path: Path) -> None:
    out = tmp_path / "out"
    for _ in range(2):
        assert main(["bench", str(small_suite), "-o", str(out), "--jobs", "2"]) == 0
    assert len(_rows(out / "summary.csv")) == 2


def test_ctrl_c_stops_the_bench_and_marks_the_runs_it_did_not_finish(small_suite: Path,
                                                                    tmp_path: Path) -> None:
    # it went on to the next scenario, wrote "5 runs; 5 ok" of 9 and exited 0
    out = tmp_path / "out"
    environment = {k: v for k, v in os.environ.items() if k != "HUBERO_DEBUG"}
    process = subprocess.Popen(
        [sys.executable, "-m", "hubero_dsl", "bench", str(small_suite), "-o", str(out),
         "--jobs", "1", "--seeds", "1..4"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
        text=True, env=environment)
    deadline = time.monotonic() + 60
    # one worker: when the second log is there, the first run has been reported
    while len(list(out.glob("runs/*/*/runs/*/seed-*.mcap"))) < 2 and time.monotonic() < deadline:
        time.sleep(0.02)
    process.send_signal(signal.SIGINT)
    stdout, stderr = process.communicate(timeout=60)
    assert "Traceback" not in stderr
    assert process.returncode == 130, stderr
    assert "hubero: interrupted:" in stderr and "the tables mark the others interrupted" in stderr
    rows = _rows(out / "crossing.csv") + _rows(out / "doorway.csv")
    assert len(rows) == 4 * (3 + 4)  # every planned run has its row
    stopped = [r for r in rows if r["status"] == "interrupted"]
    assert 1 <= len(stopped) < len(rows)
    assert all((r["succeeded"], r["termination"]) == ("false", "interrupted") for r in stopped)
    summary = {r["scenario"]: r for r in _rows(out / "summary.csv")}
    assert summary["doorway"]["variant"] == "0/16 ok"
    assert summary["doorway"]["termination"] == "interrupted:16"
    assert f"{len(rows) - len(stopped)} runs;" in stdout


def test_a_stop_between_runs_leaves_rows_for_every_run(small_suite: Path, tmp_path: Path,
                                                       monkeypatch: pytest.MonkeyPatch) -> None:
    # stopped as a finished run's log was measured, the bench wrote no tables at all
    from hubero_dsl.sweep import bench
    from hubero_dsl.sweep.executors import SerialExecutor

    measured = bench._measure
    calls = []

    def stopped_at_the_second(*args: object) -> object:
        calls.append(args)
        if len(calls) == 2:
            raise KeyboardInterrupt
        return measured(*args)  # type: ignore[arg-type]

    monkeypatch.setattr(bench, "_measure", stopped_at_the_second)
    scenarios = bench.find_suite(small_suite)
    outcome = bench.run_bench(scenarios, tmp_path / "out", SerialExecutor(), controllers={},
                              seeds=(1,))
    assert not outcome.complete and not outcome.terminated
    assert [r.status for r in outcome.rows] == ["completed"] + ["interrupted"] * 6
    assert [r.scenario for r in outcome.rows] == ["crossing"] * 3 + ["doorway"] * 4


def test_each_sides_runs_are_a_sweep_that_the_next_bench_clears(small_suite: Path,
                                                                 tmp_path: Path) -> None:
    # a bench of seeds 1 and 2, then of seed 1: seed 2's logs stayed, named by no table
    out = tmp_path / "out"
    for seeds in ("1..2", "1"):
        assert main(["bench", str(small_suite), "-o", str(out), "--jobs", "2", "--seeds",
                     seeds]) == 0
    side = out / "runs" / "crossing" / "reference"
    assert sorted(p.name for p in side.glob("runs/*/*.mcap")) == ["seed-1.mcap"] * 3
    index = json.loads((side / "index.json").read_text(encoding="utf-8"))
    assert index["complete"] and [r["seed"] for r in index["runs"]] == [1, 1, 1]
    # and `hubero diff` reads it as any sweep
    assert main(["diff", str(side), "--baseline", "robot_reaction=regular"]) == 0


def test_a_foreign_index_in_a_runs_folder_is_refused_before_any_run(
        small_suite: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # found as the doorway's turn came, after the crossing's runs
    out = tmp_path / "out"
    side = out / "runs" / "doorway" / "reference"
    side.mkdir(parents=True)
    (side / "index.json").write_text("my notes\n", encoding="utf-8")
    assert main(["bench", str(small_suite), "-o", str(out), "--jobs", "1"]) == 2
    assert f"{side / 'index.json'} exists and is not a sweep's index" in capsys.readouterr().err
    assert not list(out.glob("runs/crossing/**/*.mcap"))
    assert (side / "index.json").read_text(encoding="utf-8") == "my notes\n"
