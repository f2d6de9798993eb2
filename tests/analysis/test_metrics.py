"""Metrics of tiny synthetic runs against values worked out by hand."""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any
from unittest.mock import patch

import numpy as np
import pytest

from hubero_dsl.analysis import metrics
from hubero_dsl.analysis.metrics import RunMetrics, compute_metrics
from hubero_dsl.log.reader import load_run
from hubero_dsl.sim.status import TaskStatus
from hubero_dsl.world.shapes import Circle, Ellipse, Rectangle, Square

Factory = Callable[..., Any]

# A walks from (0, 0) to (3, 0) at 1 m/s, logged every 0.5 s, then stands until t = 5 s.
# B stands at (1, 0.5): A passes it at 0.5 m at t = 1 s (the frames at 0.5 s and 1.5 s are
# sqrt(0.5) = 0.707 m away).
TIMES = np.arange(0.0, 5.01, 0.5)
A_PATH = np.column_stack([np.minimum(TIMES, 3.0), np.zeros_like(TIMES)])
B_SPOT = [(1.0, 0.5)] * len(TIMES)


def passing(build_run: Factory, track: Factory, b_space: Any = None,
            b_heading: float = 0.0) -> RunMetrics:
    params = {"a": {"radius": 0.3, "personal_space": Circle(0.6)},
              "b": {"radius": 0.3, "personal_space": b_space or Circle(0.2)}}
    run = build_run([track("a", TIMES, A_PATH), track("b", TIMES, B_SPOT, b_heading)],
                    params=params)
    return compute_metrics(run)


def test_walker_motion(build_run: Factory, track: Factory) -> None:
    a = passing(build_run, track).humans["a"]
    assert a.path_length == pytest.approx(3.0)
    assert a.duration == pytest.approx(3.0)  # first to last movement; standing is not counted
    assert a.mean_speed == pytest.approx(1.0)
    assert a.max_speed == pytest.approx(1.0)
    assert a.final_status == "SUCCEEDED"


def test_standing_human_has_no_motion(build_run: Factory, track: Factory) -> None:
    b = passing(build_run, track).humans["b"]
    assert (b.path_length, b.duration, b.mean_speed, b.max_speed) == (0.0, 0.0, 0.0, 0.0)


def test_closest_approach_and_collision(build_run: Factory, track: Factory) -> None:
    metrics = passing(build_run, track)
    assert metrics.humans["a"].min_distance == {"b": pytest.approx(0.5)}
    assert metrics.humans["b"].min_distance == {"a": pytest.approx(0.5)}
    # bodies of 0.3 m overlap below 0.6 m: only the frame at t = 1 s
    assert metrics.humans["a"].collisions == 1
    assert metrics.humans["b"].collisions == 1


def test_circle_intrusion(build_run: Factory, track: Factory) -> None:
    # B's centre is inside A's 0.6 m circle only in the frame at t = 1 s, which lasts 0.5 s
    assert passing(build_run, track).humans["a"].personal_space_intrusion_time == (
        pytest.approx(0.5))


@pytest.mark.parametrize(("shape", "heading", "expected"), [
    # 2 m x 1.2 m box along x: A (0.5 m to the side) is inside for x in 0..2: five frames
    (Rectangle(2.0, 1.2), 0.0, 2.5),
    # the same box turned to face +y: only 0.6 m wide along x: x in 0.5..1.5
    (Rectangle(2.0, 1.2), math.pi / 2, 1.5),
    (Square(2.0), 0.0, 2.5),
    # ellipse 1 x 0.6: (x - 1)^2 <= 1 - (0.5 / 0.6)^2, |x - 1| <= 0.553: x in 0.5..1.5
    (Ellipse(1.0, 0.6), 0.0, 1.5),
    # centred 1 m behind B (towards -x): |x| <= 0.553: x in 0, 0.5
    (Ellipse(1.0, 0.6, offset=1.0), 0.0, 1.0),
    (Circle(0.2), 0.0, 0.0),
])
def test_intrusion_uses_shape_and_heading(build_run: Factory, track: Factory, shape: Any,
                                          heading: float, expected: float) -> None:
    b = passing(build_run, track, shape, heading).humans["b"]
    assert b.personal_space_intrusion_time == pytest.approx(expected)


def test_collision_episodes(build_run: Factory, track: Factory) -> None:
    # radius 0.2 each: bodies overlap closer than 0.4 m, at t = 1 and at t = 3..4: two episodes
    times = [0.0, 1.0, 2.0, 3.0, 4.0]
    a = track("a", times, [(0, 0), (1, 0), (0, 0), (1, 0), (1, 0)])
    b = track("b", times, [(1.2, 0)] * 5)
    metrics = compute_metrics(build_run([a, b], params={"a": {"radius": 0.2},
                                                        "b": {"radius": 0.2}}))
    assert metrics.humans["a"].collisions == 2
    assert metrics.humans["a"].min_distance["b"] == pytest.approx(0.2)


def test_bodies_that_just_touch_have_collided(build_run: Factory, track: Factory) -> None:
    # radius 0.2 each: 0.4 m apart they touch, as the engine leaves bodies it separates
    a = track("a", [0.0, 1.0, 2.0], [(-1, 0), (0, 0), (-1, 0)])
    b = track("b", [0.0, 1.0, 2.0], [(0.4, 0)] * 3)
    params = {"a": {"radius": 0.2}, "b": {"radius": 0.2}}
    assert compute_metrics(build_run([a, b], params=params)).humans["a"].collisions == 1


def test_overlap_from_the_first_frame_is_an_episode(build_run: Factory,
                                                    track: Factory) -> None:
    a = track("a", [0.0, 1.0], [(0, 0), (3, 0)])
    b = track("b", [0.0, 1.0], [(0.1, 0), (0.1, 0)])
    assert compute_metrics(build_run([a, b])).humans["a"].collisions == 1


def test_other_interpolated_at_own_times(build_run: Factory, track: Factory) -> None:
    # b is logged only at 0 and 2 s; at a's frame t = 1 s it is midway, at (1, 1)
    a = track("a", [0.0, 1.0, 2.0], [(5, 5), (1, 0), (5, 5)])
    b = track("b", [0.0, 2.0], [(0, 1), (2, 1)])
    assert compute_metrics(build_run([a, b])).humans["a"].min_distance["b"] == (
        pytest.approx(1.0))


SOURCE = """\
activity a {
    go: h1 move_to (1, 0)
    both: parallel {
        h1 stand for 1 s
        h2 stand for 2 s
    }
    h1 move_to (0, 0)
}
robot bot at (0, 0) { radius 0.5 m }
"""


def test_task_finish_times_by_label(build_run: Factory, track: Factory,
                                    event: Factory) -> None:
    done, active = TaskStatus.SUCCEEDED, TaskStatus.ACTIVE
    events = [event("h1", 1, "move_to", active, 0.0, 2, 5),
              event("h1", 1, "move_to", done, 2.0, 2, 5),
              event("h1", 2, "stand", active, 2.0, 4, 9),
              event("h2", 3, "stand", active, 2.0, 5, 9),
              event("h1", 2, "stand", done, 3.0, 4, 9),
              event("h2", 3, "stand", TaskStatus.PREEMPTED, 4.0, 5, 9),
              event("h1", 4, "move_to", active, 4.0, 7, 5),
              event("h1", 4, "move_to", TaskStatus.ABORTED, 6.0, 7, 5)]
    humans = [track("h1", [0.0, 6.0], [(0, 0), (1, 0)]),
              track("h2", [0.0, 6.0], [(3, 3), (3, 3)])]
    metrics = compute_metrics(build_run(humans, events=events, source=SOURCE))
    # the aborted move_to did not finish; the parallel ends for each human with its own part
    assert metrics.humans["h1"].task_finish_times == {"both": 3.0, "go": 2.0, "stand@4:9": 3.0}
    assert metrics.humans["h2"].task_finish_times == {"both": 4.0, "stand@5:9": 4.0}
    # h1 had tasks from 0 s to 6 s, though it moved only between its two frames
    assert metrics.humans["h1"].duration == pytest.approx(6.0)
    assert metrics.humans["h2"].duration == pytest.approx(2.0)  # a task, no movement


def test_task_finish_times_without_source(build_run: Factory, track: Factory,
                                          event: Factory) -> None:
    events = [event("h1", 1, "move_to", TaskStatus.SUCCEEDED, 2.0, 2, 5)]
    run = build_run([track("h1", [0.0, 2.0], [(0, 0), (1, 0)])], events=events)
    assert compute_metrics(run).humans["h1"].task_finish_times == {"move_to@2:5": 2.0}


def test_robot_metrics_and_radius_from_source(build_run: Factory, track: Factory,
                                              robot: Factory) -> None:
    human = track("h1", [0.0, 1.0, 2.0], [(0.6, 0), (0.6, 0), (0.6, 0)])
    bot = robot("bot", [0.0, 1.0, 2.0], [(0, 0), (0, 0), (0, 2)])
    with_source = compute_metrics(build_run([human], robots=[bot], source=SOURCE))
    # radius 0.5 m from the scenario + 0.2 m human: 0.6 m apart is an overlap
    assert with_source.humans["h1"].collisions == 1
    assert with_source.robots["bot"].collisions == 1
    assert with_source.robots["bot"].path_length == pytest.approx(2.0)
    assert with_source.robots["bot"].min_distance == {"h1": pytest.approx(0.6)}
    assert with_source.humans["h1"].min_distance == {"bot": pytest.approx(0.6)}
    # without the scenario text the default robot radius (0.3 m) keeps them apart
    assert compute_metrics(build_run([human], robots=[bot])).humans["h1"].collisions == 0


def test_empty_track(build_run: Factory, track: Factory) -> None:
    metrics = compute_metrics(build_run([track("h1", [], []), track("h2", [0.0], [(0, 0)])]))
    h1 = metrics.humans["h1"]
    assert (h1.path_length, h1.duration, h1.max_speed, h1.min_distance) == (0.0, 0.0, 0.0, {})
    assert h1.final_status == "IDLE"
    assert metrics.humans["h2"].min_distance == {}


def test_to_dict_is_json_safe_sorted_and_rounded(build_run: Factory, track: Factory) -> None:
    a = track("b_walker", [0.0, 3.0], [(0, 0), (1, 0)])
    b = track("a_stander", [0.0, 3.0], [(0, 1), (0, 1)])
    data = compute_metrics(build_run([a, b])).to_dict()
    assert list(data) == ["humans", "robots"]
    assert list(data["humans"]) == ["a_stander", "b_walker"]
    walker = data["humans"]["b_walker"]
    assert walker["mean_speed"] == 0.333333
    assert list(walker) == sorted(walker)
    assert json.loads(json.dumps(data)) == data


def test_flat_columns(build_run: Factory, track: Factory) -> None:
    flat = passing(build_run, track).flat()
    assert flat["a.path_length"] == 3.0
    assert flat["a.min_distance.b"] == 0.5
    assert flat["b.personal_space_intrusion_time"] == 0.0
    assert flat["a.final_status"] == "SUCCEEDED"
    assert list(flat) == sorted(flat)
    assert all(isinstance(v, float | int | str) for v in flat.values())


def test_real_log(living_room_logs: dict[str, Any]) -> None:
    metrics = compute_metrics(load_run(living_room_logs["ellipse"]))
    actor2 = metrics.humans["actor2"]
    assert set(actor2.task_finish_times) >= {"invite", "to_table"}
    assert actor2.task_finish_times["invite"] < actor2.task_finish_times["to_table"]
    assert 10.0 < actor2.path_length < 20.0
    assert 0.5 < actor2.mean_speed <= actor2.max_speed < 2.0
    assert actor2.final_status == "SUCCEEDED"
    # the ellipse keeps the two further apart than the 0.3 m the scenario expects
    assert actor2.min_distance["actor1"] > 0.3
    assert metrics.to_dict() == compute_metrics(load_run(living_room_logs["ellipse"])).to_dict()


def test_the_frame_grid_gives_the_pair_by_pair_metrics(build_run: Callable, track: Callable,
                                                       robot: Callable) -> None:
    # a crowd on one grid of frames: one arrives late and leaves early (a flow's member), one
    # turns about, two brush past each other twice, a robot crosses them
    rng = np.random.default_rng(3)
    times = [0.1 * t for t in range(40)]
    people = []
    for i in range(12):
        walk = np.cumsum(rng.normal(0.0, 0.15, (40, 2)), axis=0) + np.array([i % 4, i // 4])
        people.append(track(f"p{i}", times, walk.tolist(),
                            heading=float(rng.uniform(-3, 3))))
    people.append(track("late", times[10:30], [(1.5, 1.0 + 0.05 * t) for t in range(20)]))
    cart = robot("cart", times, [(-1.0 + 0.1 * t, 1.0) for t in range(40)])
    params = {f"p{i}": {"personal_space": Ellipse(1.0, 0.5, 0.2), "radius": 0.25}
              for i in range(0, 12, 2)}
    run = build_run(people, robots=[cart], params=params)
    fast = compute_metrics(run).to_dict()
    with patch.object(metrics.pairs, "on_grid", return_value=None):
        slow = compute_metrics(run).to_dict()
    assert fast == slow
    assert fast["humans"]["late"]["min_distance"]  # logged with the others for 20 frames
    assert any(h["collisions"] for h in fast["humans"].values())
    assert any(h["personal_space_intrusion_time"] for h in fast["humans"].values())


def test_tracks_off_the_grid_are_compared_pair_by_pair(build_run: Callable,
                                                       track: Callable) -> None:
    a = track("a", [0.0, 1.0, 2.0], [(0.0, 0.0), (1.0, 0.0), (2.0, 0.0)])
    b = track("b", [0.5, 1.5], [(0.5, 1.0), (1.5, 1.0)])   # sampled between a's frames
    assert metrics.pairs.on_grid([a.time, b.time], [a.position, b.position]) is None
    assert compute_metrics(build_run([a, b])).humans["a"].min_distance["b"] == \
        pytest.approx(1.0)


def test_a_run_of_more_bodies_than_can_be_paired_is_refused(
        build_run: Factory, track: Factory, monkeypatch: pytest.MonkeyPatch) -> None:
    from hubero_dsl.errors import InputError

    run = build_run([track("a", [0, 1], [(0, 0), (1, 0)]), track("b", [0, 1], [(5, 0), (5, 1)])])
    monkeypatch.setattr(metrics, "MAX_PAIRED", 1)  # two bodies, where a crowd has thousands
    with pytest.raises(InputError, match=r"2 people and robots are too many to compare pair "
                       r"by pair .* a sweep of such runs takes --no-metrics"):
        compute_metrics(run)


def test_a_task_cut_off_by_the_runs_end_lasts_until_it(tmp_path: Path) -> None:
    # a talk of 30 s in a run of 10 s read as 0.2 s: its start and a step of the listener
    from hubero_dsl.pipeline import compile_source
    from hubero_dsl.simulate import simulate

    root = Path(__file__).resolve().parents[2]
    program = compile_source(
        f'scenario "talk"\nmap "{root / "maps" / "living_room.yaml"}"\ntime_limit 10 s\n'
        "human ana at (-3.0, 2.0)\nhuman ben at (-2.2, 2.0)\n"
        "activity { parallel { ana talk to ben for 30 s\n ben stand for 4 s } }\n",
        str(tmp_path / "talk.hub"))
    simulate(program, log=tmp_path / "talk.mcap")
    humans = compute_metrics(load_run(tmp_path / "talk.mcap")).humans
    assert humans["ana"].duration == pytest.approx(10.0, abs=0.06)  # still talking at the end
    assert humans["ben"].duration == pytest.approx(4.0, abs=0.06)   # done after 4 s
