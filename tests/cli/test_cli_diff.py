"""`hubero diff`: tables, JSON, overlay plots, sweeps against a baseline, and every kind of bad
input ending in exit 2 with a message and no traceback."""

from __future__ import annotations

import json
import re
import shutil
from collections.abc import Callable
from pathlib import Path

import pytest
from mcap.writer import Writer
from PIL import Image

from hubero_dsl.cli.run import run_one
from hubero_dsl.pipeline import compile_file
from tests.cli.conftest import REPO_ROOT, Outcome

MAP = REPO_ROOT / "maps" / "living_room.yaml"

# Two people swap places in the living room; the variants change their personal space.
SWAP = f"""\
scenario "swap"
map "{MAP}"
time_limit 20 s
human a at (1, 1) heading 0 deg
human b at (4, 1.2) heading 180 deg
variant near {{ personal_space circle(radius: 0.2 m) }}
variant far {{ personal_space ellipse(semi_major: 1.1 m, semi_minor: 0.8 m) }}
activity {{
    parallel {{
        go: a move_to (4, 1)
        b move_to (1, 1.2)
    }}
}}
"""

ALONE = f"""\
scenario "alone"
map "{MAP}"
time_limit 5 s
human a at (1, 1)
human c at (2, 2)
activity {{ a move_to (2, 1) }}
"""

Cli = Callable[..., Outcome]


@pytest.fixture(scope="module")
def logs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp("diff")
    (folder / "swap.hub").write_text(SWAP, encoding="utf-8")
    (folder / "alone.hub").write_text(ALONE, encoding="utf-8")
    swap = compile_file(folder / "swap.hub")
    made = {}
    for variant in ("near", "far"):
        made[variant] = folder / f"{variant}.mcap"
        run_one(swap, variant, None, made[variant], 10.0, quiet=True)
    made["alone"] = folder / "alone.mcap"
    run_one(compile_file(folder / "alone.hub"), None, None, made["alone"], 10.0, quiet=True)
    return made


def test_two_runs_table(cli: Cli, logs: dict[str, Path]) -> None:
    outcome = cli("diff", str(logs["near"]), str(logs["far"]))
    assert outcome.status == 0, outcome.err
    for text in ("[near]", "[far]", "path length", "closest to b", "go done at",
                 "path Fréchet distance", "personal_space circle(radius: 0.2 m) → ellipse"):
        assert text in outcome.out
    assert outcome.err == ""


def test_json(cli: Cli, logs: dict[str, Path]) -> None:
    outcome = cli("diff", str(logs["near"]), str(logs["far"]), "--json", "--epsilon", "0.05")
    data = json.loads(outcome.out)
    assert data["epsilon"] == 0.05
    assert sorted(data["humans"]) == ["a", "b"]
    a = data["humans"]["a"]
    assert a["frechet"] > 0 and a["hausdorff"] > 0
    assert a["parameters"]["personal_space"][0] == "circle(radius: 0.2 m)"
    assert a["metrics"]["task_finish_times.go"]["delta"] == pytest.approx(
        a["metrics"]["task_finish_times.go"]["b"] - a["metrics"]["task_finish_times.go"]["a"],
        abs=1e-6)
    only_b = json.loads(cli("diff", str(logs["near"]), str(logs["far"]), "--json",
                            "--human", "b").out)
    assert list(only_b["humans"]) == ["b"]


def test_a_run_against_itself(cli: Cli, logs: dict[str, Path]) -> None:
    data = json.loads(cli("diff", str(logs["far"]), str(logs["far"]), "--json").out)
    for human in data["humans"].values():
        assert (human["frechet"], human["hausdorff"], human["diverged_at"]) == (0.0, 0.0, None)
        assert human["parameters"] == {}
        assert {m["delta"] for m in human["metrics"].values()} <= {0, None}


def test_overlay_plot(cli: Cli, logs: dict[str, Path], tmp_path: Path) -> None:
    out = tmp_path / "overlay.png"
    outcome = cli("diff", str(logs["near"]), str(logs["far"]), "--plot", str(out))
    assert outcome.status == 0
    with Image.open(out) as image:
        assert image.format == "PNG" and image.width > 500 and image.height > 300


@pytest.mark.parametrize(("name", "message"), [
    ("missing/overlay.png", "cannot be written"), (".", "give a name ending in .png"),
    ("folder.png", "cannot be written (it is a directory)")])
def test_unwritable_plot(cli: Cli, logs: dict[str, Path], tmp_path: Path, name: str,
                         message: str) -> None:
    (tmp_path / "folder.png").mkdir(exist_ok=True)
    outcome = cli("diff", str(logs["near"]), str(logs["far"]), "--plot", str(tmp_path / name))
    assert outcome.status == 2
    assert message in outcome.err


def test_different_scenarios_name_the_humans(cli: Cli, logs: dict[str, Path]) -> None:
    outcome = cli("diff", str(logs["near"]), str(logs["alone"]))
    assert outcome.status == 2
    assert "only in" in outcome.err and ": b" in outcome.err and ": c" in outcome.err
    assert "'swap' and 'alone'" in outcome.err


def write_other_mcap(path: Path) -> Path:
    with path.open("wb") as stream:
        writer = Writer(stream)
        writer.start(profile="", library="someone else")
        schema = writer.register_schema(name="x", encoding="jsonschema", data=b"{}")
        channel = writer.register_channel(topic="/x", message_encoding="json", schema_id=schema)
        writer.add_message(channel, log_time=0, data=b"{}", publish_time=0)
        writer.finish()
    return path


@pytest.mark.parametrize(("make", "message"), [
    (lambda p, log: p.write_bytes(b"hello, not a log"), "not a readable hubero run log"),
    (lambda p, log: p.write_bytes(b""), "the file is empty"),
    (lambda p, log: p.write_bytes(log.read_bytes()[: log.stat().st_size // 2]),
     "not a readable hubero run log"),
    (lambda p, log: write_other_mcap(p), "not a hubero run log"),
    (lambda p, log: None, "No such file"),
])
def test_bad_logs(cli: Cli, logs: dict[str, Path], tmp_path: Path, make: Callable[..., object],
                  message: str) -> None:
    bad = tmp_path / "bad.mcap"
    make(bad, logs["near"])
    outcome = cli("diff", str(logs["near"]), str(bad))
    assert outcome.status == 2
    assert message in outcome.err


@pytest.mark.parametrize(("extra", "message"), [
    ((), "give two run logs"),
    (("{far}", "--baseline", "near"), "--baseline goes with a sweep folder"),
    (("{far}", "--epsilon", "0"), "--epsilon must be a positive"),
    (("{far}", "--epsilon", "inf"), "--epsilon must be a positive distance in metres, got inf"),
    (("{far}", "--human", "zed"), "no human zed in these runs (humans: a, b)"),
])
def test_usage_errors(cli: Cli, logs: dict[str, Path], extra: tuple[str, ...],
                      message: str) -> None:
    argv = [arg.format(far=logs["far"]) for arg in extra]
    outcome = cli("diff", str(logs["near"]), *argv)
    assert outcome.status == 2
    assert message in outcome.err


# ---- sweeps -------------------------------------------------------------------------------


def sweep_folder(folder: Path, logs: dict[str, Path], runs: list[tuple[str, int]]) -> Path:
    (folder / "runs").mkdir(parents=True)
    entries = []
    for variant, seed in runs:
        log = folder / "runs" / f"{variant}-{seed}.mcap"
        shutil.copyfile(logs[variant], log)  # a sweep's logs lie inside it
        entries.append({"variant": variant, "seed": seed, "parameters": {},
                        "status": "completed", "reason": "", "duration": 3.0, "metrics": {},
                        "log": f"runs/{log.name}"})
    index = {"version": 1, "scenario": "swap.hub", "runs": entries}
    (folder / "index.json").write_text(json.dumps(index), encoding="utf-8")
    return folder


def test_sweep_table(cli: Cli, logs: dict[str, Path], tmp_path: Path) -> None:
    folder = sweep_folder(tmp_path / "out", logs,
                          [("near", 1), ("far", 1), ("near", 2), ("far", 2)])
    outcome = cli("diff", str(folder), "--baseline", "near")
    assert outcome.status == 0, outcome.err
    assert "far: personal_space circle(radius: 0.2 m) → ellipse" in outcome.out
    rows = [row for row in (line.split() for line in outcome.out.splitlines())
            if row[:1] == ["far"] and row[1].isdigit()]
    assert [(row[1], row[2]) for row in rows] == [("1", "a"), ("1", "b"), ("2", "a"), ("2", "b")]
    data = json.loads(cli("diff", str(folder), "--baseline", "near", "--json").out)
    assert [(c["variant"], c["seed"]) for c in data["comparisons"]] == [("far", 1), ("far", 2)]


def test_a_variant_whose_runs_could_not_be_compared_is_not_said_to_differ_in_nothing(
        cli: Cli, logs: dict[str, Path], tmp_path: Path) -> None:
    folder = sweep_folder(tmp_path / "out", logs, [("near", 1), ("far", 1)])
    (folder / "runs" / "far-1.mcap").write_bytes(b"\x89MCAP0\r\n truncated")
    outcome = cli("diff", str(folder), "--baseline", "near")
    assert "far: no run compared" in outcome.out
    assert "no parameter differs" not in outcome.out


@pytest.mark.parametrize(("index", "argv", "message"), [
    (None, ("--baseline", "near"), "has no index.json"),
    ('{"version": 1, "runs": []}', ("--baseline", "near"), "lists no runs"),
    ("[1, 2", ("--baseline", "near"), "cannot be read as a sweep index"),
    ("sweep", ("--baseline", "square"), "no run of the baseline variant 'square'"),
    ('{"version": 1, "runs": [{"variant": null, "seed": 1, "log": "runs/1.mcap"}]}',
     ("--baseline", "near"), "its scenario has no variants: a sweep of seeds alone has no "
     "baseline"),
    ("sweep", (), "--baseline VARIANT"),
    ("sweep", ("--baseline", "near", "--plot", "x.png"), "--plot draws two runs"),
])
def test_bad_sweeps(cli: Cli, logs: dict[str, Path], tmp_path: Path, index: str | None,
                    argv: tuple[str, ...], message: str) -> None:
    folder = tmp_path / "out"
    if index == "sweep":
        sweep_folder(folder, logs, [("near", 1), ("far", 1)])
    else:
        folder.mkdir()
        if index is not None:
            (folder / "index.json").write_text(index, encoding="utf-8")
    outcome = cli("diff", str(folder), *(a if a != "x.png" else str(tmp_path / a) for a in argv))
    assert outcome.status == 2
    assert message in outcome.err


def test_exit_status_in_a_real_process(cli_subprocess: Cli, tmp_path: Path) -> None:
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(b"\x89MCAP0\r\n truncated")
    outcome = cli_subprocess("diff", str(bad), str(bad))
    assert outcome.status == 2
    assert "error" in outcome.err and "bad.mcap" in outcome.err


def test_a_sweeps_long_variant_names_are_shown_whole(cli: Cli, logs: dict[str, Path],
                                                     tmp_path: Path) -> None:
    # two variants whose names differ only at their ends, past the first 24 characters
    names = {"near": "near", "speed=1.4 m/s,avoidance_strength=0.5": "far",
             "speed=1.4 m/s,avoidance_strength=1.5": "far"}
    folder = tmp_path / "out"
    (folder / "runs").mkdir(parents=True)
    entries = []
    for number, (variant, source) in enumerate(names.items()):
        shutil.copyfile(logs[source], folder / "runs" / f"{number}.mcap")
        entries.append({"variant": variant, "seed": 1, "parameters": {}, "status": "completed",
                        "reason": "", "duration": 3.0, "metrics": {},
                        "log": f"runs/{number}.mcap"})
    (folder / "index.json").write_text(json.dumps({"version": 1, "scenario": "swap.hub",
                                                   "runs": entries}), encoding="utf-8")
    outcome = cli("diff", str(folder), "--baseline", "near")
    assert outcome.status == 0, outcome.err
    for name in list(names)[1:]:  # the table's rows: the name, then the seed
        assert re.search(rf"^\s*{re.escape(name)}\s+1\s", outcome.out, re.MULTILINE), name


def test_a_sweeps_human_is_checked_as_a_pairs_is(cli: Cli, logs: dict[str, Path],
                                                tmp_path: Path) -> None:
    folder = sweep_folder(tmp_path / "out", logs, [("near", 1), ("far", 1)])
    unknown = cli("diff", str(folder), "--baseline", "near", "--human", "zz")
    assert unknown.status == 2
    assert "no human zz in these runs (humans: a, b)" in unknown.err
    chosen = cli("diff", str(folder), "--baseline", "near", "--human", "b")
    assert chosen.status == 0, chosen.err
    rows = [line.split()[:3] for line in chosen.out.splitlines() if line.startswith(" far")]
    assert rows == [["far", "1", "b"]]


PATROL = f"""\
scenario "patrol"
map "{MAP}"
seed 2
time_limit 8 s
human a at (1, 1) heading 0 deg
robot r at (1, 2.5) heading 0 deg {{ radius 0.3 m; speed 0.5 m/s; path (1, 2.5) -> (3.5, 2.5) }}
sweep speed in [1.0 m/s, 1.4 m/s]
activity {{ a move_to (4, 1) }}
"""


def test_a_sweep_against_its_baseline_has_a_row_for_each_robot_as_two_logs_have_a_table(
        cli: Cli, tmp_path: Path) -> None:
    # the sweep's table listed its humans only, while two logs' diff shows each robot
    (tmp_path / "patrol.hub").write_text(PATROL, encoding="utf-8")
    out = tmp_path / "sw"
    assert cli("sweep", str(tmp_path / "patrol.hub"), "--out-dir", str(out), "--seeds", "1..2",
               "--executor", "serial", "-q").status == 0
    outcome = cli("diff", str(out), "--baseline", "speed=1.0 m/s")
    assert outcome.status == 0, outcome.err
    rows = [line.split() for line in outcome.out.splitlines() if line.startswith(" speed=1.4")]
    assert [row[2:4] for row in rows] == [["1", "a"], ["1", "robot"], ["2", "a"], ["2", "robot"]]
    # path, closest in the baseline and in the run, collisions, Fréchet, Hausdorff, apart at:
    # no duration nor intrusion time, which are the humans'
    robot = rows[1][5:]
    assert len(robot) == 7 and robot[6] == "never"
    pair = cli("diff", str(out / "runs" / "speed=1.0m_s" / "seed-1.mcap"),
               str(out / "runs" / "speed=1.4m_s" / "seed-1.mcap")).out.split("robot r")[1]
    assert re.search(rf"│ path length +│ .* │ +{re.escape(robot[0])} m │", pair)
    assert re.search(rf"│ min distance +│ +{robot[1]} m │ +{robot[2]} m │", pair)
    assert re.search(rf"│ path Fréchet distance .* {robot[4]} m │", pair)


def test_human_selects_a_robot_too_in_two_logs_and_in_a_sweep(cli: Cli,
                                                              tmp_path: Path) -> None:
    # a robot's name was refused: "no human r in these runs", though its table is shown
    (tmp_path / "patrol.hub").write_text(PATROL, encoding="utf-8")
    out = tmp_path / "sw"
    assert cli("sweep", str(tmp_path / "patrol.hub"), "--out-dir", str(out), "--seeds", "1",
               "--executor", "serial", "-q").status == 0
    logs = [str(out / "runs" / f"speed={speed}m_s" / "seed-1.mcap") for speed in ("1.0", "1.4")]
    robot = cli("diff", *logs, "--human", "r")
    assert robot.status == 0, robot.err
    titles = [line for line in robot.out.splitlines() if line[:1].isalpha()]
    assert titles[2:] == ["robot r"]  # after the lines naming A and B: the robot alone
    both = cli("diff", *logs, "--human", "r", "--human", "a")
    assert [line for line in both.out.splitlines() if line[:1].isalpha()][2:] == [
        "a  speed 1 → 1.4", "robot r"]
    data = json.loads(cli("diff", *logs, "--human", "r", "--json").out)
    assert (list(data["humans"]), list(data["robots"])) == ([], ["r"])
    unknown = cli("diff", *logs, "--human", "zed")
    assert unknown.status == 2
    assert "no human or robot zed in these runs (humans: a; robots: r)" in unknown.err
    swept = cli("diff", str(out), "--baseline", "speed=1.0 m/s", "--human", "r")
    assert swept.status == 0, swept.err
    rows = [line.split()[2:5] for line in swept.out.splitlines() if line.startswith(" speed")]
    assert rows == [["1", "robot", "r"]]


@pytest.fixture(scope="module")
def station(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """The station's runs of seeds 3 and 4: some of the alighting flow's people came in the
    first only, most in neither."""
    folder = tmp_path_factory.mktemp("station")
    program = compile_file(REPO_ROOT / "scenarios" / "station.hub")
    for seed in (3, 4):
        run_one(program, None, seed, folder / f"seed-{seed}.mcap", 10.0, quiet=True)
    return folder / "seed-3.mcap", folder / "seed-4.mcap"


def test_a_flows_members_are_listed_in_the_runs_order_each_who_came_in_one_run_said_so(
        cli: Cli, station: tuple[Path, Path]) -> None:
    # they were sorted as text (alighting_1, alighting_10, ...), and someone who came in A only
    # had a line `alighting_34  speed 1.45852 → 1.17774  (did not come in B)`: a speed in B
    from hubero_dsl.log.reader import load_run

    runs = [load_run(path) for path in station]
    members = runs[0].metadata.members("alighting")
    came = [{m for m in members if len(run.humans[m].time)} for run in runs]
    only_a, only_b = came[0] - came[1], came[1] - came[0]
    assert only_a or only_b
    expected = [m for m in members if m in came[0] | came[1]]  # numbered as they came
    outcome = cli("diff", *map(str, station), "--human", "alighting")
    assert outcome.status == 0, outcome.err
    titles = [line for line in outcome.out.splitlines() if line.startswith("alighting_")]
    assert [title.split()[0] for title in titles] == expected
    for title in titles:
        name = title.split()[0]
        if name in only_a | only_b:
            assert title == f"{name}  (did not come in {'B' if name in only_a else 'A'})"
        else:
            assert title.startswith(f"{name}  speed ") and "did not come" not in title
    data = json.loads(cli("diff", *map(str, station), "--human", "alighting", "--json").out)
    assert set(data["humans"]) == set(expected)
    assert all(data["humans"][name]["parameters"] == {} for name in only_a | only_b)
    listed = cli("diff", *map(str, station), "--members").out.splitlines()
    names = [line.split()[0] for line in listed if line[:1].isalpha()][2:]
    assert names[:len(expected) + 1] == ["guard", *expected]  # as `hubero run --members`


def test_counts_show_as_whole_numbers_and_shape_intrusions_as_shares() -> None:
    from hubero_dsl.cli.diff import _delta, _unit, _value

    assert (_value(3.0, _unit("collisions")), _delta(3.0, _unit("collisions"))) == ("3", "+3")
    assert _value(2.0, _unit("obstacle_collisions")) == "2"
    assert _value(0.607, _unit("shape_intrusions")) == "60.7 %"
    assert _value(2.0, _unit("min_distance")) == "2.000 m"     # a whole length stays a length
