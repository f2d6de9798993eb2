"""The log of a run with a flow: its members share the flow's topics, in which they appear only
while they are in the scene; the file stays valid MCAP, read back with the mcap library."""

from __future__ import annotations

import json
import shutil
import subprocess
from collections import defaultdict
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader

from hubero_dsl.log.reader import load_run
from hubero_dsl.model.program import flow_bound
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


MARGIN = 100_000_000  # ns: frames are sampled at 10 Hz, arrivals fall between them


def test_people_are_logged_only_while_they_are_in_the_scene(
        flow_log: tuple[Path, dict[str, tuple[int, int]]]) -> None:
    log, present = flow_log
    assert len(present) >= 3
    seen: dict[str, list[int]] = defaultdict(list)
    states = [(time, json.loads(data)) for topic, time, data in _messages(log)
              if topic == "/crowds/f/state"]
    poses = [json.loads(data) for topic, _, data in _messages(log) if topic == "/crowds/f/poses"]
    assert len(states) == len(poses) > 0
    for (time, state), pose in zip(states, poses, strict=True):
        assert len(pose["poses"]) == len(state["names"])
        for key in ("x", "y", "vx", "vy", "heading", "posture", "status", "fsm_state",
                    "task_id"):
            assert len(state[key]) == len(state["names"])
        for name in state["names"]:
            seen[name].append(time)
        inside = {n for n, (a, d) in present.items() if a + MARGIN < time < d - MARGIN}
        assert inside <= set(state["names"])
    assert set(seen) == set(present)  # the members who never came are in no message
    for name, (arrival, departure) in present.items():
        assert arrival - MARGIN <= min(seen[name]) and max(seen[name]) <= departure + MARGIN


def test_members_of_a_flow_have_no_topic_frame_or_entity_of_their_own(
        flow_log: tuple[Path, dict[str, tuple[int, int]]]) -> None:
    log, _ = flow_log
    messages = _messages(log)
    assert not any(topic.startswith("/humans/f_") for topic, _, _ in messages)
    assert any(topic == "/humans/host/state" for topic, _, _ in messages)
    for topic, _, data in messages:
        if topic == "/tf":
            assert {t["child_frame_id"] for t in json.loads(data)["transforms"]} == {
                "human/host"}
        elif topic == "/scene":
            assert {e["id"] for e in json.loads(data)["entities"]} == {"human/host",
                                                                        "plan/host"}


def test_the_tracks_read_back_follow_each_member(
        flow_log: tuple[Path, dict[str, tuple[int, int]]]) -> None:
    log, present = flow_log
    run = load_run(log)
    for name, (arrival, departure) in present.items():
        track = run.humans[name]
        assert arrival - MARGIN <= track.time[0] * 1e9
        assert track.time[-1] * 1e9 <= departure + MARGIN
        assert (np.diff(track.time) > 0).all()
        assert np.linalg.norm(track.position[-1] - (9.0, 4.0)) < 1.0  # they left at the target
    never = set(run.metadata.members("f")) - set(present)
    assert all(len(run.humans[name].time) == 0 for name in never)


def test_the_start_message_counts_the_people_a_flow_may_bring_apart(
        flow_log: tuple[Path, dict[str, tuple[int, int]]]) -> None:
    # it said "32 humans": the host and every row the flow may fill, most never filled
    log, present = flow_log
    bound = len(load_run(log).metadata.members("f"))
    assert len(present) < bound == flow_bound(1.0, 8.0)
    start = next(json.loads(data)["message"] for topic, _, data in _messages(log)
                 if topic == "/log")
    assert start == (f"run of 'flow log' started: no variant, seed 2, 1 humans and up to "
                     f"{bound} more from flow f, 0 robots")


@pytest.mark.skipif(shutil.which("pymcap-cli") is None and not (
    Path(__file__).parents[2] / ".venv/bin/pymcap-cli").exists(),
    reason="pymcap-cli is not installed")
def test_mcap_doctor_accepts_a_log_with_absent_people(
        flow_log: tuple[Path, dict[str, tuple[int, int]]]) -> None:
    found = shutil.which("pymcap-cli") or str(Path(__file__).parents[2] / ".venv/bin/pymcap-cli")
    done = subprocess.run([found, "doctor", str(flow_log[0])], capture_output=True, text=True,
                          timeout=120, check=False)
    assert done.returncode == 0, done.stdout + done.stderr
