"""Maps as ROS 2 users have them: Nav2's example maps load as they are, and nobody walks through
their unknown space."""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
import pytest

from hubero_dsl.pipeline import check_source, compile_source
from hubero_dsl.planners.navfn import NavfnParams, NavfnPlanner
from hubero_dsl.sim.loop import run_program
from hubero_dsl.sim.simulation import Simulation
from hubero_dsl.world.grid import OccupancyGrid
from hubero_dsl.world.mapfile import load_map

NAV2 = Path(__file__).resolve().parent / "nav2_maps"
# name: (cells (rows, cols), resolution, origin), as the YAML files say
FRAMES = {"tb3_sandbox": ((384, 384), 0.05, (-10.0, -10.0)),
          "depot": ((307, 604), 0.05, (0.0, 0.0)),
          "warehouse": (None, 0.03, (-15.1, -25.0))}


@pytest.mark.parametrize("name", sorted(FRAMES))
def test_nav2_maps_load_with_their_frame(name: str) -> None:
    grid = load_map(NAV2 / f"{name}.yaml")
    cells, resolution, origin = FRAMES[name]
    if cells is not None:
        assert grid.shape == cells
    assert grid.resolution == pytest.approx(resolution)
    assert grid.origin == pytest.approx(origin)
    assert 0 < grid.occupied.mean() < 1
    if grid.unknown is not None:
        assert grid.occupied[grid.unknown].all()  # unknown space is never entered


def _far_apart_free_points(grid: OccupancyGrid, radius: float) -> tuple[np.ndarray, np.ndarray]:
    """Two points in the largest region a body fits in, as far apart as its cells go in x."""
    labels = grid.components(radius + 0.05)
    largest = np.bincount(labels[labels > 0]).argmax()
    rows, cols = np.nonzero(labels == largest)
    west, east = np.argmin(cols), np.argmax(cols)
    return (grid.cell_to_world((rows[west], cols[west])),
            grid.cell_to_world((rows[east], cols[east])))


@pytest.mark.parametrize("name", ["tb3_sandbox", "warehouse"])
def test_plans_never_cross_unknown_space(name: str) -> None:
    grid = load_map(NAV2 / f"{name}.yaml")
    assert grid.unknown is not None and grid.unknown.any()
    start, goal = _far_apart_free_points(grid, 0.2)
    plan = NavfnPlanner(grid, NavfnParams()).plan(tuple(start), tuple(goal), body_radius=0.2,
                                                  comfort_radius=0.3)
    waypoints = plan.waypoints
    # every point along the path, sampled finer than a cell, is on known free floor
    steps = [np.linspace(a, b, max(2, int(np.hypot(*(b - a)) / grid.resolution) * 2))
             for a, b in itertools.pairwise(waypoints)]
    along = np.concatenate(steps)
    cells = grid.world_to_cell(along)
    assert not grid.occupied[cells[:, 0], cells[:, 1]].any()
    assert grid.unknown is not None and not grid.unknown[cells[:, 0], cells[:, 1]].any()


def test_a_goal_in_unknown_space_is_an_error() -> None:
    grid = load_map(NAV2 / "tb3_sandbox.yaml")
    assert grid.unknown is not None
    rows, cols = np.nonzero(grid.unknown)
    x, y = grid.cell_to_world((rows[0], cols[0]))
    (sx, sy), _ = grid.nearest_free((0.0, 0.0), 0.3)
    text = (f'scenario "nav2"\nmap "{NAV2 / "tb3_sandbox.yaml"}"\n'
            f"human h at ({sx:.2f}, {sy:.2f})\nactivity {{ h move_to ({x:.2f}, {y:.2f}) }}\n")
    errors = check_source(text, "t.hub").errors
    assert [d.code for d in errors] == ["E403"]
    assert "unknown" in errors[0].message or "obstacle" in errors[0].message


def test_a_scenario_runs_on_the_warehouse() -> None:
    grid = load_map(NAV2 / "warehouse.yaml")
    start, goal = _far_apart_free_points(grid, 0.25)
    middle = start + (goal - start) * 0.1
    (gx, gy), _ = grid.nearest_free(tuple(middle), 0.3)
    text = (f'scenario "warehouse"\nmap "{NAV2 / "warehouse.yaml"}"\ntime_limit 2 min\n'
            f"human h at ({start[0]:.2f}, {start[1]:.2f})\n"
            f"activity {{ h move_to ({gx:.2f}, {gy:.2f}) }}\n"
            f"expect h reaches ({gx:.2f}, {gy:.2f}) within 2 min\n")
    result = run_program(Simulation(compile_source(text, "t.hub")))
    assert result.succeeded, result.reason
