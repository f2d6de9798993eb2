"""What share of a `hubero run` goes into global planning, on the crowd workloads.

    python benchmarks/planning_share.py [--repeat N]

Each workload runs `hubero run FILE -o log.mcap -q` in a fresh interpreter, as a user types it,
except that the interpreter first wraps every global planner's `plan` (and navfn's, which the
default planner is) in a timer; the run then goes through hubero's own command-line entry point.
Reported: the run's wall time from the interpreter's start, the time inside `plan` calls, their
ratio (the target is at most 20 %), and how many plans were made. Workloads: the circle
crossing of `crossing.py` (5 s, and the whole window at N = 100), the car park flow of
`flow.py` (1 person a second for 3 minutes), a crowd of 300 wandering among the parked cars
(each walk to a goal of its own), the shipped `scenarios/station.hub`, and the shipped
`scenarios/lounge_crowd.hub` (eight people wandering among the living room's furniture, on
its 2 cm cells, a family and a robot).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

from arguments import at_least_one
from crossing import circle_radius, scenario_text, window_end, write_open_map
from flow import SCENARIO as FLOW

REPO_ROOT = Path(__file__).resolve().parents[1]
# a crowd wandering among the parked cars: every walk is to a goal of its own, most of them
# behind cars, so most plans need a search
SHOPPERS = """scenario "Shoppers in the car park"
map "{map}"
seed 1
time_limit 61 s
area lot rect((-6.0, -6.5), (20.9, 21.2))
crowd shoppers 300 in lot
activity {{ shoppers move_around in lot for 60 s }}
"""

# Runs in the child: time every plan, then hand over to the CLI as `python -m hubero_dsl` does.
TIMED_RUN = """
import json, sys, time
began = time.perf_counter()
from hubero_dsl.planners import navfn, straight
spent = [0.0, 0]
def timed(plan):
    def wrapper(*args, **kwargs):
        start = time.perf_counter()
        try:
            return plan(*args, **kwargs)
        finally:
            spent[0] += time.perf_counter() - start
            spent[1] += 1
    return wrapper
for planner in {navfn.NavfnPlanner, straight.StraightLinePlanner}:
    planner.plan = timed(planner.plan)
from hubero_dsl.cli.main import main
try:
    status = main(sys.argv[1:])
finally:
    wall = time.perf_counter() - began
    print(json.dumps({"wall": wall, "planning": spent[0], "plans": spent[1]}), file=sys.stderr)
raise SystemExit(status)
"""


def timed_run(scenario: Path, log: Path) -> dict[str, float]:
    done = subprocess.run([sys.executable, "-c", TIMED_RUN, "run", str(scenario), "-o",
                           str(log), "-q"], capture_output=True, text=True, check=False,
                          cwd=REPO_ROOT)
    if done.returncode not in (0, 1):
        sys.exit(f"the run of {scenario} failed:\n{done.stdout}\n{done.stderr}")
    result: dict[str, float] = json.loads(done.stderr.strip().splitlines()[-1])
    return result


def workloads(folder: Path) -> dict[str, Path]:
    files = {}
    for count, limit in ((100, 5.0), (100, window_end(100)), (1000, 5.0)):
        room = folder / f"open{count}"
        room.mkdir(exist_ok=True)
        map_path = write_open_map(room, circle_radius(count))
        name = f"crossing N={count}, {limit:g} s"
        files[name] = folder / f"crossing{count}-{limit:g}.hub"
        files[name].write_text(scenario_text(count, map_path, limit), encoding="utf-8")
    files["flow 1/s, 3 min"] = folder / "flow.hub"
    files["flow 1/s, 3 min"].write_text(FLOW.format(
        map=REPO_ROOT / "maps" / "parking.yaml", rate=1, minutes=3, limit=300),
        encoding="utf-8")
    files["shoppers 300, 60 s"] = folder / "shoppers.hub"
    files["shoppers 300, 60 s"].write_text(SHOPPERS.format(
        map=REPO_ROOT / "maps" / "parking.yaml"), encoding="utf-8")
    for shipped in ("station.hub", "lounge_crowd.hub"):
        files[f"scenarios/{shipped}"] = REPO_ROOT / "scenarios" / shipped
    return files


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=at_least_one, default=1,
                        help="runs of each (median taken)")
    args = parser.parse_args()
    print(f"{'workload':<26} {'wall s':>8} {'planning s':>11} {'share':>7} {'plans':>6}")
    with tempfile.TemporaryDirectory() as name:
        folder = Path(name)
        for label, scenario in workloads(folder).items():
            runs = sorted((timed_run(scenario, folder / "run.mcap") for _ in range(args.repeat)),
                          key=lambda r: r["wall"])
            run = runs[len(runs) // 2]
            print(f"{label:<26} {run['wall']:>8.2f} {run['planning']:>11.3f} "
                  f"{run['planning'] / run['wall']:>7.1%} {run['plans']:>6.0f}")


if __name__ == "__main__":
    main()
