"""`hubero export --ros2`: every shipped scenario's log as a ROS 2 bag, read back with rosbags
(types, counts, values equal to the log's), and bad input refused without a half-written bag."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from hubero_dsl.analysis import ros2
from hubero_dsl.errors import InputError, LogError
from hubero_dsl.log.reader import LoggedRun, load_run
from hubero_dsl.pipeline import compile_file
from hubero_dsl.simulate import simulate

rosbag2 = pytest.importorskip("rosbags.rosbag2")

ROOT = Path(__file__).resolve().parents[2]
SCENARIOS = sorted((ROOT / "scenarios").glob("*.hub"))
TOPICS = {"/clock": "rosgraph_msgs/msg/Clock", "/map": "nav_msgs/msg/OccupancyGrid",
          "/tf": "tf2_msgs/msg/TFMessage", "/people": "people_msgs/msg/People",
          "/people/poses": "geometry_msgs/msg/PoseArray",
          "/robots/poses": "geometry_msgs/msg/PoseArray",
          "/people/markers": "visualization_msgs/msg/MarkerArray"}


def _read_bag(folder: Path) -> tuple[Any, dict[str, list[tuple[int, Any]]]]:
    """The bag's reader (for its info) and every message, deserialised, by topic."""
    typestore = ros2._typestore()
    messages: dict[str, list[tuple[int, Any]]] = {}
    with rosbag2.Reader(folder) as reader:  # what `ros2 bag info` shows, then the messages
        info = {"topics": {c.topic: c.msgtype for c in reader.connections},
                "message_count": reader.message_count, "duration": reader.duration}
        for connection, time, data in reader.messages():
            messages.setdefault(connection.topic, []).append(
                (time, typestore.deserialize_cdr(data, connection.msgtype)))
    return info, messages


@pytest.fixture(scope="module", params=SCENARIOS, ids=lambda p: p.name)
def exported(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory
             ) -> tuple[LoggedRun, Any, dict[str, list[tuple[int, Any]]]]:
    folder = tmp_path_factory.mktemp("bag")
    log = folder / "run.mcap"
    simulate(compile_file(request.param), log=log, writer_process=False)
    ros2.export_ros2(log, folder / "bag")
    reader, messages = _read_bag(folder / "bag")
    return load_run(log), reader, messages


def test_the_bag_has_the_standard_topics_and_types(
        exported: tuple[LoggedRun, Any, dict[str, list[tuple[int, Any]]]]) -> None:
    run, reader, messages = exported
    assert reader["topics"] == TOPICS
    assert reader["message_count"] == sum(len(m) for m in messages.values())
    frames = len(messages["/clock"])
    assert frames > 1 and len(messages["/map"]) == 1
    assert all(len(messages[topic]) == frames for topic in TOPICS if topic != "/map")
    assert reader["duration"] == messages["/clock"][-1][0] - messages["/clock"][0][0] + 1
    assert run.result is not None
    assert messages["/clock"][-1][0] == pytest.approx(run.result.time * 1e9, abs=1e6)


def test_people_and_frames_equal_the_log(
        exported: tuple[LoggedRun, Any, dict[str, list[tuple[int, Any]]]]) -> None:
    run, _, messages = exported
    for (time, people), (_, tf) in zip(messages["/people"], messages["/tf"], strict=True):
        assert people.header.stamp.sec * 10**9 + people.header.stamp.nanosec == time
        seconds = time / 1e9
        for person in people.people:
            track = run.humans[person.name]
            row = int(np.argmin(np.abs(track.time - seconds)))
            assert track.time[row] == pytest.approx(seconds, abs=1e-6)
            assert (person.position.x, person.position.y) == pytest.approx(
                tuple(track.position[row]), abs=1e-3)
            assert (person.velocity.x, person.velocity.y) == pytest.approx(
                tuple(track.velocity[row]), abs=1e-3)
        frames = {t.child_frame_id for t in tf.transforms}
        assert {f"human/{p.name}" for p in people.people} <= frames
        assert all(t.header.frame_id == "map" for t in tf.transforms)
    robots = {f"robot/{name}" for name in run.robots}
    assert robots <= {t.child_frame_id for t in messages["/tf"][-1][1].transforms}


def test_the_map_is_the_logs_grid(
        exported: tuple[LoggedRun, Any, dict[str, list[tuple[int, Any]]]]) -> None:
    run, _, messages = exported
    grid = messages["/map"][0][1]
    rows, cols = run.grid.shape
    assert (grid.info.height, grid.info.width) == (rows, cols)
    assert grid.info.resolution == pytest.approx(run.grid.resolution)
    assert (grid.info.origin.position.x, grid.info.origin.position.y) == pytest.approx(
        run.grid.origin)
    cells = np.asarray(grid.data).reshape(rows, cols)
    assert ((cells == 100) | (cells == -1))[run.grid.occupied].all()
    assert (cells[~run.grid.occupied] == 0).all()
    if run.grid.unknown is not None:
        assert (cells[run.grid.unknown] == -1).all()


def test_markers_replace_the_picture_each_frame(
        exported: tuple[LoggedRun, Any, dict[str, list[tuple[int, Any]]]]) -> None:
    _, _, messages = exported
    for (_, markers), (_, people) in zip(messages["/people/markers"], messages["/people"],
                                         strict=True):
        assert markers.markers[0].action == 3  # DELETEALL
        labels = {m.text for m in markers.markers if m.ns == "labels"}
        assert {p.name for p in people.people} <= labels


def test_a_failed_export_leaves_nothing(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    log = tmp_path / "run.mcap"
    simulate(compile_file(ROOT / "scenarios" / "living_room.hub"), log=log,
             writer_process=False)

    def broken(*_: Any) -> None:
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(ros2, "_write", broken)
    with pytest.raises(InputError, match=r"/bag: cannot be written \(No space left on device\)"):
        ros2.export_ros2(log, tmp_path / "bag")  # the bag asked for, not a scratch folder
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.mcap"]
    with pytest.raises(LogError):
        ros2.export_ros2(tmp_path / "missing.mcap", tmp_path / "bag")
    (tmp_path / "full").mkdir()
    (tmp_path / "full" / "x").write_text("x")
    with pytest.raises(InputError):
        ros2.export_ros2(log, tmp_path / "full")


def test_frames_nobody_is_in_are_in_the_bag_too(tmp_path: Path) -> None:
    # a flow alone: before its first person comes and after its last leaves, the frames had
    # no /clock, and nothing told RViz that the last people had gone
    scenario = tmp_path / "flow.hub"
    scenario.write_text(f'scenario "flow"\nmap "{ROOT / "maps" / "station.yaml"}"\nseed 3\n'
                        "time_limit 2 min\n"
                        "flow boarding from rect((31.0, 1.0), (34.5, 13.0)) to (15.0, 18.0) "
                        "rate 4 /min for 1 min\n", encoding="utf-8")
    log = tmp_path / "run.mcap"
    simulate(compile_file(scenario), log=log, writer_process=False)
    ros2.export_ros2(log, tmp_path / "bag")
    _, messages = _read_bag(tmp_path / "bag")
    run = load_run(log)
    assert [time for time, _ in messages["/clock"]] == run.frames.tolist()
    first_arrival = min(float(track.time[0]) for track in run.humans.values() if len(track.time))
    assert messages["/clock"][0][0] == 0 and first_arrival > 1.0
    assert messages["/people"][0][1].people == [] and messages["/people"][-1][1].people == []
    last = messages["/people/markers"][-1][1].markers
    assert [m.action for m in last] == [3]          # everyone deleted, nobody drawn
