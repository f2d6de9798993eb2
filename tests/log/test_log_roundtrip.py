"""A run written with RunLog and read back: topics, schemas, counts, metadata, attachments."""

from __future__ import annotations

import hashlib
import json
import math
from collections import Counter
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from mcap.reader import make_reader

from hubero_dsl import __version__
from hubero_dsl.log import schemas as s
from hubero_dsl.log.reader import load_run
from hubero_dsl.pipeline import compile_file
from hubero_dsl.sim.status import TaskStatus
from hubero_dsl.world.mapfile import load_map
from hubero_dsl.world.shapes import Ellipse
from tests.log.conftest import BLOCKED, MEETING, WAITING, LoggedMeeting, World, write_log


def messages(path: Path) -> list[tuple[str, str, int, Any]]:
    """(topic, schema name, log time, decoded JSON) of every message, in file order."""
    with path.open("rb") as stream:
        reader = make_reader(stream, validate_crcs=True)
        return [(channel.topic, schema.name if schema else "", message.log_time,
                 json.loads(message.data))
                for schema, channel, message in reader.iter_messages(log_time_order=False)]


def topic_counts(path: Path) -> Counter[str]:
    return Counter(topic for topic, *_ in messages(path))


def test_topics_have_their_schemas(meeting: LoggedMeeting) -> None:
    schemas = {topic: schema for topic, schema, _, _ in messages(meeting.log)}
    assert schemas == {
        "/map": "foxglove.Grid", "/scene": "foxglove.SceneUpdate",
        "/tf": "foxglove.FrameTransforms", "/tasks": "hubero.TaskEvent",
        "/log": "foxglove.Log",
        "/humans/alice/pose": "foxglove.PoseInFrame",
        "/humans/bob/pose": "foxglove.PoseInFrame",
        "/humans/alice/state": "hubero.HumanState",
        "/humans/bob/state": "hubero.HumanState",
        "/robots/r2/state": "hubero.RobotState"}
    with meeting.log.open("rb") as stream:
        summary = make_reader(stream).get_summary()
    assert summary is not None
    assert {c.message_encoding for c in summary.channels.values()} == {"json"}
    assert {x.encoding for x in summary.schemas.values()} == {"jsonschema"}
    for schema in summary.schemas.values():
        assert json.loads(schema.data) == s.schema_of(schema.name)


def test_times_are_simulation_times_in_order(meeting: LoggedMeeting) -> None:
    times = [time for _, _, time, _ in messages(meeting.log)]
    assert times[0] == 0
    assert times == sorted(times)
    assert times[-1] == round(meeting.result.time * 1e9)


@pytest.mark.parametrize(("rate", "frames"), [(10.0, 31), (4.0, 13), (3.0, 10), (1.0, 4),
                                               (50.0, 61)])
def test_frame_counts_follow_rate_and_duration(world: World, tmp_path: Path, rate: float,
                                               frames: int) -> None:
    # 3 s at 50 ms steps: a frame at t = 0 and each time the clock passes k / rate
    # (every tick when the rate is faster than the step allows).
    log = tmp_path / "waiting.mcap"
    result = write_log(world.scenario("waiting.hub", WAITING), log, rate_hz=rate)
    assert result.ticks == 60
    counts = topic_counts(log)
    assert counts["/tf"] == counts["/humans/alice/pose"] == counts["/humans/alice/state"] \
        == frames
    assert counts["/map"] == 1
    run = load_run(log)
    assert len(run.humans["alice"].time) == frames
    assert run.humans["alice"].time[-1] == pytest.approx(3.0)
    assert np.all(np.diff(run.humans["alice"].time) > 0)


def test_a_last_frame_is_written_at_the_end_of_the_run(world: World, tmp_path: Path) -> None:
    log = tmp_path / "waiting.mcap"
    write_log(world.scenario("waiting.hub", WAITING), log, rate_hz=1.0 / 0.7)
    track = load_run(log).humans["alice"]
    # samples at 0, 0.7, 1.4, 2.1, 2.8, then the end at 3.0
    assert track.time == pytest.approx([0.0, 0.7, 1.4, 2.1, 2.8, 3.0])


def test_every_task_change_is_on_tasks_with_its_source_line(meeting: LoggedMeeting) -> None:
    tasks = [value for topic, _, _, value in messages(meeting.log) if topic == "/tasks"]
    events = meeting.result.events
    assert len(tasks) == len(events) > 0
    source = meeting.scenario.read_text().splitlines()
    for value, event in zip(tasks, events, strict=True):
        assert (value["human"], value["task_id"], value["status"], value["tick"]) == \
            (event.human, event.task_id, event.status.value, event.tick)
        assert event.span is not None
        assert value["line"] == event.span.line
        assert value["source_line"] == source[event.span.line - 1].strip()
    first = tasks[0]
    assert first["source_line"] == "go: alice move_to (8, 2) heading 90 deg"
    assert first["file"] == meeting.scenario.name  # as the log names its attached source


def test_reader_gives_back_the_run(meeting: LoggedMeeting) -> None:
    run = load_run(meeting.log)
    assert set(run.humans) == {"alice", "bob"}
    alice = run.humans["alice"]
    count = len(alice.time)
    assert alice.position.shape == (count, 2) and alice.velocity.shape == (count, 2)
    assert alice.heading.shape == alice.posture.shape == alice.status.shape == (count,)
    # the first frame is the start, before the first step; then alice walks
    assert alice.status[0] == "IDLE" and alice.fsm_state[0] == "idle"
    assert alice.status[1] == "ACTIVE" and alice.fsm_state[1] == "walking"
    assert alice.task_id[1] == 1
    assert alice.status[-1] == "SUCCEEDED" and alice.task_id[-1] == 0
    assert np.linalg.norm(alice.position[-1] - [8.0, 2.0]) < 0.3
    assert {"walking", "aligning", "talking", "idle"} <= set(alice.fsm_state.tolist())
    # velocity is what moved the human between frames
    step = np.diff(alice.position, axis=0) / np.diff(alice.time)[:, None]
    moving = np.linalg.norm(step, axis=1) > 0.5
    assert np.allclose(step[moving], alice.velocity[1:][moving], atol=0.35)
    assert [e.status for e in run.events] == [e.status for e in meeting.result.events]
    assert run.events[0].span is not None and run.events[0].span.line == 18
    assert run.robots["r2"].position[0] == pytest.approx([2.5, 3.5])
    assert run.result is not None and run.result.succeeded
    assert run.result.state == "completed"
    assert run.result.expectations[0]["held"] is True
    assert [line.level for line in run.log] == [s.LOG_INFO] * 3


def test_metadata_says_what_made_the_run(meeting: LoggedMeeting) -> None:
    program = compile_file(meeting.scenario)
    metadata = load_run(meeting.log).metadata
    text = meeting.scenario.read_text(encoding="utf-8")
    assert metadata.hubero_version == __version__
    assert metadata.format_version == s.FORMAT_VERSION
    assert metadata.source == text
    assert metadata.source_sha256 == hashlib.sha256(text.encode()).hexdigest()
    assert metadata.seed == 5 and metadata.variant == "fast"
    assert metadata.variants == ("slow", "fast")
    assert metadata.step == 0.05 and metadata.log_rate_hz == 10.0
    assert metadata.humans == ("alice", "bob") and metadata.robots == ("r2",)
    params = metadata.params
    assert params["alice"]["speed"] == 1.5  # the variant's
    assert params["bob"]["speed"] == 1.5
    assert params["bob"]["personal_space"] == Ellipse(0.8, 0.5, 0.2)
    assert params["alice"]["global_planner"] == "navfn"
    # the map as the file writes it, the scenario by its name: the same wherever they lie
    assert metadata.map_path == "room.yaml" and program.map_path.is_absolute()
    assert metadata.source_path == meeting.scenario.name


def test_a_drawn_parameter_is_recorded_as_drawn(world: World, tmp_path: Path) -> None:
    log = tmp_path / "meeting.mcap"
    write_log(world.scenario("drawn.hub", "\n".join(
        line for line in MEETING.splitlines() if not line.startswith("variant"))), log)
    speed = load_run(log).metadata.params["bob"]["speed"]
    assert isinstance(speed, float) and speed != 1.2 and abs(speed - 1.2) < 0.5


def test_source_and_map_are_attached(meeting: LoggedMeeting, tmp_path: Path) -> None:
    run = load_run(meeting.log)
    folder = meeting.scenario.parent
    assert run.attachments["source/meeting.hub"] == meeting.scenario.read_bytes()
    assert run.attachments["map/room.yaml"] == (folder / "room.yaml").read_bytes()
    assert run.attachments["map/room.pgm"] == (folder / "room.pgm").read_bytes()
    # the attached map alone loads into the grid the run used, which /map also holds
    for name in ("room.yaml", "room.pgm"):
        (tmp_path / name).write_bytes(run.attachments[f"map/{name}"])
    attached = load_map(tmp_path / "room.yaml")
    assert np.array_equal(attached.occupied, run.grid.occupied)
    assert run.grid.resolution == attached.resolution == 0.1
    assert run.grid.origin == attached.origin == (0.0, 0.0)


def test_map_message_is_the_grid(meeting: LoggedMeeting) -> None:
    (grid,) = [value for topic, _, _, value in messages(meeting.log) if topic == "/map"]
    assert grid["frame_id"] == "map" and grid["column_count"] == 100
    assert grid["row_stride"] == 100 and grid["cell_stride"] == 1
    assert grid["fields"] == [{"name": "occupancy", "offset": 0, "type": 2}]
    cells = np.frombuffer(__import__("base64").b64decode(grid["data"]), np.int8)
    assert cells.size == 80 * 100 and set(np.unique(cells).tolist()) == {0, 100}
    assert cells.reshape(80, 100)[31, 50] == 100  # the box wall, rows from the lowest y
    assert cells.reshape(80, 100)[40, 50] == 0


def test_scene_draws_bodies_spaces_plans_and_robots(meeting: LoggedMeeting) -> None:
    scenes = [value for topic, _, _, value in messages(meeting.log) if topic == "/scene"]
    assert len(scenes) >= 2
    ids = [entity["id"] for entity in scenes[0]["entities"]]
    assert ids == ["human/alice", "human/bob", "plan/alice", "plan/bob", "robot/r2"]
    by_id = {entity["id"]: entity for entity in scenes[1]["entities"]}
    bob = by_id["human/bob"]
    assert bob["frame_id"] == "human/bob" and bob["frame_locked"] is True
    assert bob["texts"][0]["text"] == "bob"
    assert len(bob["cylinders"]) == 1 and bob["cylinders"][0]["size"]["z"] == 1.7
    (space,) = bob["lines"]
    assert space["type"] == 1  # LINE_LOOP
    xs = [p["x"] for p in space["points"]]
    assert max(xs) == pytest.approx(0.6) and min(xs) == pytest.approx(-1.0)  # offset 0.2
    plan = by_id["plan/alice"]
    assert plan["frame_id"] == "map" and plan["spheres"][0]["pose"]["position"]["x"] == 8.0
    final = {entity["id"]: entity for entity in scenes[-1]["entities"]}
    assert final["plan/alice"]["spheres"] == final["plan/alice"]["lines"] == []


def test_tf_places_every_frame_in_map(meeting: LoggedMeeting) -> None:
    frames = [value for topic, _, _, value in messages(meeting.log) if topic == "/tf"]
    poses = [value for topic, _, _, value in messages(meeting.log)
             if topic == "/humans/alice/pose"]
    assert len(frames) == len(poses)
    last = frames[-1]["transforms"]
    assert [t["child_frame_id"] for t in last] == ["human/alice", "human/bob", "robot/r2"]
    assert {t["parent_frame_id"] for t in last} == {"map"}
    alice = last[0]
    assert alice["translation"] == {"x": poses[-1]["pose"]["position"]["x"],
                                    "y": poses[-1]["pose"]["position"]["y"], "z": 0}
    assert alice["rotation"] == poses[-1]["pose"]["orientation"]
    heading = 2 * math.atan2(alice["rotation"]["z"], alice["rotation"]["w"])
    assert heading == pytest.approx(load_run(meeting.log).humans["alice"].heading[-1],
                                    abs=1e-4)


def test_an_aborted_task_is_a_warning_on_log(world: World, tmp_path: Path) -> None:
    log = tmp_path / "blocked.mcap"
    result = write_log(world.scenario("blocked.hub", BLOCKED), log)
    assert not result.succeeded
    run = load_run(log)
    warnings = [line for line in run.log if line.level == s.LOG_WARNING]
    assert len(warnings) == 1 and "alice move_to aborted" in warnings[0].message
    assert warnings[0].line == 7
    assert run.events[-1].status is TaskStatus.ABORTED
    # the abort stopped the run in the tick it started: no frame came after it
    assert run.events[-1].time == run.humans["alice"].time[-1] == 0.0
    assert run.result is not None and run.result.state == "failed"
    assert run.log[-1].level == s.LOG_ERROR


def test_messages_are_canonical_json(meeting: LoggedMeeting) -> None:
    with meeting.log.open("rb") as stream:
        reader = make_reader(stream)
        for _, channel, message in reader.iter_messages():
            text = message.data.decode("ascii")  # ASCII only: other text is \u-escaped
            assert "\n" not in text
            json.loads(text, object_pairs_hook=_sorted_keys(channel.topic))


def _sorted_keys(topic: str) -> Any:
    def check(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
        keys = [key for key, _ in pairs]
        assert keys == sorted(keys), f"{topic}: keys not sorted: {keys}"
        return dict(pairs)
    return check
