"""Diffs of runs: a run against itself is all zeros; path distances and divergence on hand-made
paths; parameters; tasks matched across runs; sweep folders and their bad forms."""

from __future__ import annotations

import json
import shutil
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from hubero_dsl.analysis.diff import (
    diff_runs,
    diff_sweep,
    divergence,
    load_index,
    parameter_changes,
    path_distances,
)
from hubero_dsl.errors import InputError
from hubero_dsl.log.reader import load_run
from hubero_dsl.sim.status import TaskStatus
from hubero_dsl.world.shapes import Circle, Ellipse

Factory = Callable[..., Any]


def test_a_run_against_itself_is_all_zeros(living_room_logs: dict[str, Path]) -> None:
    run = load_run(living_room_logs["ellipse"])
    diff = diff_runs(run, run)
    assert sorted(diff.humans) == ["actor1", "actor2"]
    for human in diff.humans.values():
        assert human.frechet == 0.0
        assert human.hausdorff == 0.0
        assert human.max_separation == 0.0
        assert human.diverged_at is None
        assert human.parameters == {}
        assert all(m.delta in (0, None) for m in human.metrics)
        assert all(m.a == m.b for m in human.metrics)
    assert diff.notes == ()


def test_circle_against_ellipse(living_room_logs: dict[str, Path]) -> None:
    circle, ellipse = (load_run(living_room_logs[v]) for v in ("circle", "ellipse"))
    diff = diff_runs(circle, ellipse, epsilon=0.1)
    actor2 = diff.humans["actor2"]
    assert actor2.parameters == {"personal_space": (
        "circle(radius: 0.2 m)", "ellipse(semi_major: 1.1 m, semi_minor: 0.8 m)")}
    assert actor2.frechet is not None and actor2.frechet > 0.1
    assert actor2.hausdorff is not None and 0 < actor2.hausdorff <= actor2.frechet + 1e-9
    assert actor2.diverged_at is not None
    closest = actor2.metric("min_distance.actor1")
    assert closest is not None and closest.delta is not None
    assert closest.delta == pytest.approx(float(closest.b) - float(closest.a), abs=1e-6)  # type: ignore[arg-type]
    assert (diff.a.variant, diff.b.variant) == ("circle", "ellipse")
    data = json.loads(json.dumps(diff.to_dict()))
    assert data["humans"]["actor2"]["parameters"]["personal_space"][1].startswith("ellipse")


def test_path_distances_by_hand(track: Factory) -> None:
    times = [0.0, 1.0, 2.0, 3.0, 4.0]
    a = track("h", times, [(0, 0), (1, 0), (2, 0), (3, 0), (4, 0)])
    b = track("h", times, [(0, 0), (1, 0), (2, 0.05), (3, 0.3), (4, 0.3)])
    frechet, hausdorff = path_distances(a.position, b.position)
    assert frechet == pytest.approx(0.3)
    assert hausdorff == pytest.approx(0.3)
    separation, diverged = divergence(a, b, 0.1)
    assert separation == pytest.approx(0.3)
    assert diverged == 3.0
    assert divergence(a, b, 0.5) == (pytest.approx(0.3), None)


def test_divergence_only_while_both_are_logged(track: Factory) -> None:
    a = track("h", [0.0, 1.0, 2.0, 3.0], [(0, 0), (0, 0), (0, 0), (9, 9)])
    b = track("h", [0.0, 2.0], [(0, 0), (0, 0.2)])
    separation, diverged = divergence(a, b, 0.15)
    assert separation == pytest.approx(0.2)  # t = 3 s is past B's log
    assert diverged == 2.0  # at t = 1 s B is interpolated to (0, 0.1)


def test_paths_of_one_frame_and_none(track: Factory) -> None:
    one = track("h", [0.0], [(1, 1)])
    assert path_distances(one.position, one.position) == (0.0, 0.0)
    assert path_distances(track("h", [], []).position, one.position) == (None, None)


def test_parameter_changes() -> None:
    a = {"speed": 1.29, "personal_space": Circle(0.2), "radius": 0.2, "only_a": 1.0}
    b = {"speed": 1.5, "personal_space": Ellipse(1.1, 0.8), "radius": 0.2}
    assert parameter_changes(a, b) == {
        "only_a": ("1", "(not set)"),
        "personal_space": ("circle(radius: 0.2 m)",
                           "ellipse(semi_major: 1.1 m, semi_minor: 0.8 m)"),
        "speed": ("1.29", "1.5")}


def test_unlabelled_tasks_match_by_place(build_run: Factory, track: Factory,
                                         event: Factory) -> None:
    # the same task got id 5 in one run and 6 in the other (branches started in another order)
    humans = [track("h", [0.0, 1.0], [(0, 0), (1, 0)])]
    a = build_run(humans, events=[event("h", 5, "move_to", TaskStatus.SUCCEEDED, 3.0, 9, 5)])
    b = build_run(humans, events=[event("h", 6, "move_to", TaskStatus.SUCCEEDED, 4.0, 9, 5)])
    rows = {m.name: m for m in diff_runs(a, b).humans["h"].metrics}
    task = rows["task_finish_times.move_to@9:5"]
    assert (task.a, task.b, task.delta) == (3.0, 4.0, 1.0)
    assert rows["collisions"].delta == 0 and isinstance(rows["collisions"].delta, int)
    assert rows["final_status"].delta is None


def test_different_humans_are_named(build_run: Factory, track: Factory) -> None:
    a = build_run([track("alice", [0.0], [(0, 0)]), track("bob", [0.0], [(1, 1)])],
                  title="first")
    b = build_run([track("alice", [0.0], [(0, 0)]), track("carol", [0.0], [(1, 1)])],
                  title="second")
    with pytest.raises(InputError, match=r"only in first.mcap: bob; only in second.mcap: carol"):
        diff_runs(a, b)


def test_a_flows_members_who_never_came_are_counted_not_named(build_run: Factory,
                                                              track: Factory) -> None:
    # 53 names, 26 of them never in the scene, sorted as strings (walkers_1, walkers_10, ...)
    came = [track(f"walkers_{i}", [0.0], [(0, 0)]) for i in range(1, 13)]
    never = [track(f"walkers_{i}", [], []) for i in range(13, 16)]
    a = build_run([track("alice", [0.0], [(0, 0)])], title="first")
    b = build_run([track("alice", [0.0], [(0, 0)]), *came, *never], title="second")
    with pytest.raises(InputError) as failed:
        diff_runs(a, b)
    assert ("only in second.mcap: walkers_1, walkers_2, walkers_3, walkers_4, walkers_5, "
            "walkers_6, walkers_7, walkers_8, walkers_9, walkers_10 and 2 more, and 3 flow "
            "members who never came)") in failed.value.message


def test_other_scenario_text_is_noted(build_run: Factory, track: Factory) -> None:
    humans = [track("alice", [0.0], [(0, 0)])]
    diff = diff_runs(build_run(humans, source="a"), build_run(humans, source="b"))
    assert any("scenario texts differ" in note for note in diff.notes)
    # the same title: the note says where the texts part (it quoted the title twice)
    diff = diff_runs(build_run(humans, source="x\nspeed 1 m/s\n"),
                     build_run(humans, source="x\nspeed 2 m/s\n"))
    assert "the scenario texts differ (first at line 2: 'speed 1 m/s' in A, 'speed 2 m/s' "\
           "in B)" in diff.notes


@pytest.mark.parametrize("epsilon", [0.0, -1.0, float("nan"), float("inf")])
def test_bad_epsilon(build_run: Factory, track: Factory, epsilon: float) -> None:
    run = build_run([track("alice", [0.0], [(0, 0)])])
    with pytest.raises(InputError, match="epsilon"):
        diff_runs(run, run, epsilon=epsilon)


# ---- sweeps -------------------------------------------------------------------------------


def write_index(folder: Path, runs: list[dict[str, Any]], **extra: Any) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    index = {"version": 1, "scenario": "scenarios/living_room.hub", "runs": runs, **extra}
    (folder / "index.json").write_text(json.dumps(index), encoding="utf-8")
    return folder


def entry(variant: str, seed: int, log: str | None, status: str = "completed") -> dict[str, Any]:
    return {"variant": variant, "seed": seed, "parameters": {}, "status": status,
            "reason": "" if log else "crashed", "duration": 1.0, "metrics": {}, "log": log}


@pytest.fixture
def sweep_dir(tmp_path: Path, living_room_logs: dict[str, Path]) -> Path:
    runs = tmp_path / "sweep" / "runs"
    runs.mkdir(parents=True)
    for variant, log in living_room_logs.items():
        shutil.copyfile(log, runs / f"{variant}.mcap")  # a sweep's logs lie inside it
    return write_index(tmp_path / "sweep", [
        entry("circle", 7, "runs/circle.mcap"), entry("ellipse", 7, "runs/ellipse.mcap"),
        entry("ellipse", 8, "runs/ellipse.mcap"), entry("square", 7, None, "error")])


def test_sweep_against_baseline(sweep_dir: Path) -> None:
    sweep = diff_sweep(sweep_dir, "circle")
    assert [(c.variant, c.seed) for c in sweep.comparisons] == [
        ("ellipse", 7), ("square", 7), ("ellipse", 8)]
    compared = [c for c in sweep.comparisons if c.diff is not None]
    assert len(compared) == 1
    assert compared[0].diff is not None
    assert compared[0].diff.humans["actor1"].parameters["personal_space"][0].startswith("circle")
    notes = sorted(c.note for c in sweep.comparisons if c.diff is None)
    assert notes == ["no baseline run with seed 8", "no log (crashed)"]
    assert json.loads(json.dumps(sweep.to_dict()))["baseline"] == "circle"


def test_sweep_against_another_baseline(sweep_dir: Path) -> None:
    sweep = diff_sweep(sweep_dir, "ellipse")
    compared = [c for c in sweep.comparisons if c.diff is not None]
    assert [c.variant for c in compared] == ["circle"]
    assert compared[0].diff is not None
    assert compared[0].diff.a.variant == "ellipse"  # the baseline is always side A


def test_sweep_bad_log_spoils_only_its_row(tmp_path: Path, sweep_dir: Path) -> None:
    (sweep_dir / "runs" / "junk.mcap").write_bytes(b"not a log at all")
    index = json.loads((sweep_dir / "index.json").read_text())
    index["runs"].append(entry("junk", 7, "runs/junk.mcap"))
    (sweep_dir / "index.json").write_text(json.dumps(index))
    sweep = diff_sweep(sweep_dir, "circle")
    junk = next(c for c in sweep.comparisons if c.variant == "junk")
    assert junk.diff is None and "not a readable hubero run log" in junk.note


def test_missing_baseline_variant(sweep_dir: Path) -> None:
    with pytest.raises(InputError,
                       match=r"baseline variant 'triangle'.*variants: circle, ellipse, square"):
        diff_sweep(sweep_dir, "triangle")


@pytest.mark.parametrize(("content", "message"), [
    (None, "has no index.json"),
    ("{not json", "cannot be read as a sweep index"),
    ('{"version": 1, "runs": []}', "lists no runs"),
    ('{"version": 1}', "no list of runs"),
    ('{"version": 9, "runs": [1]}', "index version 9"),
    ('{"version": 1, "runs": [{"variant": "a"}]}', "a run entry is malformed"),
    ('{"version": "1", "runs": [1]}', "its version is not a number"),
    ("[" * 200_000 + "]" * 200_000, "its JSON is nested too deeply"),
])
def test_bad_indexes(tmp_path: Path, content: str | None, message: str) -> None:
    if content is not None:
        (tmp_path / "index.json").write_text(content, encoding="utf-8")
    with pytest.raises(InputError, match=message):
        load_index(tmp_path)


def test_index_of_a_file(tmp_path: Path) -> None:
    (tmp_path / "x").write_text("")
    with pytest.raises(InputError, match="not a directory"):
        load_index(tmp_path / "x")


def test_an_index_that_is_a_device_is_not_read(tmp_path: Path) -> None:
    (tmp_path / "index.json").symlink_to("/dev/zero")
    with pytest.raises(InputError, match="not a regular file"):
        load_index(tmp_path)


@pytest.mark.parametrize("log", ["/etc/passwd", "../../../../etc/shadow", "/dev/zero",
                                 "runs/../../outside.mcap", "runs/link.mcap"])
def test_a_log_outside_the_sweep_folder_is_never_opened(
        sweep_dir: Path, living_room_logs: dict[str, Path], monkeypatch: pytest.MonkeyPatch,
        log: str) -> None:
    (sweep_dir / "runs" / "link.mcap").symlink_to(living_room_logs["ellipse"])
    shutil.copyfile(living_room_logs["ellipse"], sweep_dir.parent / "outside.mcap")
    index = json.loads((sweep_dir / "index.json").read_text())
    index["runs"].append(entry("stranger", 7, log))
    (sweep_dir / "index.json").write_text(json.dumps(index))
    opened: list[Path] = []

    def recorded_load_run(path: Path) -> Any:
        opened.append(path)
        return load_run(path)

    monkeypatch.setattr("hubero_dsl.log.reader.load_run", recorded_load_run)
    sweep = diff_sweep(sweep_dir, "circle")
    stranger = next(c for c in sweep.comparisons if c.variant == "stranger")
    assert stranger.diff is None
    assert stranger.note.startswith("the index names a log outside the sweep folder")
    assert opened and all(p.is_relative_to(sweep_dir.resolve()) for p in opened)
    ellipse = next(c for c in sweep.comparisons if c.variant == "ellipse" and c.seed == 7)
    assert ellipse.diff is not None  # the other runs are compared as before
