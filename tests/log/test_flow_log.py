"""The log of a run with a flow: people are logged only while they are in the scene, and the
scene adds and deletes them; the file stays valid MCAP, read back with the mcap library."""

from __future__ import annotations

import json
import shutil
import subprocess
from collections import defaultdict
from pathlib import Path

import pytest
from mcap.reader import make_reader

from hubero_dsl.pipeline import compile_file
from hubero_dsl.sim.status import TaskStatus
from hubero_dsl.simulate import simulate
from tests.log.conftest import write_room

SCENARIO = """scenario "flow log"
map "room.yaml"
seed 2
time_limit 1 min
human host at (5, 7)
flow f from rect((0.5, 0.5), (2.5, 7.5)) to (9.0, 4.0) rate 1 /s for 8 s
activity { host stand for 2 s }
"""


@pytest.fixture(scope="module")
def flow_log(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict[str, tuple[int, int]]]:
    """The log, and each member's (arrival, departure) in nanoseconds of simulated time."""
    folder = tmp_path_factory.mktemp("flow")
    write_room(folder)
    scenario = folder / "flow.hub"
    scenario.write_text(SCENARIO, encoding="utf-8")
    log = folder / "flow.mcap"
    result = simulate(compile_file(scenario), log=log, writer_process=False)
    times: dict[str, list[int]] = defaultdict(list)
    for event in result.events:
        if event.human.startswith("f_") and (event.status is TaskStatus.ACTIVE
                                             or event.status.is_final):
            times[event.human].append(round(event.time * 1e9))
    return log, {name: (t[0], t[-1]) for name, t in times.items()}


def _messages(log: Path) -> list[tuple[str, int, bytes]]:
    with log.open("rb") as stream:
        return [(channel.topic, message.log_time, message.data)
                for _, channel, message in make_reader(stream).iter_messages()]


def test_people_are_logged_only_while_they_are_in_the_scene(
        flow_log: tuple[Path, dict[str, tuple[int, int]]]) -> None:
    log, present = flow_log
    assert len(present) >= 3
    poses: dict[str, list[int]] = defaultdict(list)
    for topic, time, _ in _messages(log):
        if topic.startswith("/humans/f_") and topic.endswith("/pose"):
            poses[topic.split("/")[2]].append(time)
    assert set(poses) == set(present)  # the members who never came have no messages
    for name, (arrival, departure) in present.items():
        assert arrival - 1e8 <= min(poses[name]) and max(poses[name]) <= departure + 1e8


def test_the_scene_adds_and_deletes_people(
        flow_log: tuple[Path, dict[str, tuple[int, int]]]) -> None:
    log, present = flow_log
    scenes = [(time, json.loads(data)) for topic, time, data in _messages(log)
              if topic == "/scene"]
    assert all(s["deletions"] and s["deletions"][0]["type"] == 1 for _, s in scenes)
    shown = {time: {e["id"] for e in s["entities"]} for time, s in scenes}
    first = min(present, key=lambda n: present[n][0])
    arrival, departure = present[first]
    times = sorted(shown)
    before = max(t for t in times if t < arrival)
    during = max(t for t in times if t <= (arrival + departure) // 2)
    after = min(t for t in times if t > departure)
    assert f"human/{first}" not in shown[before]
    assert f"human/{first}" in shown[during]
    assert f"human/{first}" not in shown[after]
    assert all("human/host" in ids for ids in shown.values())


def test_transforms_name_only_the_people_present(
        flow_log: tuple[Path, dict[str, tuple[int, int]]]) -> None:
    log, present = flow_log
    margin = 100_000_000  # a frame is sampled at 10 Hz: arrivals fall between frames
    for topic, time, data in _messages(log):
        if topic != "/tf":
            continue
        frames = {t["child_frame_id"] for t in json.loads(data)["transforms"]}
        members = {f.removeprefix("human/") for f in frames} - {"host"}
        assert all(present[m][0] - margin <= time <= present[m][1] + margin for m in members)
        inside = {n for n, (a, d) in present.items() if a + margin < time < d - margin}
        assert inside <= members


@pytest.mark.skipif(shutil.which("pymcap-cli") is None and not (
    Path(__file__).parents[2] / ".venv/bin/pymcap-cli").exists(),
    reason="pymcap-cli is not installed")
def test_mcap_doctor_accepts_a_log_with_absent_people(
        flow_log: tuple[Path, dict[str, tuple[int, int]]]) -> None:
    found = shutil.which("pymcap-cli") or str(Path(__file__).parents[2] / ".venv/bin/pymcap-cli")
    done = subprocess.run([found, "doctor", str(flow_log[0])], capture_output=True, text=True,
                          timeout=120, check=False)
    assert done.returncode == 0, done.stdout + done.stderr
