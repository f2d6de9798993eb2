"""Measured against simulated: mean speed and flow per density bin, and individual speeds.

    comparison = compare(name, measured_diagram, simulated_diagram)
    comparison.bins            # per Voronoi-density bin: frames, mean speeds, flows, error
    comparison.to_dict()       # what `hubero validate --json` prints for one file

A bin counts when both sides have at least `MIN_FRAMES` frames in it. The relative error of a
bin is (simulated - measured) / measured mean speed; the file's error is the largest over its
bins (the calibration minimises the mean of squares). Individual speeds are compared by their
means and the two-sample Kolmogorov-Smirnov statistic (scipy).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from hubero_dsl.validation.fundamental import Diagram

BIN_WIDTH = 0.5      # 1/m^2
MIN_FRAMES = 10      # frames a bin needs on each side to count


@dataclass(frozen=True)
class DensityBin:
    low: float
    high: float
    measured_frames: int
    simulated_frames: int
    measured_speed: float
    simulated_speed: float
    measured_flow: float     # specific flow, 1/(m s)
    simulated_flow: float

    @property
    def counted(self) -> bool:
        return self.measured_frames >= MIN_FRAMES and self.simulated_frames >= MIN_FRAMES

    @property
    def speed_error(self) -> float:
        """Relative error of the simulated mean speed (NaN when the bin does not count)."""
        if not self.counted or self.measured_speed <= 0:
            return math.nan
        return (self.simulated_speed - self.measured_speed) / self.measured_speed


@dataclass(frozen=True)
class Comparison:
    name: str
    bins: tuple[DensityBin, ...]
    measured_speed: float        # mean individual speed in the area
    simulated_speed: float
    speed_ks: float              # Kolmogorov-Smirnov statistic of the individual speeds
    measured_line_flow: float    # people/s
    simulated_line_flow: float

    @property
    def errors(self) -> list[float]:
        return [b.speed_error for b in self.bins if b.counted and not math.isnan(b.speed_error)]

    @property
    def worst_error(self) -> float:
        """The largest relative speed error over the counted bins (NaN when none counts)."""
        errors = self.errors
        return max(abs(e) for e in errors) if errors else math.nan

    def to_dict(self) -> dict[str, Any]:
        return {
            "file": self.name,
            "bins": [{"density": [b.low, b.high], "measured_frames": b.measured_frames,
                      "simulated_frames": b.simulated_frames,
                      "measured_speed": _num(b.measured_speed),
                      "simulated_speed": _num(b.simulated_speed),
                      "relative_error": _num(b.speed_error),
                      "measured_flow": _num(b.measured_flow),
                      "simulated_flow": _num(b.simulated_flow)} for b in self.bins],
            "worst_relative_error": _num(self.worst_error),
            "individual_speed": {"measured_mean": _num(self.measured_speed),
                                 "simulated_mean": _num(self.simulated_speed),
                                 "ks_statistic": _num(self.speed_ks)},
            "line_flow": {"measured": _num(self.measured_line_flow),
                          "simulated": _num(self.simulated_line_flow)},
        }


def _num(value: float) -> float | None:
    """JSON has no NaN: a missing value is null; values are rounded to 4 digits."""
    return None if math.isnan(value) else round(float(value), 4)


def _binned(diagram: Diagram, low: float, high: float) -> tuple[int, float, float]:
    frames = diagram.frames
    inside = frames[(frames["voronoi_density"] >= low) & (frames["voronoi_density"] < high)]
    if len(inside) == 0:
        return 0, math.nan, math.nan
    return (len(inside), float(inside["voronoi_speed"].mean()),
            float(inside["flow"].mean()))


def compare(name: str, measured: Diagram, simulated: Diagram) -> Comparison:
    from scipy.stats import ks_2samp

    top = max([0.0, *(float(d.frames["voronoi_density"].max())
                      for d in (measured, simulated) if not d.empty)])
    bins = []
    for index in range(int(top // BIN_WIDTH) + 1):
        low, high = index * BIN_WIDTH, (index + 1) * BIN_WIDTH
        m_frames, m_speed, m_flow = _binned(measured, low, high)
        s_frames, s_speed, s_flow = _binned(simulated, low, high)
        if m_frames or s_frames:
            bins.append(DensityBin(low, high, m_frames, s_frames, m_speed, s_speed,
                                   m_flow, s_flow))
    both = len(measured.speeds) > 0 and len(simulated.speeds) > 0
    ks = float(ks_2samp(measured.speeds, simulated.speeds).statistic) if both else math.nan
    return Comparison(name=name, bins=tuple(bins), measured_speed=_mean(measured.speeds),
                      simulated_speed=_mean(simulated.speeds), speed_ks=ks,
                      measured_line_flow=measured.line_flow,
                      simulated_line_flow=simulated.line_flow)


def _mean(values: np.ndarray[Any, Any]) -> float:
    return float(np.mean(values)) if len(values) else math.nan
