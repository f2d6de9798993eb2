"""Comparing runs: two logs side by side, or every run of a sweep against a baseline variant.

    d = diff_runs(load_run("circle.mcap"), load_run("ellipse.mcap"), epsilon=0.1)
    d.humans["actor1"].frechet, d.humans["actor1"].diverged_at, d.humans["actor1"].parameters
    s = diff_sweep("sweep_out/", baseline="circle")   # reads sweep_out/index.json

Humans are matched by name; runs whose humans differ are not comparable (InputError naming
them). Per human a diff holds every metric of both runs with its delta (B - A), the discrete
Fréchet and Hausdorff distances between the two paths (shapely, over the logged positions), the
first time the two are more than `epsilon` apart at the same instant, and the parameters whose
values differ between the runs.
"""

from __future__ import annotations

import itertools
import json
import math
import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import shapely

from hubero_dsl.analysis.metrics import (
    DECIMALS,
    NO_STATUS,
    HumanMetrics,
    RunMetrics,
    Scalar,
    compute_metrics,
    vars_of,
)
from hubero_dsl.analysis.socialnav_log import robot_social_metrics
from hubero_dsl.errors import InputError
from hubero_dsl.files import read_bounded
from hubero_dsl.sim.status import TaskStatus
from hubero_dsl.world.shapes import Circle, Ellipse, Rectangle, describe_shape

if TYPE_CHECKING:
    from hubero_dsl.log.reader import HumanTrack, LoggedRun, RobotTrack

    FloatArray = np.ndarray[Any, np.dtype[np.float64]]

DEFAULT_EPSILON = 0.1  # m
INDEX_NAME = "index.json"
INDEX_VERSION = 1
MAX_INDEX_BYTES = 512 << 20  # the index of the largest sweep (100,000 runs) with its metrics

# Metrics in the order tables show them; keys of dict metrics follow their group.
_ORDER = ("path_length", "duration", "mean_speed", "max_speed", "min_distance",
          "personal_space_intrusion_time", "collisions", "task_finish_times", "final_status")


@dataclass(frozen=True)
class MetricDelta:
    """One metric of one human in both runs; `delta` is B - A (None for text or a missing side)."""

    name: str
    a: Scalar | None
    b: Scalar | None
    delta: float | int | None


@dataclass(frozen=True)
class HumanDiff:
    name: str
    metrics: tuple[MetricDelta, ...]
    frechet: float | None        # m, discrete Fréchet distance between the paths
    hausdorff: float | None      # m
    max_separation: float | None  # m, largest distance between the two at the same instant
    diverged_at: float | None    # s, first instant they are more than epsilon apart; None: never
    parameters: dict[str, tuple[str, str]]  # parameter -> (value in A, value in B), if different

    def metric(self, name: str) -> MetricDelta | None:
        return next((m for m in self.metrics if m.name == name), None)

    def to_dict(self) -> dict[str, Any]:
        return {
            "metrics": {m.name: {"a": m.a, "b": m.b, "delta": m.delta} for m in self.metrics},
            "frechet": self.frechet, "hausdorff": self.hausdorff,
            "max_separation": self.max_separation, "diverged_at": self.diverged_at,
            "parameters": {k: list(v) for k, v in sorted(self.parameters.items())},
        }


@dataclass(frozen=True)
class RunSide:
    """Which run one side of a diff is."""

    path: str
    title: str
    variant: str | None
    seed: int


@dataclass(frozen=True)
class RunDiff:
    a: RunSide
    b: RunSide
    epsilon: float
    humans: dict[str, HumanDiff]
    notes: tuple[str, ...] = ()  # what else differs (the scenario, the map), said in words
    robots: dict[str, HumanDiff] = field(default_factory=dict)  # social-navigation metrics
    # A's crowds, flows and groups (name -> kind, members), as its log names them
    sets: dict[str, tuple[str, tuple[str, ...]]] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return {"a": vars(self.a), "b": vars(self.b), "epsilon": self.epsilon,
                "humans": {n: h.to_dict() for n, h in sorted(self.humans.items())},
                "robots": {n: r.to_dict() for n, r in sorted(self.robots.items())},
                "sets": {n: c.to_dict() for n, c in set_diffs(self).items()},
                "notes": list(self.notes)}


def diff_runs(a: LoggedRun, b: LoggedRun, *, epsilon: float = DEFAULT_EPSILON,
              metrics_a: RunMetrics | None = None,
              metrics_b: RunMetrics | None = None) -> RunDiff:
    """Compare two runs human by human; InputError if their humans differ."""
    if not (epsilon > 0 and math.isfinite(epsilon)):
        raise InputError(f"epsilon must be a positive number of metres, got {epsilon!r}")
    _check_same_humans(a, b)
    metrics_a = metrics_a or compute_metrics(a)
    metrics_b = metrics_b or compute_metrics(b)
    humans = {}
    for name in a.humans:  # in the run's order, as its log and `hubero run` list them
        frechet, hausdorff = path_distances(a.humans[name].position, b.humans[name].position)
        separation, diverged = divergence(a.humans[name], b.humans[name], epsilon)
        humans[name] = HumanDiff(
            name=name,
            metrics=metric_deltas(metrics_a.humans[name], metrics_b.humans[name]),
            frechet=frechet, hausdorff=hausdorff, max_separation=separation,
            diverged_at=diverged,
            parameters=parameter_changes(a.metadata.params.get(name, {}),
                                         b.metadata.params.get(name, {})))
    diff = RunDiff(_side(a), _side(b), epsilon, humans, _notes(a, b),
                   _robot_diffs(a, b, epsilon), a.metadata.sets)
    for member, absent in came_in_one_run(diff).items():
        diff.humans[member] = _one_sided(diff.humans[member], absent)
    return diff


def _one_sided(human: HumanDiff, absent: str) -> HumanDiff:
    """A flow's member who came in one run only: the run it did not come in (`absent`, "A"
    or "B") has nothing of it to compare, not the zeros of someone who stood still, nor the
    parameters drawn for someone who never walked there."""
    metrics = tuple(MetricDelta(m.name, None if absent == "A" else m.a,
                                None if absent == "B" else m.b, None) for m in human.metrics)
    return replace(human, metrics=metrics, frechet=None, hausdorff=None, max_separation=None,
                   diverged_at=None, parameters={})


def _robot_diffs(a: LoggedRun, b: LoggedRun, epsilon: float) -> dict[str, HumanDiff]:
    """Each robot both runs have: its path against itself, and its social-navigation metrics
    among the people (`hubero_dsl.socialnav`, from the logs' tracks)."""
    robots = {}
    for name in sorted(set(a.robots) & set(b.robots)):
        frechet, hausdorff = path_distances(a.robots[name].position, b.robots[name].position)
        separation, diverged = divergence(a.robots[name], b.robots[name], epsilon)
        robots[name] = HumanDiff(name, _number_deltas(robot_social_metrics(a, name),
                                                      robot_social_metrics(b, name)),
                                 frechet, hausdorff, separation, diverged, {})
    return robots


def _number_deltas(a: dict[str, float], b: dict[str, float]) -> tuple[MetricDelta, ...]:
    """B - A of each metric; None where either side is not finite (no goal, no people)."""
    return tuple(_compared(name, _finite(a.get(name)), _finite(b.get(name)))
                 for name in sorted(set(a) | set(b)))


def _side(run: LoggedRun) -> RunSide:
    return RunSide(str(run.path), run.metadata.title, run.metadata.variant, run.metadata.seed)


def _check_same_humans(a: LoggedRun, b: LoggedRun) -> None:
    only_a, only_b = set(a.humans) - set(b.humans), set(b.humans) - set(a.humans)
    if not only_a and not only_b:
        return
    parts = [f"only in {run.path}: {_named(run, names)}"
             for run, names in ((a, only_a), (b, only_b)) if names]
    raise InputError(f"the runs have different humans ({'; '.join(parts)}): are they runs of "
                     f"the same scenario? ('{a.metadata.title}' and '{b.metadata.title}')")


_SHOWN_NAMES = 10


def _named(run: LoggedRun, names: set[str]) -> str:
    """The people of `names` who were in the run's scene, in the order of their numbers
    (walkers_2 before walkers_10), at most _SHOWN_NAMES; a flow's members who never came are
    counted, not named."""
    came = sorted((n for n in names if len(run.humans[n].time)), key=_in_number_order)
    never = len(names) - len(came)
    words = ", ".join(came[:_SHOWN_NAMES])
    if len(came) > _SHOWN_NAMES:
        words += f" and {len(came) - _SHOWN_NAMES} more"
    if never:
        words += f"{', and ' if came else ''}{never} flow member{'s' * (never != 1)} who " \
                 "never came"
    return words


def _in_number_order(name: str) -> list[str | int]:
    return [int(part) if part.isdigit() else part for part in re.split(r"(\d+)", name)]


def _notes(a: LoggedRun, b: LoggedRun) -> tuple[str, ...]:
    notes = []
    if a.metadata.source_sha256 != b.metadata.source_sha256:
        notes.append(f"the scenario texts differ ({_first_difference(a, b)})")
    if a.grid.shape != b.grid.shape or not np.array_equal(a.grid.occupied, b.grid.occupied):
        notes.append("the maps differ")
    return tuple(notes)


def _first_difference(a: LoggedRun, b: LoggedRun) -> str:
    """Where two runs' scenario texts first part: the titles when those differ, else the
    first line that does (as the logs carry them)."""
    if a.metadata.title != b.metadata.title:
        return f"'{a.metadata.title}' in A, '{b.metadata.title}' in B"
    lines_a, lines_b = a.metadata.source.splitlines(), b.metadata.source.splitlines()
    for number, (line_a, line_b) in enumerate(itertools.zip_longest(lines_a, lines_b), 1):
        if line_a != line_b:
            return (f"first at line {number}: {_quoted_line(line_a)} in A, "
                    f"{_quoted_line(line_b)} in B")
    return "in their line endings"


def _quoted_line(line: str | None) -> str:
    if line is None:
        return "nothing"
    text = line.strip()
    return f"'{text[:57]}...'" if len(text) > 60 else f"'{text}'"


# ---- the pieces ---------------------------------------------------------------------------


def _rounded(value: float) -> float:
    return round(value, DECIMALS) + 0.0


def _metric_values(metrics: HumanMetrics) -> dict[str, Scalar]:
    values: dict[str, Scalar] = {}
    for key, value in vars_of(metrics).items():
        if not isinstance(value, dict):
            assert isinstance(value, float | int | str)
            values[key] = value
            continue
        for inner, number in sorted(value.items()):
            values[f"{key}.{inner}"] = number
    return values


def _finite(value: float | None) -> float | None:
    """A number JSON can hold: None for a missing or infinite one (no goal, nobody near)."""
    return _rounded(value) if value is not None and math.isfinite(value) else None


def _tidy(value: Scalar | None) -> Scalar | None:
    return _rounded(value) if isinstance(value, float) else value


def _order(name: str) -> tuple[int, str]:
    return _ORDER.index(name.split(".", 1)[0]), name


def metric_deltas(a: HumanMetrics, b: HumanMetrics) -> tuple[MetricDelta, ...]:
    """Every metric either run has, in table order, with B - A where both are numbers (tasks
    line up by their keys: labels, or where they are written)."""
    values_a, values_b = _metric_values(a), _metric_values(b)
    return tuple(_compared(name, _tidy(values_a.get(name)), _tidy(values_b.get(name)))
                 for name in sorted(set(values_a) | set(values_b), key=_order))


def _line(position: FloatArray) -> shapely.LineString | None:
    if len(position) == 0:
        return None
    points = position if len(position) > 1 else np.repeat(position, 2, axis=0)
    return shapely.LineString(points)


def path_distances(a: FloatArray, b: FloatArray) -> tuple[float | None, float | None]:
    """Discrete Fréchet and Hausdorff distances between two paths (None if either is empty)."""
    line_a, line_b = _line(a), _line(b)
    if line_a is None or line_b is None:
        return None, None
    return (_rounded(float(shapely.frechet_distance(line_a, line_b))),
            _rounded(float(shapely.hausdorff_distance(line_a, line_b))))


def divergence(a: HumanTrack | RobotTrack, b: HumanTrack | RobotTrack,
               epsilon: float) -> tuple[float | None, float | None]:
    """(largest same-instant separation, first instant it exceeds epsilon) over the times both
    runs logged; B's position is interpolated at A's frame times."""
    if len(a.time) == 0 or len(b.time) == 0:
        return None, None
    both = (a.time >= b.time[0]) & (a.time <= b.time[-1])
    times = a.time[both]
    if len(times) == 0:
        return None, None
    where_b = np.column_stack([np.interp(times, b.time, b.position[:, axis]) for axis in (0, 1)])
    gap = np.linalg.norm(where_b - a.position[both], axis=1)
    apart = np.flatnonzero(gap > epsilon)
    return _rounded(float(gap.max())), (_rounded(float(times[apart[0]])) if len(apart) else None)


def describe_value(value: object) -> str:
    if isinstance(value, Circle | Ellipse | Rectangle):
        return describe_shape(value)
    if isinstance(value, float):
        return f"{value:g}"
    return str(value)


def parameter_changes(a: dict[str, Any], b: dict[str, Any]) -> dict[str, tuple[str, str]]:
    """Parameters with different values in the two runs: name -> (A's, B's), as text."""
    missing = "(not set)"
    return {key: (describe_value(a[key]) if key in a else missing,
                  describe_value(b[key]) if key in b else missing)
            for key in sorted(set(a) | set(b)) if a.get(key) != b.get(key)}


# ---- crowds and flows, each as a whole ------------------------------------------------------

# A crowd's metric, the members' metric it sums up (with its keys: `min_distance.NAME`), and
# how: over the members with a value on a side.
_SET_METRICS = (("path_length", "path_length", "mean"), ("duration", "duration", "mean"),
                ("mean_speed", "mean_speed", "mean"), ("max_speed", "max_speed", "max"),
                ("min_distance", "min_distance", "min"),
                ("personal_space_intrusion_time", "personal_space_intrusion_time", "sum"),
                ("collisions", "collisions", "sum"), ("succeeded", "final_status", "count"))


@dataclass(frozen=True)
class SetDiff:
    """A crowd's or flow's members compared as a whole. `metrics` holds, on each side, how
    many `members` were in the scene, their mean path length, duration and speed, their top
    speed, the closest any of them came to anyone (`min_distance`), their intrusions and
    collisions summed, and how many ended their last task `succeeded`; then how far their
    paths moved: the median Fréchet distance, the largest Hausdorff distance, how many were
    ever more than epsilon apart from themselves, and the first instant one was."""

    name: str
    kind: str
    members: int
    metrics: tuple[MetricDelta, ...]
    frechet_median: float | None
    hausdorff_max: float | None
    diverged: int
    first_diverged_at: float | None

    def to_dict(self) -> dict[str, Any]:
        return {"kind": self.kind, "members": self.members,
                "metrics": {m.name: {"a": m.a, "b": m.b, "delta": m.delta}
                            for m in self.metrics},
                "frechet_median": self.frechet_median, "hausdorff_max": self.hausdorff_max,
                "diverged": self.diverged, "first_diverged_at": self.first_diverged_at}


def set_diffs(diff: RunDiff) -> dict[str, SetDiff]:
    """Each crowd and flow of the runs (`diff.sets`) as a whole; groups are left out, their
    members being humans named one by one. A flow's metrics on a side count the members who
    came in that run."""
    result = {}
    for name, (kind, members) in sorted(diff.sets.items()):
        humans = [diff.humans[m] for m in members if m in diff.humans]
        if kind == "group" or not humans:
            continue
        came = {side: [h for h in humans if kind != "flow" or _came(h, side)]
                for side in ("a", "b")}
        metrics = (_compared("members", len(came["a"]), len(came["b"])),
                   *(_set_metric(came, name, source, how) for name, source, how in _SET_METRICS))
        frechet = [h.frechet for h in humans if h.frechet is not None]
        hausdorff = [h.hausdorff for h in humans if h.hausdorff is not None]
        apart = [h.diverged_at for h in humans if h.diverged_at is not None]
        result[name] = SetDiff(
            name, kind, len(humans), metrics,
            _rounded(float(np.median(frechet))) if frechet else None,
            max(hausdorff) if hausdorff else None, len(apart), min(apart) if apart else None)
    return result


def never_came(diff: RunDiff) -> set[str]:
    """The flows' members who came in neither run: names with nothing to compare."""
    return {member for kind, members in diff.sets.values() if kind == "flow"
            for member in members if member in diff.humans
            and not any(_came(diff.humans[member], side) for side in ("a", "b"))}


def came_in_one_run(diff: RunDiff) -> dict[str, str]:
    """The flows' members who came in one run only, and the run ("A" or "B") they did not
    come in: their numbers there are those of someone who never walked."""
    return {member: "B" if _came(diff.humans[member], "a") else "A"
            for kind, members in diff.sets.values() if kind == "flow"
            for member in members if member in diff.humans
            and _came(diff.humans[member], "a") != _came(diff.humans[member], "b")}


def _came(human: HumanDiff, side: str) -> bool:
    """Whether a flow's member came in the run of `side` (it had a task: flows give their
    people theirs when they come)."""
    status = human.metric("final_status")
    return status is not None and getattr(status, side) not in (None, NO_STATUS)


def _set_metric(came: dict[str, list[HumanDiff]], name: str, source: str, how: str
                ) -> MetricDelta:
    """Crowd metric `name`: the members' `source` (and its keys) summed up `how` on each side,
    over the members who `came` in that side's run."""
    def side(which: str) -> float | int | None:
        return aggregate([getattr(m, which) for h in came[which] for m in h.metrics
                          if m.name == source or m.name.startswith(f"{source}.")], how)
    return _compared(name, side("a"), side("b"))


def _compared(name: str, left: Scalar | None, right: Scalar | None) -> MetricDelta:
    """A metric's two sides and B - A (None unless both are numbers)."""
    delta: float | int | None = None
    if isinstance(left, int) and isinstance(right, int):
        delta = right - left
    elif isinstance(left, int | float) and isinstance(right, int | float):
        delta = _rounded(float(right) - float(left))
    return MetricDelta(name, left, right, delta)


def aggregate(values: Sequence[Scalar | None], how: str) -> float | int | None:
    """`values` (one per member; None where it has none) summed up `how`: mean, max, min, sum,
    or count (of SUCCEEDED statuses). None when no member has a number."""
    if how == "count":
        return sum(1 for v in values if v == TaskStatus.SUCCEEDED)
    numbers = [v for v in values if isinstance(v, int | float) and not isinstance(v, bool)]
    if not numbers:
        return None
    picked: float | int
    if how == "mean":
        picked = float(np.mean(numbers))
    else:
        picked = sum(numbers) if how == "sum" else max(numbers) if how == "max" else min(numbers)
    return _rounded(float(picked)) if isinstance(picked, float) else picked


def collapse_closest(metrics: Sequence[MetricDelta], set_of: Callable[[str], str | None]
                     ) -> tuple[MetricDelta, ...]:
    """`metrics` with the closest approach to each member of a crowd or flow (`set_of` says
    which, None for a named human) as one row per crowd or flow, where its first member's row
    was: the closest to any of them."""
    rows: list[MetricDelta | str] = []
    members: dict[str, list[MetricDelta]] = {}
    for metric in metrics:
        group, _, other = metric.name.partition(".")
        crowd = set_of(other) if group == "min_distance" and other else None
        if crowd is None:
            rows.append(metric)
            continue
        if crowd not in members:
            members[crowd] = []
            rows.append(crowd)
        members[crowd].append(metric)
    return tuple(row if isinstance(row, MetricDelta) else _compared(
        f"min_distance.{row}", aggregate([m.a for m in members[row]], "min"),
        aggregate([m.b for m in members[row]], "min")) for row in rows)


# ---- sweeps -------------------------------------------------------------------------------


@dataclass(frozen=True)
class IndexedRun:
    """One entry of a sweep's index.json."""

    variant: str | None
    seed: int
    status: str
    reason: str
    log: Path | None  # absolute (resolved against the sweep folder); None when not written
    parameters: dict[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class SweepIndex:
    directory: Path
    scenario: str
    runs: tuple[IndexedRun, ...]


@dataclass(frozen=True)
class SweepComparison:
    """One run of a sweep against the baseline of its seed; `diff` is None when it could not be
    compared, and `note` says why."""

    variant: str | None
    seed: int
    status: str
    diff: RunDiff | None
    note: str = ""

    def to_dict(self) -> dict[str, Any]:
        return {"variant": self.variant, "seed": self.seed, "status": self.status,
                "note": self.note, "diff": self.diff.to_dict() if self.diff else None}


@dataclass(frozen=True)
class SweepDiff:
    directory: str
    scenario: str
    baseline: str
    epsilon: float
    comparisons: tuple[SweepComparison, ...]

    def to_dict(self) -> dict[str, Any]:
        return {"directory": self.directory, "scenario": self.scenario,
                "baseline": self.baseline, "epsilon": self.epsilon,
                "comparisons": [c.to_dict() for c in self.comparisons]}


def load_index(directory: str | Path) -> SweepIndex:
    """Read DIR/index.json as `hubero sweep` writes it; InputError for anything else."""
    directory = Path(directory)
    path = directory / INDEX_NAME
    if not directory.is_dir():
        raise InputError(f"{directory} is not a directory of sweep results")
    if not path.exists():
        raise InputError(f"{directory} has no {INDEX_NAME}: is it the output folder of "
                         f"`hubero sweep`?")
    index = _index_json(path)
    if not isinstance(index, dict) or not isinstance(index.get("runs"), list):
        raise InputError(f"{path} is not a sweep index (no list of runs)")
    version = index.get("version", INDEX_VERSION)
    if not isinstance(version, int):
        raise InputError(f"{path} is not a sweep index (its version is not a number)")
    if version > INDEX_VERSION:
        raise InputError(f"{path} has index version {version}; this hubero reads "
                         f"version {INDEX_VERSION}")
    if not index["runs"]:
        raise InputError(f"{path} lists no runs: the sweep is empty")
    runs = tuple(_indexed_run(entry, directory, path) for entry in index["runs"])
    return SweepIndex(directory, str(index.get("scenario", "")), runs)


def _index_json(path: Path) -> Any:
    """The index's JSON value; InputError for a file that is not a regular file of at most
    `MAX_INDEX_BYTES`, not UTF-8 JSON, or nested too deeply for the decoder."""
    data = read_bounded(path, MAX_INDEX_BYTES, "sweep index")
    try:
        return json.loads(data.decode("utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise InputError(f"{path} cannot be read as a sweep index: {exc}") from None
    except RecursionError:  # the decoder recurses once per level
        raise InputError(f"{path} cannot be read as a sweep index: its JSON is nested too "
                         f"deeply") from None


def _indexed_run(entry: Any, directory: Path, path: Path) -> IndexedRun:
    try:
        log = entry.get("log")
        return IndexedRun(
            variant=None if entry.get("variant") is None else str(entry["variant"]),
            seed=int(entry["seed"]), status=str(entry.get("status", "")),
            reason=str(entry.get("reason") or ""),
            log=directory / str(log) if log else None,
            parameters=dict(entry.get("parameters") or {}))
    except (AttributeError, KeyError, TypeError, ValueError):
        raise InputError(f"{path}: a run entry is malformed: {entry!r}") from None


def diff_sweep(directory: str | Path, baseline: str, *,
               epsilon: float = DEFAULT_EPSILON) -> SweepDiff:
    """Every run of a sweep against the baseline variant's run of the same seed."""
    from hubero_dsl.log.reader import load_run

    index = load_index(directory)
    variants = sorted({r.variant for r in index.runs if r.variant is not None})
    bases = {r.seed: r for r in index.runs if r.variant == baseline}
    if not bases:
        known = (f"variants: {', '.join(variants)}" if variants else
                 "its scenario has no variants: a sweep of seeds alone has no baseline")
        raise InputError(f"no run of the baseline variant '{baseline}' in {index.directory} "
                         f"({known})")
    loaded: dict[Path, tuple[LoggedRun, RunMetrics]] = {}

    def read(path: Path) -> tuple[LoggedRun, RunMetrics]:
        if path not in loaded:
            run = load_run(_inside(path, index.directory))
            loaded[path] = (run, compute_metrics(run))
        return loaded[path]

    comparisons = []
    for run in sorted(index.runs, key=lambda r: (r.seed, str(r.variant))):
        if run.variant == baseline:
            continue
        base = bases.get(run.seed)
        note = _why_not_comparable(run, base)
        if note:
            comparisons.append(SweepComparison(run.variant, run.seed, run.status, None, note))
            continue
        assert base is not None and base.log is not None and run.log is not None
        try:
            (left, left_metrics), (right, right_metrics) = read(base.log), read(run.log)
            diff = diff_runs(left, right, epsilon=epsilon, metrics_a=left_metrics,
                             metrics_b=right_metrics)
        except InputError as exc:  # one bad log spoils its row, not the whole table
            comparisons.append(SweepComparison(run.variant, run.seed, run.status, None,
                                               exc.message))
            continue
        comparisons.append(SweepComparison(run.variant, run.seed, run.status, diff))
    return SweepDiff(str(index.directory), index.scenario, baseline, epsilon, tuple(comparisons))


def _inside(path: Path, directory: Path) -> Path:
    """`path`, symbolic links and '..' resolved, when it lies inside the sweep folder; an
    InputError otherwise. A sweep writes its logs there, so an index naming any other file
    (/etc/passwd, ../x, a link out of the folder) is damaged or forged, and it is not opened."""
    try:
        resolved = path.resolve()
        inside = resolved.is_relative_to(directory.resolve())
    except (OSError, RuntimeError):  # RuntimeError: a loop of symbolic links
        inside = False
    if not inside:
        raise InputError(f"the index names a log outside the sweep folder {directory}: "
                         f"{path} (not read)")
    return resolved


def _why_not_comparable(run: IndexedRun, base: IndexedRun | None) -> str:
    if base is None:
        return f"no baseline run with seed {run.seed}"
    if base.log is None:
        return f"the baseline run with seed {run.seed} wrote no log ({base.reason or base.status})"
    if run.log is None:
        return f"no log ({run.reason or run.status})"
    return ""
