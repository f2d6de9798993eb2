"""What measuring a log costs: social-navigation metrics of every human of a crowd's log, against
reading the log and against the standard metrics (`compute_metrics`), measured in the same run.

    python benchmarks/socialnav_metrics.py [--humans 1000] [--time-limit 20] [--rate 10]

The log is the crossing of `benchmarks/logging_cost.py` (N humans on a circle, 0.8 m apart,
each walking to the antipode) run once with `hubero run`. Reported: wall seconds of `load_run`,
`log_social_metrics` (every human, among its neighbours), all-pairs `social_metrics` for ten
humans scaled to N, and `compute_metrics`, with their ratios to `load_run`.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

from arguments import at_least_one
from logging_cost import crossing_scenario

from hubero_dsl.analysis.metrics import compute_metrics
from hubero_dsl.analysis.socialnav_log import human_social_metrics, log_social_metrics
from hubero_dsl.log.reader import LoggedRun, load_run

SAMPLE = 10  # humans measured among everyone, for the all-pairs estimate


def seconds(work: Callable[[], object]) -> float:
    start = time.perf_counter()
    work()
    return time.perf_counter() - start


def all_pairs(run: LoggedRun) -> None:
    for name in sorted(run.humans)[:SAMPLE]:
        human_social_metrics(run, name)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--humans", type=at_least_one, default=1000)
    parser.add_argument("--time-limit", type=float, default=20.0, help="simulated seconds")
    parser.add_argument("--rate", type=float, default=10.0, help="log rate in Hz")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as name:
        folder = Path(name)
        scenario = crossing_scenario(folder, args.humans, args.time_limit)
        log = folder / "crossing.mcap"
        subprocess.run([sys.executable, "-m", "hubero_dsl", "run", str(scenario), "-o", str(log),
                        "--log-rate", f"{args.rate:g}", "--quiet"], check=False)  # may time out
        if not log.exists():
            sys.exit("the run wrote no log")
        run = load_run(log)
        frames = len(next(iter(run.humans.values())).time)
        rows = [("load_run", seconds(lambda: load_run(log))),
                ("log_social_metrics", seconds(lambda: log_social_metrics(run))),
                ("all pairs (estimate)",
                 seconds(lambda: all_pairs(run)) * len(run.humans) / SAMPLE),
                ("compute_metrics", seconds(lambda: compute_metrics(run)))]
    print(f"crossing: {args.humans} humans, {frames} frames")
    base = rows[0][1]
    print(f"  {'':22s} {'wall s':>8s} {'ratio':>7s}")
    for label, wall in rows:
        print(f"  {label:22s} {wall:8.2f} {wall / base:7.2f}")


if __name__ == "__main__":
    main()
