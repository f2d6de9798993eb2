"""Social-navigation metrics over trajectories: how a robot (or a person) moved among people.

The metrics a robot researcher reports, after HuNavSim's evaluator and SocNavBench, computed from
sampled tracks alone (times, positions, body radii), so that a run's expectations
(`expect min_distance(cart) >= 0.2 m`) and the analysis of a log give the same numbers. Distances
between bodies are surface to surface (centre distance less both radii) unless a name says
otherwise; time shares weight each sample by the time until the next one.

Each metric (METRICS, below) is defined with its formula, unit and source in docs/analysis.md,
section "Social-navigation metrics".

The bands 0.45 / 1.2 / 3.6 m are HuNavSim's (after Hall's proxemics). `metric(NAME, OTHER)`
measures against OTHER only.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]

INTIMATE, PERSONAL, SOCIAL = 0.45, 1.2, 3.6   # m, surface gaps
NOT_MOVING = 0.05                              # m/s
FORCE_A, FORCE_B = 2.1, 0.3                    # m/s^2, m (Helbing & Molnar 1995)


@dataclass(frozen=True, slots=True)
class MetricSpec:
    name: str
    dimension: str    # length, time, ratio, count, number (angle per metre, jerk, work)
    unit: str
    summary: str


METRICS: dict[str, MetricSpec] = {spec.name: spec for spec in (
    MetricSpec("path_length", "length", "m", "distance travelled"),
    MetricSpec("path_efficiency", "ratio", "%", "straight-line distance over path length"),
    MetricSpec("path_irregularity", "number", "rad/m", "turning per metre travelled"),
    MetricSpec("time_to_goal", "time", "s", "when the goal was first reached"),
    MetricSpec("min_distance", "length", "m", "smallest surface gap to a person"),
    MetricSpec("avg_distance", "length", "m", "mean surface gap to the nearest person"),
    MetricSpec("min_centre_distance", "length", "m", "smallest centre distance to a person"),
    MetricSpec("intimate_intrusions", "ratio", "%", "time share with a person within 0.45 m"),
    MetricSpec("personal_intrusions", "ratio", "%", "time share with a person at 0.45-1.2 m"),
    MetricSpec("social_intrusions", "ratio", "%", "time share with a person at 1.2-3.6 m"),
    MetricSpec("collisions", "count", "", "contact episodes with people"),
    MetricSpec("time_not_moving", "time", "s", "time spent standing still"),
    MetricSpec("jerk", "number", "m/s^3", "mean magnitude of the jerk"),
    MetricSpec("social_work", "number", "m/s", "social force exerted on people, over time"),
)}


@dataclass(frozen=True)
class Track:
    """One body's samples: times (T,), positions (T, 2), its radius."""

    time: FloatArray
    position: FloatArray
    radius: float


def social_metrics(subject: Track, people: Sequence[Track], *,
                   goal: tuple[float, float] | None = None,
                   goal_tolerance: float = 0.2) -> dict[str, float]:
    """Every metric of METRICS for `subject` among `people` (sampled at the subject's times)."""
    time, position = subject.time, subject.position
    weights = _durations(time)
    total = float(weights.sum())
    step = np.diff(position, axis=0)
    lengths = np.hypot(step[:, 0], step[:, 1]) if len(step) else np.zeros(0)
    arrived = _arrival(time, position, goal, goal_tolerance)
    gaps, centres = _gaps(subject, people)            # (P, T)
    nearest = gaps.min(axis=0) if len(people) else np.full(len(time), math.inf)
    return {
        "path_length": float(lengths.sum()),
        "path_efficiency": _efficiency(position, lengths, goal, arrived, time),
        "path_irregularity": _irregularity(step, lengths),
        "time_to_goal": arrived if arrived is not None else math.inf,
        "min_distance": float(nearest.min()) if len(nearest) else math.inf,
        "avg_distance": _time_average(np.minimum(nearest, 1e9), weights, total),
        "min_centre_distance": float(centres.min()) if centres.size else math.inf,
        "intimate_intrusions": _share(nearest < INTIMATE, weights, total),
        "personal_intrusions": _share((nearest >= INTIMATE) & (nearest < PERSONAL), weights,
                                      total),
        "social_intrusions": _share((nearest >= PERSONAL) & (nearest < SOCIAL), weights, total),
        "collisions": float(_episodes(gaps < 0.0)),
        "time_not_moving": _still_time(time, lengths),
        "jerk": _jerk(time, position),
        "social_work": float((FORCE_A * np.exp(-np.maximum(gaps, 0.0) / FORCE_B)
                              * weights).sum()) if len(people) else 0.0,
    }


def _durations(time: FloatArray) -> FloatArray:
    """Each sample's weight: the time until the next (the last sample: none)."""
    if len(time) < 2:
        return np.zeros(len(time))
    return np.append(np.diff(time), 0.0)


def _arrival(time: FloatArray, position: FloatArray, goal: tuple[float, float] | None,
             tolerance: float) -> float | None:
    if goal is None or not len(time):
        return None
    near = np.hypot(position[:, 0] - goal[0], position[:, 1] - goal[1]) <= tolerance + 1e-9
    return float(time[int(np.argmax(near))]) if near.any() else None


def _gaps(subject: Track, people: Sequence[Track]) -> tuple[FloatArray, FloatArray]:
    """(P, T) surface gaps and centre distances to each person at the subject's times."""
    if not people:
        empty = np.zeros((0, len(subject.time)))
        return empty, empty
    centres = np.stack([np.hypot(*(_at(person, subject.time) - subject.position).T)
                        for person in people])
    radii = np.array([[person.radius] for person in people])
    return centres - radii - subject.radius, centres


def _at(track: Track, times: FloatArray) -> FloatArray:
    """The track's positions at `times` (linear between samples, held beyond its ends)."""
    if len(track.time) == len(times) and np.array_equal(track.time, times):
        return track.position
    x = np.interp(times, track.time, track.position[:, 0])
    y = np.interp(times, track.time, track.position[:, 1])
    return np.stack([x, y], axis=1)


def _efficiency(position: FloatArray, lengths: FloatArray, goal: tuple[float, float] | None,
                arrived: float | None, time: FloatArray) -> float:
    if not len(position):
        return 1.0
    end = np.asarray(goal) if goal is not None else position[-1]
    travelled = lengths
    if goal is not None and arrived is not None:  # count the path up to the arrival
        travelled = lengths[:int(np.searchsorted(time, arrived, side="right")) - 1]
    path = float(travelled.sum())
    straight = float(np.hypot(*(end - position[0])))
    if path < 1e-9:
        return 1.0 if straight < 1e-9 else 0.0
    return min(1.0, straight / path)


def _irregularity(step: FloatArray, lengths: FloatArray) -> float:
    moving = lengths > 1e-3
    if moving.sum() < 2:
        return 0.0
    headings = np.arctan2(step[moving, 1], step[moving, 0])
    turns = np.abs((np.diff(headings) + math.pi) % (2 * math.pi) - math.pi)
    return float(turns.sum() / lengths.sum())


def _time_average(values: FloatArray, weights: FloatArray, total: float) -> float:
    if total <= 0:
        return float(values[0]) if len(values) else math.inf
    return float((values * weights).sum() / total)


def _share(mask: npt.NDArray[np.bool_], weights: FloatArray, total: float) -> float:
    return float(weights[mask].sum() / total) if total > 0 else 0.0


def _episodes(contact: npt.NDArray[np.bool_]) -> int:
    """Runs of True along the time axis, summed over the rows."""
    if contact.size == 0:
        return 0
    starts = contact[:, 0].astype(int) + (contact[:, 1:] & ~contact[:, :-1]).sum(axis=1)
    return int(starts.sum())


def _still_time(time: FloatArray, lengths: FloatArray) -> float:
    if len(time) < 2:
        return 0.0
    dt = np.diff(time)
    speed = np.divide(lengths, dt, out=np.zeros_like(lengths), where=dt > 0)
    return float(dt[speed < NOT_MOVING].sum())


def _jerk(time: FloatArray, position: FloatArray) -> float:
    if len(time) < 4:
        return 0.0
    dt = float(np.median(np.diff(time)))
    if dt <= 0:
        return 0.0
    third = np.diff(position, n=3, axis=0) / dt ** 3
    return float(np.hypot(third[:, 0], third[:, 1]).mean())
