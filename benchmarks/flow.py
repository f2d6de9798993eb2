"""A flow of people through the car park, through the command a user types.

    python benchmarks/flow.py [--rate PER_SECOND] [--minutes M] [--repeat N]

People arrive at `--rate` a second (1 by default) for `--minutes` simulated minutes (10) at the
car park's south-west corner and walk to the north row of cars: about 40 are in the car park at
any time, and 600 come and go. Each repeat runs `hubero run FILE -o log.mcap` in a fresh
interpreter (start-up, compiling, planning, simulating and logging all counted) and the best
wall time is reported with the simulated time it covered: their ratio is the speed against real
time (the target is 200x). A second row runs the same file with `--no-log`, so the log's share
shows.
"""

from __future__ import annotations

import argparse
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from arguments import at_least_one

REPO_ROOT = Path(__file__).resolve().parents[1]
SCENARIO = """scenario "A flow through the car park"
map "{map}"
seed 1
time_limit {limit} s
flow shoppers from rect((-6, -7), (-3, -4)) to (0.3, 18.8) rate {rate} /s for {minutes} min
"""
ENDED = re.compile(r"completed at t = ([0-9.]+) s")


def run(command: list[str], repeat: int) -> tuple[float, float]:
    """Best wall time of `repeat` runs, and the simulated time the run reported."""
    best, simulated = float("inf"), 0.0
    for _ in range(repeat):
        start = time.perf_counter()
        done = subprocess.run(command, capture_output=True, text=True, check=False,
                              env={"COLUMNS": "200", "PATH": ""})
        best = min(best, time.perf_counter() - start)
        found = ENDED.search(done.stdout)
        if done.returncode != 0 or found is None:
            sys.exit(f"the run failed:\n{done.stdout}\n{done.stderr}")
        simulated = float(found.group(1))
    return best, simulated


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rate", type=float, default=1.0, help="people per second")
    parser.add_argument("--minutes", type=float, default=10.0, help="simulated minutes")
    parser.add_argument("--repeat", type=at_least_one, default=3,
                        help="runs of each row (best taken)")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        scenario = Path(folder) / "flow.hub"
        scenario.write_text(SCENARIO.format(
            map=REPO_ROOT / "maps" / "parking.yaml", rate=args.rate, minutes=args.minutes,
            limit=args.minutes * 60 + 120), encoding="utf-8")
        hubero = [sys.executable, "-m", "hubero_dsl", "run", str(scenario)]
        rows = {"hubero run -o log.mcap": [*hubero, "-o", str(Path(folder) / "flow.mcap")],
                "hubero run --no-log": [*hubero, "--no-log"]}
        print(f"flow of {args.rate:g}/s for {args.minutes:g} min through maps/parking.yaml, "
              f"best of {args.repeat}")
        print(f"{'command':<26} {'wall s':>8} {'simulated s':>12} {'x real time':>12}")
        for name, command in rows.items():
            wall, simulated = run(command, args.repeat)
            print(f"{name:<26} {wall:>8.2f} {simulated:>12.1f} {simulated / wall:>12.1f}")


if __name__ == "__main__":
    main()
