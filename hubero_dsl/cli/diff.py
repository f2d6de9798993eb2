"""`hubero diff A.mcap B.mcap`: compare two runs human by human; `hubero diff DIR --baseline V`
compares every run of a sweep with the baseline variant's run of the same seed.

    hubero diff circle.mcap ellipse.mcap
    hubero diff circle.mcap ellipse.mcap --json
    hubero diff circle.mcap ellipse.mcap --plot overlay.png --human actor1
    hubero diff sweep_out/ --baseline "speed=1.0 m/s,avoidance_strength=0.5"

Per human: every metric of both runs with B - A, the discrete Fréchet and Hausdorff distances
between the two paths, the largest distance between the two at the same instant, the first
instant they are more than --epsilon apart, and the parameters that differ. A crowd or flow is
one table of its members' metrics summed up (--members, or --human NAME, lists its members one
by one: a flow's who came in either run), and a human's closest approach to its members is one
row. Then each robot: its path, and its social-navigation metrics. --human shows only the
humans and robots it names. Exit 0 when the comparison was made (runs of different scenario
texts or maps with the same humans are compared, with a note), 2 for unreadable logs, runs
whose humans differ or a missing baseline.
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

from hubero_dsl.cli.outputs import PNG

if TYPE_CHECKING:
    from collections.abc import Callable, Mapping

    from rich.console import Console

    from hubero_dsl.analysis.diff import HumanDiff, MetricDelta, RunDiff, SetDiff, SweepDiff

_UNITS = {"path_length": "m", "duration": "s", "mean_speed": "m/s", "max_speed": "m/s",
          "min_distance": "m", "personal_space_intrusion_time": "s", "collisions": "",
          "task_finish_times": "s", "final_status": "",
          "shape_intrusions": "%"}  # the logs' own social-navigation metric (docs/analysis.md)
_LABELS = {"personal_space_intrusion_time": "personal space intruded",
           "mean_speed": "mean speed (moving)"}


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    parser: argparse.ArgumentParser = subparsers.add_parser(
        "diff", help="compare two runs, or a sweep's runs with a baseline", description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("first", metavar="A", help="a run log (.mcap), or a sweep's folder")
    parser.add_argument("second", metavar="B", nargs="?", help="the run log to compare with A")
    parser.add_argument("--baseline", metavar="VARIANT",
                        help="with a sweep folder: the variant the others are compared with")
    parser.add_argument("--epsilon", metavar="M", type=float, default=0.1,
                        help="paths further apart than this have diverged (default 0.1 m)")
    parser.add_argument("--human", metavar="NAME", action="append",
                        help="show only this human or robot, or the members of this crowd, "
                        "flow or group (repeat for more)")
    parser.add_argument("--members", action="store_true",
                        help="list every member of a crowd or flow, not one table per crowd "
                        "or flow")
    parser.add_argument("--json", action="store_true", help="print JSON instead of tables")
    parser.add_argument("--plot", metavar="OUT.png", type=PNG,
                        help="draw both runs on the map into a PNG")
    return parser


def run(args: argparse.Namespace) -> int:
    from hubero_dsl.errors import InputError

    if not (math.isfinite(args.epsilon) and args.epsilon > 0):
        raise InputError(f"--epsilon must be a positive distance in metres, got {args.epsilon}")
    if args.plot is not None:
        from hubero_dsl.cli.outputs import check_picture

        check_picture(args.plot, tuple(Path(p) for p in (args.first, args.second) if p))
    if Path(args.first).is_dir():
        return _sweep(args)
    if args.second is None:
        raise InputError("give two run logs (hubero diff A.mcap B.mcap), or a sweep folder "
                         "and --baseline VARIANT")
    if args.baseline is not None:
        raise InputError("--baseline goes with a sweep folder, not with two logs")
    return _pair(args)


def _pair(args: argparse.Namespace) -> int:
    from hubero_dsl.analysis.diff import diff_runs, never_came, set_diffs
    from hubero_dsl.log.reader import load_run

    a, b = load_run(args.first), load_run(args.second)
    if args.plot is not None:  # nor over the scenarios or maps they were run from
        from hubero_dsl.cli.outputs import refuse_run_inputs

        refuse_run_inputs(args.plot, a, b)
    diff = diff_runs(a, b, epsilon=args.epsilon)
    humans, robots = _chosen(_expanded(args.human, a.metadata.members), list(diff.humans),
                             diff.sets, sorted(diff.robots))
    # a flow's members who came in neither run have nothing to compare: its name stands for
    # those who came in either; named one by one, a line says so
    absent = never_came(diff)
    if args.human:
        humans = [h for h in humans if h not in absent or h in args.human]
    if args.plot is not None:
        from hubero_dsl.analysis.plot import plot_overlay

        plot_overlay(a, b, args.plot, epsilon=args.epsilon, humans=humans)
    if args.json:
        data = diff.to_dict()
        data["humans"] = {n: h for n, h in data["humans"].items() if n in humans}
        data["robots"] = {n: r for n, r in data["robots"].items() if n in robots}
        print(json.dumps(data, indent=2))
        return 0
    # with neither --human nor --members a crowd's or flow's members are its table
    sets = {} if args.human or args.members else set_diffs(diff)
    listed = [h for h in humans if a.metadata.set_of(h) not in sets and h not in absent]
    named_absent = [h for h in args.human or () if h in absent]
    _print_pair(diff, listed, list(sets.values()), robots, a.metadata.set_of, _console(),
                named_absent)
    return 0


def _expanded(wanted: list[str] | None, members: Callable[[str], tuple[str, ...]]
              ) -> list[str] | None:
    """Names as given, a crowd's, flow's or group's name standing for its members."""
    return None if not wanted else [m for name in wanted for m in members(name)]


def _chosen(wanted: list[str] | None, known: list[str],
            sets: Mapping[str, tuple[str, tuple[str, ...]]], robots: list[str]
            ) -> tuple[list[str], list[str]]:
    """The humans and the robots `wanted` names (all when none), checked against those the
    runs have (`known`, `robots`), in their order; `sets` are the runs' crowds, flows and
    groups: kind and members by name."""
    from hubero_dsl.errors import InputError

    if not wanted:
        return known, robots
    unknown = sorted(set(wanted) - set(known) - set(robots))
    if unknown:
        # a crowd's or flow's members go by its name; a group's have names of their own
        members = {member for kind, held in sets.values() if kind != "group" for member in held}
        listed = [*(name for name in sorted(known) if name not in members),
                  *(f"{kind} {name}" for name, (kind, _) in sorted(sets.items()))]
        also = f"; robots: {', '.join(robots)}" if robots else ""
        raise InputError(f"no human{' or robot' * bool(robots)} {', '.join(unknown)} in these "
                         f"runs (humans: {', '.join(listed)}{also})")
    named = set(wanted)
    return [name for name in known if name in named], [name for name in robots if name in named]


def _sweep(args: argparse.Namespace) -> int:
    from hubero_dsl.analysis.diff import diff_sweep
    from hubero_dsl.errors import InputError

    if args.baseline is None:
        raise InputError(f"{args.first} is a folder: compare a sweep's runs with "
                         f"--baseline VARIANT")
    if args.second is not None:
        raise InputError("give a sweep folder alone, or two run logs")
    if args.plot is not None:
        raise InputError("--plot draws two runs: give two logs (A.mcap B.mcap)")
    sweep = diff_sweep(args.first, args.baseline, epsilon=args.epsilon)
    humans = _sweep_humans(args.human, sweep)
    if args.json:
        print(json.dumps(sweep.to_dict(), indent=2))
    else:
        _print_sweep(sweep, humans, _console())
    return 0


def _sweep_humans(wanted: list[str] | None, sweep: SweepDiff) -> set[str]:
    """The humans and robots --human names in a sweep's runs, a crowd's, flow's or group's
    name standing for its members; InputError for a name no compared run has."""
    diffs = [c.diff for c in sweep.comparisons if c.diff is not None]
    if not wanted or not diffs:
        return set(wanted or ())
    sets = {name: kind_members for diff in diffs for name, kind_members in diff.sets.items()}
    known = list({human: None for diff in diffs for human in diff.humans})
    robots = sorted({robot for diff in diffs for robot in diff.robots})
    humans, chosen_robots = _chosen(
        _expanded(wanted, lambda name: sets.get(name, ("", (name,)))[1]), known, sets, robots)
    return {*humans, *chosen_robots}


# ---- rendering ----------------------------------------------------------------------------


def _console() -> Console:
    from hubero_dsl.cli.console import make_console

    console = make_console(highlight=False)
    if not console.is_terminal:  # a file or a pipe: no terminal to fit, keep tables whole
        console = make_console(highlight=False, width=max(console.width, 132))
    return console


def _unit(metric: str) -> str:
    """A metric's unit: the diff's own, or the social-navigation metric's (docs/analysis.md)."""
    from hubero_dsl.socialnav import METRICS

    name = metric.split(".", 1)[0]
    spec = METRICS.get(name)
    return _UNITS.get(name, spec.unit if spec is not None else "")


def _value(value: object, unit: str) -> str:
    if value is None:
        return "-"
    if isinstance(value, float):
        if unit == "%":                                # a share, as the summary shows it
            return f"{100 * value:.1f} %"
        return f"{value:.0f}" if _a_count(value, unit) else f"{value:.3f} {unit}".rstrip()
    return f"{value} {unit}".rstrip()


def _a_count(value: float, unit: str) -> bool:
    """Unitless whole numbers are counts (collisions), shown as such."""
    return not unit and value.is_integer()


def _delta(value: float | int | None, unit: str) -> str:
    if value is None:
        return ""
    if value == 0:
        return "[dim]0[/]"
    if unit == "%":
        return f"{100 * value:+.1f} %"
    text = (f"{value:+.3f}" if isinstance(value, float) and not _a_count(value, unit)
            else f"{value:+.0f}")
    return f"{text} {unit}".rstrip()


def _side(label: str, side: Any) -> str:
    from rich.markup import escape

    from hubero_dsl.cli.diagnostic_formats import printable

    variant = f" [{side.variant}]" if side.variant else ""
    return escape(printable(f"{label}: {side.path}  {side.title}{variant}, seed {side.seed}"))


def _print_pair(diff: RunDiff, humans: list[str], sets: list[SetDiff], robots: list[str],
                set_of: Callable[[str], str | None], console: Console,
                came_in_neither: list[str] | None = None) -> None:
    from rich.markup import escape

    from hubero_dsl.analysis.diff import came_in_one_run
    from hubero_dsl.cli.diagnostic_formats import printable

    console.print(_side("A", diff.a))
    console.print(_side("B", diff.b))
    for note in diff.notes:
        console.print(f"[yellow]note:[/] {escape(printable(note))}")
    for name in came_in_neither or ():
        flow = escape(printable(set_of(name) or ""))
        console.print(f"{escape(printable(name))} (of flow {flow}) came in neither run: "
                      "nothing to compare")
    absent = came_in_one_run(diff)
    for name in humans:
        console.print(_human_table(diff.humans[name], diff.epsilon, set_of,
                                   absent_from=absent.get(name)))
    for crowd in sets:
        console.print(_set_table(crowd, diff.epsilon))
    for name in robots:
        console.print(_human_table(diff.robots[name], diff.epsilon, set_of, "robot "))


def _metric_table(title: str) -> Any:
    from rich.table import Table

    table = Table(title=title, title_justify="left")
    table.add_column("metric", no_wrap=True)
    for column in ("A", "B", "Δ (B - A)"):
        table.add_column(column, justify="right", no_wrap=True)
    return table


def _human_table(human: HumanDiff, epsilon: float, set_of: Callable[[str], str | None],
                 kind: str = "", absent_from: str | None = None) -> Any:
    """A human's (or robot's) metrics side by side; `absent_from`: the run a flow's member
    did not come in, said in the title."""
    from rich.markup import escape

    from hubero_dsl.analysis.diff import collapse_closest

    changed = "; ".join(f"{name} {a} → {b}" for name, (a, b) in human.parameters.items())
    title = f"[bold]{kind}{escape(human.name)}[/]" + (f"  {escape(changed)}" if changed else "")
    if absent_from is not None:
        title += f"  (did not come in {absent_from})"
    table = _metric_table(title)
    for metric in collapse_closest(human.metrics, set_of):
        table.add_row(*_metric_row(metric))
    table.add_section()
    table.add_row("path Fréchet distance", "", "", _value(human.frechet, "m"))
    table.add_row("path Hausdorff distance", "", "", _value(human.hausdorff, "m"))
    table.add_row("largest same-time gap", "", "", _value(human.max_separation, "m"))
    diverged = ("-" if absent_from is not None else "never" if human.diverged_at is None
                else f"t = {human.diverged_at:.2f} s")
    table.add_row(f"first > {epsilon:g} m apart", "", "", diverged)
    return table


_SET_LABELS = {"members": "members in the scene", "path_length": "mean path length",
               "duration": "mean duration",
               "mean_speed": "mean speed (moving)", "max_speed": "max speed",
               "min_distance": "closest to anyone",
               "personal_space_intrusion_time": "personal space intruded (all)",
               "collisions": "collisions (all)", "succeeded": "last task succeeded"}


def _set_table(crowd: SetDiff, epsilon: float) -> Any:
    """A crowd's or flow's members summed up (`hubero_dsl.analysis.diff.SetDiff`)."""
    from rich.markup import escape

    # a flow's members are as many as it may bring; the first row says how many came
    size = "" if crowd.kind == "flow" else f"  {crowd.members} members"
    table = _metric_table(f"[bold]{crowd.kind} {escape(crowd.name)}[/]{size}")
    for metric in crowd.metrics:
        unit = _unit(metric.name)
        label = ("members who came" if metric.name == "members" and crowd.kind == "flow"
                 else _SET_LABELS[metric.name])
        table.add_row(label, _value(metric.a, unit), _value(metric.b, unit),
                      _delta(metric.delta, unit))
    table.add_section()
    table.add_row("path Fréchet distance (median)", "", "", _value(crowd.frechet_median, "m"))
    table.add_row("path Hausdorff distance (largest)", "", "", _value(crowd.hausdorff_max, "m"))
    table.add_row(f"members ever > {epsilon:g} m apart", "", "", str(crowd.diverged))
    first = ("never" if crowd.first_diverged_at is None
             else f"t = {crowd.first_diverged_at:.2f} s")
    table.add_row(f"first > {epsilon:g} m apart", "", "", first)
    return table


def metric_label(name: str) -> str:
    """`min_distance.actor2` -> `closest to actor2`, `task_finish_times.invite` -> `invite done`."""
    group, _, key = name.partition(".")
    if group == "min_distance" and key:
        return f"closest to {key}"
    if group == "task_finish_times":
        kind, at, place = key.partition("@")
        return f"{kind} (line {place.split(':')[0]}) done at" if at else f"{key} done at"
    return _LABELS.get(group, group.replace("_", " "))


def _metric_row(metric: MetricDelta) -> tuple[str, str, str, str]:
    from rich.markup import escape

    unit = _unit(metric.name)
    return (escape(metric_label(metric.name)), escape(_value(metric.a, unit)),
            escape(_value(metric.b, unit)), _delta(metric.delta, unit))


def _closest(human: HumanDiff) -> tuple[float | int | None, float | int | None]:
    """The closest approach to anyone, in A and in B (a human's to each other one, a robot's
    to any person)."""
    from hubero_dsl.analysis.diff import aggregate

    rows = [m for m in human.metrics
            if m.name == "min_distance" or m.name.startswith("min_distance.")]
    return aggregate([m.a for m in rows], "min"), aggregate([m.b for m in rows], "min")


def _number(value: object, signed: bool = False) -> str:
    """A number for the sweep's table ("-" for none, or for text)."""
    if not isinstance(value, int | float):
        return "-"
    if value == 0:
        return "0"
    if isinstance(value, int):
        return f"{value:+d}" if signed else str(value)
    # a robot touching someone is a gap of a hair below zero: 0.000, not -0.000
    return f"{value:+.3f}" if signed else f"{round(value, 3) + 0.0:.3f}"


def _change(human: HumanDiff, name: str, count: bool = False) -> str:
    metric = human.metric(name)
    if metric is None:
        return ""
    delta = metric.delta
    if count and isinstance(delta, float) and delta.is_integer():
        delta = int(delta)  # a robot's counts are numbers as its metrics have them: floats
    return _number(delta, signed=True)


_SWEEP_COLUMNS = ("variant", "seed", "human", "Δ path\nm", "Δ duration\ns",
                  "closest\nbase m", "closest\nrun m", "Δ intruded\ns", "Δ\ncollisions",
                  "Fréchet\nm", "Hausdorff\nm", "apart at\ns")


def _print_sweep(sweep: SweepDiff, humans: set[str], console: Console) -> None:
    from rich import box
    from rich.markup import escape
    from rich.table import Table

    console.print(escape(f"{sweep.scenario or sweep.directory}: each run against the baseline "
                         f"'{sweep.baseline}' of the same seed"))
    for variant, changes in _variant_changes(sweep).items():
        console.print(escape(f"  {variant}: {changes or 'no parameter differs'}"))
    table = Table(box=box.SIMPLE_HEAD, pad_edge=False)
    # variants' names whole up to 48 characters, folded beyond, never cut: two may differ
    # only at their ends
    widest = min(48, max([24, *(len(str(c.variant)) for c in sweep.comparisons)]))
    for column in _SWEEP_COLUMNS:
        text = column in ("variant", "human")
        table.add_column(column, justify="left" if text else "right", no_wrap=not text,
                         max_width=widest if column == "variant" else None,
                         overflow="fold" if text else "ellipsis")
    for comparison in sweep.comparisons:
        variant = escape(str(comparison.variant))
        if comparison.diff is None:
            table.add_row(variant, str(comparison.seed),
                          f"[yellow]not compared:[/] {escape(comparison.note)}")
            continue
        for name, cells in _sweep_rows(comparison.diff, humans):
            table.add_row(variant, str(comparison.seed), escape(name), *cells)
    console.print(table)
    console.print(f"apart at: the first instant a human or robot is more than "
                  f"{sweep.epsilon:g} m from where it was at that time in the baseline run")
    console.print("closest: a human's centre-to-centre distance to anyone, a robot's surface "
                  "gap to a person (as the two logs' tables give them)")


def _variant_changes(sweep: SweepDiff) -> dict[str, str]:
    """Each compared variant -> the parameters that differ from the baseline, in words."""
    changes: dict[str, dict[str, str]] = {}
    compared: set[str] = set()
    for comparison in sweep.comparisons:
        listed = changes.setdefault(str(comparison.variant), {})
        if comparison.diff is None:
            continue
        compared.add(str(comparison.variant))
        for human in comparison.diff.humans.values():
            for name, (left, right) in human.parameters.items():
                listed.setdefault(name, f"{name} {left} → {right}")
    return {variant: "; ".join(texts.values()) if variant in compared
            else "no run compared" for variant, texts in changes.items()}


def _sweep_rows(diff: RunDiff, humans: set[str]) -> list[tuple[str, list[str]]]:
    """A run's rows of the sweep's table: the humans and robots asked for (`humans`), else the
    named humans one by one, each crowd or flow in one row, and each robot (its path, closest
    approach to a person and collisions with people; no duration or intrusion time)."""
    from hubero_dsl.analysis.diff import set_diffs

    if humans:
        return [*((n, _sweep_cells(h)) for n, h in diff.humans.items() if n in humans),
                *((f"robot {n}", _sweep_cells(r)) for n, r in diff.robots.items()
                  if n in humans)]
    sets = set_diffs(diff)
    members = {m for name in sets for m in diff.sets[name][1]}
    return [*((n, _sweep_cells(h)) for n, h in diff.humans.items() if n not in members),
            *((f"{crowd.kind} {name}", _sweep_set_cells(crowd)) for name, crowd in sets.items()),
            *((f"robot {name}", _sweep_cells(robot)) for name, robot in diff.robots.items())]


def _sweep_set_cells(crowd: SetDiff) -> list[str]:
    """A crowd's or flow's cells: its mean changes, its closest, its totals' changes, its
    median Fréchet and largest Hausdorff distance, the first of its members to part."""
    metric = {m.name: m for m in crowd.metrics}
    apart = "never" if crowd.first_diverged_at is None else f"{crowd.first_diverged_at:.2f}"
    return [_number(metric["path_length"].delta, signed=True),
            _number(metric["duration"].delta, signed=True),
            _number(metric["min_distance"].a), _number(metric["min_distance"].b),
            _number(metric["personal_space_intrusion_time"].delta, signed=True),
            _number(metric["collisions"].delta, signed=True),
            _number(crowd.frechet_median), _number(crowd.hausdorff_max), apart]


def _sweep_cells(human: HumanDiff) -> list[str]:
    base, run = _closest(human)
    apart = "never" if human.diverged_at is None else f"{human.diverged_at:.2f}"
    return [_change(human, "path_length"), _change(human, "duration"),
            _number(base), _number(run),
            _change(human, "personal_space_intrusion_time"),
            _change(human, "collisions", count=True),
            _number(human.frechet), _number(human.hausdorff), apart]
