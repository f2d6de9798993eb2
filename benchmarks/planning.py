"""Global planning speed on the HuBeRo parking map: navfn cold and cached, against networkx A*.

Run as `python benchmarks/planning.py`. It plans between the paper's start and goal points
(every start to every goal) for a body of radius 0.2 m and prints one table per comfort radius
(0.125 m: the paper's 0.25 m square personal space; 0.70 m: its large circle), then medians and
ratios. "cold" is a plan to a goal the planner has no field for yet (the cost grid, the coarse
grid of corridor searches and the search are set up, as they are after a run's first plans);
"cached" is the same plan again. The A* baseline is `nx.astar_path` on `nx.grid_2d_graph` of
the cells where the body fits, with a Euclidean heuristic (it ignores comfort). Skips with a
message when the shared maps are absent.
"""

from __future__ import annotations

import math
import statistics
import sys
import time
from collections.abc import Callable
from functools import partial
from pathlib import Path
from typing import TypeVar

import networkx as nx

from hubero_dsl.planners.navfn import NavfnParams, NavfnPlanner
from hubero_dsl.world.grid import OccupancyGrid
from hubero_dsl.world.mapfile import load_map

MAP = Path(__file__).resolve().parents[1] / ".." / "shared" / "maps" / "hubero-original" / \
    "parking.yaml"
STARTS = [(-5.0, -6.0), (-4.0, -1.8), (-2.0, 0.0), (1.5, 2.0)]
GOALS = [(0.5, 6.6), (0.3, 18.8), (7.0, 2.9), (1.2, -5.7), (-3.5, 10.5), (-0.5, 14.8)]
BODY = 0.2
COMFORTS = (0.125, 0.70)
WARM_GOAL = (10.0, 0.0)   # a goal outside the table, planned once to set each planner up

T = TypeVar("T")
Point = tuple[float, float]
Cell = tuple[int, int]


def timed(call: Callable[[], T]) -> tuple[T, float]:
    """The call's result and its duration in milliseconds."""
    began = time.perf_counter()
    result = call()
    return result, (time.perf_counter() - began) * 1e3


def navfn_rows(grid: OccupancyGrid, comfort: float) -> list[tuple[float, float, float]]:
    """(cold ms, cached ms, length m) per (start, goal) pair, each on a freshly set-up planner."""
    rows = []
    for start in STARTS:
        for goal in GOALS:
            planner = NavfnPlanner(grid, NavfnParams())
            planner.cost_to_go(WARM_GOAL, body_radius=BODY, comfort_radius=comfort)
            # a far plan sets up the coarse grid of corridor searches, as a run's first one does
            planner.plan(STARTS[0], WARM_GOAL, body_radius=BODY, comfort_radius=comfort)
            plan_once = partial(planner.plan, start, goal, body_radius=BODY,
                                comfort_radius=comfort)
            plan, cold = timed(plan_once)
            _, cached = timed(plan_once)
            rows.append((cold, cached, plan.length))
    return rows


def navfn_setup(grid: OccupancyGrid, comfort: float) -> tuple[float, float, float]:
    """(first plan of a fresh planner, whole-component field for a new goal, its cached read)."""
    planner = NavfnPlanner(grid, NavfnParams())
    _, first = timed(lambda: planner.plan(STARTS[0], GOALS[0], body_radius=BODY,
                                          comfort_radius=comfort))
    _, whole = timed(lambda: planner.cost_to_go(GOALS[1], body_radius=BODY,
                                                comfort_radius=comfort))
    _, again = timed(lambda: planner.cost_to_go(GOALS[1], body_radius=BODY,
                                                comfort_radius=comfort))
    return first, whole, again


def astar_rows(grid: OccupancyGrid) -> tuple[float, list[tuple[float, float]]]:
    """Graph build ms, and (ms, length m) per pair of networkx A* over the cells the body fits."""
    def build() -> nx.Graph:
        graph = nx.grid_2d_graph(*grid.shape)
        blocked = zip(*(grid.clearance <= BODY).nonzero(), strict=True)
        graph.remove_nodes_from((int(r), int(c)) for r, c in blocked)
        return graph

    graph, build_ms = timed(build)

    def cell(xy: Point) -> Cell:
        row, col = grid.world_to_cell(xy)
        return int(row), int(col)

    def euclid(a: Cell, b: Cell) -> float:
        return math.hypot(a[0] - b[0], a[1] - b[1])

    rows = []
    for start in STARTS:
        for goal in GOALS:
            path, ms = timed(partial(nx.astar_path, graph, cell(start), cell(goal),
                                     heuristic=euclid))
            rows.append((ms, (len(path) - 1) * grid.resolution))
    return build_ms, rows


def main() -> int:
    if not MAP.is_file():
        print(f"skipped: the shared maps are absent ({MAP.resolve()} not found)")
        return 0
    grid, load_ms = timed(lambda: load_map(MAP))
    _, clearance_ms = timed(lambda: grid.clearance)
    rows, cols = grid.shape
    print(f"parking map: {cols} x {rows} cells at {grid.resolution} m; load {load_ms:.0f} ms, "
          f"clearance {clearance_ms:.0f} ms; body radius {BODY} m")
    build_ms, astar = astar_rows(grid)
    astar_median = statistics.median(ms for ms, _ in astar)
    print(f"networkx: grid_2d_graph of the free cells built in {build_ms:.0f} ms "
          f"({grid.shape[0] * grid.shape[1]} cells)")
    for comfort in COMFORTS:
        first, whole, again = navfn_setup(grid, comfort)
        table = navfn_rows(grid, comfort)
        print(f"\ncomfort radius {comfort} m: fresh planner's first plan {first:.1f} ms "
              f"(cost grid, search set-up, field); whole-component field {whole:.1f} ms, "
              f"read from the cache {again:.3f} ms")
        print(f"{'start':>14} {'goal':>14} | {'cold ms':>8} {'cached ms':>9} {'length m':>8} | "
              f"{'A* ms':>8} {'A* m (4-conn.)':>14}")
        pairs = [(s, g) for s in STARTS for g in GOALS]
        for (start, goal), (cold, cached, length), (a_ms, a_len) in zip(pairs, table, astar,
                                                                        strict=True):
            print(f"{start!s:>14} {goal!s:>14} | {cold:8.1f} {cached:9.2f} {length:8.2f} | "
                  f"{a_ms:8.1f} {a_len:14.2f}")
        cold_median = statistics.median(row[0] for row in table)
        cached_median = statistics.median(row[1] for row in table)
        print(f"medians: navfn cold {cold_median:.1f} ms, cached {cached_median:.2f} ms, "
              f"A* {astar_median:.1f} ms")
        print(f"ratios: A*/cold {astar_median / cold_median:.1f}x, "
              f"A*/cached {astar_median / cached_median:.0f}x, "
              f"cold/cached {cold_median / cached_median:.0f}x")
    return 0


if __name__ == "__main__":
    sys.exit(main())
