"""Cost-to-go fields searched on a region around start and goal are exact where they answer.

A first plan to a goal searches only the region that proves the start's path optimal; its field
must give the start the optimal cost (that of the whole component's field), keep only cells whose
values are exact, and still lead along an optimal path when the best way is a long detour.
"""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import numpy as np
import pytest

from hubero_dsl.planners import costfield
from hubero_dsl.planners.costfield import CostKey, build_cost_grid

RES = 0.05
PARKING = Path(__file__).resolve().parents[2] / ".." / "shared" / "maps" / "hubero-original" / \
    "parking.yaml"
PARKING_STARTS = [(-5.0, -6.0), (-4.0, -1.8), (-2.0, 0.0), (1.5, 2.0)]    # the paper's
PARKING_GOALS = [(0.5, 6.6), (0.3, 18.8), (7.0, 2.9), (1.2, -5.7), (-3.5, 10.5), (-0.5, 14.8)]


def maze(seed: int) -> np.ndarray:
    """A 120 x 160 cell room with random walls, some with doors, and pillars."""
    rng = np.random.default_rng(seed)
    occupied = np.zeros((120, 160), dtype=bool)
    for _ in range(4):
        col = int(rng.integers(20, 140))
        occupied[:, col:col + 3] = True
        door = int(rng.integers(5, 100))
        occupied[door:door + 15, col:col + 3] = False
    for _ in range(12):
        r, c = rng.integers(0, 115), rng.integers(0, 155)
        occupied[r:r + 5, c:c + 5] = True
    return occupied


def clearance_of(occupied: np.ndarray) -> np.ndarray:
    from scipy import ndimage

    padded = np.pad(occupied, 1, constant_values=True)
    return ndimage.distance_transform_edt(~padded, sampling=RES)[1:-1, 1:-1]


def free_cells(labels: np.ndarray, label: int, count: int, seed: int) -> list[tuple[int, int]]:
    cells = np.argwhere(labels == label)
    picks = np.random.default_rng(seed).choice(len(cells), size=count, replace=False)
    return [(int(r), int(c)) for r, c in cells[picks]]


@pytest.mark.parametrize("seed", range(4))
@pytest.mark.parametrize("comfort", [0.2, 0.6])
def test_bounded_fields_agree_with_the_whole_field_where_they_answer(seed: int,
                                                                      comfort: float) -> None:
    grid = build_cost_grid(clearance_of(maze(seed)), RES, CostKey.of(0.15, comfort), 40.0)
    label = int(np.bincount(grid.labels.ravel())[1:].argmax()) + 1
    search = grid.search(label)
    cells = free_cells(grid.labels, label, 12, seed)
    for goal, start in zip(cells[::2], cells[1::2], strict=True):
        whole = search.solve(goal)
        bounded = search.solve_between(goal, start)
        assert bounded.value(start) == whole.value(start)
        # every value the bounded field keeps is the exact one
        local = bounded.cost
        rows = slice(bounded.offset[0] - whole.offset[0],
                     bounded.offset[0] - whole.offset[0] + local.shape[0])
        cols = slice(bounded.offset[1] - whole.offset[1],
                     bounded.offset[1] - whole.offset[1] + local.shape[1])
        kept = np.isfinite(local)
        np.testing.assert_array_equal(local[kept], whole.cost[rows, cols][kept])
        # the start's path descends to the goal through kept cells, each step downhill
        path = bounded.descend(start)
        assert tuple(path[0]) == start and tuple(path[-1]) == goal
        values = [bounded.value((int(r), int(c))) for r, c in path]
        assert all(math.isfinite(v) for v in values)
        assert all(a > b for a, b in itertools.pairwise(values))


def test_a_long_detour_is_found_through_a_small_first_region() -> None:
    occupied = np.zeros((100, 200), dtype=bool)
    occupied[:90, 98:102] = True           # a wall with its only opening far from the line
    grid = build_cost_grid(clearance_of(occupied), RES, CostKey.of(0.1, 0.1), 40.0)
    search = grid.search(int(grid.labels[10, 50]))
    start, goal = (10, 50), (10, 150)
    bounded = search.solve_between(goal, start)
    assert bounded.value(start) == search.solve(goal).value(start)
    assert bounded.value(start) > 1.8 * math.dist(start, goal)   # it really goes round
    assert max(row for row, _ in bounded.descend(start)) >= 90   # through the opening


def test_whole_fields_stay_whole_after_searches_that_stopped_early() -> None:
    grid = build_cost_grid(clearance_of(maze(5)), RES, CostKey.of(0.15, 0.4), 40.0)
    label = int(np.bincount(grid.labels.ravel())[1:].argmax()) + 1
    cells = free_cells(grid.labels, label, 8, 5)
    reused = grid.search(label)
    for goal, start in zip(cells[::2], cells[1::2], strict=True):
        reused.solve(goal, start)                  # stops early
        whole = reused.solve(goal)
        fresh = build_cost_grid(clearance_of(maze(5)), RES, CostKey.of(0.15, 0.4), 40.0) \
            .search(label).solve(goal)
        np.testing.assert_array_equal(whole.cost, fresh.cost)
        assert np.isfinite(whole.cost).sum() == (grid.labels == label).sum()


def test_a_narrow_passage_far_from_the_line_is_searched_to_its_optimum() -> None:
    occupied = np.zeros((120, 160), dtype=bool)
    occupied[:, 78:82] = True
    occupied[104:112, 78:82] = False        # a door just wide enough, near the far edge
    grid = build_cost_grid(clearance_of(occupied), RES, CostKey.of(0.15, 0.3), 40.0)
    start, goal = (20, 30), (20, 130)
    assert grid.labels[start] == grid.labels[goal]
    search = grid.search(int(grid.labels[start]))
    bounded = search.solve_between(goal, start)
    assert bounded.value(start) == search.solve(goal).value(start)
    assert max(row for row, _ in bounded.descend(start)) >= 104     # through the door


def test_disconnected_components_are_searched_apart() -> None:
    occupied = np.zeros((80, 120), dtype=bool)
    occupied[:, 58:62] = True                # a wall without a door
    grid = build_cost_grid(clearance_of(occupied), RES, CostKey.of(0.15, 0.3), 40.0)
    left, right = (40, 20), (40, 100)
    assert grid.labels[left] != grid.labels[right]
    for goal, start in ((left, (10, 40)), (right, (70, 80))):
        search = grid.search(int(grid.labels[goal]))
        bounded = search.solve_between(goal, start)
        assert bounded.value(start) == search.solve(goal).value(start)
        # the field never reaches across the wall
        assert not np.isfinite(bounded.value(right if goal == left else left))


def test_straight_open_paths_keep_their_own_cells_despite_ties(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """A path costing exactly the bound ties with it; rounding must not drop its cells."""
    monkeypatch.setattr(costfield, "_FIRST_BOUND", 1.0)    # the bound is the octile distance
    monkeypatch.setattr(costfield, "_BOUND_SLACK", 0.0)
    grid = build_cost_grid(clearance_of(np.zeros((100, 100), dtype=bool)), RES,
                           CostKey.of(0.1, 0.1), 40.0)
    search = grid.search(int(grid.labels[50, 50]))
    for start, goal in (((20, 20), (80, 80)), ((20, 30), (80, 50)), ((50, 10), (50, 90))):
        bounded = search.solve_between(goal, start)
        assert bounded.value(start) == search.solve(goal).value(start)
        path = bounded.descend(start)
        assert all(bounded.covers((int(r), int(c))) for r, c in path)


@pytest.mark.skipif(not PARKING.is_file(), reason="shared maps are absent")
@pytest.mark.parametrize("comfort", [0.125, 0.7])
def test_parking_plans_cost_what_the_whole_field_says(comfort: float) -> None:
    """The paper's starts and goals on the parking map: each first-plan search finds the
    optimal cost of the whole component's Dijkstra field."""
    from hubero_dsl.world.mapfile import load_map

    occupancy = load_map(PARKING)
    grid = build_cost_grid(np.asarray(occupancy.clearance, dtype=np.float64),
                           occupancy.resolution, CostKey.of(0.2, comfort), 40.0)

    def cell(xy: tuple[float, float]) -> tuple[int, int]:
        row, col = occupancy.world_to_cell(xy)
        return int(row), int(col)

    for goal_xy in PARKING_GOALS:
        goal = cell(goal_xy)
        search = grid.search(int(grid.labels[goal]))
        whole = search.solve(goal)
        for start in map(cell, PARKING_STARTS):
            assert search.solve_between(goal, start).value(start) == whole.value(start)


# ---- corridors: far plans, and near ones that bend, search along a coarse path ------------

PROJECT_PARKING = Path(__file__).resolve().parents[2] / "maps" / "parking.yaml"
LIVING_ROOM = PROJECT_PARKING.with_name("living_room.yaml")


def parking_grid(comfort: float) -> costfield.CostGrid:
    from hubero_dsl.world.mapfile import load_map

    occupancy = load_map(PROJECT_PARKING)
    return build_cost_grid(np.asarray(occupancy.clearance, dtype=np.float64),
                           occupancy.resolution, CostKey.of(0.2, comfort), 40.0)


def far_pairs(grid: costfield.CostGrid, count: int, seed: int
              ) -> list[tuple[tuple[int, int], tuple[int, int]]]:
    """Goal and start cells of the largest component, far enough apart for a corridor."""
    label = int(np.bincount(grid.labels.ravel())[1:].argmax()) + 1
    cells = free_cells(grid.labels, label, 6 * count, seed)
    reach = costfield._CORRIDOR_MIN_BLOCKS * grid.block
    pairs = [(goal, start) for goal, start in zip(cells[::2], cells[1::2], strict=True)
             if costfield._octile(goal[0] - start[0], goal[1] - start[1]) >= reach]
    assert len(pairs) >= count
    return pairs[:count]


@pytest.mark.parametrize("comfort", [0.2, 0.5])
def test_far_plans_search_a_corridor_and_come_close_to_the_optimum(comfort: float) -> None:
    grid = parking_grid(comfort)
    assert grid.block == 8    # 0.4 m at 5 cm
    in_corridor = 0
    for goal, start in far_pairs(grid, 12, seed=3):
        search = grid.search(int(grid.labels[goal]))
        optimal = search.solve_between(goal, start)
        corridor = grid.field_between(goal, start)
        # a corridor's field settles fewer cells than the region that proves the optimum (a
        # corridor that holds no way falls back to that region: then the fields are equal)
        settled = np.isfinite(corridor.cost).sum()
        assert settled <= np.isfinite(optimal.cost).sum()
        in_corridor += settled < np.isfinite(optimal.cost).sum()
        assert optimal.value(start) <= corridor.value(start) <= 1.05 * optimal.value(start)
        path = corridor.descend(start)
        assert tuple(path[0]) == start and tuple(path[-1]) == goal
        assert not grid.lethal[path[:, 0], path[:, 1]].any()
        values = [corridor.value((int(r), int(c))) for r, c in path]
        assert all(a > b for a, b in itertools.pairwise(values))
        # without the corridor the plan is the optimal search's
        exact = grid.field_between(goal, start, corridor=False)
        assert exact.value(start) == optimal.value(start)
    assert in_corridor >= 9


def test_near_plans_close_to_the_straight_line_search_the_region_that_proves_them() -> None:
    grid = build_cost_grid(clearance_of(maze(2)), RES, CostKey.of(0.15, 0.4), 40.0)
    label = int(np.bincount(grid.labels.ravel())[1:].argmax()) + 1
    search = grid.search(label)
    reach = costfield._CORRIDOR_MIN_BLOCKS * grid.block
    proven = 0
    for goal, start in zip(*[iter(free_cells(grid.labels, label, 120, 2))] * 2, strict=True):
        if costfield._octile(goal[0] - start[0], goal[1] - start[1]) >= reach:
            continue
        first, _ = search.region_step(goal, start)
        if first is None:
            continue
        proven += 1
        np.testing.assert_array_equal(grid.field_between(goal, start).cost, first.cost)
        assert first.value(start) == search.solve_between(goal, start).value(start)
    assert proven >= 5


@pytest.mark.parametrize("comfort", [0.3, 0.5])
def test_near_plans_round_furniture_search_a_corridor_close_to_the_optimum(comfort: float
                                                                           ) -> None:
    """On the living room (2 cm cells, a block of 20), near plans whose way bends round the
    furniture do not grow the region to the whole room: they search a corridor, whose cost
    is within a hair of the optimum."""
    from hubero_dsl.world.mapfile import load_map

    occupancy = load_map(LIVING_ROOM)
    grid = build_cost_grid(np.asarray(occupancy.clearance, dtype=np.float64),
                           occupancy.resolution, CostKey.of(0.25, comfort), 40.0)
    assert grid.block == 20
    label = int(np.bincount(grid.labels.ravel())[1:].argmax()) + 1
    search = grid.search(label)
    reach = costfield._CORRIDOR_MIN_BLOCKS * grid.block
    detours = in_corridor = 0
    cells = free_cells(grid.labels, label, 400, 4)
    for goal, start in zip(cells[::2], cells[1::2], strict=True):
        if detours == 6:
            break
        if costfield._octile(goal[0] - start[0], goal[1] - start[1]) >= reach or \
                search.region_step(goal, start)[0] is not None:
            continue
        detours += 1
        # the region search resumed from the first search's raised bound is the one from the
        # start (what a corridor with no way falls back to)
        _, raised = search.region_step(goal, start)
        np.testing.assert_array_equal(search.solve_between(goal, start, raised).cost,
                                      search.solve_between(goal, start).cost)
        whole = search.solve(goal)
        found = grid.field_between(goal, start)
        assert whole.value(start) <= found.value(start) <= 1.02 * whole.value(start)
        # a corridor that holds no way falls back to the region search, which may grow to it
        in_corridor += np.isfinite(found.cost).sum() < np.isfinite(whole.cost).sum() / 4
        path = found.descend(start)
        assert tuple(path[0]) == start and tuple(path[-1]) == goal
        assert not grid.lethal[path[:, 0], path[:, 1]].any()
    assert detours == 6 and in_corridor >= 4


def test_a_corridor_through_a_thin_wall_falls_back_to_the_optimal_search() -> None:
    """The coarse grid sees through a wall thinner than a block (its blocks keep the free
    cells on both sides); the corridor then holds no way, and the region search finds the
    door far from the line."""
    occupied = np.zeros((160, 400), dtype=bool)
    occupied[:, 203:205] = True              # two cells thick, inside the blocks 200-207
    occupied[140:160, 203:205] = False       # the only door, near the bottom
    grid = build_cost_grid(clearance_of(occupied), RES, CostKey.of(0.03, 0.03), 40.0)
    start, goal = (20, 20), (20, 380)
    assert grid.labels[start] == grid.labels[goal]
    coarse = grid.coarse()
    wall_blocks = coarse.cost[:, 203 // grid.block]
    assert np.isfinite(wall_blocks[:10]).all()    # the coarse grid walks through the wall
    field = grid.field_between(goal, start)
    assert field.value(start) == grid.search(int(grid.labels[goal])).solve(goal).value(start)
    assert max(row for row, _ in field.descend(start)) >= 140   # through the door


@pytest.mark.parametrize("seed", range(6))
def test_cells_connected_on_the_map_are_connected_on_the_coarse_grid(seed: int) -> None:
    grid = build_cost_grid(clearance_of(maze(seed)), RES, CostKey.of(0.15, 0.3), 40.0)
    coarse, block = grid.coarse(), grid.block
    rows, cols = np.nonzero(grid.labels)
    fine_labels = grid.labels[rows, cols]
    coarse_labels = coarse.labels[rows // block, cols // block]
    assert (coarse_labels > 0).all()
    # every fine component lies in one coarse component
    for label in np.unique(fine_labels):
        assert len(np.unique(coarse_labels[fine_labels == label])) == 1


def test_a_corridor_field_costs_what_mcp_charges_on_the_same_cells() -> None:
    """The corridor is searched as a graph of its cells; every value it gives is MCP's on the
    box with the cells outside the corridor impassable, and its steps lead downhill."""
    from skimage.graph import MCP_Geometric

    grid = parking_grid(0.5)
    for goal, start in far_pairs(grid, 6, seed=5):
        offset, mask = grid._corridor(grid._coarse_path(goal, start), 1)
        field = grid.search(int(grid.labels[goal])).solve_within(goal, start, offset, mask)
        assert field is not None
        window = grid.cost[offset[0]:offset[0] + mask.shape[0],
                           offset[1]:offset[1] + mask.shape[1]]
        mcp = MCP_Geometric(np.where(mask, window, np.inf), fully_connected=True)
        whole, _ = mcp.find_costs([(goal[0] - offset[0], goal[1] - offset[1])])
        reached = np.isfinite(field.cost)
        np.testing.assert_array_equal(reached, np.isfinite(whole))
        np.testing.assert_array_equal(field.cost[reached], whole[reached].astype(np.float32))
        path = field.descend(start)
        assert tuple(path[-1]) == goal
        values = [field.value((int(r), int(c))) for r, c in path]
        assert all(a > b for a, b in itertools.pairwise(values))
