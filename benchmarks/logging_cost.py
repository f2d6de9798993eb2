"""What writing an MCAP log adds to a run: a workload with and without `RunLog`.

    python benchmarks/logging_cost.py [--humans 1000] [--time-limit 20] [--rate 10] [--repeat 5]
                                      [--workload crossing|crowd]

`crossing` (the default) is the workload of `benchmarks/crossing.py`: N humans written one by
one on a circle (0.8 m apart) on an open map each walk to the antipode (straight-line global
planner, social force local planner, 50 ms steps, personal space a 0.3 m circle); each has
topics of their own. `crowd` is one `crowd` of N people wandering (`move_around`) in a square
of 4 m^2 per person on the same kind of map, with the default planners; the crowd's members
share its two aggregate topics. The scenario is compiled once; each repetition runs
a fresh `Simulation` without a log, with a log encoded by a writer process (the default where
the platform can fork), with a log encoded in this process, and (when foxglove-sdk is
installed) with a log also served live at `max` pace to no client (`hubero run --live`, before
anyone connects); these are interleaved so that a busy machine disturbs them alike. Opening,
every frame, closing and renaming are timed. Reported:
medians of wall time and of this process's CPU time, their ratios to the run without a log,
the writer process's CPU time, the log's size and frame count.
"""

from __future__ import annotations

import argparse
import math
import resource
import statistics
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

from arguments import at_least_one
from crossing import write_open_map

from hubero_dsl.log.reader import load_run
from hubero_dsl.log.writer import can_fork
from hubero_dsl.model.program import Program
from hubero_dsl.pipeline import compile_file
from hubero_dsl.simulate import simulate

SPACING = 0.8  # m between neighbours on the circle


def crossing_scenario(folder: Path, humans: int, time_limit: float) -> Path:
    """Write the open map and the crossing scenario into `folder`; return the scenario."""
    radius = max(4.0, SPACING * humans / (2 * math.pi))
    write_open_map(folder, radius)
    lines = [f'scenario "crossing {humans}"', 'map "open.yaml"', "seed 1", "step 50 ms",
             f"time_limit {time_limit:g} s",
             "defaults { global_planner straight; personal_space circle(radius: 0.3 m) }"]
    steps = []
    for i in range(humans):
        angle = 2 * math.pi * i / humans
        x, y = radius * math.cos(angle), radius * math.sin(angle)
        heading = math.degrees(angle) + 180.0
        lines.append(f"human h{i} at ({x:.3f}, {y:.3f}) heading {heading:.1f} deg")
        steps.append(f"    h{i} move_to ({-x:.3f}, {-y:.3f})")
    lines += ["activity crossing {", "  parallel {", *steps, "  }", "}"]
    scenario = folder / "crossing.hub"
    scenario.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return scenario


def crowd_scenario(folder: Path, humans: int, time_limit: float) -> Path:
    """The same open map with one `crowd` of N people wandering in a square at about one
    person per 4 m^2 (their log is the crowd's two topics, not two topics per person)."""
    half_side = math.sqrt(4.0 * humans) / 2
    write_open_map(folder, half_side)
    area = f"rect(({-half_side:.2f}, {-half_side:.2f}), ({half_side:.2f}, {half_side:.2f}))"
    text = "\n".join([
        f'scenario "crowd {humans}"', 'map "open.yaml"', "seed 1", "step 50 ms",
        f"time_limit {time_limit + 1:g} s",
        "defaults { personal_space circle(radius: 0.3 m) }",
        f"crowd walkers {humans} in {area}",
        f"activity {{ walkers move_around in {area} for {time_limit:g} s }}"]) + "\n"
    scenario = folder / "crowd.hub"
    scenario.write_text(text, encoding="utf-8")
    return scenario


WORKLOADS = {"crossing": crossing_scenario, "crowd": crowd_scenario}


def timed(run: Callable[[], int]) -> tuple[float, float, float, int]:
    """(wall s, CPU s of this process, CPU s of finished child processes, what run() gave)."""
    wall, cpu, children = time.perf_counter(), time.process_time(), _children_cpu()
    value = run()
    return (time.perf_counter() - wall, time.process_time() - cpu,
            _children_cpu() - children, value)


def _children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def run_bare(program: Program) -> int:
    simulate(program)
    return 0


def run_logged(program: Program, output: Path, rate: float, writer_process: bool) -> int:
    simulate(program, log=output, log_rate=rate, writer_process=writer_process)
    return 0


def run_live(program: Program, output: Path, rate: float) -> int:
    from hubero_dsl.log.live import LiveServer

    with LiveServer(port=0, pace=None) as live:
        simulate(program, log=output, log_rate=rate, live=live)
    return 0


def _live_available() -> bool:
    import importlib.util

    return importlib.util.find_spec("foxglove") is not None


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--humans", type=at_least_one, default=1000)
    parser.add_argument("--time-limit", type=float, default=20.0, help="simulated seconds")
    parser.add_argument("--rate", type=float, default=10.0, help="log rate in Hz")
    parser.add_argument("--repeat", type=at_least_one, default=5)
    parser.add_argument("--workload", choices=sorted(WORKLOADS), default="crossing",
                        help="crossing: N named humans (topics of their own); crowd: one "
                             "crowd of N (aggregate topics)")
    args = parser.parse_args()
    modes = [("writer process", True)] if can_fork() else []
    modes.append(("in this process", False))
    times: dict[str, list[tuple[float, float, float, int]]] = {"no log": []}
    times.update({name: [] for name, _ in modes})
    if _live_available():
        times["live, no client"] = []
    frames, size = 0, 0
    with tempfile.TemporaryDirectory() as name:
        folder = Path(name)
        program = compile_file(WORKLOADS[args.workload](folder, args.humans, args.time_limit))
        output = folder / "run.mcap"
        for _ in range(args.repeat):
            times["no log"].append(timed(lambda: run_bare(program)))
            for mode, writer_process in modes:
                times[mode].append(timed(
                    lambda w=writer_process: run_logged(program, output, args.rate, w)))
            if "live, no client" in times:
                times["live, no client"].append(timed(
                    lambda: run_live(program, output, args.rate)))
            size = output.stat().st_size
        frames = len(next(iter(load_run(output).humans.values())).time)
    print(f"{args.workload}: {args.humans} humans, {args.time_limit:g} s simulated at 50 ms "
          f"steps, log at {args.rate:g} Hz ({frames} frames, {size / 1e6:.1f} MB); "
          f"median of {args.repeat}")
    bare_wall = statistics.median(sample[0] for sample in times["no log"])
    bare_cpu = statistics.median(sample[1] for sample in times["no log"])
    print(f"  {'':16s} {'wall s':>8s} {'ratio':>7s} {'cpu s':>8s} {'ratio':>7s} "
          f"{'writer cpu s':>13s}")
    for mode, samples in times.items():
        wall = statistics.median(sample[0] for sample in samples)
        cpu = statistics.median(sample[1] for sample in samples)
        writer = statistics.median(sample[2] for sample in samples)
        print(f"  {mode:16s} {wall:8.3f} {wall / bare_wall:7.2f} {cpu:8.3f} "
              f"{cpu / bare_cpu:7.2f} {writer:13.3f}")


if __name__ == "__main__":
    main()
