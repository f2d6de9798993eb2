"""Crowds, flows and groups in logs and their readers: the log names its sets of people, `plot`
gives each crowd or flow one colour and one legend entry, and `diff --human` takes a set's name."""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path
from typing import Any

import pytest
from matplotlib.figure import Figure

from hubero_dsl.analysis import plot as plot_module
from hubero_dsl.cli.main import main
from hubero_dsl.log.reader import load_run
from hubero_dsl.pipeline import compile_file
from hubero_dsl.simulate import simulate

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def lounge(tmp_path_factory: pytest.TempPathFactory) -> Path:
    log = tmp_path_factory.mktemp("sets") / "lounge.mcap"
    simulate(compile_file(ROOT / "scenarios" / "lounge_crowd.hub"), log=log,
             writer_process=False)
    return log


def test_the_log_names_crowds_and_groups(lounge: Path) -> None:
    metadata = load_run(lounge).metadata
    assert metadata.sets["visitors"] == ("crowd", tuple(f"visitors_{i}" for i in range(1, 9)))
    assert metadata.sets["family"][0] == "group"
    assert metadata.members("visitors")[0] == "visitors_1"
    assert metadata.members("mum") == ("mum",)
    assert metadata.set_of("visitors_3") == "visitors" and metadata.set_of("mum") is None


def _legends(module: Any, monkeypatch: pytest.MonkeyPatch) -> list[list[str]]:
    """The labels of every legend `module` places from now on (its `place_legend` spied on)."""
    legends: list[list[str]] = []
    original = module.place_legend

    def spy(figure: Figure, axes: Any, handles: list[Any]) -> None:
        legends.append([str(h.get_label()) for h in handles])
        original(figure, axes, handles)

    monkeypatch.setattr(module, "place_legend", spy)
    return legends


def test_a_crowd_is_one_colour_and_one_legend_entry(lounge: Path, tmp_path: Path,
                                                    monkeypatch: pytest.MonkeyPatch) -> None:
    legends = _legends(plot_module, monkeypatch)
    plot_module.plot_run(load_run(lounge), tmp_path / "lounge.png")
    labels = legends[0]
    assert "crowd visitors (8 people)" in labels
    assert not any(label.startswith("visitors_") for label in labels)
    assert any(label.startswith("mum:") for label in labels) and "robot cart" in labels


def test_the_replay_draws_a_crowd_as_the_picture_does(lounge: Path, tmp_path: Path,
                                                      monkeypatch: pytest.MonkeyPatch) -> None:
    from matplotlib.figure import Figure as Canvas

    from hubero_dsl.analysis import animate

    run = load_run(lounge)
    legends = _legends(animate, monkeypatch)
    animate.animate_run(run, tmp_path / "lounge.gif", max_frames=2)
    assert "crowd visitors (8 people)" in legends[0]
    assert not any(label.startswith("visitors_") for label in legends[0])
    named = [n for n in run.humans if run.metadata.set_of(n) is None]
    scene = animate._Scene(run, Canvas().subplots(), plot_module.colours(named),
                           plot_module.set_colours(run), 30.0)
    members = [n for n in run.humans if run.metadata.set_of(n) == "visitors"]
    assert members and not any(m in scene.spaces for m in members)   # no personal spaces
    assert len({tuple(scene.trails[m].get_color()) for m in members}) == 1  # one colour
    assert "mum" in scene.spaces


def test_a_replay_shows_someone_only_while_they_are_in_the_scene(build_run: Any,
                                                                 track: Any) -> None:
    from matplotlib.figure import Figure as Canvas

    from hubero_dsl.analysis.animate import _Scene

    late = build_run([track("early", [0.0, 1.0, 2.0, 3.0], [(0, 0), (1, 0), (2, 0), (3, 0)]),
                      track("late", [1.0, 2.0], [(0, 1), (1, 1)])])
    scene = _Scene(late, Canvas().subplots(), {"early": "red", "late": "blue"}, {}, 3.0)
    scene.show(0.5)
    assert scene.bodies["early"].get_visible() and not scene.bodies["late"].get_visible()
    scene.show(1.5)
    assert scene.bodies["late"].get_visible()
    scene.show(2.5)                     # gone after its last frame (a flow's person who left)
    assert not scene.bodies["late"].get_visible() and scene.bodies["early"].get_visible()


def test_diff_takes_a_crowds_name(lounge: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["diff", str(lounge), str(lounge), "--human", "visitors", "--json"]) == 0
    shown = json.loads(capsys.readouterr().out)["humans"]
    assert sorted(shown) == sorted(f"visitors_{i}" for i in range(1, 9))
    capsys.readouterr()
    assert main(["diff", str(lounge), str(lounge), "--human", "nobody"]) == 2
    # the names --human takes: the named humans, each crowd and group (not its members), and
    # the robots
    assert ("(humans: dad, kid, mum, group family, crowd visitors; robots: cart)"
            in capsys.readouterr().err)


def test_diff_compares_robots(lounge: Path, tmp_path: Path) -> None:
    from hubero_dsl.analysis.diff import diff_runs

    other = tmp_path / "other.mcap"
    simulate(compile_file(ROOT / "scenarios" / "lounge_crowd.hub"), log=other, seed=11,
             writer_process=False)
    run = load_run(lounge)
    assert run.robots["cart"].radius > 0
    diff = diff_runs(run, load_run(other))
    cart = diff.robots["cart"]
    assert {m.name for m in cart.metrics} >= {"min_distance", "path_length", "collisions"}
    same = diff_runs(run, run).robots["cart"]
    assert all(m.delta in (0, 0.0, None) for m in same.metrics)
    assert same.max_separation == 0.0 and same.diverged_at is None
    assert "cart" in json.loads(json.dumps(diff.to_dict()))["robots"]


@pytest.fixture(scope="module")
def reseeded(lounge: Path) -> Path:
    other = lounge.with_name("lounge-11.mcap")
    simulate(compile_file(ROOT / "scenarios" / "lounge_crowd.hub"), log=other, seed=11,
             writer_process=False)
    return other


def test_diff_shows_a_crowd_as_one_table(lounge: Path, reseeded: Path,
                                         capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["diff", str(lounge), str(reseeded)]) == 0
    out = capsys.readouterr().out
    assert "crowd visitors  8 members" in out and "closest to anyone" in out
    assert not re.search(r"^visitors_3\b", out, re.M)       # no table of its own
    assert "closest to visitors " in out and "closest to visitors_" not in out
    assert main(["diff", str(lounge), str(reseeded), "--members"]) == 0
    listed = capsys.readouterr().out
    assert re.search(r"^visitors_3\b", listed, re.M) and "crowd visitors" not in listed


def test_a_crowds_table_sums_up_its_members(lounge: Path, reseeded: Path,
                                            capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["diff", str(lounge), str(reseeded), "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    visitors = data["sets"]["visitors"]
    members = [data["humans"][f"visitors_{i}"]["metrics"] for i in range(1, 9)]
    metrics = visitors["metrics"]
    assert visitors["kind"] == "crowd" and metrics["members"]["a"] == 8
    for side in ("a", "b"):
        lengths = [m["path_length"][side] for m in members]
        assert metrics["path_length"][side] == pytest.approx(sum(lengths) / 8, abs=1e-6)
        closest = [v[side] for m in members for k, v in m.items()
                   if k.startswith("min_distance.") and v[side] is not None]
        assert metrics["min_distance"][side] == pytest.approx(min(closest))
    assert "family" not in data["sets"]                    # a group's members are named


def test_a_flows_table_counts_the_members_who_came() -> None:
    from hubero_dsl.analysis.diff import (
        HumanDiff,
        MetricDelta,
        RunDiff,
        RunSide,
        never_came,
        set_diffs,
    )

    def member(name: str, status_a: str, status_b: str, length: float) -> HumanDiff:
        metrics = (MetricDelta("path_length", length, length, 0.0),
                   MetricDelta("final_status", status_a, status_b, None))
        return HumanDiff(name, metrics, None, None, None, None, {})

    side = RunSide("a.mcap", "t", None, 1)
    humans = {"p_1": member("p_1", "SUCCEEDED", "SUCCEEDED", 10.0),
              "p_2": member("p_2", "ACTIVE", "IDLE", 4.0),
              "p_3": member("p_3", "IDLE", "IDLE", 0.0)}   # never came in either run
    diff = RunDiff(side, side, 0.1, humans, sets={"p": ("flow", ("p_1", "p_2", "p_3"))})
    flow = set_diffs(diff)["p"]
    metrics = {m.name: m for m in flow.metrics}
    assert (metrics["members"].a, metrics["members"].b) == (2, 1)
    assert (metrics["path_length"].a, metrics["path_length"].b) == (7.0, 10.0)
    assert (metrics["succeeded"].a, metrics["succeeded"].delta) == (1, 0)
    assert never_came(diff) == {"p_3"}


def test_diff_lists_a_flows_members_who_came(tmp_path: Path,
                                             capsys: pytest.CaptureFixture[str]) -> None:
    from hubero_dsl.pipeline import compile_source

    text = (f'scenario "f"\nmap "{ROOT / "maps" / "parking.yaml"}"\nseed 2\ntime_limit 40 s\n'
            "flow walkers from rect((14, 0), (16, 3)) to (12.0, 7.0) rate 20 /min for 10 s\n")
    program = compile_source(text, str(tmp_path / "f.hub"))
    logs = [tmp_path / "a.mcap", tmp_path / "b.mcap"]
    for log, seed in zip(logs, (2, 3), strict=True):
        simulate(program, log=log, seed=seed, writer_process=False)
    came_a, came_b = ({e.human for e in load_run(log).events} for log in logs)
    came = came_a | came_b
    members = load_run(logs[0]).metadata.members("walkers")
    assert came < set(members)   # the flow may bring more than came in either run
    assert main(["diff", *map(str, logs)]) == 0
    table = capsys.readouterr().out
    assert "flow walkers\n" in table and "members who came" in table
    assert main(["diff", *map(str, logs), "--human", "walkers"]) == 0
    titles = re.findall(r"^(walkers_\d+)(?:  \(did not come in ([AB])\))?$",
                        capsys.readouterr().out, re.MULTILINE)
    assert {name for name, _ in titles} == came and came_a != came_b
    # someone who came in one run only has no numbers of the other: the title says so
    assert {(name, absent) for name, absent in titles if absent} == {
        *((name, "B") for name in came_a - came_b), *((name, "A") for name in came_b - came_a)}
    # ... nor a difference to it, nor paths compared: not the zeros of someone standing still
    from hubero_dsl.analysis.diff import diff_runs

    diff = diff_runs(*(load_run(log) for log in logs))
    one_sided = [(name, "a") for name in came_b - came_a] + [(n, "b") for n in came_a - came_b]
    assert one_sided
    for name, absent in one_sided:
        human = diff.humans[name]
        assert all(getattr(m, absent) is None and m.delta is None for m in human.metrics)
        assert (human.frechet, human.diverged_at) == (None, None)
    # and one named who came in neither run is said so, not a table of zeros
    nobody = sorted(set(members) - came)[0]
    assert main(["diff", *map(str, logs), "--human", nobody]) == 0
    out = capsys.readouterr().out
    assert f"{nobody} (of flow walkers) came in neither run: nothing to compare" in out
    assert "path length" not in out


def test_a_sweeps_table_gives_a_crowd_one_row(lounge: Path, reseeded: Path, tmp_path: Path,
                                              capsys: pytest.CaptureFixture[str]) -> None:
    folder = tmp_path / "sweep"
    (folder / "runs").mkdir(parents=True)
    runs = []
    for variant, log in (("base", lounge), ("other", reseeded)):
        shutil.copyfile(log, folder / "runs" / log.name)  # a sweep's logs lie inside it
        runs.append({"variant": variant, "seed": 1, "parameters": {}, "status": "completed",
                     "reason": "", "duration": 1.0, "metrics": {}, "log": f"runs/{log.name}"})
    (folder / "index.json").write_text(json.dumps(
        {"version": 1, "scenario": "lounge_crowd.hub", "runs": runs}), encoding="utf-8")
    assert main(["diff", str(folder), "--baseline", "base"]) == 0
    rows = [row for row in (line.split() for line in capsys.readouterr().out.splitlines())
            if row[:1] == ["other"]]
    names = [" ".join(row[2:4]) if row[2] == "crowd" else row[2] for row in rows]
    assert "crowd visitors" in names and "mum" in names
    assert not any(name.startswith("visitors_") for name in names)
    assert main(["diff", str(folder), "--baseline", "base", "--human", "visitors_2"]) == 0
    assert "visitors_2" in capsys.readouterr().out
    assert main(["diff", str(folder), "--baseline", "base", "--json"]) == 0
    (comparison,) = json.loads(capsys.readouterr().out)["comparisons"]
    assert comparison["diff"]["sets"]["visitors"]["members"] == 8


def test_the_overlay_of_two_runs_draws_a_crowd_as_the_picture_does(
        lounge: Path, reseeded: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    legends = _legends(plot_module, monkeypatch)
    a, b = load_run(lounge), load_run(reseeded)
    plot_module.plot_overlay(a, b, tmp_path / "both.png", epsilon=0.1)
    labels = legends[-1]
    assert "crowd visitors (8 people)" in labels and "mum" in labels
    assert not any(label.startswith("visitors_") for label in labels)
    # a member asked for by name is drawn in full, as a named human is
    plot_module.plot_overlay(a, b, tmp_path / "one.png", humans=["visitors_2"])
    assert "visitors_2" in legends[-1] and not any("crowd" in x for x in legends[-1])


def test_a_flows_member_who_left_at_its_target_ends_with_its_task_done(
        tmp_path: Path) -> None:
    from hubero_dsl.analysis.metrics import compute_metrics
    from hubero_dsl.pipeline import compile_source

    text = (f'scenario "f"\nmap "{ROOT / "maps" / "parking.yaml"}"\nseed 2\ntime_limit 40 s\n'
            "flow walkers from rect((14, 0), (16, 3)) to (12.0, 7.0) rate 20 /min for 10 s\n")
    log = tmp_path / "flow.mcap"
    simulate(compile_source(text, str(tmp_path / "f.hub")), log=log, writer_process=False)
    run = load_run(log)
    came = {e.human for e in run.events if e.status.value == "SUCCEEDED"}
    assert came
    metrics = compute_metrics(run)
    assert {metrics.humans[name].final_status for name in came} == {"SUCCEEDED"}


def test_an_unlabelled_task_has_one_key_whatever_else_started_before_it(
        tmp_path: Path) -> None:
    """Task ids count tasks as they start, and a flow's arrivals interleave with the humans'
    tasks by the seed: the metrics key a task by where it is written, so that the sweep's
    columns and diff's rows line up across runs."""
    from hubero_dsl.analysis.metrics import compute_metrics
    from hubero_dsl.pipeline import compile_source

    text = (f'scenario "f"\nmap "{ROOT / "maps" / "parking.yaml"}"\ntime_limit 40 s\n'
            "human h at (12.0, 7.0)\n"
            "flow walkers from rect((14, 0), (16, 3)) to (12.0, 4.0) rate 30 /min for 10 s\n"
            "activity {\n    h stand for 3 s\n    h move_to (10.0, 7.0)\n}\n")
    program = compile_source(text, str(tmp_path / "f.hub"))
    keys, ids = set(), set()
    for seed in (1, 2, 3):
        log = tmp_path / f"{seed}.mcap"
        simulate(program, log=log, seed=seed, writer_process=False)
        run = load_run(log)
        ids.add(max(e.task_id for e in run.events if e.human == "h"))
        keys.add(tuple(compute_metrics(run).humans["h"].task_finish_times))
    assert len(ids) > 1                                   # the walk's id differs by seed
    assert keys == {("move_to@8:5", "stand@7:5")}          # its key does not
