"""Per-actor metrics of one logged run: how far and how fast each human (and robot) went, when
its tasks finished, how close it came to the others, how long someone stood inside its personal
space and how often bodies overlapped.

    metrics = compute_metrics(load_run("run.mcap"))
    metrics.humans["actor1"].path_length
    metrics.to_dict()   # JSON-safe, sorted, rounded: equal runs give equal dicts
    metrics.flat()      # {"actor1.path_length": 7.18, ...} for one CSV row per run

Definitions (docs/analysis.md says the same with examples):

- A *segment* joins two consecutive logged frames; its speed is its length over its time. An
  actor is *moving* on a segment faster than `MOVING_SPEED`.
- `path_length`: sum of segment lengths. `mean_speed`: length over time of the moving segments.
  `max_speed`: the fastest segment.
- `duration`: from the earlier of the first movement and the first task start to the later of
  the last movement and the last task end (the run's end, for a task still under way then); 0
  for an actor that never moved nor had a task.
- `min_distance`: smallest centre-to-centre distance to each other actor over the frames both
  were logged (the other's track interpolated at this actor's frame times).
- `personal_space_intrusion_time`: total time during which another actor's centre lay inside
  this human's personal space, placed at its position and turned to its heading. A frame counts
  for the time until the next frame.
- `collisions`: episodes (runs of consecutive frames) during which the bodies of this actor and
  another touched or overlapped (centre distance below the sum of the radii plus
  `socialnav.CONTACT`), summed over the others.
- `task_finish_times`: for each task of the human that ended done (SUCCEEDED or PREEMPTED, as
  the language's `LABEL done`), its label, or `kind@line:column` where it is written when it
  has none (`kind#task_id` for a task with no place in a scenario), to the time it ended: the
  same key in every run, whatever order tasks started in; a labelled `parallel`/`race`/
  sequence/`repeat` step also gets an entry, the time this human's last task inside it ended,
  when all of them ended done.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from hubero_dsl.analysis import pairs
from hubero_dsl.analysis.socialnav_log import robot_outcome
from hubero_dsl.errors import InputError
from hubero_dsl.sim.status import TaskStatus
from hubero_dsl.socialnav import CONTACT
from hubero_dsl.world.personal_space import contains
from hubero_dsl.world.shapes import Circle, Ellipse, Rectangle, Shape, ShapeArrays

if TYPE_CHECKING:
    from hubero_dsl.diagnostics import Span
    from hubero_dsl.log.reader import LoggedRun
    from hubero_dsl.pipeline import Outline
    from hubero_dsl.sim.status import TaskEvent

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]

MOVING_SPEED = 0.05  # m/s: slower than this is standing (turning on the spot, numerical drift)
DECIMALS = 6  # floats in to_dict/flat are rounded to 1e-6 so runs compare exactly
NO_STATUS = "IDLE"  # the status a log shows before a human's first task
DEFAULT_HUMAN_RADIUS = 0.2
DEFAULT_ROBOT_RADIUS = 0.3
_DONE = (TaskStatus.SUCCEEDED, TaskStatus.PREEMPTED)

Scalar = float | int | str


@dataclass(frozen=True)
class HumanMetrics:
    name: str
    path_length: float                      # m
    duration: float                         # s
    task_finish_times: dict[str, float]     # label, "kind@line:column" or "kind#id" -> s
    mean_speed: float                       # m/s
    max_speed: float                        # m/s
    min_distance: dict[str, float]          # other actor -> m (centre to centre)
    personal_space_intrusion_time: float    # s
    collisions: int                         # overlap episodes of bodies
    final_status: str                       # the status in the last frame


@dataclass(frozen=True)
class RobotMetrics:
    name: str
    path_length: float
    duration: float
    mean_speed: float
    max_speed: float
    min_distance: dict[str, float]
    collisions: int
    social: dict[str, float]  # hubero_dsl.socialnav's metrics among the people, from the log
    success: bool             # it reached its goal before any collision
    termination: str          # what ended its run first: reached_goal, collision, timeout, ...
    collided_with: dict[str, int]  # collisions per partner: a person's name, or "obstacle"


@dataclass(frozen=True)
class RunMetrics:
    humans: dict[str, HumanMetrics]
    robots: dict[str, RobotMetrics]

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe, keys sorted, floats rounded to 1e-6 (so executors agree exactly)."""
        return {
            "humans": {name: _clean(vars_of(m)) for name, m in sorted(self.humans.items())},
            "robots": {name: _clean(vars_of(m)) for name, m in sorted(self.robots.items())},
        }

    def flat(self) -> dict[str, Scalar]:
        """One level: `actor1.path_length`, `actor1.min_distance.actor2`, ... (sorted)."""
        rows: dict[str, Scalar] = {}
        for actors in self.to_dict().values():
            _flatten("", actors, rows)
        return dict(sorted(rows.items()))


def vars_of(metrics: HumanMetrics | RobotMetrics) -> dict[str, object]:
    return {key: value for key, value in vars(metrics).items() if key != "name"}


def _round(value: float) -> float:
    if not math.isfinite(value):
        return value
    return round(float(value), DECIMALS) + 0.0  # + 0.0 turns -0.0 into 0.0


def _clean(value: object) -> object:
    if isinstance(value, dict):
        return {str(k): _clean(v) for k, v in sorted(value.items())}
    if isinstance(value, bool | int | str):
        return value
    if isinstance(value, float | np.floating):
        return _round(float(value))
    raise TypeError(f"unexpected metric value {value!r}")


def _flatten(prefix: str, value: object, rows: dict[str, Scalar]) -> None:
    if isinstance(value, dict):
        for key, inner in value.items():
            _flatten(f"{prefix}.{key}" if prefix else str(key), inner, rows)
    else:
        assert isinstance(value, float | int | str)
        rows[prefix] = value


# ---- computing ---------------------------------------------------------------------------


def _final_status(time: FloatArray, status: npt.NDArray[Any], events: list[TaskEvent]) -> str:
    """The status in the last frame; a task's end after it (a flow's member leaves the scene
    as it arrives: its last frame shows it still walking) is the human's last word."""
    last = events[-1] if events else None
    if last is not None and (not len(time) or last.time > float(time[-1])):
        return str(last.status.value)
    return str(status[-1]) if len(status) else NO_STATUS


@dataclass(frozen=True)
class _Actor:
    """What the pairwise metrics need of any actor, human or robot."""

    name: str
    time: FloatArray
    position: FloatArray
    radius: float


MAX_PAIRED = 3000  # people and robots: every pair's closest approach is kept, N^2 of them


def compute_metrics(run: LoggedRun) -> RunMetrics:
    """Every human's and robot's metrics, from a log read by `load_run` (InputError for a
    run of more than MAX_PAIRED bodies: their pairs' metrics would not fit in memory)."""
    bodies = len(run.humans) + len(run.robots)
    if bodies > MAX_PAIRED:
        raise InputError(f"{run.path}: {bodies} people and robots are too many to compare "
                         f"pair by pair (at most {MAX_PAIRED}: every pair's closest approach "
                         "is kept); a sweep of such runs takes --no-metrics")
    outline = _outline(run)
    actors = _actors(run, outline)
    spans = _label_spans(outline)
    pairs = _pair_metrics(run, actors)
    humans = {}
    for name, track in sorted(run.humans.items()):
        events = [e for e in run.events if e.human == name]
        speeds = _Motion.of(actors[name], events, run.result.time if run.result else None)
        humans[name] = HumanMetrics(
            name=name, path_length=speeds.path_length, duration=speeds.duration,
            task_finish_times=task_finish_times(events, spans),
            mean_speed=speeds.mean_speed, max_speed=speeds.max_speed,
            min_distance=pairs.min_distance[name],
            personal_space_intrusion_time=pairs.intrusion_time[name],
            collisions=pairs.collisions[name],
            final_status=_final_status(track.time, track.status, events))
    robots = {}
    for name in sorted(run.robots):
        speeds = _Motion.of(actors[name], [])
        outcome = robot_outcome(run, name)
        robots[name] = RobotMetrics(
            name=name, path_length=speeds.path_length, duration=speeds.duration,
            mean_speed=speeds.mean_speed, max_speed=speeds.max_speed,
            min_distance=pairs.min_distance[name], collisions=pairs.collisions[name],
            social=outcome.social, success=outcome.termination.success,
            termination=outcome.termination.cause, collided_with=outcome.collided_with)
    return RunMetrics(humans, robots)


@dataclass(frozen=True)
class _PairMetrics:
    """The metrics of each actor that depend on the others."""

    min_distance: dict[str, dict[str, float]]
    collisions: dict[str, int]
    intrusion_time: dict[str, float]  # humans only


def _pair_metrics(run: LoggedRun, actors: dict[str, _Actor]) -> _PairMetrics:
    """For all actors at once on the log's frame grid (`pairs`), or pair by pair when the
    tracks are sampled otherwise."""
    names = sorted(actors)
    humans = sorted(run.humans)
    shapes = {name: _personal_space(run, actors[name]) for name in humans}
    grid = pairs.on_grid([actors[n].time for n in names], [actors[n].position for n in names])
    if grid is None:
        return _pair_by_pair(run, actors, shapes)
    closest = pairs.min_distances(grid)
    counts = pairs.collision_counts(grid, np.array([actors[n].radius for n in names]))
    owner = np.array([names.index(n) for n in humans], dtype=np.intp)
    intrusion = pairs.intrusion_times(grid, owner, [shapes[n] for n in humans],
                                      [run.humans[n].heading for n in humans])
    return _PairMetrics(
        min_distance={name: {other: float(closest[i, j]) for j, other in enumerate(names)
                             if np.isfinite(closest[i, j])} for i, name in enumerate(names)},
        collisions={name: int(counts[i]) for i, name in enumerate(names)},
        intrusion_time={name: float(intrusion[k]) for k, name in enumerate(humans)})


def _pair_by_pair(run: LoggedRun, actors: dict[str, _Actor], shapes: dict[str, Shape]
                  ) -> _PairMetrics:
    others = {name: [a for a in actors.values() if a.name != name] for name in actors}
    return _PairMetrics(
        min_distance={name: min_distances(actors[name], others[name]) for name in actors},
        collisions={name: collisions(actors[name], others[name]) for name in actors},
        intrusion_time={name: intrusion_time(actors[name], run.humans[name].heading,
                                             shapes[name], others[name]) for name in shapes})


def _personal_space(run: LoggedRun, actor: _Actor) -> Shape:
    shape = run.metadata.params.get(actor.name, {}).get("personal_space")
    return shape if isinstance(shape, Circle | Ellipse | Rectangle) else Circle(actor.radius)


def _actors(run: LoggedRun, outline: Outline | None) -> dict[str, _Actor]:
    actors = {}
    for name, human in run.humans.items():
        radius = run.metadata.params.get(name, {}).get("radius", DEFAULT_HUMAN_RADIUS)
        actors[name] = _Actor(name, human.time, human.position,
                              float(radius) if isinstance(radius, int | float) else
                              DEFAULT_HUMAN_RADIUS)
    robot_radius = outline.robot_radii(run.metadata.variant) if outline is not None else {}
    for name, robot in run.robots.items():
        actors[name] = _Actor(name, robot.time, robot.position,
                              robot_radius.get(name, DEFAULT_ROBOT_RADIUS))
    return actors


@dataclass(frozen=True)
class _Motion:
    path_length: float
    duration: float
    mean_speed: float
    max_speed: float

    @staticmethod
    def of(actor: _Actor, events: list[TaskEvent], end: float | None = None) -> _Motion:
        """`end`: when the run ended, which a task still under way then lasted to."""
        steps = np.diff(actor.position, axis=0)
        lengths = np.hypot(steps[:, 0], steps[:, 1])
        dt = np.diff(actor.time)
        speed = np.divide(lengths, dt, out=np.zeros_like(lengths), where=dt > 0)
        moving = speed > MOVING_SPEED
        moving_time = float(dt[moving].sum())
        moments = [e.time for e in events]
        ended = {e.task_id for e in events if e.status.is_final}
        if end is not None and any(e.task_id not in ended for e in events):
            moments.append(end)  # a task cut off by the run's end lasted until then
        if np.any(moving):
            index = np.flatnonzero(moving)
            moments += [float(actor.time[index[0]]), float(actor.time[index[-1] + 1])]
        return _Motion(
            path_length=float(lengths.sum()),
            duration=max(moments) - min(moments) if moments else 0.0,
            mean_speed=float(lengths[moving].sum()) / moving_time if moving_time > 0 else 0.0,
            max_speed=float(speed.max()) if len(speed) else 0.0)


def _resampled(other: _Actor, times: FloatArray) -> tuple[FloatArray, BoolArray]:
    """The other's positions at `times` (linear between its frames) and where it was logged."""
    if len(other.time) == 0:
        return np.zeros((len(times), 2)), np.zeros(len(times), dtype=np.bool_)
    x = np.interp(times, other.time, other.position[:, 0])
    y = np.interp(times, other.time, other.position[:, 1])
    logged = (times >= other.time[0] - 1e-9) & (times <= other.time[-1] + 1e-9)
    return np.column_stack([x, y]), logged


def _distances(actor: _Actor, other: _Actor) -> tuple[FloatArray, BoolArray]:
    where, logged = _resampled(other, actor.time)
    gap = where - actor.position
    return np.hypot(gap[:, 0], gap[:, 1]), logged


def min_distances(actor: _Actor, others: list[_Actor]) -> dict[str, float]:
    """Closest approach, centre to centre, to each other actor (only while both are logged)."""
    result = {}
    for other in sorted(others, key=lambda a: a.name):
        distance, logged = _distances(actor, other)
        if np.any(logged):
            result[other.name] = float(distance[logged].min())
    return result


def collisions(actor: _Actor, others: list[_Actor]) -> int:
    """Episodes of overlapping bodies, counted per other actor and summed."""
    total = 0
    for other in others:
        distance, logged = _distances(actor, other)
        overlap = logged & (distance < actor.radius + other.radius + CONTACT)
        starts = overlap[1:] & ~overlap[:-1]
        total += int(starts.sum()) + int(overlap[:1].sum())
    return total


def frame_durations(time: FloatArray) -> FloatArray:
    """How long each frame's state held: until the next frame (the last holds for no time)."""
    return np.append(np.diff(time), 0.0) if len(time) else np.zeros(0)


def intrusion_time(actor: _Actor, heading: FloatArray, shape: Shape,
                   others: list[_Actor]) -> float:
    """Time with any other actor's centre inside this human's personal space."""
    frames = len(actor.time)
    if frames == 0 or not others:
        return 0.0
    placed = [_resampled(other, actor.time) for other in others]
    points = np.stack([where for where, _ in placed], axis=1)      # (T, K, 2)
    logged = np.stack([mask for _, mask in placed], axis=1)        # (T, K)
    shapes = ShapeArrays.from_shapes([shape] * frames)
    inside = contains(shapes, heading, actor.position, points) & logged
    return float(frame_durations(actor.time)[inside.any(axis=1)].sum())


# ---- labels and robot sizes, from the scenario text kept in the log ---------------------------


def _outline(run: LoggedRun) -> Outline | None:
    """The scenario as read from the log's copy of its text; None when there is none."""
    from hubero_dsl.errors import HuberoError
    from hubero_dsl.pipeline import outline_source

    if not run.metadata.source.strip():
        return None
    try:
        return outline_source(run.metadata.source, run.metadata.source_path)
    except HuberoError:
        return None  # a log of a scenario this version cannot parse: no labels, default radii


def _label_spans(outline: Outline | None) -> list[tuple[str, Span, bool]]:
    """(label, span, is a single task) of every labelled step."""
    if outline is None:
        return []
    from hubero_dsl.model.activities import TaskStep, walk_steps

    steps = walk_steps(tuple(s for a in outline.activities for s in a.steps))
    return [(step.label.name, step.span, isinstance(step, TaskStep))
            for step in steps if step.label is not None]


def _inside(span: Span | None, outer: Span) -> bool:
    if span is None:
        return False
    start = (span.line, span.column)
    return (outer.line, outer.column) <= start < (outer.end_line, outer.end_column)


def task_finish_times(events: list[TaskEvent],
                      labels: list[tuple[str, Span, bool]]) -> dict[str, float]:
    """One human's done tasks and labelled steps -> the time they ended (see the module doc)."""
    started = {e.task_id: e for e in events}
    ended = {e.task_id: e for e in events if e.status.is_final}
    finished: dict[str, float] = {}
    for task_id, event in sorted(ended.items()):
        if event.status not in _DONE:
            continue
        key = _own_label(event.span, labels) or _task_place(event.kind, task_id, event.span)
        finished[key] = max(finished.get(key, event.time), event.time)
    for name, span, single in labels:
        inside = [i for i, e in started.items() if _inside(e.span, span)]
        if single or not inside:
            continue
        if all(i in ended and ended[i].status in _DONE for i in inside):
            finished[name] = max(ended[i].time for i in inside)
    return dict(sorted(finished.items()))


def _task_place(kind: str, task_id: int, span: Span | None) -> str:
    """An unlabelled task's key: where it is written (task ids count tasks in the order they
    start, which differs between runs when branches or a flow's arrivals interleave)."""
    return f"{kind}@{span.line}:{span.column}" if span is not None else f"{kind}#{task_id}"


def _own_label(span: Span | None, labels: list[tuple[str, Span, bool]]) -> str | None:
    """The label written on this task's own step (`invite: actor2 move_to sofa`)."""
    if span is None:
        return None
    return next((name for name, where, single in labels
                 if single and (where.line, where.column) == (span.line, span.column)), None)
