"""Social-navigation metrics over trajectories: how a robot (or a person) moved among people.

The metrics a robot researcher reports, after HuNavSim's evaluator and SocNavBench, computed from
sampled tracks (times, positions, body radii; groups of people and the map's clearance when
given), so that a run's expectations (`expect min_distance(cart) >= 0.2 m`) and the analysis of
a log give the same numbers. Distances between bodies are surface to surface (centre distance
less both radii) unless a name says otherwise; time shares weight each sample by the time until
the next one.

Each metric (METRICS, below) is defined with its formula, unit and source in docs/analysis.md,
section "Social-navigation metrics".

The bands 0.45 / 1.2 / 3.6 m are HuNavSim's (after Hall's proxemics). `metric(NAME, OTHER)`
measures against OTHER only.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

FloatArray = npt.NDArray[np.float64]

INTIMATE, PERSONAL, SOCIAL = 0.45, 1.2, 3.6   # m, surface gaps
NOT_MOVING = 0.05                              # m/s
FORCE_A, FORCE_B = 2.1, 0.3                    # m/s^2, m (Helbing & Molnar 1995)
# m: two bodies whose surface gap is below this are in contact. The engine pushes overlapping
# bodies apart until they just touch, so a contact's gap comes out as 0 give or take a float's
# rounding (1e-16 m) in a run, and give or take the log's (positions to 0.1 mm: a distance
# off by up to 1.42e-4 m) when the metrics are read from a log. Counting only gaps below 0,
# or below 1 nm, counted such a contact or not by the rounding: a run's own verdict saw a
# collision that the same run's log did not. Below 0.2 mm, both see it.
CONTACT = 2e-4
# m: a body this far beyond its goal tolerance has reached the goal all the same (a float's
# rounding of an approach that ends exactly at the tolerance); `NAME reaches P` counts it too
GOAL_SLACK = 1e-9
# m/s: two bodies closing more slowly than this are not on a collision course. Velocities come
# from differences of positions, and a log keeps positions to 0.1 mm: two standing bodies
# "close" at rounding speeds, which gave times to contact of 10^14 s.
CLOSING = 0.01
# s: times this close are one sample time (float sums of a step)
_SAME_TIME = 1e-9


@dataclass(frozen=True, slots=True)
class MetricSpec:
    name: str
    dimension: str    # length, time, speed, acceleration, ratio, count, number (turning, jerk)
    unit: str
    summary: str


METRICS: dict[str, MetricSpec] = {spec.name: spec for spec in (
    MetricSpec("path_length", "length", "m", "distance travelled"),
    MetricSpec("path_efficiency", "ratio", "%", "straight-line distance over path length"),
    MetricSpec("path_irregularity", "number", "rad/m", "turning per metre travelled"),
    MetricSpec("plan_efficiency", "ratio", "%", "global plan's length over path length"),
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
    MetricSpec("social_work", "speed", "m/s", "social force exerted on people, over time"),
    MetricSpec("max_distance", "length", "m", "largest surface gap to the nearest person"),
    MetricSpec("avg_centre_distance", "length", "m", "mean centre distance to the nearest person"),
    MetricSpec("max_centre_distance", "length", "m",
               "largest centre distance to the nearest person"),
    MetricSpec("avg_speed", "speed", "m/s", "path length over the time"),
    MetricSpec("max_speed", "speed", "m/s", "the fastest move between samples"),
    MetricSpec("avg_acceleration", "acceleration", "m/s^2", "mean magnitude of the acceleration"),
    MetricSpec("max_acceleration", "acceleration", "m/s^2",
               "largest magnitude of the acceleration"),
    MetricSpec("motion_energy", "number", "m^2/s", "integral of the squared speed"),
    MetricSpec("min_time_to_collision", "time", "s",
               "soonest contact with a person, both keeping their velocity"),
    MetricSpec("social_force", "acceleration", "m/s^2", "mean social force the people exert on it"),
    MetricSpec("group_intrusions", "ratio", "%", "time share inside a group's space"),
    MetricSpec("obstacle_collisions", "count", "", "contact episodes with obstacles"),
)}

Clearance = Callable[[FloatArray], FloatArray]   # (N, 2) points -> (N,) metres to an obstacle
# (N, 2) points -> (N,) metres to the nearest obstacle and (N, 2) unit vectors away from it
ClearanceAndDirection = Callable[[FloatArray], tuple[FloatArray, FloatArray]]
OBSTACLE = -1   # Contact.partner of a contact with the map


@dataclass(frozen=True, slots=True)
class Contact:
    """One collision: an episode (run of samples) during which the subject's body overlapped a
    person's (surface gap below 0) or an obstacle (clearance below its radius)."""

    time: float                   # s, its first sample
    end: float                    # s, its last sample
    partner: int                  # index into the people, or OBSTACLE
    point: tuple[float, float]    # the person's centre, or the obstacle's nearest point, then
    struck: bool                  # the subject moved into the partner at least as fast as the
                                  # partner moved into it (always, for an obstacle)


@dataclass(frozen=True)
class Track:
    """One body's samples: times (T,), positions (T, 2), its radius."""

    time: FloatArray
    position: FloatArray
    radius: float


def social_metrics(subject: Track, people: Sequence[Track], *,
                   goal: tuple[float, float] | None = None,
                   goal_tolerance: float = 0.2,
                   groups: Sequence[Sequence[int]] = (),
                   clearance: Clearance | None = None,
                   plan_length: float | None = None) -> dict[str, float]:
    """Every metric of METRICS for `subject` among `people` (sampled at the subject's times).

    `groups` lists groups of people as indices into `people`; `clearance` gives the distance
    from points to the nearest obstacle (`OccupancyGrid.clearance_at`): without it there are
    no obstacle collisions. `plan_length` is the length of the global plan from the subject's
    first position to its goal (`planners.navfn.reference_plan_length`); without it
    `plan_efficiency` is `path_efficiency`.
    """
    time, position = subject.time, subject.position
    weights = _durations(time)
    total = float(weights.sum())
    step = np.diff(position, axis=0)
    lengths = np.hypot(step[:, 0], step[:, 1]) if len(step) else np.zeros(0)
    arrived = _arrival(time, position, goal, goal_tolerance)
    others = _positions(subject, people)               # (P, T, 2) at the subject's times
    gaps, centres = _gaps(subject, people, others)     # (P, T)
    nearest = gaps.min(axis=0) if len(people) else np.full(len(time), math.inf)
    return {
        "path_length": float(lengths.sum()),
        "path_efficiency": _efficiency(position, lengths, goal, arrived, time),
        "plan_efficiency": _efficiency(position, lengths, goal, arrived, time, plan_length),
        "path_irregularity": _irregularity(step, lengths),
        "time_to_goal": arrived if arrived is not None else math.inf,
        "min_distance": float(nearest.min()) if len(nearest) else math.inf,
        "avg_distance": _present_average(nearest, weights),
        "min_centre_distance": float(centres.min()) if centres.size else math.inf,
        "intimate_intrusions": _share(nearest < INTIMATE, weights, total),
        "personal_intrusions": _share((nearest >= INTIMATE) & (nearest < PERSONAL), weights,
                                      total),
        "social_intrusions": _share((nearest >= PERSONAL) & (nearest < SOCIAL), weights, total),
        "collisions": float(_episodes(gaps < CONTACT)),
        "time_not_moving": _still_time(time, lengths),
        "jerk": _jerk(time, position),
        "social_work": float((FORCE_A * np.exp(-np.maximum(gaps, 0.0) / FORCE_B)
                              * weights).sum()) if len(people) else 0.0,
        **_distance_extremes(nearest, centres, weights),
        **motion_metrics(time, position),
        "min_time_to_collision": _min_time_to_collision(subject, people, others),
        "social_force": _social_force(subject, others, gaps, centres, weights, total),
        "group_intrusions": _group_share(subject, people, others, groups, weights, total),
        "obstacle_collisions": _obstacle_episodes(subject, clearance),
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
    near = np.hypot(position[:, 0] - goal[0], position[:, 1] - goal[1]) <= tolerance + GOAL_SLACK
    return float(time[int(np.argmax(near))]) if near.any() else None


def _positions(subject: Track, people: Sequence[Track]) -> FloatArray:
    """(P, T, 2): each person's position at the subject's times."""
    if not people:
        return np.zeros((0, len(subject.time), 2))
    return np.stack([_at(person, subject.time) for person in people])


def _gaps(subject: Track, people: Sequence[Track], others: FloatArray
          ) -> tuple[FloatArray, FloatArray]:
    """(P, T) surface gaps and centre distances to each person at the subject's times."""
    if not people:
        empty = np.zeros((0, len(subject.time)))
        return empty, empty
    away = others - subject.position
    centres = np.hypot(away[..., 0], away[..., 1])
    centres[np.isnan(centres)] = math.inf        # absent (NaN positions): nowhere near
    radii = np.array([[person.radius] for person in people])
    return centres - radii - subject.radius, centres


def _at(track: Track, times: FloatArray) -> FloatArray:
    """The track's positions at `times` (`sampled_at`: NaN while the body is absent)."""
    return sampled_at(track.time, track.position, times)


def sampled_at(time: FloatArray, values: FloatArray, at: FloatArray, *,
               held: bool = False) -> FloatArray:
    """Values (T,) or (T, k) sampled at `time`, at the times `at`: linear between samples,
    held for one sample spacing beyond the ends (a log's last frame may come early), NaN
    further out: a flow's member before it came or after it left is absent, not standing
    where it was last seen. `held`: held however far beyond the ends (for a search that
    takes no NaN)."""
    if len(time) == len(at) and np.array_equal(time, at):
        return values
    columns = values.reshape(len(time), -1)
    found = np.column_stack([np.interp(at, time, column) for column in columns.T])
    if not held:
        spacing = float(np.median(np.diff(time))) if len(time) > 1 else 0.0
        found[(at < time[0] - spacing - _SAME_TIME)
              | (at > time[-1] + spacing + _SAME_TIME)] = np.nan
    return found.reshape((len(at), *values.shape[1:]))


def _efficiency(position: FloatArray, lengths: FloatArray, goal: tuple[float, float] | None,
                arrived: float | None, time: FloatArray, shortest: float | None = None
                ) -> float:
    """The shortest way to the goal (`shortest`, or the straight line) over the path taken;
    not a number when the goal was never reached (a path that stops short is no measure of
    the way to it, however straight: success-only, as SocNavBench reports it)."""
    if goal is not None and arrived is None:
        return math.nan
    if not len(position):
        return 1.0
    end = np.asarray(goal) if goal is not None else position[-1]
    travelled = lengths
    if goal is not None and arrived is not None:  # count the path up to the arrival
        travelled = lengths[:int(np.searchsorted(time, arrived, side="right")) - 1]
    path = float(travelled.sum())
    straight = float(np.hypot(*(end - position[0]))) if shortest is None else shortest
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


def _present_average(values: FloatArray, weights: FloatArray) -> float:
    """The time average of `values` over the samples where it is finite (someone there):
    infinite when nobody ever was."""
    present = np.isfinite(values)
    if not present.any():
        return math.inf
    return _time_average(values[present], weights[present], float(weights[present].sum()))


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
    """The mean magnitude of the third derivative, each derivative taken over the true time
    between its samples' midpoints (a run's last frame comes early; repeated times dropped):
    the third difference over the step cubed where the steps are even."""
    distinct = np.diff(time, prepend=-np.inf) > 0
    time, position = time[distinct], position[distinct]
    if len(time) < 4:
        return 0.0
    derivative = position
    for _ in range(3):
        step = np.diff(time)
        derivative = np.diff(derivative, axis=0) / step[:, None]
        time = time[:-1] + step / 2
    return float(np.hypot(derivative[:, 0], derivative[:, 1]).mean())


def _distance_extremes(nearest: FloatArray, centres: FloatArray, weights: FloatArray
                       ) -> dict[str, float]:
    present = np.isfinite(nearest)
    if not present.any():
        return {"max_distance": math.inf, "avg_centre_distance": math.inf,
                "max_centre_distance": math.inf}
    nearest_centre = centres.min(axis=0)
    return {"max_distance": float(nearest[present].max()),
            "avg_centre_distance": _present_average(nearest_centre, weights),
            "max_centre_distance": float(nearest_centre[present].max())}


def motion_metrics(time: FloatArray, position: FloatArray) -> dict[str, float]:
    """Speed, acceleration and motion energy of one track (no people needed).

    Velocities are per segment (its displacement over its time); accelerations are between
    consecutive segments, over the time between their midpoints.
    """
    zero = {"avg_speed": 0.0, "max_speed": 0.0, "avg_acceleration": 0.0,
            "max_acceleration": 0.0, "motion_energy": 0.0}
    if len(time) < 2:
        return zero
    dt = np.diff(time)
    ok = dt > 0
    velocity = np.zeros((len(dt), 2))
    velocity[ok] = np.diff(position, axis=0)[ok] / dt[ok, None]
    speed = np.hypot(velocity[:, 0], velocity[:, 1])
    total = float(dt.sum())
    result = dict(zero, max_speed=float(speed.max()),
                  avg_speed=float((speed * dt).sum() / total) if total > 0 else 0.0,
                  motion_energy=float((speed ** 2 * dt).sum()))
    if len(dt) >= 2:
        middle = (dt[1:] + dt[:-1]) / 2
        change = np.diff(velocity, axis=0)
        accel = np.divide(np.hypot(change[:, 0], change[:, 1]), middle,
                          out=np.zeros(len(middle)), where=middle > 0)
        result["avg_acceleration"] = float(accel.mean())
        result["max_acceleration"] = float(accel.max())
    return result


def _velocity(time: FloatArray, position: FloatArray, axis: int) -> FloatArray:
    """Velocities at the samples along `axis` (central differences, one-sided at the ends;
    repeated times give no velocity)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        velocity = np.gradient(position, time, axis=axis)
    return np.nan_to_num(np.asarray(velocity, dtype=np.float64), nan=0.0, posinf=0.0,
                         neginf=0.0)


def _min_time_to_collision(subject: Track, people: Sequence[Track], others: FloatArray
                           ) -> float:
    """The smallest time to contact over the samples, each pair keeping its velocity; 0 when in
    contact, infinite when no pair is ever closing on a contact course."""
    times = subject.time
    if not people or len(times) < 2 or np.any(np.diff(times) <= 0):
        return math.inf
    relative = others - subject.position                                          # (P, T, 2)
    closing = _velocity(times, relative, axis=1)
    reach = np.array([p.radius for p in people])[:, None] + subject.radius
    a = (closing ** 2).sum(axis=2)
    b = 2 * (relative * closing).sum(axis=2)
    c = (relative ** 2).sum(axis=2) - reach ** 2
    disc = b * b - 4 * a * c
    hit = (b < 0) & (disc >= 0) & (a > CLOSING ** 2)
    root = np.divide(-b - np.sqrt(np.maximum(disc, 0.0)), 2 * a, out=np.full(a.shape, math.inf),
                     where=hit)
    in_contact = c < (reach + CONTACT) ** 2 - reach ** 2   # a gap below CONTACT
    ttc = np.where(in_contact, 0.0, np.where(hit, root, math.inf))
    return float(ttc.min())


def _social_force(subject: Track, others: FloatArray, gaps: FloatArray,
                  centres: FloatArray, weights: FloatArray, total: float) -> float:
    """Time average of the magnitude of the people's summed social force on the subject."""
    if not len(others) or not len(subject.time):
        return 0.0
    away = subject.position[None, :, :] - others
    there = (centres > 0) & np.isfinite(centres)
    unit = np.divide(away, centres[:, :, None], out=np.zeros_like(away),
                     where=there[:, :, None])
    force = (FORCE_A * np.exp(-np.maximum(gaps, 0.0) / FORCE_B))[:, :, None] * unit
    summed = force.sum(axis=0)
    return _time_average(np.hypot(summed[:, 0], summed[:, 1]), weights, total)


def group_space(positions: FloatArray, radii: FloatArray) -> tuple[FloatArray, FloatArray]:
    """A group's space from its members' positions (M, T, 2) and radii (M,): the circle about
    their mean position that holds every member's body, as centres (T, 2) and radii (T,)."""
    centre = positions.mean(axis=0)
    offset = positions - centre
    reach = np.hypot(offset[..., 0], offset[..., 1]) + radii[:, None]
    return centre, reach.max(axis=0)


def _group_share(subject: Track, people: Sequence[Track], others: FloatArray,
                 groups: Sequence[Sequence[int]], weights: FloatArray, total: float) -> float:
    """Share of the time the subject's body overlaps some group's space (it not a member)."""
    inside = np.zeros(len(subject.time), dtype=np.bool_)
    for group in groups:
        if len(group) < 2:
            continue
        members = list(group)
        centre, radius = group_space(others[members],
                                     np.array([people[i].radius for i in members]))
        gap = np.hypot(*(subject.position - centre).T) - radius - subject.radius
        inside |= gap < 0
    return _share(inside, weights, total)


def _obstacle_episodes(subject: Track, clearance: Clearance | None) -> float:
    if clearance is None or not len(subject.time):
        return 0.0
    return float(_episodes((clearance(subject.position) < subject.radius)[None, :]))


def contacts(subject: Track, people: Sequence[Track], *,
             obstacles: ClearanceAndDirection | None = None) -> list[Contact]:
    """Every collision of `subject` with a person or (given the map's `clearance_and_direction_at`)
    an obstacle, in order of time: the episodes `collisions` and `obstacle_collisions` count.

    Who hit whom: at the contact's first sample, each body's approach speed is its velocity
    (central differences) along the line towards the other; the subject `struck` when its own
    is at least the person's.
    """
    time = subject.time
    found: list[Contact] = []
    if people and len(time):
        others = _positions(subject, people)
        gaps, _ = _gaps(subject, people, others)
        mine = _velocity(time, subject.position, axis=0) if len(time) > 1 else np.zeros((1, 2))
        for index, first, last in _runs(gaps < CONTACT):
            theirs = (_velocity(time, others[index], axis=0)[first] if len(time) > 1
                      else np.zeros(2))
            towards = others[index, first] - subject.position[first]
            length = float(np.hypot(*towards))
            unit = towards / length if length > 0 else np.zeros(2)
            struck = float(mine[first] @ unit) >= float(-(theirs @ unit))
            found.append(Contact(float(time[first]), float(time[last]), index,
                                 _pair(others[index, first]), struck))
    if obstacles is not None and len(time):
        clearance, away = obstacles(subject.position)
        for _, first, last in _runs((clearance < subject.radius)[None, :]):
            touched = subject.position[first] - clearance[first] * away[first]
            found.append(Contact(float(time[first]), float(time[last]), OBSTACLE,
                                 _pair(touched), True))
    return sorted(found, key=lambda c: (c.time, c.partner))


def _runs(mask: npt.NDArray[np.bool_]) -> list[tuple[int, int, int]]:
    """(row, first, last) of every run of True along the time axis of a (P, T) mask."""
    padded = np.pad(mask.astype(np.int8), ((0, 0), (1, 1)))
    edges = np.diff(padded, axis=1)
    rows, firsts = np.nonzero(edges == 1)
    _, lasts = np.nonzero(edges == -1)
    return [(int(r), int(f), int(e) - 1) for r, f, e in zip(rows, firsts, lasts, strict=True)]


def _pair(point: FloatArray) -> tuple[float, float]:
    return (float(point[0]), float(point[1]))


def member_indices(groups: Iterable[Sequence[str]], people: Sequence[str], subject: str
                   ) -> list[list[int]]:
    """Groups of names as indices into `people`, leaving out groups the subject belongs to."""
    index = {name: i for i, name in enumerate(people)}
    return [[index[m] for m in members if m in index] for members in groups
            if subject not in members]
