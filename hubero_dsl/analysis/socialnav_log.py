"""Social-navigation metrics from a run log alone (`hubero_dsl.socialnav`, per robot and human).

    from hubero_dsl.analysis.socialnav_log import log_social_metrics
    metrics = log_social_metrics(load_run("run.mcap"))
    metrics["robots"]["cart"]["min_time_to_collision"], metrics["humans"]["actor1"]["jerk"]

What the log records is used: tracks, humans' radii and personal-space shapes (their resolved
parameters), robots' radii (from /scene), groups (metadata `sets`), the map (for collisions
with obstacles). Robots' goals and plans are not logged: efficiency is against the straight
line from a body's first to its last position, and `time_to_goal` is infinite. On top of
`social_metrics`, `shape_intrusions` is the share of the time the subject's centre lay inside
some person's own personal space, in its shape and turned to its heading.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from scipy.spatial import cKDTree

from hubero_dsl.socialnav import FloatArray, Track, member_indices, social_metrics
from hubero_dsl.world.personal_space import contains
from hubero_dsl.world.shapes import Circle, Ellipse, Rectangle, Shape, ShapeArrays

if TYPE_CHECKING:
    from hubero_dsl.log.reader import LoggedRun

DEFAULT_HUMAN_RADIUS = 0.2
DEFAULT_ROBOT_RADIUS = 0.3
NEAR = 6.0  # m between centres: beyond the social band (3.6 m) plus two bodies and a margin


def log_social_metrics(run: LoggedRun, *, humans: bool = True
                       ) -> dict[str, dict[str, dict[str, float]]]:
    """`{"robots": {name: metrics}, "humans": {name: metrics}}` (humans only if asked)."""
    neighbours = _neighbours(run) if humans else {}
    return {
        "robots": {name: robot_social_metrics(run, name) for name in sorted(run.robots)},
        "humans": {name: human_social_metrics(run, name, neighbours.get(name))
                   for name in sorted(run.humans)},
    }


def robot_social_metrics(run: LoggedRun, name: str) -> dict[str, float]:
    """A robot's metrics among every human of the log."""
    robot = run.robots[name]
    subject = Track(robot.time, robot.position, robot.radius or DEFAULT_ROBOT_RADIUS)
    return _metrics(run, subject, name, [h for h in run.humans if len(run.humans[h].time)])


def human_social_metrics(run: LoggedRun, name: str, among: list[str] | None = None
                         ) -> dict[str, float]:
    """A human's metrics among the other humans of the log (or those of `among` only)."""
    human = run.humans[name]
    subject = Track(human.time, human.position, _radius(run, name))
    others = [h for h in (among if among is not None else run.humans)
              if h != name and len(run.humans[h].time)]
    return _metrics(run, subject, name, others)


def _neighbours(run: LoggedRun) -> dict[str, list[str]]:
    """Per human, the others that matter to its metrics: whoever came within NEAR (centres) at
    some frame, whoever was its nearest at some frame, and every group's members.

    Comparing every human with every other costs people squared times frames; a k-d tree per
    frame finds these few. Left out are only people always further than NEAR: beyond every
    intrusion band, their social force below 1e-7 m/s^2; they are left out of time to
    collision too.
    """
    names = [h for h in sorted(run.humans) if len(run.humans[h].time)]
    if len(names) < 2:
        return {}
    times = np.unique(np.concatenate([run.humans[h].time for h in names]))
    positions = np.stack([_interpolated(run.humans[h].time, run.humans[h].position, times)
                          for h in names], axis=1)                              # (T, P, 2)
    pairs: set[tuple[int, int]] = set()
    for frame in positions:
        tree = cKDTree(frame)
        pairs.update(map(tuple, tree.query_pairs(NEAR, output_type="ndarray").tolist()))
        _, nearest = tree.query(frame, k=2)
        pairs.update(zip(range(len(names)), nearest[:, 1].tolist(), strict=True))
    chosen: dict[str, set[str]] = {name: set() for name in names}
    for i, j in pairs:
        chosen[names[i]].add(names[j])
        chosen[names[j]].add(names[i])
    # group members always: a group's space needs all of them
    every_member = {m for kind, members in run.metadata.sets.values() if kind == "group"
                    for m in members if m in chosen}
    return {name: sorted((chosen[name] | every_member) - {name}) for name in names}


def _metrics(run: LoggedRun, subject: Track, name: str, others: list[str]) -> dict[str, float]:
    people = [Track(run.humans[h].time, run.humans[h].position, _radius(run, h)) for h in others]
    groups = [members for kind, members in run.metadata.sets.values() if kind == "group"]
    metrics = social_metrics(subject, people, groups=member_indices(groups, others, name),
                             clearance=run.grid.clearance_at if len(subject.time) else None)
    metrics["shape_intrusions"] = shape_intrusions(run, subject, others)
    return metrics


def shape_intrusions(run: LoggedRun, subject: Track, others: list[str]) -> float:
    """Share of the subject's time (each sample weighs the time until the next) during which its
    centre lay inside some person's own personal space."""
    times = subject.time
    if len(times) < 2 or not others:
        return 0.0
    count = len(times)
    shapes = ShapeArrays.from_shapes([_shape(run, h) for h in others])
    repeated = ShapeArrays(np.repeat(shapes.kind, count), np.repeat(shapes.a, count),
                           np.repeat(shapes.b, count), np.repeat(shapes.offset, count))
    centres = np.concatenate([_interpolated(run.humans[h].time, run.humans[h].position, times)
                              for h in others])
    headings = np.concatenate([np.interp(times, run.humans[h].time,
                                         np.unwrap(run.humans[h].heading)) for h in others])
    points = np.tile(subject.position, (len(others), 1))
    inside = np.asarray(contains(repeated, headings, centres, points))
    intruded = np.asarray(inside.reshape(len(others), count).any(axis=0), dtype=np.bool_)[:-1]
    dt = np.diff(times)
    return float(dt[intruded].sum() / dt.sum()) if dt.sum() > 0 else 0.0


def _interpolated(time: FloatArray, position: FloatArray, at: FloatArray) -> FloatArray:
    return np.column_stack([np.interp(at, time, position[:, 0]),
                            np.interp(at, time, position[:, 1])])


def _radius(run: LoggedRun, human: str) -> float:
    radius = run.metadata.params.get(human, {}).get("radius", DEFAULT_HUMAN_RADIUS)
    return float(radius) if isinstance(radius, int | float) else DEFAULT_HUMAN_RADIUS


def _shape(run: LoggedRun, human: str) -> Shape:
    shape = run.metadata.params.get(human, {}).get("personal_space")
    return shape if isinstance(shape, Circle | Ellipse | Rectangle) else Circle(_radius(run, human))
