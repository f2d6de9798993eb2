"""Circle crossing: N humans on a circle walk to the antipode, social force, open space.

Runs a generated `.hub` file through the same code path as `hubero run` (compile, Simulation,
run_program) and reports agent-steps per second for N = 10, 100, 1000, 3000. Start-up,
compilation and the first plans cancel out: the cost of a short run of the same file is
subtracted from the cost of a long one.

    python benchmarks/crossing.py            # all sizes
    python benchmarks/crossing.py 100 1000   # some sizes
"""

from __future__ import annotations

import math
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from hubero_dsl.lang.compile import compile_file
from hubero_dsl.sim.run import run_program
from hubero_dsl.sim.simulation import Simulation
from hubero_dsl.world.grid import OccupancyGrid
from hubero_dsl.world.mapfile import save_map

SIZES = (10, 100, 1000, 3000)
SPACING = 0.8          # m between neighbours on the circle
SHORT, LONG = 2.0, 12.0  # s of simulated time


def circle_radius(count: int) -> float:
    return max(4.0, SPACING * count / (2 * math.pi))


def write_open_map(folder: Path, radius: float) -> Path:
    """An empty square room just larger than the circle."""
    half = radius + 3.0
    resolution = 0.1 if half < 60 else 0.5
    cells = math.ceil(2 * half / resolution)
    occupied = np.zeros((cells, cells), dtype=bool)
    occupied[[0, -1], :] = occupied[:, [0, -1]] = True
    return save_map(OccupancyGrid(occupied, resolution, (-half, -half)), folder / "open.yaml") \
        .with_suffix(".yaml")


def scenario_text(count: int, map_path: Path, time_limit: float) -> str:
    radius = circle_radius(count)
    lines = [f'scenario "crossing {count}"', f'map "{map_path}"', "seed 1",
             f"time_limit {time_limit} s",
             "defaults { global_planner straight; personal_space circle(radius: 0.3 m) }"]
    steps = []
    for i in range(count):
        angle = 2 * math.pi * i / count
        x, y = radius * math.cos(angle), radius * math.sin(angle)
        heading = math.degrees(angle) + 180
        lines.append(f"human h{i} at ({x:.3f}, {y:.3f}) heading {heading:.1f} deg")
        steps.append(f"    h{i} move_to ({-x:.3f}, {-y:.3f})")
    lines += ["activity crossing {", "  parallel {", *steps, "  }", "}"]
    return "\n".join(lines) + "\n"


def run_seconds(folder: Path, count: int, time_limit: float) -> tuple[float, int]:
    """Wall time of compile + run of the generated file, and the ticks it simulated."""
    map_path = write_open_map(folder, circle_radius(count))
    file = folder / f"crossing_{count}_{time_limit:g}.hub"
    file.write_text(scenario_text(count, map_path, time_limit), encoding="utf-8")
    start = time.perf_counter()
    program = compile_file(file)
    result = run_program(Simulation(program))
    return time.perf_counter() - start, result.ticks


def agent_steps_per_second(count: int) -> float:
    with tempfile.TemporaryDirectory() as folder:
        short_time, short_ticks = run_seconds(Path(folder), count, SHORT)
        long_time, long_ticks = run_seconds(Path(folder), count, LONG)
    return count * (long_ticks - short_ticks) / max(long_time - short_time, 1e-9)


def main(argv: list[str]) -> None:
    sizes = [int(a) for a in argv] or list(SIZES)
    print(f"circle crossing, social force, dt 0.05 s, {LONG - SHORT:g} s of simulated time "
          "measured (long run minus short run)")
    print(f"{'N':>6} {'agent-steps/s':>15} {'us/agent-step':>14}")
    for count in sizes:
        rate = agent_steps_per_second(count)
        print(f"{count:>6} {rate:>15,.0f} {1e6 / rate:>14.2f}")


if __name__ == "__main__":
    main(sys.argv[1:])
