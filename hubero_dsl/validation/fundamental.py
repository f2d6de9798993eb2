"""The fundamental diagram of a recording or a run, computed by PedPy.

    diagram = fundamental_diagram(trajectory, experiment)
    diagram.frames          # per frame: density, voronoi_density, speed, voronoi_speed, flow
    diagram.speeds          # individual speeds inside the measurement area
    diagram.line_flow       # people per second across the measurement line

Measured and simulated trajectories go through the same calls, so they are measured alike:
speeds along the walking direction over a window of half a second (`compute_individual_speed`),
classic and Voronoi density and speed in the measurement area (`compute_classic_density`,
`compute_voronoi_density`, `compute_voronoi_speed`; cells are not cut off, so that they cover
the area and the Voronoi speed of a sparse crowd is not diluted by uncovered area),
specific flow as Voronoi density times Voronoi speed (their J_s = rho v), and the flow across
the line from PedPy's N(t). Only frames in steady state count, and only those with someone in
the area.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt
import pandas as pd

from hubero_dsl.validation.experiments import Experiment, pedpy

FloatArray = npt.NDArray[np.float64]
SPEED_WINDOW = 0.5   # s: individual speeds over +-frame_step frames of this duration


@dataclass(frozen=True)
class Diagram:
    frames: pd.DataFrame   # frame, density, voronoi_density, speed, voronoi_speed, flow
    speeds: FloatArray     # individual speeds (m/s) in the area, steady frames
    line_flow: float       # people/s across the measurement line in the steady frames
    frame_rate: float

    @property
    def empty(self) -> bool:
        return len(self.frames) == 0


def pooled(diagrams: Sequence[Diagram]) -> Diagram:
    """Several runs of one experiment as one diagram: their frames and individual speeds
    together (each frame counts in its density bin as often as the runs have one), their
    flows across the line averaged."""
    if len(diagrams) == 1:
        return diagrams[0]
    return Diagram(frames=pd.concat([d.frames for d in diagrams], ignore_index=True),
                   speeds=np.concatenate([d.speeds for d in diagrams]),
                   line_flow=float(np.mean([d.line_flow for d in diagrams])),
                   frame_rate=diagrams[0].frame_rate)


def fundamental_diagram(trajectory: Any, experiment: Experiment,
                        steady: tuple[int, int] | None = None) -> Diagram:
    """The diagram of `trajectory` (a pedpy.TrajectoryData) in the experiment's area, over
    the `steady` frames (default: the experiment's, else every frame)."""
    p = pedpy()
    area = p.MeasurementArea(list(experiment.measurement_area.exterior.coords)[:-1])
    walkable = p.WalkableArea(list(experiment.walkable.exterior.coords)[:-1])
    step = max(1, round(SPEED_WINDOW * trajectory.frame_rate))
    speed = p.compute_individual_speed(
        traj_data=trajectory, frame_step=step,
        movement_direction=np.array(experiment.direction),
        speed_calculation=p.SpeedCalculation.BORDER_SINGLE_SIDED)
    classic = p.compute_classic_density(traj_data=trajectory, measurement_area=area)
    mean_speed = p.compute_mean_speed_per_frame(traj_data=trajectory, measurement_area=area,
                                                individual_speed=speed)
    cells = p.compute_individual_voronoi_polygons(
        traj_data=trajectory, walkable_area=walkable,
        cut_off=None)
    voronoi, intersecting = p.compute_voronoi_density(individual_voronoi_data=cells,
                                                      measurement_area=area)
    voronoi_speed = p.compute_voronoi_speed(traj_data=trajectory, individual_speed=speed,
                                            individual_voronoi_intersection=intersecting,
                                            measurement_area=area)
    parts = [classic, mean_speed, voronoi.rename(columns={"density": "voronoi_density"}),
             voronoi_speed.rename(columns={"speed": "voronoi_speed"})]
    frames = pd.concat([part.set_index("frame") for part in parts], axis=1, join="inner")
    window = steady or experiment.steady
    if window is not None:
        frames = frames[(frames.index >= window[0]) & (frames.index <= window[1])]
    frames = frames[frames["density"] > 0].copy()
    frames["flow"] = frames["voronoi_density"] * frames["voronoi_speed"]
    return Diagram(frames=frames.reset_index(),
                   speeds=_speeds_in_area(trajectory, speed, experiment, set(frames.index)),
                   line_flow=_line_flow(p, trajectory, experiment, frames),
                   frame_rate=float(trajectory.frame_rate))


def _speeds_in_area(trajectory: Any, speed: pd.DataFrame, experiment: Experiment,
                    frames: set[int]) -> FloatArray:
    """Each person's speed in every counted frame they are inside the measurement area."""
    import shapely

    data = trajectory.data.merge(speed, on=["id", "frame"])
    inside = shapely.contains_xy(experiment.measurement_area, data["x"].to_numpy(),
                                 data["y"].to_numpy())
    counted = data["frame"].isin(frames).to_numpy()
    return np.sort(data["speed"].to_numpy(dtype=np.float64)[inside & counted])


def _line_flow(p: Any, trajectory: Any, experiment: Experiment, frames: pd.DataFrame) -> float:
    """People per second across the line between the first and last counted frame."""
    if len(frames) < 2:
        return 0.0
    line = p.MeasurementLine(list(experiment.measurement_line.coords))
    nt, _ = p.compute_n_t(traj_data=trajectory, measurement_line=line)
    first, last = int(frames.index.min()), int(frames.index.max())
    counts = nt.set_index("frame")["cumulative_pedestrians"]
    before = counts[counts.index <= first]
    after = counts[counts.index <= last]
    crossed = (int(after.iloc[-1]) if len(after) else 0) - (int(before.iloc[-1])
                                                             if len(before) else 0)
    return crossed * trajectory.frame_rate / max(last - first, 1)

