"""Small worlds and runs for the log tests: a 10 m x 8 m room, two humans and a robot."""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from hubero_dsl.log.writer import RunLog
from hubero_dsl.pipeline import compile_file
from hubero_dsl.sim.loop import RunResult, run_program
from hubero_dsl.sim.simulation import Simulation
from hubero_dsl.world.grid import OccupancyGrid
from hubero_dsl.world.mapfile import save_map

REPO_ROOT = Path(__file__).resolve().parents[2]

MEETING = """\
scenario "log test: a meeting"
map "room.yaml"
seed 5
step 50 ms
time_limit 30 s
human alice at (1, 1) heading 0 deg
human bob at (8, 6) {
    personal_space ellipse(semi_major: 0.8 m, semi_minor: 0.5 m, offset: 0.2 m)
    speed normal(1.2 m/s, 0.1 m/s)
}
robot r2 at (2.5, 3.5) {
    path (2.5, 3.5) -> (3.5, 3.5) loop
    speed 0.5 m/s
}
variant slow { speed 0.8 m/s }
variant fast { speed 1.5 m/s }
activity main {
    go: alice move_to (8, 2) heading 90 deg
    parallel {
        alice talk to bob for 1 s
        bob move_to (2, 6)
    }
}
expect alice reaches (8, 2) within 20 s
"""

# Times out at exactly 3 s (60 ticks of 50 ms): frame counts are known in advance.
WAITING = """\
scenario "log test: waiting"
map "room.yaml"
step 50 ms
time_limit 3 s
human alice at (1, 1)
activity main {
    alice stand for 10 s
}
"""

# The goal is inside the walled box, free but out of reach: the task is aborted, the run fails.
BLOCKED = """\
scenario "log test: blocked"
map "room.yaml"
step 50 ms
time_limit 10 s
human alice at (1, 1)
activity main {
    alice move_to (5.0, 4.0)
}
"""

# Long enough (200 000 ticks) to be interrupted while it runs.
ENDLESS = """\
scenario "log test: endless"
map "room.yaml"
step 10 ms
time_limit 3000 s
human alice at (1, 1)
activity main {
    alice stand for 2000 s
}
"""


def write_room(folder: Path) -> Path:
    """A walled 10 m x 8 m room at 0.1 m with a closed box around (5, 4)."""
    occupied = np.zeros((80, 100), dtype=bool)
    occupied[[0, -1], :] = occupied[:, [0, -1]] = True
    occupied[30:50, 45:55] = True  # a walled box, x 4.5-5.5 and y 3-5, free inside
    occupied[33:47, 47:53] = False  # room for a body of 0.2 m at (5, 4)
    return save_map(OccupancyGrid(occupied, 0.1, (0.0, 0.0)), folder / "room.yaml")


@dataclass(frozen=True)
class World:
    folder: Path

    def scenario(self, name: str, text: str) -> Path:
        path = self.folder / name
        path.write_text(text, encoding="utf-8")
        return path


@pytest.fixture(scope="session")
def world(tmp_path_factory: pytest.TempPathFactory) -> World:
    folder = tmp_path_factory.mktemp("world")
    write_room(folder)
    return World(folder)


def write_log(scenario: Path, output: Path, *, variant: str | None = None,
              seed: int | None = None, rate_hz: float = 10.0,
              writer_process: bool | None = None) -> RunResult:
    """Run `scenario` in this process with a log, as `hubero run -o` does."""
    sim = Simulation(compile_file(scenario), variant=variant, seed=seed)
    with RunLog(output, sim, rate_hz=rate_hz, writer_process=writer_process) as log:
        result = run_program(sim, [log.observe])
        log.close(result)
    return result


@dataclass(frozen=True)
class LoggedMeeting:
    scenario: Path
    log: Path
    result: RunResult


@pytest.fixture(scope="session")
def meeting(world: World, tmp_path_factory: pytest.TempPathFactory) -> LoggedMeeting:
    """The meeting scenario, run once (variant fast) with a 10 Hz log."""
    scenario = world.scenario("meeting.hub", MEETING)
    log = tmp_path_factory.mktemp("logs") / "meeting.mcap"
    result = write_log(scenario, log, variant="fast")
    return LoggedMeeting(scenario, log, result)


def hubero(*argv: str, cwd: Path | None = None, timeout: float = 60,
           **env: str) -> subprocess.CompletedProcess[str]:
    """`python -m hubero_dsl ARGV` in a fresh interpreter."""
    environment = {k: v for k, v in os.environ.items()
                   if k not in ("FORCE_COLOR", "HUBERO_DEBUG")}
    environment.update(env)
    return subprocess.run([sys.executable, "-m", "hubero_dsl", *argv], cwd=cwd,
                          env=environment, capture_output=True, text=True, timeout=timeout,
                          check=False)


@pytest.fixture
def cli() -> Callable[..., subprocess.CompletedProcess[str]]:
    return hubero
