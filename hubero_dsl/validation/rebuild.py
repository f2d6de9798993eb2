"""An experiment rebuilt as a hubero scenario, run, and read back as a PedPy trajectory.

    trajectory = simulate_experiment(experiment, measured, speeds, seed=1)

The scenario is a `Program` built in code: the map is the experiment's room rasterised
(`hubero_dsl.world.drawing.grid_from_walkable`); over the steady state, everyone in the room
at its first frame stands where they were measured, and everyone who came later enters at
their first measured frame and place (each person a flow of one with an explicit arrival time,
`hubero_dsl.sim.flows`); each walks to the far end of the room beyond the exit, level with where
they came in, and leaves the scene there, so that nobody waits on a goal another stands on.
Desired speeds are drawn from the measured distribution (`desired_speeds`). The run is logged
to MCAP, and the log's tracks are turned into a `pedpy.TrajectoryData` of the part of the room
that was measured, so that the run is analysed exactly as the recording is.
"""

from __future__ import annotations

import tempfile
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import pandas as pd
import shapely
from shapely.geometry import Polygon, box
from shapely.geometry.base import BaseGeometry

from hubero_dsl.diagnostics import SourceFile, Span
from hubero_dsl.errors import InputError
from hubero_dsl.graph.build import build_activity_graph
from hubero_dsl.model.program import (
    FlowSpec,
    HumanSpec,
    ParamLayer,
    ParamValue,
    Pose,
    Program,
)
from hubero_dsl.validation.experiments import Experiment, pedpy
from hubero_dsl.world.drawing import grid_from_walkable
from hubero_dsl.world.mapfile import save_map

FloatArray = npt.NDArray[np.float64]
LOG_RATE = 10.0         # Hz: frames of the simulated trajectory
GOAL_SPACING = 0.7      # m between goals in the room beyond the exit
BODY_RADIUS = 0.2       # m, hubero's default body


def desired_speeds(trajectory: Any, experiment: Experiment) -> FloatArray:
    """Each measured person's desired speed: their mean speed along the walking direction
    over their whole track (PedPy's individual speed), sorted. Taken from a free-flow recording
    it is the speed people choose when nobody is in their way. InputError for a recording
    with nobody measured long enough to have a speed."""
    p = pedpy()
    speed = p.compute_individual_speed(
        traj_data=trajectory, frame_step=max(1, round(trajectory.frame_rate / 2)),
        movement_direction=np.array(experiment.direction),
        speed_calculation=p.SpeedCalculation.BORDER_SINGLE_SIDED)
    speeds = speed.groupby("id")["speed"].mean().to_numpy(dtype=np.float64)
    speeds = speeds[np.isfinite(speeds)]  # someone measured in a single frame has no speed
    if not len(speeds):
        raise InputError(f"{experiment.path}: not a trajectory file hubero can read: nobody in "
                         f"it is measured long enough for a speed, from which the rebuilds' "
                         f"desired speeds are drawn")
    return np.sort(speeds)


def arrivals_program(experiment: Experiment, measured: Any, speeds: FloatArray, *,
                     seed: int, params: Mapping[str, ParamValue] | None = None,
                     map_path: Path) -> Program:
    """The experiment's steady state as measured, as a program: those in the room at its first
    frame stand where they were, everyone who came later enters at their first measured frame
    and place (each person a flow of one with an explicit arrival time), and everyone leaves the
    scene on reaching the far end of the room beyond the exit."""
    grid = grid_from_walkable(experiment.room, source=str(map_path))
    save_map(grid, map_path, comment=f"{experiment.name}: rebuilt from its geometry")
    frames = measured.data["frame"]
    first, last = experiment.steady or (int(frames.min()), int(frames.max()))
    entries = _entries(measured.data, experiment, first, last)
    rng = np.random.default_rng([seed, first])
    drawn = rng.choice(speeds, size=len(entries)) if len(speeds) else np.full(len(entries), 1.3)
    far = _goals(experiment, 1)[0]
    span = Span.whole_file(experiment.name)
    duration = (last - first) / experiment.frame_rate
    humans, flows = [], []
    for (person, frame, x, y), speed in zip(entries, drawn, strict=True):
        name = f"p{person}"
        (px, py), _ = grid.nearest_free((x, y), BODY_RADIUS)
        layer = ParamLayer({"speed": float(speed), "max_speed": max(1.8, 1.3 * float(speed))})
        humans.append(HumanSpec(name, Pose(px, py), layer, span, group=f"arrival_{person}"))
        # Each aims at the far end of the room beyond the exit level with where they came in,
        # not at one point: people keep to their side of a corridor (one shared goal would
        # pull everyone onto one line; measured lateral spread 0.38 m in free flow).
        target = _level_with(experiment, far, (px, py))
        flows.append(FlowSpec(f"arrival_{person}", box(px - 0.1, py - 0.1, px + 0.1, py + 0.1),
                              target, 1.0, (name,), span, duration=duration + 1.0,
                              arrivals=(max(0.0, (frame - first) / experiment.frame_rate),)))
    return Program(
        source=SourceFile(experiment.name, _description(experiment, first, len(humans), seed)),
        title=f"{experiment.name} rebuilt", map_path=map_path, grid=grid, seed=seed,
        step=0.05, time_limit=duration, on_failure="continue", bounds=None, places={},
        areas={}, defaults=ParamLayer(dict(params or {})), humans=tuple(humans), robots=(),
        variants={}, activities=(), expectations=(), graph=build_activity_graph([]),
        flows=tuple(flows))


def _entries(data: pd.DataFrame, experiment: Experiment, first: int,
             last: int) -> list[tuple[int, int, float, float]]:
    """(person, frame, x, y) of everyone in the steady window: where they were at its first
    frame, or where and when they were first measured after it."""
    inside = data[(data["frame"] >= first) & (data["frame"] <= last)]
    inside = inside[shapely.contains_xy(experiment.walkable, inside["x"].to_numpy(),
                                        inside["y"].to_numpy())]
    firsts = inside.sort_values(["id", "frame"]).groupby("id").head(1)
    return [(int(r.id), int(r.frame), float(r.x), float(r.y))
            for r in firsts.sort_values(["frame", "id"]).itertuples()]


def _level_with(experiment: Experiment, far: FloatArray,
                where: tuple[float, float]) -> tuple[float, float]:
    """The point of the far end of the sink across from `where` (the walking direction's
    normal coordinate of `where`, clamped inside the sink)."""
    dx = experiment.direction[0]
    parts = getattr(experiment.sink, "geoms", [experiment.sink])
    x0, y0, x1, y1 = max(parts, key=lambda part: part.area).bounds
    margin = GOAL_SPACING
    if dx == 0.0:   # walking along y: keep x
        return (float(np.clip(where[0], x0 + margin, x1 - margin)), float(far[1]))
    return (float(far[0]), float(np.clip(where[1], y0 + margin, y1 - margin)))


def _progress(experiment: Experiment, xy: FloatArray) -> FloatArray:
    """How far along the walking direction each point is."""
    return np.asarray(xy @ np.array(experiment.direction), dtype=np.float64)


def _goals(experiment: Experiment, count: int) -> FloatArray:
    """`count` goal points in the room beyond the exit, furthest first."""
    parts = getattr(experiment.sink, "geoms", [experiment.sink])
    room: Polygon = max(parts, key=lambda part: part.area)
    x0, y0, x1, y1 = room.bounds
    margin = GOAL_SPACING / 2
    xs = np.arange(x0 + margin, x1 - margin + 1e-9, GOAL_SPACING)
    ys = np.arange(y0 + margin, y1 - margin + 1e-9, GOAL_SPACING)
    lattice = np.stack(np.meshgrid(xs, ys), axis=-1).reshape(-1, 2)
    lattice = lattice[shapely.contains_xy(room, lattice[:, 0], lattice[:, 1])]
    order = np.lexsort((lattice[:, 0], -_progress(experiment, lattice)))
    lattice = lattice[order]
    if len(lattice) < count:  # more people than goals: some share, the room still holds them
        lattice = np.resize(lattice, (count, 2))
    return lattice[:count]


def _description(experiment: Experiment, frame: int, people: int, seed: int) -> str:
    return (f"# {experiment.name} rebuilt by hubero validate: {people} people placed where "
            f"they were measured at frame {frame}, seed {seed}\n")


def run_rebuild(program: Program, experiment: Experiment, log: Path) -> Any:
    """Run the program with its log and read the log back as a pedpy.TrajectoryData."""
    from hubero_dsl.log.reader import load_run
    from hubero_dsl.simulate import simulate

    simulate(program, log=log, log_rate=LOG_RATE, writer_process=False)
    return trajectory_from_log(load_run(log), experiment.walkable)


def trajectory_from_log(run: Any, walkable: BaseGeometry | None = None) -> Any:
    """A hubero run's human tracks as a pedpy.TrajectoryData, frames at the log's rate, ids
    numbered in name order; only points inside `walkable` when given (PedPy's Voronoi cells
    need points inside its walkable area)."""
    rate = run.metadata.log_rate_hz
    rows = []
    for number, (_, track) in enumerate(sorted(run.humans.items()), start=1):
        frame = np.rint(track.time * rate).astype(np.int64)
        rows.append(pd.DataFrame({"id": number, "frame": frame, "x": track.position[:, 0],
                                  "y": track.position[:, 1]}))
    data = pd.concat(rows, ignore_index=True).drop_duplicates(["id", "frame"])
    if walkable is not None:
        data = data[shapely.contains_xy(walkable, data["x"].to_numpy(), data["y"].to_numpy())]
    return pedpy().TrajectoryData(data=data.reset_index(drop=True), frame_rate=rate)


def simulate_experiment(experiment: Experiment, measured: Any, speeds: FloatArray, *,
                        seed: int, params: Mapping[str, ParamValue] | None = None) -> Any:
    """Rebuild, run and read back one experiment, in a temporary folder."""
    with tempfile.TemporaryDirectory(prefix="hubero-validate-") as folder:
        program = arrivals_program(experiment, measured, speeds, seed=seed, params=params,
                                   map_path=Path(folder) / f"{experiment.name}.yaml")
        return run_rebuild(program, experiment, Path(folder) / "run.mcap")
