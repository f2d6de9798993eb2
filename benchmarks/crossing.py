"""Circle crossing: N humans on a circle walk to the antipode, social force, open space.

hubero is measured as a user runs it: `hubero run FILE -o log.mcap -q` in a fresh interpreter,
with the default planners (navfn and social force), start-up, planning and logging included.
Two runs of the same file are timed: one that stops at START (5 s) and one that goes on to the
window's end, past the dense meeting in the middle of the circle (1.5 x the time to walk to the
centre); their difference is the cost of the window. Agent-steps are counted for the people
still walking (from the log's task events), since those who arrived stand still. The 5 s run
on its own is the start-up cost a user feels (target: 3 s + 5 ms per person). A run can end
before the window does: someone who makes no progress for 20 s in the crowd is aborted as
stuck, which fails the crossing (exit status 1, like the time limit). The window then ends
where the run did (read from the log and marked `*`), and the peers run over that window too.

When installed (`pip install 'hubero[bench]'`), JuPedSim's social force model runs the same
positions and goals in the same process (C++, dt = 0.01 s, which that model needs to stay
stable; an exit stage at each antipode) over the same window of simulated time, counting the
agents it still has at each iteration; PySocialForce (numpy + numba, O(N^2) per step) is timed
on a few steps at the start. Everything is compared per agent-step: one agent advanced by one
step of its simulator.

    python benchmarks/crossing.py                      # N = 100, 1000, 3000, best of 3
    python benchmarks/crossing.py 100 1000 --repeat 1
    python benchmarks/crossing.py --no-peers
    python benchmarks/crossing.py 1000 --log-cost --repeat 4   # the log's cost, whole runs
"""

from __future__ import annotations

import argparse
import contextlib
import importlib.util
import io
import json
import logging
import math
import os
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from arguments import at_least_one

from hubero_dsl.world.grid import OccupancyGrid
from hubero_dsl.world.mapfile import save_map

SIZES = (100, 1000, 3000)
SPACING = 0.8            # m between neighbours on the circle
MIN_RADIUS = 9.0         # m: nobody arrives (18 m at 1.29 m/s) before the long run ends
SPEED = 1.29             # m/s, hubero's default walking speed, given to the peers too
BODY_RADIUS = 0.2        # m, hubero's default body radius, given to the peers too
START = 5.0              # s: the window starts here (the short run's end)
PAST_THE_MIDDLE = 1.5    # the window ends at this many times the walk to the centre
JUPEDSIM_DT = 0.01       # s
PSF_STEPS = {10: 200, 100: 40, 1000: 4, 3000: 2}  # O(N^2): a few steps suffice at large N

Rate = Callable[[int, float], float]  # agent-steps/s of N people from START to an end time


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


def window_end(count: int) -> float:
    """Seconds of simulated time that take everyone through the dense middle."""
    return round(START + PAST_THE_MIDDLE * circle_radius(count) / SPEED, 1)


def scenario_text(count: int, map_path: Path, time_limit: float) -> str:
    start, goal = circle(count)
    lines = [f'scenario "crossing {count}"', f'map "{map_path}"', "seed 1",
             f"time_limit {time_limit} s",
             "defaults { personal_space circle(radius: 0.3 m) }"]
    steps = []
    for i, ((x, y), (gx, gy)) in enumerate(zip(start, goal, strict=True)):
        heading = math.degrees(math.atan2(gy - y, gx - x))
        lines.append(f"human h{i} at ({x:.3f}, {y:.3f}) heading {heading:.1f} deg")
        steps.append(f"    h{i} move_to ({gx:.3f}, {gy:.3f})")
    lines += ["activity crossing {", "  parallel {", *steps, "  }", "}"]
    return "\n".join(lines) + "\n"


def hubero_run(file: Path, log: Path | None) -> tuple[float, str]:
    """Wall time of `hubero run FILE -o LOG -q` (`--no-log` without a LOG) in a fresh
    interpreter, and how it ended when not at its time limit (exit status 1 is the time
    limit, or a task that failed)."""
    began = time.perf_counter()
    output = ["-o", str(log)] if log is not None else ["--no-log"]
    done = subprocess.run([sys.executable, "-m", "hubero_dsl", "run", str(file), *output,
                           "-q"], capture_output=True, text=True, check=False)
    wall = time.perf_counter() - began
    if done.returncode not in (0, 1) or (log is not None and not log.exists()):
        sys.exit(f"hubero run {file} failed:\n{done.stderr}")
    lines = done.stderr.strip().splitlines()
    return wall, lines[-1] if lines else ""


def run_end(log: Path) -> float:
    """The simulated time a run reached: its log's last message (a frame at its last tick)."""
    from mcap.reader import make_reader

    with log.open("rb") as stream:
        summary = make_reader(stream).get_summary()
    assert summary is not None and summary.statistics is not None
    return round(summary.statistics.message_end_time / 1e9, 2)


def walking_steps(log: Path, count: int, start: float, end: float, dt: float) -> float:
    """Agent-steps from `start` to `end` of the people still walking (until their move_to
    ended), from the log's task events."""
    from mcap.reader import make_reader

    # only /tasks is decoded: the log of a long window holds tens of millions of messages
    arrived = {}
    with log.open("rb") as stream:
        for _, _, message in make_reader(stream).iter_messages(topics=["/tasks"]):
            event = json.loads(message.data)
            if event["status"] in ("SUCCEEDED", "ABORTED", "PREEMPTED"):
                arrived[event["human"]] = event["tick"] * dt
    ends = np.array([min(arrived.get(f"h{i}", end), end) for i in range(count)])
    return float(np.clip(ends - start, 0.0, None).sum() / dt)


@dataclass(frozen=True)
class HuberoWindow:
    start_up: float      # s, wall time of the run that stops at START
    window: float        # s, wall time of the window (the long run minus the short one)
    agent_steps: float   # in the window, of the people still walking
    end: float           # s of simulated time the long run reached (the window's end)
    ended: str           # why it ended before the window's end ("" when it did not)

    @property
    def rate(self) -> float:
        return self.agent_steps / max(self.window, 1e-9)


def hubero_window(count: int, repeat: int) -> HuberoWindow:
    """Best of `repeat` for each of the two runs, then the window between them."""
    end = window_end(count)
    with tempfile.TemporaryDirectory() as name:
        folder = Path(name)
        map_path = write_open_map(folder, circle_radius(count))
        files = {}
        for label, limit in (("short", START), ("long", end)):
            files[label] = folder / f"crossing_{count}_{label}.hub"
            files[label].write_text(scenario_text(count, map_path, limit), encoding="utf-8")
        short = min(hubero_run(files["short"], folder / "short.mcap")[0]
                    for _ in range(repeat))
        long, ended = min(hubero_run(files["long"], folder / "long.mcap")
                          for _ in range(repeat))
        # a run can end before the window does: a walker stuck in the crowd fails the crossing
        reached = run_end(folder / "long.mcap")
        steps = walking_steps(folder / "long.mcap", count, START, reached, 0.05)
    return HuberoWindow(short, long - short, steps, reached,
                        ended if reached < end - 1e-6 else "")


def log_cost(count: int, repeat: int) -> tuple[float, float]:
    """Best wall times of the whole crossing (to the window's end, or where it ends) through
    `hubero run` with its log and with `--no-log`, run alternately."""
    with tempfile.TemporaryDirectory() as name:
        folder = Path(name)
        file = folder / f"crossing_{count}.hub"
        file.write_text(scenario_text(count, write_open_map(folder, circle_radius(count)),
                                      window_end(count)), encoding="utf-8")
        logged, bare = [], []
        for _ in range(repeat):
            logged.append(hubero_run(file, folder / "run.mcap")[0])
            bare.append(hubero_run(file, None)[0])
    return min(logged), min(bare)


# ---- peers ---------------------------------------------------------------------------------

def jupedsim_rate(count: int, end: float) -> float:
    """JuPedSim's social force model from START to `end`: agent-steps of the agents it still
    has (they leave at their exit stage) per second of wall time."""
    import jupedsim as jps
    import shapely

    start, goal = circle(count)
    # room to spare: in the dense middle its model throws some agents far out, and an agent
    # outside the geometry ends the simulation with an error
    half = 2.0 * circle_radius(count) + 10.0
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
    sim.iterate(round(START / JUPEDSIM_DT))
    chunk, agent_steps = 50, 0
    iterations = round((end - START) / JUPEDSIM_DT)
    began = time.perf_counter()
    for done in range(iterations // chunk):
        alive = sim.agent_count()
        if alive == 0:
            break
        try:
            sim.iterate(chunk)
        except RuntimeError as exc:  # an agent thrown out of the geometry ends its run
            raise PeerStoppedError(agent_steps / (time.perf_counter() - began),
                                   START + done * chunk * JUPEDSIM_DT, str(exc)) from None
        agent_steps += alive * chunk
    return agent_steps / (time.perf_counter() - began)


class PeerStoppedError(RuntimeError):
    """A peer's simulation ended with its own error part way: its rate until then."""

    def __init__(self, rate: float, reached: float, reason: str) -> None:
        super().__init__(reason)
        self.rate, self.reached = rate, reached


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


def pysocialforce_rate(count: int, end: float) -> float:
    """PySocialForce with hubero's step (0.05 s) and no groups; time per step after a warm-up
    step (numba compiles on the first), over a fixed number of steps from the start (`end` is
    not used: its rate does not follow density)."""
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

def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("sizes", nargs="*", type=at_least_one, default=list(SIZES))
    parser.add_argument("--repeat", type=at_least_one, default=3, help="runs of each (best taken)")
    parser.add_argument("--no-peers", action="store_true", help="measure hubero only")
    parser.add_argument("--log-cost", action="store_true",
                        help="time each whole crossing with and without its log instead")
    args = parser.parse_args(argv)
    if args.log_cost:
        print(f"what the log (10 Hz) adds to the whole crossing through `hubero run`, best of "
              f"{args.repeat}, run alternately")
        for count in args.sizes:
            logged, bare = log_cost(count, args.repeat)
            print(f"N = {count}: {logged:.2f} s with the log, {bare:.2f} s without: "
                  f"+{(logged / bare - 1) * 100:.0f} %", flush=True)
        return 0
    peers = {} if args.no_peers else {
        name: rate for name, (module, rate) in PEERS.items()
        if importlib.util.find_spec(module) is not None}
    missing = sorted(set(PEERS) - set(peers)) if not args.no_peers else []
    print(f"circle crossing, social force, open space, default planners; hubero through "
          f"`hubero run FILE -o log.mcap -q` (dt 0.05 s) over {START:g} s to the window's end, "
          f"best of {args.repeat}; JuPedSim dt {JUPEDSIM_DT} s over the same window; "
          "agent-steps per second of the people still walking")
    if missing:
        print(f"not installed, skipped: {', '.join(missing)} (pip install 'hubero[bench]')")
    header = (f"{'N':>5} {'window s':>9} {'5 s run':>8} {'target':>7} {'hubero':>11} "
              f"{'us/step':>8}")
    for name in peers:
        header += f" {name:>14} {'hubero/' + name[:3]:>10}"
    print(header)
    for count in args.sizes:
        ours = hubero_window(count, args.repeat)
        window = f"{START:g}-{ours.end:g}" + ("*" if ours.ended else "")
        if ours.window <= 0.0:  # start-up noise larger than the window's cost
            print(f"{count:>5} {window:>9} {ours.start_up:>7.2f}s: the long run took no longer "
                  "than the 5 s run; time it again with a larger --repeat", flush=True)
            continue
        line = (f"{count:>5} {window:>9} {ours.start_up:>7.2f}s "
                f"{3 + 0.005 * count:>6.2f}s {ours.rate:>11,.0f} {1e6 / ours.rate:>8.2f}")
        if ours.ended:
            print(f"* hubero at N = {count} ended at t = {ours.end:g} s, before "
                  f"{window_end(count):g} s ({ours.ended}): every rate in its row is over "
                  f"{START:g}-{ours.end:g} s", file=sys.stderr)
        for name, rate in peers.items():
            try:
                theirs = max(rate(count, ours.end) for _ in range(args.repeat))
            except PeerStoppedError as stop:  # measured up to its failure, said so
                line += f" {stop.rate:>13,.0f}* {ours.rate / stop.rate:>9.2f}x"
                print(f"* {name} at N = {count} stopped at t = {stop.reached:g} s with its own "
                      f"error ({stop}): its rate is over {START:g}-{stop.reached:g} s",
                      file=sys.stderr)
                continue
            except RuntimeError as exc:  # the peer's own failure, said and skipped
                line += f" {'failed':>14} {'-':>10}"
                print(f"{name} at N = {count} failed: {exc}", file=sys.stderr)
                continue
            line += f" {theirs:>14,.0f} {ours.rate / theirs:>9.2f}x"
        print(line, flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
