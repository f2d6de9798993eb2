"""Seeded random places for bodies in an area of the map: where a crowd's members start.

The area's cells where a body of the given radius can stand and walk on are taken in a seeded
random order, and each becomes a place when the body there touches no body already placed.
Only the area's largest connected part counts, so nobody starts in a pocket cut off from the
rest.
"""

from __future__ import annotations

import zlib
from typing import TYPE_CHECKING

import numpy as np

from hubero_dsl.world.grid import REACH_MARGIN

if TYPE_CHECKING:
    from shapely.geometry import Polygon

    from hubero_dsl.world.grid import OccupancyGrid

# A body already placed: x, y, radius.
Body = tuple[float, float, float]


def crowd_places(grid: OccupancyGrid, crowd: str, count: int, area: Polygon, radius: float,
                 taken: list[Body], seed: int) -> list[tuple[float, float]]:
    """Up to `count` places in `area` for the bodies of `radius` of the crowd named `crowd`,
    drawn from `seed` (each crowd its own stream), clear of the obstacles and of every body in
    `taken` (which each new place extends); fewer when no more fit."""
    rng = np.random.default_rng([seed, zlib.crc32(f"crowd {crowd}".encode())])
    labels = grid.components(radius + REACH_MARGIN)  # where it may wander, not just fit
    rows, cols, candidates = grid.cells_in(area, labels)
    inside_labels = labels[rows, cols]
    if len(inside_labels):  # the area's largest connected part: no start in a cut-off pocket
        candidates = candidates[inside_labels == np.bincount(inside_labels).argmax()]
    order = rng.permutation(len(candidates))
    # bodies in a grid of buckets one largest diameter wide: a new body can only touch those
    # in its own bucket and the eight around it
    cell = 2.0 * max([radius, *(r for _, _, r in taken)])
    buckets: dict[tuple[int, int], list[Body]] = {}
    for x, y, r in taken:
        buckets.setdefault((int(x // cell), int(y // cell)), []).append((x, y, r))
    placed: list[tuple[float, float]] = []
    for index in order:
        x, y = float(candidates[index, 0]), float(candidates[index, 1])
        key = (int(x // cell), int(y // cell))
        near = (b for dx in (-1, 0, 1) for dy in (-1, 0, 1)
                for b in buckets.get((key[0] + dx, key[1] + dy), ()))
        if all((x - bx) ** 2 + (y - by) ** 2 >= (radius + br) ** 2 for bx, by, br in near):
            placed.append((x, y))
            buckets.setdefault(key, []).append((x, y, radius))
            taken.append((x, y, radius))
            if len(placed) == count:
                break
    return placed
