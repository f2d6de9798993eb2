"""The social-navigation benchmark: every scenario of a suite folder, every variant, run with
the reference controller the scenarios name and with the caller's own, side by side.

Runs go through the sweep runner (`run_sweep`) on any executor; the robot's metrics come from
each log with `hubero_dsl.analysis.diff.robot_metrics` (socialnav's). The tables are plain text
(CSV and Markdown) written atomically; paths per scenario are drawn with matplotlib.
"""

from __future__ import annotations

import csv
import io
import math
from collections import Counter
from collections.abc import Mapping, Sequence
from concurrent.futures import Executor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from hubero_dsl.errors import InputError, Terminated
from hubero_dsl.log.reader import LoggedRun, load_run
from hubero_dsl.pipeline import compile_file
from hubero_dsl.sweep.index import earlier_logs, write_atomically, write_index
from hubero_dsl.sweep.plan import RunSpec, SweepPlan, plan_sweep, variant_label
from hubero_dsl.sweep.runner import prepare_out_dir, run_sweep
from hubero_dsl.sweep.worker import RunRecord

REFERENCE, YOURS = "reference", "yours"
METRICS = ("min_distance", "collisions", "intimate_intrusions", "personal_intrusions",
           "path_length")
COLUMNS = ("scenario", "variant", "seed", "controller", "status", "succeeded", *METRICS,
           "success", "termination", "collided_with", "reason")


@dataclass(frozen=True, slots=True)
class BenchRow:
    """One run of one scenario's variant with one controller."""

    scenario: str
    variant: str | None
    controller: str      # reference | yours
    status: str
    succeeded: bool
    reason: str
    metrics: Mapping[str, float] = field(default_factory=dict)
    log: str | None = None  # absolute
    seed: int | None = None  # None in a summary row
    termination: str = ""    # the robot's: socialnav_log.robot_termination's cause
    success: str = ""        # true/false: it reached its goal before any collision (k/n: runs)
    collided_with: Mapping[str, int] = field(default_factory=dict)  # partner -> collisions


def find_suite(folder: str | Path) -> list[Path]:
    """The suite's scenarios, sorted; InputError when there are none."""
    path = Path(folder)
    if not path.is_dir():
        raise InputError(f"{folder}: not a folder of scenarios")
    scenarios = sorted(path.glob("*.hub"))
    if not scenarios:
        raise InputError(f"{folder}: no scenarios (*.hub) in this folder")
    return scenarios


def robots_of(scenarios: Sequence[Path]) -> set[str]:
    """The robots every scenario of the suite names; InputError for a scenario with none (a
    bench compares robots: it would report runs with nothing to measure as ok)."""
    names = [{robot.name for robot in compile_file(path).robots} for path in scenarios]
    for path, robots in zip(scenarios, names, strict=True):
        if not robots:
            raise InputError(f"{path}: no robot under test; hubero bench compares robots' "
                             "navigation, so each scenario of a suite has one")
    return set.intersection(*names) if names else set()


@dataclass(frozen=True, slots=True)
class BenchOutcome:
    """The rows of every planned run, in plan order; when the bench was stopped, the runs that
    had not finished are rows with the status INTERRUPTED."""

    rows: list[BenchRow]
    complete: bool
    terminated: bool = False  # stopped by SIGTERM, not Ctrl-C


INTERRUPTED = "interrupted"


def run_bench(scenarios: Sequence[Path], out_dir: Path, executor: Executor, *,
              controllers: Mapping[str, type], seeds: Sequence[int] = ()) -> BenchOutcome:
    """Every scenario's every variant (with each of `seeds`, else the scenario's own seed) with
    the reference, then (when given) the caller's controllers; a run that goes wrong is a row,
    never an exception. Stopped (Ctrl-C, SIGTERM: in a run, or between runs as their logs are
    measured or the next scenario planned), it runs nothing more, and the runs that had not
    finished are rows of their own."""
    sides: list[tuple[str, dict[str, type]]] = [(REFERENCE, {})]
    if controllers:
        sides.append((YOURS, dict(controllers)))
    plans: dict[Path, tuple[SweepPlan, list[str]]] = {}
    finished: dict[tuple[str, str, str | None, int], BenchRow] = {}
    stopped: KeyboardInterrupt | None = None
    try:
        for path in scenarios:
            plan, robots = plans[path] = _planned(path, seeds)
            for side, handed in sides:
                folder = side_folder(out_dir, path.stem, side)
                prepare_out_dir(plan, folder, earlier_logs(folder))
                outcome = run_sweep(plan, folder, executor, metrics=None, controllers=handed)
                write_index(folder, plan, outcome)
                for record in outcome.records:
                    finished[(path.stem, side, record.variant, record.seed)] = _measured(
                        path.stem, side, record, folder, robots)
                if not outcome.complete:  # stopped in a run: as if stopped here
                    raise Terminated if outcome.terminated else KeyboardInterrupt
    except KeyboardInterrupt as stop:  # Terminated too
        stopped = stop
    rows = [finished.get((path.stem, side, run.variant, run.seed))
            or _interrupted(path.stem, side, run)
            for path in scenarios for side, _ in sides
            for run in (plans.get(path) or _planned(path, seeds))[0].runs]
    return BenchOutcome(rows, stopped is None, isinstance(stopped, Terminated))


def side_folder(out_dir: Path, scenario: str, side: str) -> Path:
    """Where a scenario's runs with one side's controllers go: a sweep's folder, with its
    index, which `hubero diff FOLDER --baseline VARIANT` reads and the next bench clears."""
    return out_dir / "runs" / scenario / side


def _planned(path: Path, seeds: Sequence[int]) -> tuple[SweepPlan, list[str]]:
    """A scenario's runs (every variant with each of `seeds`, else its own seed) and its
    robots."""
    program = compile_file(path)
    plan = plan_sweep(path, program, list(program.variants) or [None],
                      tuple(seeds) or (program.seed,))
    return plan, sorted(robot.name for robot in program.robots)


def _interrupted(scenario: str, side: str, run: RunSpec) -> BenchRow:
    return BenchRow(scenario, run.variant, side, INTERRUPTED, False,
                    "the bench was stopped before this run finished", seed=run.seed,
                    termination=INTERRUPTED)


def _measured(scenario: str, side: str, record: RunRecord, folder: Path,
              robots: Sequence[str]) -> BenchRow:
    log = str(folder / record.log) if record.log else None
    metrics, ended, hits = _measure(log, robots)
    return BenchRow(scenario, record.variant, side, record.status, record.succeeded,
                    record.reason, metrics, log, record.seed,
                    ended or _no_log_cause(record.status),
                    "true" if ended == "reached_goal" else "false", hits)


def _measure(log: str | None, robots: Sequence[str]
             ) -> tuple[dict[str, float], str, dict[str, int]]:
    """The first robot's social-navigation metrics, termination cause and collisions per
    partner; empty when there is no readable log."""
    from hubero_dsl.analysis.socialnav_log import robot_outcome

    if log is None or not robots or not Path(log).is_file():
        return {}, "", {}
    try:
        outcome = robot_outcome(load_run(log), robots[0])
        return outcome.social, outcome.termination.cause, outcome.collided_with
    except Exception:  # a run that died mid-way may leave a log without the robot's track
        return {}, "", {}


def _no_log_cause(status: str) -> str:
    """A run without a log ended by an error (its controller raised, its worker died)."""
    return "error" if status == "error" else ""


def table_csv(rows: Sequence[BenchRow]) -> str:
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(COLUMNS)
    for row in rows:
        writer.writerow(_cells(row))
    return out.getvalue()


def table_markdown(rows: Sequence[BenchRow]) -> str:
    lines = ["| " + " | ".join(COLUMNS) + " |", "|" + "---|" * len(COLUMNS)]
    lines += ["| " + " | ".join(c.replace("|", "/") for c in _cells(row)) + " |"
              for row in rows]
    return "\n".join(lines) + "\n"


def summary_rows(rows: Sequence[BenchRow]) -> list[BenchRow]:
    """Per controller and scenario: the worst of each metric over the variants (the smallest
    distance, the largest of the rest), succeeded only if every run did."""
    summary = []
    for scenario in dict.fromkeys(r.scenario for r in rows):
        for side in dict.fromkeys(r.controller for r in rows):
            mine = [r for r in rows if r.scenario == scenario and r.controller == side]
            if not mine:
                continue
            worst = {name: _worst(name, [r.metrics.get(name) for r in mine]) for name in METRICS}
            ok = sum(r.succeeded for r in mine)
            causes = Counter(r.termination or "unknown" for r in mine)
            hits: Counter[str] = Counter()
            for row in mine:
                hits.update(row.collided_with)
            summary.append(BenchRow(scenario, f"{ok}/{len(mine)} ok", side,
                                    "completed" if ok == len(mine) else "not ok",
                                    ok == len(mine), "", worst,
                                    termination=" ".join(f"{cause}:{count}" for cause, count
                                                         in sorted(causes.items())),
                                    success=f"{causes['reached_goal']}/{len(mine)}",
                                    collided_with=dict(hits)))
    return summary


def _worst(name: str, values: list[float | None]) -> float:
    finite = [v for v in values if v is not None and math.isfinite(v)]
    if not finite:
        return math.nan
    return min(finite) if name == "min_distance" else max(finite)


def _cells(row: BenchRow) -> list[str]:
    return [row.scenario, variant_label(row.variant),
            "" if row.seed is None else str(row.seed), row.controller, row.status,
            "true" if row.succeeded else "false",
            *(_number(row.metrics.get(name)) for name in METRICS), row.success,
            row.termination,
            " ".join(f"{partner}:{count}" for partner, count in sorted(row.collided_with.items())),
            row.reason]


def _number(value: float | None) -> str:
    if value is None or not math.isfinite(value):
        return ""
    return f"{value + 0.0:.3f}".replace("-0.000", "0.000")  # a tiny negative gap is none


def write_tables(rows: Sequence[BenchRow], out_dir: Path) -> list[Path]:
    """Per scenario NAME.csv and NAME.md, and summary.csv and summary.md; the paths."""
    written = []
    groups: dict[str, list[BenchRow]] = {}
    for row in rows:
        groups.setdefault(row.scenario, []).append(row)
    groups["summary"] = summary_rows(rows)
    for name, group in groups.items():
        for suffix, text in ((".csv", table_csv(group)), (".md", table_markdown(group))):
            path = out_dir / f"{name}{suffix}"
            write_atomically(path, text)
            written.append(path)
    return written


def plot_paths(rows: Sequence[BenchRow], out_dir: Path) -> list[Path]:
    """Per scenario NAME.png: the robot's path in every run, reference and yours."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from hubero_dsl.analysis.plot import draw_map

    written = []
    for scenario in dict.fromkeys(r.scenario for r in rows):
        figure, axes = plt.subplots(figsize=(7, 6))
        drawn_map = False
        for row in rows:
            if row.scenario != scenario or row.log is None or not Path(row.log).is_file():
                continue
            run = load_run(row.log)
            if not drawn_map:  # every run of a scenario is on its map
                draw_map(axes, run.grid)
                drawn_map = True
            _draw_run(axes, run, f"{row.controller} {row.variant or ''} seed {row.seed}",
                      "-" if row.controller == REFERENCE else "--")
        axes.set_aspect("equal")
        axes.set_xlabel("x (m)")
        axes.set_ylabel("y (m)")
        axes.set_title(scenario)
        axes.legend(fontsize="x-small", loc="upper center", bbox_to_anchor=(0.5, -0.12),
                    ncol=2)
        figure.tight_layout()
        path = out_dir / f"{scenario}.png"
        tmp = path.with_suffix(".png.tmp")
        figure.savefig(tmp, format="png", dpi=100)
        plt.close(figure)
        tmp.replace(path)
        written.append(path)
    return written


def _draw_run(axes: Any, run: LoggedRun, label: str, style: str) -> None:
    for name, robot in run.robots.items():
        axes.plot(robot.position[:, 0], robot.position[:, 1], style, label=f"{name} {label}")
