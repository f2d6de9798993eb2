"""How long the command line takes, as a user feels it.

    python benchmarks/cli.py [SCENARIO] [--repeat N]

Each row runs a command in a fresh interpreter N times (after one discarded warm-up run that fills
the OS file cache and the bytecode cache) and reports the median wall time, next to a bare
`python -c pass`: the ratio and the difference are what hubero itself costs. Rows are
`Measurement`s in `MEASUREMENTS`; more (run speed against real time) are to be added there.
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[1]
DEFAULT_SCENARIO = REPO_ROOT / "scenarios" / "living_room.hub"


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


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenario", nargs="?", type=Path, default=DEFAULT_SCENARIO)
    parser.add_argument("--repeat", type=int, default=10)
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
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
