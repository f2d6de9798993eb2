"""A simulation as it stands, drawn top-down into an RGB array (the Gymnasium environment's
`render_mode="rgb_array"`, which `gymnasium.wrappers.RecordVideo` turns into videos).

The map is drawn once, scaled so that its longer side is `size` pixels (free white, occupied
black, unknown grey, as `hubero map` draws it; north up), and each frame copies it and draws
on it with Pillow: every human in the scene as a disc of its body radius, every robot as a disc
with a line to where it faces, and the goal of the robot under test as a ring of its goal
tolerance. A frame costs well under a millisecond beyond the copy; nothing is drawn with
matplotlib, which would cost tens of milliseconds a frame.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt
from PIL import Image, ImageDraw

from hubero_dsl.analysis.mapview import map_colours

if TYPE_CHECKING:
    from hubero_dsl.sim.simulation import Simulation
    from hubero_dsl.world.grid import OccupancyGrid

HUMAN = (31, 119, 180)       # matplotlib's default colours: blue, orange, purple, green
ROBOT = (255, 127, 14)
OTHER_ROBOT = (148, 103, 189)
GOAL = (44, 160, 44)
HEADING = (0, 0, 0)
MIN_DISC = 2                 # px: a body is never drawn smaller than this radius
Point = tuple[float, float]


class FrameRenderer:
    """Frames of the simulations on one map, about `size` pixels along the map's longer side
    (each side rounded to an even number)."""

    def __init__(self, grid: OccupancyGrid, size: int = 480) -> None:
        if size < 16:
            raise ValueError(f"a frame is at least 16 pixels wide, not {size}")
        rows, cols = grid.shape
        self.scale = size / (max(rows, cols) * grid.resolution)   # pixels per metre
        # even sides: video encoders (H.264 in yuv420p, as RecordVideo writes) need them
        self.width = max(2, 2 * round(cols * grid.resolution * self.scale / 2))
        self.height = max(2, 2 * round(rows * grid.resolution * self.scale / 2))
        self._origin = grid.origin
        colours = (map_colours(grid)[::-1] * 255).round().astype(np.uint8)  # north up
        self._background = Image.fromarray(colours).resize(
            (self.width, self.height), Image.Resampling.BOX)

    def pixel(self, point: Point) -> Point:
        """Where a world point lies in the frame (x right, y down), in pixels."""
        return ((point[0] - self._origin[0]) * self.scale,
                self.height - (point[1] - self._origin[1]) * self.scale)

    def draw(self, sim: Simulation, robot: str | None = None, goal: Point | None = None,
             goal_tolerance: float = 0.0) -> npt.NDArray[np.uint8]:
        """(height, width, 3) uint8: `sim` now, `robot` (the one under test) in its own colour
        and `goal` as a ring of `goal_tolerance`."""
        image = self._background.copy()
        pen = ImageDraw.Draw(image)
        if goal is not None:
            self._ring(pen, goal, max(goal_tolerance, 0.1), GOAL)
        humans = sim.engine.humans
        present = humans.present
        for row, (x, y) in enumerate(humans.position.tolist()):
            if present is None or present[row]:
                self._disc(pen, (x, y), float(humans.radius[row]), HUMAN)
        robots = sim.engine.robots
        for name, (x, y), radius, heading in zip(robots.names, robots.position.tolist(),
                                                 robots.radius.tolist(),
                                                 robots.heading.tolist(), strict=True):
            self._disc(pen, (x, y), radius, ROBOT if name == robot else OTHER_ROBOT)
            tip = (x + radius * math.cos(heading), y + radius * math.sin(heading))
            pen.line([self.pixel((x, y)), self.pixel(tip)], fill=HEADING,
                     width=max(1, round(self.scale * 0.05)))
        return np.asarray(image)

    def _disc(self, pen: ImageDraw.ImageDraw, centre: Point, radius: float,
              colour: tuple[int, int, int]) -> None:
        (u, v), r = self.pixel(centre), max(radius * self.scale, MIN_DISC)
        pen.ellipse([u - r, v - r, u + r, v + r], fill=colour)

    def _ring(self, pen: ImageDraw.ImageDraw, centre: Point, radius: float,
              colour: tuple[int, int, int]) -> None:
        (u, v), r = self.pixel(centre), max(radius * self.scale, MIN_DISC)
        pen.ellipse([u - r, v - r, u + r, v + r], outline=colour,
                    width=max(1, round(self.scale * 0.05)))
