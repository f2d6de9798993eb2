"""Runs for the analysis tests: tiny synthetic `LoggedRun`s whose metrics can be worked out by
hand, and real logs of the living-room scenario (run once per variant per test session)."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from hubero_dsl.cli.run import run_one
from hubero_dsl.diagnostics import Span
from hubero_dsl.log.reader import HumanTrack, LoggedRun, RobotTrack, RunMetadata
from hubero_dsl.pipeline import compile_file
from hubero_dsl.sim.status import TaskEvent, TaskStatus
from hubero_dsl.world.grid import OccupancyGrid

REPO_ROOT = Path(__file__).resolve().parents[2]

Track = tuple[Sequence[float], Sequence[Sequence[float]], Sequence[float]]  # time, xy, heading


def human_track(name: str, time: Sequence[float], position: Sequence[Sequence[float]],
                heading: Sequence[float] | float = 0.0, status: str = "SUCCEEDED") -> HumanTrack:
    t = np.asarray(time, dtype=np.float64)
    xy = np.asarray(position, dtype=np.float64).reshape(-1, 2)
    yaw = np.broadcast_to(np.asarray(heading, dtype=np.float64), t.shape).copy()
    velocity = np.zeros_like(xy)
    return HumanTrack(name=name, time=t, position=xy, velocity=velocity, heading=yaw,
                      posture=np.zeros(len(t), dtype=np.int8),
                      status=np.array([status] * len(t), dtype=np.str_),
                      fsm_state=np.array(["walking"] * len(t), dtype=np.str_),
                      task_id=np.zeros(len(t), dtype=np.int64))


def robot_track(name: str, time: Sequence[float],
                position: Sequence[Sequence[float]]) -> RobotTrack:
    t = np.asarray(time, dtype=np.float64)
    return RobotTrack(name, t, np.asarray(position, dtype=np.float64).reshape(-1, 2),
                      np.zeros(len(t)))


def task_event(human: str, task_id: int, kind: str, status: TaskStatus, time: float,
               line: int, column: int) -> TaskEvent:
    return TaskEvent(tick=round(time * 20), time=time, task_id=task_id, human=human, kind=kind,
                     status=status, reason="",
                     span=Span("x.hub", line, column, line, column + 10))


def make_run(humans: Sequence[HumanTrack], *, params: dict[str, dict[str, Any]] | None = None,
             robots: Sequence[RobotTrack] = (), events: Sequence[TaskEvent] = (),
             source: str = "", variant: str | None = None, seed: int = 1,
             title: str = "synthetic") -> LoggedRun:
    """A `LoggedRun` as `load_run` would give it, on an empty 10 m x 10 m map."""
    params = params or {}
    metadata = RunMetadata(
        format_version=1, hubero_version="test", title=title, source_path="x.hub",
        source_sha256=str(hash(source)), source=source, map_path="map.yaml", seed=seed,
        variant=variant, variants=(), params={h.name: dict(params.get(h.name, {}))
                                              for h in humans},
        step=0.05, time_limit=60.0, log_rate_hz=2.0, humans=tuple(h.name for h in humans),
        robots=tuple(r.name for r in robots))
    grid = OccupancyGrid(np.zeros((100, 100), dtype=bool), 0.1, (-5.0, -5.0))
    return LoggedRun(path=Path(f"{title}.mcap"), metadata=metadata, grid=grid,
                     humans={h.name: h for h in humans}, robots={r.name: r for r in robots},
                     events=list(events), log=[], result=None, attachments={})


@pytest.fixture
def build_run() -> Callable[..., LoggedRun]:
    return make_run


@pytest.fixture
def track() -> Callable[..., HumanTrack]:
    return human_track


@pytest.fixture
def robot() -> Callable[..., RobotTrack]:
    return robot_track


@pytest.fixture
def event() -> Callable[..., TaskEvent]:
    return task_event


@pytest.fixture(scope="session")
def living_room_logs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """The paper's living room, one log per variant (circle, ellipse)."""
    folder = tmp_path_factory.mktemp("living_room")
    program = compile_file(REPO_ROOT / "scenarios" / "living_room.hub")
    logs = {}
    for variant in ("circle", "ellipse"):
        logs[variant] = folder / f"{variant}.mcap"
        run_one(program, variant, None, logs[variant], 10.0, quiet=True)
    return logs
