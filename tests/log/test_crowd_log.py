"""The log of a crowd: its members share two topics, and `load_run` gives each member back the
track the simulation had, frame by frame."""

from __future__ import annotations

import json
from collections import Counter
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader

from hubero_dsl.log.reader import load_run
from hubero_dsl.log.writer import RunLog
from hubero_dsl.pipeline import compile_file
from hubero_dsl.sim.loop import run_program
from hubero_dsl.sim.simulation import Simulation
from tests.log.conftest import World

SCENARIO = """\
scenario "log test: a crowd"
map "room.yaml"
seed 4
step 50 ms
time_limit 8 s
human guide at (9, 1) heading 90 deg
crowd visitors 8 in rect((1, 1), (4, 7)) { speed 1.0 m/s }
group pair of (visitors_1, visitors_2)
activity main {
    parallel {
        visitors move_to (8.0, 5.0)
        guide stand for 3 s
    }
}
"""


class Truth:
    """The engine's state at every tick, as the simulation had it."""

    def __init__(self) -> None:
        self.position: dict[int, np.ndarray] = {}
        self.heading: dict[int, np.ndarray] = {}

    def observe(self, sim: Simulation) -> None:
        humans = sim.engine.humans
        self.position[sim.engine.tick] = humans.position.copy()
        self.heading[sim.engine.tick] = humans.heading.copy()


@pytest.fixture(scope="module")
def crowd_run(world: World, tmp_path_factory: pytest.TempPathFactory
              ) -> tuple[Path, Truth, list[str]]:
    scenario = world.scenario("crowd.hub", SCENARIO)
    log = tmp_path_factory.mktemp("crowd") / "crowd.mcap"
    sim = Simulation(compile_file(scenario))
    truth = Truth()
    with RunLog(log, sim, writer_process=False) as run_log:
        truth.observe(sim)
        result = run_program(sim, [run_log.observe, truth.observe])
        run_log.close(result)
    return log, truth, list(sim.engine.humans.names)


def test_members_share_the_crowds_topics(crowd_run: tuple[Path, Truth, list[str]]) -> None:
    log, _, _ = crowd_run
    with log.open("rb") as stream:
        reader = make_reader(stream)
        counts = Counter(channel.topic for _, channel, _ in reader.iter_messages())
    frames = counts["/tf"]
    assert counts["/crowds/visitors/poses"] == counts["/crowds/visitors/state"] == frames
    assert counts["/humans/guide/state"] == frames
    assert not any(topic.startswith("/humans/visitors") for topic in counts)


def test_every_member_reads_back_as_simulated(crowd_run: tuple[Path, Truth, list[str]]
                                             ) -> None:
    log, truth, names = crowd_run
    run = load_run(log)
    assert set(run.humans) == set(names)
    assert run.metadata.format_version == 2
    for row, name in enumerate(names):
        track = run.humans[name]
        ticks = np.rint(track.time / 0.05).astype(int)
        assert len(ticks) == len(run.humans["guide"].time)  # a crowd is always present
        expected = np.array([truth.position[tick][row] for tick in ticks])
        assert np.abs(track.position - expected).max() <= 5e-5
        headings = np.array([truth.heading[tick][row] for tick in ticks])
        assert np.abs(np.angle(np.exp(1j * (track.heading - headings)))).max() <= 5e-5
    member = run.humans["visitors_3"]
    assert member.status[0] == "IDLE" and "ACTIVE" in member.status.tolist()
    assert "walking" in member.fsm_state.tolist()
    assert (member.task_id[member.status == "ACTIVE"] > 0).all()


def test_poses_follow_the_state(crowd_run: tuple[Path, Truth, list[str]]) -> None:
    log, _, _ = crowd_run
    with log.open("rb") as stream:
        messages = [(channel.topic, json.loads(message.data)) for _, channel, message
                    in make_reader(stream).iter_messages(topics=["/crowds/visitors/poses",
                                                                 "/crowds/visitors/state"])]
    poses = [m for topic, m in messages if topic.endswith("poses")]
    states = [m for topic, m in messages if topic.endswith("state")]
    for pose, state in zip(poses, states, strict=True):
        assert pose["frame_id"] == "map" and pose["timestamp"] == state["timestamp"]
        xy = [(p["position"]["x"], p["position"]["y"]) for p in pose["poses"]]
        assert xy == list(zip(state["x"], state["y"], strict=True))
        yaw = [2 * np.arctan2(p["orientation"]["z"], p["orientation"]["w"])
               for p in pose["poses"]]
        assert np.allclose(np.angle(np.exp(1j * (np.array(yaw) - state["heading"]))), 0,
                           atol=2e-4)
