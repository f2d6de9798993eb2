"""Regenerate docs/experiments.md and its pictures: the HuBeRo paper's two personal-space
comparisons, run and measured with `hubero run`, `hubero diff` and `hubero plot`'s library code.

    .venv/bin/python scripts/experiments.py            # writes docs/experiments.md, docs/images/
    .venv/bin/python scripts/experiments.py --out DIR  # DIR/experiments.md, DIR/images/

The logs go to a temporary folder and are deleted; the markdown and the PNGs are rewritten in
place. Nothing depends on the wall clock, so an unchanged simulator gives unchanged files
(tests/test_docs_experiments.py checks that the page is what this script writes).
"""

from __future__ import annotations

import argparse
import tempfile
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from hubero_dsl.analysis.diff import RunDiff, diff_runs
from hubero_dsl.analysis.metrics import compute_metrics
from hubero_dsl.analysis.plot import View, plot_overlay, plot_run
from hubero_dsl.cli.diff import metric_label
from hubero_dsl.log.reader import LoggedRun, load_run
from hubero_dsl.pipeline import compile_file
from hubero_dsl.simulate import simulate

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
EPSILON = 0.1
# The parking lot's narrow aisle (docs/maps.md): x -4.1 .. 0.4, y -8.0 .. -7.0.
AISLE = (-4.1, 0.4, -8.0, -7.0)
UNITS = {"path_length": "m", "duration": "s", "mean_speed": "m/s", "max_speed": "m/s",
         "min_distance": "m", "personal_space_intrusion_time": "s",
         "task_finish_times": "s"}


@dataclass(frozen=True)
class Comparison:
    """One of the paper's comparisons: a scenario, its two variants, the humans to show."""

    name: str
    scenario: str
    variants: tuple[str, str]
    focus: tuple[str, ...]  # humans whose tables and overlay the text discusses


LIVING_ROOM = Comparison("living_room", "scenarios/living_room.hub", ("circle", "ellipse"),
                         ("actor1", "actor2"))
PARKING = Comparison("parking", "scenarios/parking.hub", ("square", "circle"), ("actor1",))


def run_variants(comparison: Comparison, folder: Path) -> dict[str, LoggedRun]:
    program = compile_file(ROOT / comparison.scenario)
    runs = {}
    for variant in comparison.variants:
        log = folder / f"{comparison.name}-{variant}.mcap"
        simulate(program, variant=variant, log=log)
        runs[variant] = load_run(log)
    return runs


# ---- markdown -----------------------------------------------------------------------------


def _cell(value: object, unit: str) -> str:
    if value is None:
        return "–"
    if isinstance(value, float):
        return f"{value:.2f} {unit}".rstrip()
    return f"{value} {unit}".rstrip()


def _delta(value: float | int | None, unit: str) -> str:
    if value is None:
        return ""
    if value == 0:
        return "0"
    return (f"{value:+.2f} {unit}" if isinstance(value, float) else f"{value:+d}").rstrip()


def diff_table(diff: RunDiff, human: str) -> list[str]:
    """One human's part of `hubero diff` as a markdown table."""
    entry = diff.humans[human]
    a, b = diff.a.variant, diff.b.variant
    lines = [f"| {human} | {a} | {b} | Δ ({b} − {a}) |", "|---|---:|---:|---:|"]
    for metric in entry.metrics:
        unit = UNITS.get(metric.name.split(".")[0], "")
        lines.append(f"| {metric_label(metric.name)} | {_cell(metric.a, unit)} | "
                     f"{_cell(metric.b, unit)} | {_delta(metric.delta, unit)} |")
    apart = "never" if entry.diverged_at is None else f"t = {entry.diverged_at:.2f} s"
    lines += [f"| path Fréchet distance | | | {_cell(entry.frechet, 'm')} |",
              f"| path Hausdorff distance | | | {_cell(entry.hausdorff, 'm')} |",
              f"| largest same-time gap | | | {_cell(entry.max_separation, 'm')} |",
              f"| first > {diff.epsilon:g} m apart | | | {apart} |"]
    for name, (left, right) in entry.parameters.items():
        lines.append(f"| parameter `{name}` | `{left}` | `{right}` | changed |")
    return lines


def aisle_time(run: LoggedRun, human: str) -> float:
    """Seconds the human's centre spent inside the narrow aisle."""
    track = run.humans[human]
    x0, x1, y0, y1 = AISLE
    inside = ((track.position[:, 0] >= x0) & (track.position[:, 0] <= x1)
              & (track.position[:, 1] >= y0) & (track.position[:, 1] <= y1))
    durations = np.append(np.diff(track.time), 0.0)
    return float(durations[inside].sum())


def image(name: str) -> str:
    return f"images/{name}.png"


# ---- the two comparisons ------------------------------------------------------------------


def living_room_section(runs: dict[str, LoggedRun], images: Path) -> list[str]:
    circle, ellipse = runs["circle"], runs["ellipse"]
    diff = diff_runs(circle, ellipse, epsilon=EPSILON)
    view = View.around([circle, ellipse], whole_map=False)
    for variant, run in runs.items():
        plot_run(run, images / f"living_room_{variant}.png", view=view)
    plot_overlay(circle, ellipse, images / "living_room_diff.png", epsilon=EPSILON)
    moments = {v: closest_moment(r, "actor1", "actor2") for v, r in runs.items()}
    actor2 = diff.humans["actor2"]
    lines = [
        "## The living room: circle 0.20 m vs ellipse 1.10 x 0.80 m",
        "",
        "actor2 walks to actor1 by the sofa, invites them to dinner (a 5 s talk), then both walk "
        "to the table (`scenarios/living_room.hub`, `docs/scenarios.md`). The two variants give "
        "both humans the paper's two personal spaces.",
        "",
        "```sh",
        "hubero run scenarios/living_room.hub --variant circle -o circle.mcap",
        "hubero run scenarios/living_room.hub --variant ellipse -o ellipse.mcap",
        "hubero plot circle.mcap -o living_room_circle.png",
        "hubero plot ellipse.mcap -o living_room_ellipse.png",
        f"hubero diff circle.mcap ellipse.mcap --epsilon {EPSILON:g} "
        "--plot living_room_diff.png",
        "```",
        "",
        "**Measured.** With the ellipse the two keep further apart. Their closest approach "
        "(centre to centre) comes when they walk off together towards the table: "
        + "; ".join(f"{distance:.2f} m at t = {when:.1f} s with the {variant} (actor1 "
                    f"{state1}, actor2 {state2})"
                    for variant, (distance, when, state1, state2) in moments.items())
        + f". The paths themselves move by tens of centimetres: actor2's path is "
        f"{actor2.frechet:.2f} m from the circle run's in Fréchet distance and leaves it "
        f"(by more than {EPSILON:g} m at the same instant) from t = {actor2.diverged_at:.1f} s. "
        + contact_sentence(runs),
        "",
    ]
    for human in LIVING_ROOM.focus:
        lines += [*diff_table(diff, human), ""]
    lines += [
        "| circle 0.20 m (the paper's Fig. 11) | ellipse 1.10 x 0.80 m (Fig. 12) |",
        "|---|---|",
        f"| ![living room, circle]({image('living_room_circle')}) "
        f"| ![living room, ellipse]({image('living_room_ellipse')}) |",
        "",
        "Both runs on one map (`hubero diff ... --plot`): circle solid with filled personal "
        "spaces, ellipse dashed with outlines; a cross marks where each human's two paths first "
        f"part by more than {EPSILON:g} m.",
        "",
        f"![living room, circle vs ellipse]({image('living_room_diff')})",
        "",
    ]
    return lines


def parking_section(runs: dict[str, LoggedRun], flips: list[str], images: Path) -> list[str]:
    square, circle = runs["square"], runs["circle"]
    diff = diff_runs(square, circle, epsilon=EPSILON)
    view = View.around([square, circle], whole_map=False)  # both show the aisle
    for variant, run in runs.items():
        plot_run(run, images / f"parking_{variant}.png", view=view)
    plot_overlay(square, circle, images / "parking_diff_actor1.png", epsilon=EPSILON,
                 humans=["actor1"])
    actor1 = diff.humans["actor1"]
    at = actor1.metric("task_finish_times.at_dumpster")
    length = actor1.metric("path_length")
    assert at is not None and length is not None
    lines = [
        "## The parking lot: square 0.25 m vs circle 0.70 m",
        "",
        "Four people cross the car park (`scenarios/parking.hub`). The interesting one is "
        "actor1: between its start (-5, -6) and the dumpster (1.2, -5.7) runs a narrow aisle, "
        "1.0 m wide and 4.5 m long, centred on (-1.85, -7.5) (`docs/maps.md`, \"The narrow "
        "aisle\"); the other way goes north round the yard's fence and through its gate.",
        "",
        "```sh",
        "hubero run scenarios/parking.hub --variant square -o square.mcap",
        "hubero run scenarios/parking.hub --variant circle -o circle.mcap",
        "hubero plot square.mcap -o parking_square.png",
        "hubero plot circle.mcap -o parking_circle.png",
        f"hubero diff square.mcap circle.mcap --epsilon {EPSILON:g} --human actor1 "
        "--plot parking_diff_actor1.png",
        "```",
        "",
        f"**Measured.** With the 0.25 m square actor1 squeezes through the aisle (its centre is "
        f"inside it for {aisle_time(square, 'actor1'):.1f} s) and is at the dumpster at "
        f"t = {at.a:.2f} s. The 0.70 m circle is wider than the aisle, so the global planner never "
        f"sends actor1 into it ({aisle_time(circle, 'actor1'):.1f} s inside): it walks round "
        f"through the gate and reaches the dumpster at t = {at.b:.2f} s, {at.delta:.2f} s "
        f"later, having walked {length.delta:.2f} m more over the whole run. The paths part at "
        f"once (first more than {EPSILON:g} m apart at t = {actor1.diverged_at:.1f} s) and "
        f"their Fréchet distance is {actor1.frechet:.2f} m.",
        "",
        *diff_table(diff, "actor1"),
        "",
        f"![parking lot, actor1, square vs circle]({image('parking_diff_actor1')})",
        "",
        "| square 0.25 m (the paper's Fig. 13) | circle 0.70 m (Fig. 14) |",
        "|---|---|",
        f"| ![parking lot, square]({image('parking_square')}) "
        f"| ![parking lot, circle]({image('parking_circle')}) |",
        "",
        *flips,
    ]
    return lines


RADII = (0.25, 0.35, 0.45, 0.50, 0.55, 0.60, 0.70)


def radius_table(folder: Path) -> list[str]:
    """actor1's route in the parking lot for circles of growing radius: where it flips."""
    from hubero_dsl.pipeline import compile_source

    path = ROOT / PARKING.scenario
    names = {radius: f"r{round(radius * 100):03d}" for radius in RADII}
    extra = "".join(f"variant {name} {{ personal_space circle(radius: {radius:.2f} m) }}\n"
                    for radius, name in names.items())
    program = compile_source(path.read_text(encoding="utf-8") + "\n" + extra, str(path))
    rows = ["### Where the route flips", "",
            "The same scenario with every personal space a circle of growing radius (variants "
            "added to the scenario text for this table). The aisle's clearance along its middle "
            "is 0.50 m, so circles up to that radius fit.", "",
            "| circle radius | actor1 in the aisle | at dumpster | actor1's path length |",
            "|---:|---:|---:|---:|"]
    for radius, name in names.items():
        log = folder / f"parking-{name}.mcap"
        simulate(program, variant=name, log=log)
        run = load_run(log)
        metrics = compute_metrics(run).humans["actor1"]
        at = metrics.task_finish_times.get("at_dumpster")
        rows.append(f"| {radius:.2f} m | {aisle_time(run, 'actor1'):.1f} s | "
                    f"{_cell(at, 's')} | {metrics.path_length:.2f} m |")
    return [*rows, ""]


def contact_sentence(runs: dict[str, LoggedRun]) -> str:
    """What the runs measured of intrusions and collisions, in words."""
    parts = []
    for variant, run in runs.items():
        humans = compute_metrics(run).humans.values()
        intruded = sum(h.personal_space_intrusion_time for h in humans)
        touched = sum(h.collisions for h in humans)
        parts.append(f"{intruded:.1f} s of personal-space intrusion and {touched} collisions "
                     f"with the {variant}")
    return "Summed over both humans: " + "; ".join(parts) + "."


def closest_moment(run: LoggedRun, first: str, second: str) -> tuple[float, float, str, str]:
    """(distance, time, what first was doing, what second was doing) at their closest."""
    a, b = run.humans[first], run.humans[second]
    gap = np.linalg.norm(a.position - b.position, axis=1)
    i = int(gap.argmin())
    return float(gap[i]), float(a.time[i]), str(a.fsm_state[i]), str(b.fsm_state[i])


HEADER = [
    "# Experiments: the paper's personal-space result, measured",
    "",
    "<!-- Generated by scripts/experiments.py; edit that script, not this file. -->",
    "",
    "The HuBeRo paper shows, in two scenarios, that the shape of a human's personal space changes "
    "how it moves: in the living room a larger ellipse keeps people further apart, in the "
    "parking lot a large circle keeps a person out of a narrow aisle. This page runs both "
    "comparisons and measures them with `hubero diff` (metrics, path distances, first "
    "divergence, changed parameters; see `docs/analysis.md`) and draws them with `hubero plot`. "
    "Regenerate it with `.venv/bin/python scripts/experiments.py`.",
    "",
    "Tables: every metric of `hubero diff` for one human in both runs and the difference; "
    "`closest to X` is the smallest centre-to-centre distance, `… done at` the time a labelled "
    "step (or an unlabelled task, by its line) finished. In the pictures, circles mark where "
    "humans start, stars the goals they reached, and the personal space is drawn every 1.5 m "
    "along each path in its shape and heading.",
    "",
]


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", type=Path, default=DOCS,
                        help="folder for experiments.md and images/ (default: docs/)")
    out = parser.parse_args(argv).out
    images = out / "images"
    images.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="hubero-experiments-") as temp:
        folder = Path(temp)
        living_room = living_room_section(run_variants(LIVING_ROOM, folder), images)
        flips = radius_table(folder)
        parking = parking_section(run_variants(PARKING, folder), flips, images)
    page = out / "experiments.md"
    page.write_text("\n".join([*HEADER, *living_room, *parking]).rstrip() + "\n",
                    encoding="utf-8")
    print(f"wrote {page} and {len(list(images.glob('*.png')))} images")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
