"""Occupancy grids drawn from polygons: the walkable space of a place given as geometry.

A cell is free when its centre lies in (or on the edge of) the walkable polygon, as
`maps/draw_maps.py` decides for obstacles; everything else is wall. Used where hubero builds a
map in code (the validation corridors) rather than reading a drawn map file.
"""

from __future__ import annotations

import math

import numpy as np
import shapely
from shapely.geometry.base import BaseGeometry

from hubero_dsl.world.grid import OccupancyGrid


def grid_from_walkable(walkable: BaseGeometry, resolution: float = 0.05,
                       margin: float = 0.5, source: str = "<memory>") -> OccupancyGrid:
    """A grid covering `walkable` plus `margin` metres of wall on every side."""
    x0, y0, x1, y1 = walkable.bounds
    origin = (x0 - margin, y0 - margin)
    cols = math.ceil((x1 - x0 + 2 * margin) / resolution)
    rows = math.ceil((y1 - y0 + 2 * margin) / resolution)
    xs = origin[0] + (np.arange(cols) + 0.5) * resolution
    ys = origin[1] + (np.arange(rows) + 0.5) * resolution
    cx, cy = np.meshgrid(xs, ys)  # row 0 is the lowest y, as OccupancyGrid counts rows
    free = shapely.intersects_xy(walkable, cx, cy)
    return OccupancyGrid(occupied=~free, resolution=resolution, origin=origin, source=source)
