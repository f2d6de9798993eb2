"""Circle crossing: N humans on a circle walk to the antipode, social force, open space.

hubero runs a generated `.hub` file through the same code path as `hubero run` (compile,
Simulation, simulate). Start-up, compilation and the first plans are left out in two ways:
the ticks from SHORT to LONG are timed inside the run (by an observer of simulate, the hook
the log writer uses), and the cost of a short run of the same scenario is subtracted from the
cost of the long one. The first is the headline: on a shared machine the subtraction is as noisy
as compiling the file (at N = 10 the measured ticks take ~30 ms, less than that jitter); it is
printed beside it as a check. When they are
installed (`pip install 'hubero[bench]'`), the same workload runs through the peers in the same
process: JuPedSim's social force model (C++, dt = 0.01 s, which that model needs to stay
stable) and PySocialForce (numpy + numba, O(N^2) per step). Everything is compared per
agent-step: one agent advanced by one step of its simulator.

    python benchmarks/crossing.py                      # N = 10, 100, 1000, 3000, 3 repeats
    python benchmarks/crossing.py 100 1000 --repeat 5
    python benchmarks/crossing.py --no-peers

Each cell of the table is the median of the repeats, with the spread (max / min - 1) beside it.
Nobody reaches their goal while the clock runs (the circle is at least 9 m in radius), so every
agent walks during every measured step, in every simulator.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib.util
import io
import logging
import math
import os
import statistics
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np

from hubero_dsl.pipeline import compile_file
from hubero_dsl.sim.simulation import Simulation
from hubero_dsl.simulate import simulate
from hubero_dsl.world.grid import OccupancyGrid
from hubero_dsl.world.mapfile import save_map

SIZES = (10, 100, 1000, 3000)
SPACING = 0.8            # m between neighbours on the circle
MIN_RADIUS = 9.0         # m: nobody arrives (18 m at 1.29 m/s) before the long run ends
SPEED = 1.29             # m/s, hubero's default walking speed, given to the peers too
BODY_RADIUS = 0.2        # m, hubero's default body radius, given to the peers too
SHORT, LONG = 2.0, 12.0  # s of simulated time (hubero)
JUPEDSIM_DT = 0.01       # s
WARM_UP, MEASURED = 2.0, 10.0  # s of simulated time (JuPedSim)
PSF_STEPS = {10: 200, 100: 40, 1000: 4, 3000: 2}  # O(N^2): a few steps suffice at large N

Rate = Callable[[int], float]


def circle_radius(count: int) -> float:
    return max(MIN_RADIUS, SPACING * count / (2 * math.pi))


def circle(count: int) -> tuple[np.ndarray, np.ndarray]:
    """Start points on the circle and their antipodes, (N, 2) each."""
    radius = circle_radius(count)
    angle = 2 * math.pi * np.arange(count) / count
    start = np.column_stack([radius * np.cos(angle), radius * np.sin(angle)])
    return start, -start


# ---- hubero --------------------------------------------------------------------------------

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
    start, goal = circle(count)
    lines = [f'scenario "crossing {count}"', f'map "{map_path}"', "seed 1",
             f"time_limit {time_limit} s",
             "defaults { global_planner straight; personal_space circle(radius: 0.3 m) }"]
    steps = []
    for i, ((x, y), (gx, gy)) in enumerate(zip(start, goal, strict=True)):
        heading = math.degrees(math.atan2(gy - y, gx - x))
        lines.append(f"human h{i} at ({x:.3f}, {y:.3f}) heading {heading:.1f} deg")
        steps.append(f"    h{i} move_to ({gx:.3f}, {gy:.3f})")
    lines += ["activity crossing {", "  parallel {", *steps, "  }", "}"]
    return "\n".join(lines) + "\n"


class _Clock:
    """An observer of the run: the wall time at which each tick ended."""

    def __init__(self) -> None:
        self.ended: list[float] = []

    def __call__(self, _: Simulation) -> None:
        self.ended.append(time.perf_counter())


def run_seconds(folder: Path, count: int, time_limit: float) -> tuple[float, int, _Clock]:
    """Wall time of compile + run of the generated file, the ticks it simulated, and when each
    tick ended."""
    map_path = write_open_map(folder, circle_radius(count))
    file = folder / f"crossing_{count}_{time_limit:g}.hub"
    file.write_text(scenario_text(count, map_path, time_limit), encoding="utf-8")
    clock = _Clock()
    start = time.perf_counter()
    program = compile_file(file)
    result = simulate(program, observers=[clock])
    return time.perf_counter() - start, result.ticks, clock


def hubero_rates(count: int) -> tuple[float, float]:
    """Agent-steps per second two ways: the long run minus the short one, and the ticks from
    SHORT to LONG timed inside the long run."""
    with tempfile.TemporaryDirectory() as folder:
        short_time, short_ticks, _ = run_seconds(Path(folder), count, SHORT)
        long_time, long_ticks, clock = run_seconds(Path(folder), count, LONG)
    subtracted = count * (long_ticks - short_ticks) / max(long_time - short_time, 1e-9)
    within = count * (long_ticks - short_ticks) / (clock.ended[-1] - clock.ended[short_ticks - 1])
    return subtracted, within


# ---- peers ---------------------------------------------------------------------------------

def jupedsim_rate(count: int) -> float:
    """JuPedSim's social force model: one exit stage at each antipode, one journey each."""
    import jupedsim as jps
    import shapely

    start, goal = circle(count)
    half = circle_radius(count) + 3.0
    sim = jps.Simulation(model=jps.SocialForceModel(),
                         geometry=shapely.box(-half, -half, half, half), dt=JUPEDSIM_DT)
    for (x, y), (gx, gy) in zip(start, goal, strict=True):
        stage = sim.add_exit_stage(shapely.box(gx - 0.3, gy - 0.3, gx + 0.3, gy + 0.3))
        journey = sim.add_journey(jps.JourneyDescription([stage]))
        length = math.hypot(gx - x, gy - y)
        sim.add_agent(jps.SocialForceModelAgentParameters(
            journey_id=journey, stage_id=stage, position=(float(x), float(y)),
            orientation=((gx - x) / length, (gy - y) / length), desired_speed=SPEED,
            radius=BODY_RADIUS))
    sim.iterate(round(WARM_UP / JUPEDSIM_DT))
    chunk, agent_steps = 50, 0
    began = time.perf_counter()
    for _ in range(round(MEASURED / JUPEDSIM_DT) // chunk):
        agent_steps += sim.agent_count() * chunk
        sim.iterate(chunk)
    return agent_steps / (time.perf_counter() - began)


@contextlib.contextmanager
def _inside(folder: str) -> Iterator[None]:
    here = os.getcwd()
    os.chdir(folder)
    try:
        yield
    finally:
        os.chdir(here)


def _quiet_pysocialforce() -> None:
    """PySocialForce logs at DEBUG to the terminal and to ./file.log from the moment it is
    imported: import it from a scratch folder and silence its logger (and numba's)."""
    with tempfile.TemporaryDirectory() as folder, _inside(folder), \
            contextlib.redirect_stderr(io.StringIO()):
        import pysocialforce  # noqa: F401

        root = logging.getLogger("root")
        for handler in list(root.handlers):
            root.removeHandler(handler)
            handler.close()
    root.setLevel(logging.WARNING)
    logging.getLogger("numba").setLevel(logging.WARNING)


def pysocialforce_rate(count: int) -> float:
    """PySocialForce with hubero's step (0.05 s) and no groups; time per step after a warm-up
    step (numba compiles on the first)."""
    _quiet_pysocialforce()
    import pysocialforce as psf

    start, goal = circle(count)
    direction = (goal - start) / np.linalg.norm(goal - start, axis=1, keepdims=True)
    state = np.column_stack([start, direction * SPEED, goal])
    with tempfile.TemporaryDirectory() as folder:
        config = Path(folder) / "crossing.toml"
        config.write_text("[scene]\nenable_group = false\nagent_radius = 0.35\n"
                          "step_width = 0.05\nmax_speed_multiplier = 1.3\ntau = 0.5\n"
                          "resolution = 10\n", encoding="utf-8")
        sim = psf.Simulator(state, config_file=str(config))
    sim.step(1)
    steps = PSF_STEPS.get(count, max(2, 200_000 // max(count, 1) ** 2))
    began = time.perf_counter()
    sim.step(steps)
    return count * steps / (time.perf_counter() - began)


PEERS: dict[str, tuple[str, Rate]] = {
    "JuPedSim": ("jupedsim", jupedsim_rate),
    "PySocialForce": ("pysocialforce", pysocialforce_rate),
}


# ---- the table -----------------------------------------------------------------------------

def spread(rates: list[float]) -> float:
    return max(rates) / min(rates) - 1.0 if min(rates) > 0 else math.inf


def measure(rate: Rate, count: int, repeat: int) -> tuple[float, float]:
    """Median agent-steps per second of `repeat` runs, and their spread (max / min - 1)."""
    rates = [rate(count) for _ in range(repeat)]
    return statistics.median(rates), spread(rates)


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("sizes", nargs="*", type=int, default=list(SIZES))
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--no-peers", action="store_true", help="measure hubero only")
    args = parser.parse_args(argv)
    peers = {} if args.no_peers else {
        name: rate for name, (module, rate) in PEERS.items()
        if importlib.util.find_spec(module) is not None}
    missing = sorted(set(PEERS) - set(peers)) if not args.no_peers else []
    print(f"circle crossing, social force, open space; hubero dt 0.05 s, ticks from {SHORT:g} s "
          f"to {LONG:g} s timed inside the run (and, in brackets, the long run minus the short "
          f"one); JuPedSim dt {JUPEDSIM_DT} s; agent-steps per second, median of {args.repeat} "
          "(spread max/min - 1)")
    if missing:
        print(f"not installed, skipped: {', '.join(missing)} (pip install 'hubero[bench]')")
    header = f"{'N':>5} {'hubero':>17} {'(long - short)':>22} {'us/step':>7}"
    for name in peers:
        header += f" {name:>19} {'hubero/' + name[:3]:>10}"
    print(header)
    per_step: dict[int, float] = {}
    hubero_rates(10)  # warm-up: lazy imports and first-use set-up would land in the first run
    for count in args.sizes:
        both = [hubero_rates(count) for _ in range(args.repeat)]
        within = [w for _, w in both]
        subtracted = [s for s, _ in both]
        ours = statistics.median(within)
        per_step[count] = 1e6 / ours
        line = (f"{count:>5} {ours:>11,.0f} ({spread(within):>3.0%}) "
                f"({statistics.median(subtracted):>11,.0f}, {spread(subtracted):>4.0%}) "
                f"{per_step[count]:>7.2f}")
        for rate in peers.values():
            theirs, their_spread = measure(rate, count, args.repeat)
            line += f" {theirs:>13,.0f} ({their_spread:>3.0%}) {ours / theirs:>9.2f}x"
        print(line, flush=True)
    if 100 in per_step and 3000 in per_step:
        print(f"hubero cost per agent-step, N = 3000 vs N = 100: "
              f"{per_step[3000] / per_step[100]:.2f}x")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
