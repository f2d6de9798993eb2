"""What `hubero run` and `hubero test` show: a progress bar over simulated time, and tables.

Rich renders both; the progress bar goes to stderr and disappears when the run ends, the
summary goes to stdout (plain text when stdout is not a terminal).
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from statistics import mean
from typing import TYPE_CHECKING

from rich.console import Console
from rich.markup import escape
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table

from hubero_dsl.cli.console import make_console, shows_progress

if TYPE_CHECKING:
    from hubero_dsl.model.program import Program
    from hubero_dsl.sim.loop import HumanSummary, RunResult
    from hubero_dsl.sim.simulation import Simulation

STATE_STYLE = {"completed": "green", "failed": "red", "timed_out": "yellow"}
STATUS_STYLE = {"SUCCEEDED": "green", "ABORTED": "red", "PREEMPTED": "yellow", "ACTIVE": "cyan"}


def _label(program: Program, variant: str | None) -> str:
    return escape(f"{Path(program.source.path).name}" + (f" [{variant}]" if variant else ""))


@contextmanager
def progress_observer(program: Program, variant: str | None
                      ) -> Iterator[Callable[[Simulation], None]]:
    """A rich progress bar over simulated time (to the time limit), updated a few times a second
    of simulated time so it costs nothing measurable."""
    console = make_console(stderr=True)
    progress = Progress(TextColumn("[bold]{task.description}"), BarColumn(),
                        TextColumn("{task.fields[clock]}"), TimeElapsedColumn(),
                        console=console, transient=True, disable=not shows_progress(console))
    task = progress.add_task(_label(program, variant), total=program.time_limit, clock="")
    every = max(1, round(0.25 / program.step))

    def observe(sim: Simulation) -> None:
        if sim.tick % every == 0:
            progress.update(task, completed=sim.time, clock=f"t = {sim.time:6.1f} s")

    with progress:
        yield observe


def print_summary(program: Program, result: RunResult, output: Path | None,
                  console: Console | None = None, *, members: bool = False) -> None:
    """The run's tables: named humans one by one, and crowds and flows one row each (every
    member on a row of their own with `members`), robots, their metrics, expectations."""
    console = console or make_console()
    state = result.state.value
    title = (f"{_label(program, result.variant)}: [{STATE_STYLE.get(state, '')}]{state}[/] "
             f"at t = {result.time:.2f} s (seed {result.seed})")
    console.print(title)
    if result.reason:
        console.print(f"  reason: {result.reason}")
    sets = None if members else _sets_table(program, result.humans)
    named = _came(program, result.humans) if members else _named(program, result.humans)
    if named or sets is None:
        console.print(_actors_table(named, "human", "humans"))
    if sets is not None:
        console.print(sets)
    if result.robots:
        console.print(_actors_table(result.robots, "robot", "robots"))
    if result.robot_metrics:
        console.print(_robot_metrics_table(result.robot_metrics))
    if result.expectations:
        console.print(_expectations_table(result))
    if output is not None:
        console.print(f"log written to {output}")


def print_failure(program: Program, result: RunResult) -> None:
    """One line on stderr for a run that failed, and one per expectation that fails."""
    console = make_console(stderr=True)
    reason = f": {escape(result.reason)}" if result.reason else ""
    console.print(f"{_label(program, result.variant)}: {result.state.value} at "
                  f"t = {result.time:.2f} s{reason}", highlight=False)
    for expectation in result.expectations:
        if not expectation.held:
            console.print(f"    expectation fails: {escape(expectation.text)}", highlight=False)


def _robot_metrics_table(metrics: dict[str, dict[str, float]]) -> Table:
    """The social-navigation metrics robot researchers report (docs/analysis.md)."""
    table = Table("robot", "min distance", "intimate", "personal", "collisions (people/walls)",
                  "min TTC", "path length", "efficiency", "time to goal",
                  title="robots among people", title_justify="left")
    for name, values in metrics.items():
        table.add_row(name, _finite(values["min_distance"], "m"),
                      f"{100 * values['intimate_intrusions']:.0f} %",
                      f"{100 * values['personal_intrusions']:.0f} %",
                      f"{values['collisions']:.0f} / {values['obstacle_collisions']:.0f}",
                      _finite(values["min_time_to_collision"], "s"),
                      f"{values['path_length']:.2f} m",
                      _percent(values["path_efficiency"]),
                      _finite(values["time_to_goal"], "s"))
    return table


def _percent(value: float) -> str:
    return f"{100 * value:.0f} %" if math.isfinite(value) else "-"  # nan: goal not reached


def _finite(value: float, unit: str) -> str:
    """The value in its unit; "-" for infinity (never happened, nobody there). A gap that
    rounds to zero reads 0.00, whichever side of it the rounding fell (bodies touching)."""
    if value == float("inf"):
        return "-"
    shown = f"{value:.2f}"
    return f"{'0.00' if shown == '-0.00' else shown} {unit}"


def _actors_table(actors: list[HumanSummary], column: str, title: str) -> Table:
    table = Table(column, "tasks done", "status", "path length", "time on tasks",
                  title=title, title_justify="left")
    for human in actors:
        style = STATUS_STYLE.get(human.last_status, "")
        table.add_row(human.name, f"{human.tasks_done}/{human.tasks_total}",
                      f"[{style}]{human.last_status}[/]" if style else human.last_status,
                      f"{human.path_length:.2f} m", f"{human.busy_time:.2f} s")
    return table


def _named(program: Program, humans: list[HumanSummary]) -> list[HumanSummary]:
    """The humans declared one by one (not members of a crowd or flow)."""
    named = {spec.name for spec in program.humans if spec.group is None}
    return [human for human in humans if human.name in named]


def _came(program: Program, humans: list[HumanSummary]) -> list[HumanSummary]:
    """Everyone but the people a flow could have brought and did not (no task ever)."""
    flows = {m for _, (kind, members) in program.people_sets().items() if kind == "flow"
             for m in members}
    return [human for human in humans if human.name not in flows or human.tasks_total]


def _sets_table(program: Program, humans: list[HumanSummary]) -> Table | None:
    """One row per crowd and flow: how many took part, tasks done, how their last tasks ended,
    and the mean path length and time on tasks of those who took part."""
    by_name = {human.name: human for human in humans}
    sets = {name: (kind, [by_name[m] for m in members if m in by_name])
            for name, (kind, members) in program.people_sets().items() if kind != "group"}
    if not sets:
        return None
    table = Table("crowd or flow", "people", "tasks done", "last status", "mean path length",
                  "mean time on tasks", title="crowds and flows", title_justify="left")
    for name, (kind, everyone) in sets.items():
        came = [h for h in everyone if h.tasks_total or kind != "flow"]
        statuses = Counter(h.last_status for h in came)
        people = f"{len(came)} came" if kind == "flow" else str(len(came))
        table.add_row(f"{name} ({kind})", people,
                      f"{sum(h.tasks_done for h in came)}/{sum(h.tasks_total for h in came)}",
                      ", ".join(f"{count} {status}" for status, count in sorted(
                          statuses.items())) or "-",
                      f"{mean(h.path_length for h in came):.2f} m" if came else "-",
                      f"{mean(h.busy_time for h in came):.2f} s" if came else "-")
    return table


def _expectations_table(result: RunResult) -> Table:
    table = Table("expectation", "result", "decided at", title="expectations",
                  title_justify="left")
    for expectation in result.expectations:
        verdict = "[green]holds[/]" if expectation.held else "[red]FAILS[/]"
        when = f"{expectation.decided_at:.2f} s" if expectation.decided_at is not None else "-"
        table.add_row(escape(expectation.text), verdict, when)
    return table
