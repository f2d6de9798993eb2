"""Social-navigation metrics from a run log alone (`hubero_dsl.socialnav`, per robot and human).

    from hubero_dsl.analysis.socialnav_log import log_social_metrics
    metrics = log_social_metrics(load_run("run.mcap"))
    metrics["robots"]["cart"]["min_time_to_collision"], metrics["humans"]["actor1"]["jerk"]

What the log records is used: tracks, humans' radii and personal-space shapes (their resolved
parameters), robots' radii (from /scene), groups (metadata `sets`), the map (for collisions
with obstacles), robots' goals and goal tolerances (their resolved parameters, in logs that
record them): a robot's `time_to_goal` and `path_efficiency` are then those `expect` judges in
the run. Without a goal (a human, a robot without `goal`, an older log) efficiency is against
the straight line from the first to the last position, and `time_to_goal` is infinite. On top of
`social_metrics`, `shape_intrusions` is the share of the time the subject's centre lay inside
some person's own personal space, in its shape and turned to its heading.

Per robot, too: its collisions, who hit whom (`robot_collisions`, `collided_with`), and how its
run ended (`robot_termination`: reached its goal, collided, aborted, timed out, ...).
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from scipy.spatial import cKDTree

from hubero_dsl.planners.navfn import reference_plan_length
from hubero_dsl.sim.status import TaskStatus
from hubero_dsl.socialnav import (
    OBSTACLE,
    FloatArray,
    Track,
    contacts,
    member_indices,
    sampled_at,
    social_metrics,
)
from hubero_dsl.world.personal_space import contains
from hubero_dsl.world.shapes import Circle, Ellipse, Rectangle, Shape, ShapeArrays

if TYPE_CHECKING:
    from hubero_dsl.log.reader import LoggedRun

OBSTACLE_NAME = "obstacle"  # Collision.partner of a contact with the map
DEFAULT_HUMAN_RADIUS = 0.2
DEFAULT_ROBOT_RADIUS = 0.3
NEAR = 6.0  # m between centres: beyond the social band (3.6 m) plus two bodies and a margin


def log_social_metrics(run: LoggedRun, *, humans: bool = True
                       ) -> dict[str, dict[str, dict[str, float]]]:
    """`{"robots": {name: metrics}, "humans": {name: metrics}}` (humans only if asked)."""
    neighbours = _neighbours(run) if humans else {}
    headings = _headings(run)
    return {
        "robots": {name: robot_social_metrics(run, name, headings) for name in sorted(run.robots)},
        "humans": {name: human_social_metrics(run, name, neighbours.get(name), headings)
                   for name in sorted(run.humans)} if humans else {},
    }


def robot_social_metrics(run: LoggedRun, name: str,
                         headings: dict[str, FloatArray] | None = None) -> dict[str, float]:
    """A robot's metrics among every human of the log."""
    robot = run.robots[name]
    subject = Track(robot.time, robot.position, robot.radius or DEFAULT_ROBOT_RADIUS)
    goal, tolerance = run.metadata.robot_goal(name)
    plan_length = None
    if goal is not None and len(robot.time):
        start = (float(robot.position[0, 0]), float(robot.position[0, 1]))
        plan_length = reference_plan_length(run.grid, start, goal, subject.radius)
    return _metrics(run, subject, name, [h for h in run.humans if len(run.humans[h].time)],
                    headings, goal=goal, goal_tolerance=tolerance, plan_length=plan_length)


@dataclass(frozen=True, slots=True)
class Collision:
    """One collision of a robot: with whom, when, where, and who moved into whom."""

    time: float                   # s, first sample in contact
    end: float                    # s, last sample in contact
    partner: str                  # the person's name, or OBSTACLE_NAME
    point: tuple[float, float]    # the person's centre, or the obstacle's nearest point, then
    hit_by: str                   # the robot's name, or the person's: who moved into whom


@dataclass(frozen=True, slots=True)
class Termination:
    """How a robot's run ended (docs/analysis.md, "Success and termination")."""

    cause: str      # one of CAUSES
    time: float     # s: when
    detail: str     # the task's reason, the run's, or whom it hit

    @property
    def success(self) -> bool:
        return self.cause == "reached_goal"


CAUSES = ("reached_goal", "done", "collision", "aborted", "timeout", "stopped", "no_task",
          "unfinished")
_DONE = {TaskStatus.SUCCEEDED, TaskStatus.PREEMPTED}


def robot_collisions(run: LoggedRun, name: str) -> list[Collision]:
    """The robot's collisions with the humans of the log and with the map, in time order."""
    robot = run.robots[name]
    subject = Track(robot.time, robot.position, robot.radius or DEFAULT_ROBOT_RADIUS)
    others = [h for h in run.humans if len(run.humans[h].time)]
    people = [Track(run.humans[h].time, run.humans[h].position, _radius(run, h)) for h in others]
    found = contacts(subject, people, obstacles=run.grid.clearance_and_direction_at)
    return [Collision(c.time, c.end, OBSTACLE_NAME if c.partner == OBSTACLE else others[c.partner],
                      c.point, name if c.struck else others[c.partner]) for c in found]


@dataclass(frozen=True, slots=True)
class RobotOutcome:
    """What a log says of a robot's run: its metrics among the people, how it ended, and its
    collisions per partner."""

    social: dict[str, float]
    termination: Termination
    collided_with: dict[str, int]


def robot_outcome(run: LoggedRun, name: str) -> RobotOutcome:
    """`robot_social_metrics`, `robot_termination` and `collided_with` of one robot, its
    collisions found once for both."""
    hits = robot_collisions(run, name)
    return RobotOutcome(robot_social_metrics(run, name), robot_termination(run, name, hits),
                        collided_with(hits))


def collided_with(collisions: Sequence[Collision]) -> dict[str, int]:
    """Collisions counted per partner (a person's name, or "obstacle"), names sorted."""
    return dict(sorted(Counter(c.partner for c in collisions).items()))


def robot_termination(run: LoggedRun, name: str,
                      collisions: Sequence[Collision] | None = None) -> Termination:
    """What ended the robot's run first: its first collision, or how its tasks ended (their
    events) and, for a task still going at the end, how the run ended. A collision after the
    robot's tasks ended (someone walking into it at its goal) does not count."""
    ended = _tasks_ending(run, name)
    hits = robot_collisions(run, name) if collisions is None else collisions
    if hits and hits[0].time <= ended.time:
        return Termination("collision", hits[0].time, f"with {hits[0].partner}")
    return ended


def _tasks_ending(run: LoggedRun, name: str) -> Termination:
    last: dict[int, tuple[TaskStatus, float, str, str]] = {}
    for event in run.events:
        if event.human == name:
            last[event.task_id] = (event.status, event.time, event.reason, event.kind)
    end = run.result.time if run.result is not None else _last_time(run, name)
    if not last:
        return Termination("no_task", end, "")
    finals = sorted(last.values(), key=lambda final: final[1])
    aborted = [f for f in finals if f[0] is TaskStatus.ABORTED]
    if aborted:
        return Termination("aborted", aborted[0][1], aborted[0][2])
    if any(f[0] not in _DONE for f in finals):   # a task still going when the run ended
        if run.result is None:
            return Termination("unfinished", end, "the log has no result: the run was cut off")
        cause = "timeout" if run.result.state == "timed_out" else "stopped"
        return Termination(cause, end, run.result.reason)
    status, time, _, kind = finals[-1]
    reached = status is TaskStatus.SUCCEEDED and kind == "move_to"
    return Termination("reached_goal" if reached else "done", time, "")


def _last_time(run: LoggedRun, name: str) -> float:
    time = run.robots[name].time
    return float(time[-1]) if len(time) else 0.0


def human_social_metrics(run: LoggedRun, name: str, among: list[str] | None = None,
                         headings: dict[str, FloatArray] | None = None) -> dict[str, float]:
    """A human's metrics among the other humans of the log (or those of `among` only)."""
    human = run.humans[name]
    subject = Track(human.time, human.position, _radius(run, name))
    others = [h for h in (among if among is not None else run.humans)
              if h != name and len(run.humans[h].time)]
    return _metrics(run, subject, name, others, headings)


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
    positions = np.stack([sampled_at(run.humans[h].time, run.humans[h].position, times,
                                     held=True)
                          for h in names], axis=1)                              # (T, P, 2)
    count, found = len(names), []
    for frame in positions:
        tree = cKDTree(frame)
        found.append(tree.query_pairs(NEAR, output_type="ndarray"))
        _, nearest = tree.query(frame, k=2)
        found.append(np.column_stack([np.arange(count), nearest[:, 1]]))
    pairs = np.concatenate(found).astype(np.int64)
    codes = np.unique(np.concatenate([pairs[:, 0] * count + pairs[:, 1],
                                      pairs[:, 1] * count + pairs[:, 0]]))
    starts = np.searchsorted(codes // count, np.arange(count + 1))
    chosen = {name: {names[j] for j in (codes[starts[i]:starts[i + 1]] % count).tolist()}
              for i, name in enumerate(names)}
    # group members always: a group's space needs all of them
    every_member = {m for kind, members in run.metadata.sets.values() if kind == "group"
                    for m in members if m in chosen}
    return {name: sorted((chosen[name] | every_member) - {name}) for name in names}


def _metrics(run: LoggedRun, subject: Track, name: str, others: list[str],
             headings: dict[str, FloatArray] | None, *,
             goal: tuple[float, float] | None = None, goal_tolerance: float = 0.2,
             plan_length: float | None = None) -> dict[str, float]:
    people = [Track(run.humans[h].time, run.humans[h].position, _radius(run, h)) for h in others]
    groups = [members for kind, members in run.metadata.sets.values() if kind == "group"]
    metrics = social_metrics(subject, people, groups=member_indices(groups, others, name),
                             goal=goal, goal_tolerance=goal_tolerance, plan_length=plan_length,
                             clearance=run.grid.clearance_at if len(subject.time) else None)
    metrics["shape_intrusions"] = shape_intrusions(run, subject, others, headings)
    return metrics


def shape_intrusions(run: LoggedRun, subject: Track, others: list[str],
                     headings: dict[str, FloatArray] | None = None) -> float:
    """Share of the subject's time (each sample weighs the time until the next) during which its
    centre lay inside some person's own personal space. `headings`: `_headings(run)`, when
    known already."""
    times = subject.time
    if len(times) < 2 or not others:
        return 0.0
    count = len(times)
    shapes = ShapeArrays.from_shapes([_shape(run, h) for h in others])
    repeated = ShapeArrays(np.repeat(shapes.kind, count), np.repeat(shapes.a, count),
                           np.repeat(shapes.b, count), np.repeat(shapes.offset, count))
    centres = np.concatenate([sampled_at(run.humans[h].time, run.humans[h].position, times)
                              for h in others])
    unwrapped = headings if headings is not None else _headings(run)
    turned = np.concatenate([sampled_at(run.humans[h].time, unwrapped[h], times, held=True)
                             for h in others])
    points = np.tile(subject.position, (len(others), 1))
    there = ~np.isnan(centres[:, 0])               # not a flow's member before it came or after
    present = ShapeArrays(repeated.kind[there], repeated.a[there], repeated.b[there],
                          repeated.offset[there])
    inside = np.zeros(len(centres), dtype=np.bool_)
    inside[there] = np.asarray(contains(present, turned[there], centres[there], points[there]))
    intruded = np.asarray(inside.reshape(len(others), count).any(axis=0), dtype=np.bool_)[:-1]
    dt = np.diff(times)
    return float(dt[intruded].sum() / dt.sum()) if dt.sum() > 0 else 0.0



def _headings(run: LoggedRun) -> dict[str, FloatArray]:
    """Each human's heading without jumps of 2 pi, so that it interpolates."""
    return {name: np.unwrap(human.heading) for name, human in run.humans.items()}


def _radius(run: LoggedRun, human: str) -> float:
    radius = run.metadata.params.get(human, {}).get("radius", DEFAULT_HUMAN_RADIUS)
    return float(radius) if isinstance(radius, int | float) else DEFAULT_HUMAN_RADIUS


def _shape(run: LoggedRun, human: str) -> Shape:
    shape = run.metadata.params.get(human, {}).get("personal_space")
    return shape if isinstance(shape, Circle | Ellipse | Rectangle) else Circle(_radius(run, human))
