"""Two flows through one door or corridor: with turns (`sim/right_of_way.py`), with turns and
people keeping to the right of the oncoming (`social_force.oncoming_side_preference 1`), and
with the social force alone.

    python scripts/counterflow.py [--seeds 3]

Each map (the two halls of `maps/halls.yaml`, 12 m x 10 m each, joined by a door 1.2 m wide;
the two rooms of the doorway benchmark, `maps/benchmark/doorway.yaml`, 6 m x 6 m each; and the
two halls of `maps/corridor_halls.yaml`, joined by a corridor 8 m long and 1.6 m wide) gets four
pairs of rates (20/20, 30/15, 30/30 and 40/20 a minute, for one minute), each run with
`--seeds` seeds; the table gives, per map, how many of the people who came were given up
(stuck) or still walking at the time limit of 5 minutes, and the mean time on the walk of those
who arrived.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager, nullcontext
from pathlib import Path

import hubero_dsl  # noqa: F401  (before numpy: it chooses numpy's loops for every machine)
from hubero_dsl.pipeline import compile_file
from hubero_dsl.sim.right_of_way import RightOfWay
from hubero_dsl.simulate import simulate

ROOT = Path(__file__).resolve().parents[1]
RATES = ((20, 20), (30, 15), (30, 30), (40, 20))
# map, the east flow's area and target, the west flow's area and target
MAPS = {
    "halls": (ROOT / "maps" / "halls.yaml", "rect((0.5, 0.5), (3.0, 9.5))", "(23.0, 5.0)",
              "rect((21.2, 0.5), (23.7, 9.5))", "(1.0, 5.0)"),
    "doorway rooms": (ROOT / "maps" / "benchmark" / "doorway.yaml",
                      "rect((0.5, 0.5), (2.5, 5.5))", "(11.0, 3.0)",
                      "rect((9.7, 0.5), (11.7, 5.5))", "(1.0, 3.0)"),
    "corridor halls": (ROOT / "maps" / "corridor_halls.yaml", "rect((0.5, 0.5), (3.0, 9.5))",
                       "(31.0, 5.0)", "rect((29.0, 0.5), (31.5, 9.5))", "(1.0, 5.0)"),
}
# how the runs differ: whether jams are settled by turns, and how much people keep right
SETTINGS = (("turns", True, 0.0), ("turns, keeping right", True, 1.0),
            ("social force alone", False, 0.0))


def scenario(map_name: str, east: int, west: int, keep_right: float) -> str:
    path, east_area, east_target, west_area, west_target = MAPS[map_name]
    walk = f"{{ social_force.oncoming_side_preference {keep_right} }}"
    return (f'scenario "two flows through one narrow place"\nmap "{path}"\ntime_limit 5 min\n'
            f"flow east from {east_area} to {east_target} rate {east} /min for 1 min {walk}\n"
            f"flow west from {west_area} to {west_target} rate {west} /min for 1 min {walk}\n")


@contextmanager
def without_turns() -> Iterator[None]:
    """The social force alone: no jam is ever settled."""
    look = RightOfWay.look
    RightOfWay.look = lambda self, rows: None  # type: ignore[method-assign]
    try:
        yield
    finally:
        RightOfWay.look = look  # type: ignore[method-assign]


def outcome(text: str, folder: Path, seed: int) -> tuple[int, int, list[float]]:
    """People who came, those not through (given up, or walking still), walks of the rest."""
    file = folder / "two_way.hub"
    file.write_text(text, encoding="utf-8")
    result = simulate(compile_file(file), seed=seed)
    started = {e.human: e.time for e in result.events if e.status.name == "ACTIVE"}
    arrived = {e.human: e.time for e in result.events if e.status.name == "SUCCEEDED"}
    walks = [arrived[name] - started[name] for name in arrived]
    return len(started), len(started) - len(arrived), walks


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seeds", type=int, default=3, help="seeds per pair of rates")
    seeds = range(1, parser.parse_args(argv).seeds + 1)
    rows: list[tuple[str, str, int, int, float]] = []
    with tempfile.TemporaryDirectory() as folder:
        for label, turns, keep_right in SETTINGS:
            for map_name in MAPS:
                came = lost = 0
                walks: list[float] = []
                for east, west in RATES:
                    for seed in seeds:
                        with nullcontext() if turns else without_turns():
                            counts = outcome(scenario(map_name, east, west, keep_right),
                                             Path(folder), seed)
                        came, lost = came + counts[0], lost + counts[1]
                        walks += counts[2]
                rows.append((label, map_name, came, lost, sum(walks) / max(len(walks), 1)))
    print(f"{'':20} {'map':14} {'came':>5} {'not through':>12} {'mean walk':>10}")
    for label, map_name, came, lost, walk in rows:
        print(f"{label:20} {map_name:14} {came:5d} {lost:6d} ({lost / came:4.0%}) {walk:8.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
