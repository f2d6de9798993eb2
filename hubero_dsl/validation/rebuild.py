"""An experiment rebuilt as a hubero scenario, run, and read back as a PedPy trajectory.

    trajectory = simulate_experiment(experiment, measured, speeds, seed=1, start=500)

The scenario is a `Program` built in code: the map is the experiment's room rasterised
(`hubero_dsl.world.raster`), every person measured at a start frame stands where they were
measured, facing the walking direction, and walks to a goal of their own in the room
beyond the exit (goals on a lattice, the first to leave going furthest), so that nobody waits on
a goal another stands on and those who left never block the exit. Desired speeds are drawn from
the measured distribution (`desired_speeds`). The run is logged to MCAP, and the log's tracks are
turned into a `pedpy.TrajectoryData` of the part of the room that was measured, so that the run
is analysed exactly as the recording is.
"""

from __future__ import annotations

import math
import tempfile
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import pandas as pd
import shapely
from shapely.geometry import Polygon
from shapely.geometry.base import BaseGeometry

from hubero_dsl.diagnostics import SourceFile, Span
from hubero_dsl.graph.build import build_activity_graph
from hubero_dsl.model.activities import Activity, ParallelStep, TaskStep
from hubero_dsl.model.program import HumanSpec, ParamLayer, ParamValue, Pose, Program
from hubero_dsl.model.tasks import Task
from hubero_dsl.validation.experiments import Experiment, pedpy
from hubero_dsl.world.mapfile import save_map
from hubero_dsl.world.raster import grid_from_walkable

FloatArray = npt.NDArray[np.float64]
LOG_RATE = 10.0         # Hz: frames of the simulated trajectory
GOAL_SPACING = 0.7      # m between goals in the room beyond the exit
BODY_RADIUS = 0.2       # m, hubero's default body
SNAPSHOT = 10.0         # s each rebuild runs from its start frame


def desired_speeds(trajectory: Any, experiment: Experiment) -> FloatArray:
    """Each measured person's desired speed: their mean speed along the walking direction
    over their whole track (PedPy's individual speed), sorted. Taken from a free-flow recording
    it is the speed people choose when nobody is in their way."""
    p = pedpy()
    speed = p.compute_individual_speed(
        traj_data=trajectory, frame_step=max(1, round(trajectory.frame_rate / 2)),
        movement_direction=np.array(experiment.direction),
        speed_calculation=p.SpeedCalculation.BORDER_SINGLE_SIDED)
    return np.sort(speed.groupby("id")["speed"].mean().to_numpy(dtype=np.float64))


def start_frames(experiment: Experiment, measured: Any) -> list[int]:
    """The frames rebuilds start from: every SNAPSHOT seconds through the steady state (the
    whole recording when it has none), so that together they sample its densities."""
    frames = measured.data["frame"]
    first, last = experiment.steady or (int(frames.min()), int(frames.max()))
    spacing = round(SNAPSHOT * experiment.frame_rate)
    return list(range(first, max(first, last - spacing) + 1, spacing))


def rebuild_program(experiment: Experiment, measured: Any, speeds: FloatArray, *,
                    seed: int, start: int, params: Mapping[str, ParamValue] | None = None,
                    map_path: Path) -> Program:
    """The experiment from frame `start` on, as a program; its map is written to `map_path`
    (the log attaches it)."""
    grid = grid_from_walkable(experiment.room, source=str(map_path))
    save_map(grid, map_path, comment=f"{experiment.name}: rebuilt from its geometry")
    present = measured.data[measured.data["frame"] == start]
    present = present[shapely.contains_xy(experiment.walkable, present["x"].to_numpy(),
                                          present["y"].to_numpy())]
    rng = np.random.default_rng([seed, start])
    drawn = rng.choice(speeds, size=len(present)) if len(speeds) else np.full(len(present), 1.3)
    goals = _goals(experiment, len(present))
    order = np.argsort(_progress(experiment, present[["x", "y"]].to_numpy()))[::-1]
    span = Span.whole_file(experiment.name)
    heading = math.atan2(experiment.direction[1], experiment.direction[0])
    humans, steps = [], []
    for rank, index in enumerate(order):
        row = present.iloc[int(index)]
        name = f"p{int(row['id'])}"
        where, _ = grid.nearest_free((float(row["x"]), float(row["y"])), BODY_RADIUS)
        speed = float(drawn[index])
        layer = ParamLayer({"speed": speed, "max_speed": max(1.8, 1.3 * speed)})
        humans.append(HumanSpec(name, Pose(where[0], where[1], heading), layer, span))
        steps.append(TaskStep(name, Task("move_to", tuple(goals[rank]), {}, span), None, None,
                              False, span, f"{name} move_to goal"))
    activity = Activity("rebuild", (ParallelStep(tuple(steps), span),), span, span)
    return Program(
        source=SourceFile(experiment.name, _description(experiment, start, len(humans), seed)),
        title=f"{experiment.name} rebuilt", map_path=map_path, grid=grid, seed=seed,
        step=0.05, time_limit=SNAPSHOT, on_failure="continue", bounds=None, places={},
        areas={}, defaults=ParamLayer(dict(params or {})), humans=tuple(humans), robots=(),
        variants={}, activities=(activity,), expectations=(),
        graph=build_activity_graph([activity]))


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
                        seed: int, start: int,
                        params: Mapping[str, ParamValue] | None = None) -> Any:
    """Rebuild from frame `start`, run and read back one experiment, in a temporary folder."""
    with tempfile.TemporaryDirectory(prefix="hubero-validate-") as folder:
        program = rebuild_program(experiment, measured, speeds, seed=seed, start=start,
                                  params=params,
                                  map_path=Path(folder) / f"{experiment.name}.yaml")
        return run_rebuild(program, experiment, Path(folder) / "run.mcap")
