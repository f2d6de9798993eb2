"""How long the command line takes, as a user feels it, and how fast the paper scenarios run.

    python benchmarks/cli.py [SCENARIO] [--repeat N] [--runs N]

Each row of the first table runs a command in a fresh interpreter N times (after one discarded
warm-up run that fills the OS file cache and the bytecode cache) and reports the median wall
time, next to a bare `python -c pass`: the ratio and the difference are what hubero itself costs.
Rows are `Measurement`s in `MEASUREMENTS`.

The second table is the paper scenarios' speed relative to real time: simulated seconds per
wall-clock second of everything `hubero run` does after start-up (compile the file, build the
simulation, plan, simulate until every activity has ended), each run in a fresh interpreter
whose imports are done before the clock starts, once per variant; then the same run again in
that interpreter (what each run of a sweep costs, once the process has set itself up); and the
whole `hubero run FILE -q` command, interpreter start-up and imports included.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

from arguments import at_least_one

REPO_ROOT = Path(__file__).resolve().parents[1]
DEFAULT_SCENARIO = REPO_ROOT / "scenarios" / "living_room.hub"
PAPER_SCENARIOS = (REPO_ROOT / "scenarios" / "living_room.hub",
                   REPO_ROOT / "scenarios" / "parking.hub")

# One run in a fresh interpreter: imports first, then the clock runs over compile + run.
RUN_ONCE = """
import json, sys, time
from hubero_dsl.pipeline import compile_file
from hubero_dsl.simulate import simulate
import hubero_dsl.planners.navfn, hubero_dsl.planners.social_force, hubero_dsl.planners.straight
import hubero_dsl.world.mapfile
import scipy.ndimage, scipy.sparse.csgraph, skimage.graph  # what they import when first used
variant = sys.argv[2] or None
seconds = []
for _ in range(2):  # the first run in a fresh process, then one in a process that has run one
    start = time.perf_counter()
    result = simulate(compile_file(sys.argv[1]), variant=variant)
    seconds.append(time.perf_counter() - start)
print(json.dumps({"simulated": result.time, "seconds": seconds, "state": result.state.value}))
"""


@dataclass(frozen=True)
class Measurement:
    """One row: a command line, built from the scenario path."""

    name: str
    command: Callable[[Path], list[str]]


def hubero(*arguments: str) -> list[str]:
    return [sys.executable, "-m", "hubero_dsl", *arguments]


MEASUREMENTS: tuple[Measurement, ...] = (
    Measurement("hubero --version", lambda _: hubero("--version")),
    Measurement("hubero check SCENARIO", lambda scenario: hubero("check", str(scenario))),
)


def wall_times(command: Sequence[str], repeat: int) -> list[float]:
    subprocess.run(command, capture_output=True, check=False)  # warm-up, not counted
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        completed = subprocess.run(command, capture_output=True, check=False)
        times.append(time.perf_counter() - start)
        if completed.returncode not in (0, 1):
            raise SystemExit(f"{' '.join(command)} failed ({completed.returncode}):\n"
                             f"{completed.stderr.decode(errors='replace')}")
    return times


def table(rows: list[tuple[str, float]], baseline: float) -> str:
    width = max(len(name) for name, _ in rows)
    lines = [f"{'command':<{width}}  {'median':>9}  {'ratio':>6}  {'overhead':>9}",
             f"{'-' * width}  {'-' * 9}  {'-' * 6}  {'-' * 9}"]
    for name, seconds in rows:
        lines.append(f"{name:<{width}}  {seconds * 1000:7.0f} ms  {seconds / baseline:5.1f}x  "
                     f"{(seconds - baseline) * 1000:+6.0f} ms")
    return "\n".join(lines)


@dataclass(frozen=True)
class RunSpeed:
    """Median wall time of one scenario variant's run, and the simulated time it covers."""

    scenario: str
    variant: str
    simulated: float
    seconds: float
    spread: float     # max / min - 1 over the repeats
    warm_seconds: float  # the same run again in the same process

    @property
    def real_time_factor(self) -> float:
        return self.simulated / self.seconds


def variants_of(scenario: Path) -> list[str]:
    """"" (the scenario as written, what `hubero run FILE` runs) and each variant's name."""
    from hubero_dsl.pipeline import compile_file

    return ["", *compile_file(scenario).variants]


def run_speed(scenario: Path, variant: str, repeat: int) -> RunSpeed:
    seconds, warm, simulated = [], [], 0.0
    for _ in range(repeat):
        completed = subprocess.run([sys.executable, "-c", RUN_ONCE, str(scenario), variant],
                                   capture_output=True, text=True, check=False)
        if completed.returncode != 0:
            raise SystemExit(f"{scenario} {variant}: the run failed:\n{completed.stderr}")
        measured = json.loads(completed.stdout)
        seconds.append(measured["seconds"][0])
        warm.append(measured["seconds"][1])
        simulated = measured["simulated"]
    return RunSpeed(scenario.name, variant or "(as written)", simulated,
                    statistics.median(seconds), max(seconds) / min(seconds) - 1.0,
                    statistics.median(warm))


def speed_table(speeds: list[RunSpeed], commands: dict[str, float]) -> str:
    lines = [f"{'scenario':<16} {'variant':<13} {'simulated':>9}  {'run':>8}  {'spread':>6}  "
             f"{'x real time':>11}  {'again':>8}  {'x real time':>11}",
             f"{'-' * 16} {'-' * 13} {'-' * 9}  {'-' * 8}  {'-' * 6}  {'-' * 11}  {'-' * 8}  "
             f"{'-' * 11}"]
    for speed in speeds:
        lines.append(f"{speed.scenario:<16} {speed.variant:<13} {speed.simulated:7.1f} s  "
                     f"{speed.seconds * 1000:5.0f} ms  {speed.spread:6.0%}  "
                     f"{speed.real_time_factor:10.0f}x  {speed.warm_seconds * 1000:5.0f} ms  "
                     f"{speed.simulated / speed.warm_seconds:10.0f}x")
    for name, seconds in commands.items():
        simulated = next(s.simulated for s in speeds if s.scenario == name and
                         s.variant == "(as written)")
        lines.append(f"{'hubero run ' + name + ' -q':<30} {simulated:7.1f} s  "
                     f"{seconds * 1000:5.0f} ms  {'':>6}  {simulated / seconds:10.0f}x")
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenario", nargs="?", type=Path, default=DEFAULT_SCENARIO)
    parser.add_argument("--repeat", type=at_least_one, default=10)
    parser.add_argument("--runs", type=int, default=5,
                        help="repeats of each paper scenario run (0: skip them)")
    args = parser.parse_args(argv)
    if not args.scenario.is_file():
        parser.error(f"{args.scenario}: no such scenario file")
    baseline = statistics.median(wall_times([sys.executable, "-c", "pass"], args.repeat))
    rows = [("python -c pass", baseline)]
    for measurement in MEASUREMENTS:
        times = wall_times(measurement.command(args.scenario), args.repeat)
        rows.append((measurement.name, statistics.median(times)))
    print(f"scenario: {args.scenario}   median of {args.repeat} cold runs each")
    print(table(rows, baseline))
    if args.runs > 0:
        speeds = [run_speed(scenario, variant, args.runs) for scenario in PAPER_SCENARIOS
                  for variant in variants_of(scenario)]
        commands = {scenario.name: statistics.median(wall_times(
            hubero("run", str(scenario), "-q"), args.runs)) for scenario in PAPER_SCENARIOS}
        print(f"\npaper scenarios against real time, median of {args.runs} runs each "
              "(run: compile + simulation + plans + every tick, after start-up; again: the same "
              "run repeated in that process, as in a sweep)")
        print(speed_table(speeds, commands))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
