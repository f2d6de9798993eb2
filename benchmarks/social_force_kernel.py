"""Throughput of the social force planner: agent-steps per second for crowds of 10 to 3000.

N humans fill a disc at one person per 2 m^2 (a sunflower pattern, so the layout is
deterministic and evenly dense), each walking to the antipode of its start on an open grid, so
every walker crosses the crowded centre. Each timed step is what the engine does per tick:
`velocities()` for every human, then position += velocity * dt and the heading update.

Run: .venv/bin/python benchmarks/social_force_kernel.py [--steps 200] [--sizes 10 100 1000 3000]
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np
from arguments import at_least_one

from hubero_dsl.planners.base import Crowd, Drive
from hubero_dsl.planners.social_force import SocialForceParams, SocialForcePlanner
from hubero_dsl.world.grid import OccupancyGrid
from hubero_dsl.world.shapes import Circle, ShapeArrays

DT = 0.05
AREA_PER_PERSON = 2.0  # m^2
RESOLUTION = 0.1


def sunflower(count: int, radius: float) -> np.ndarray:
    """`count` points spread evenly over a disc (Vogel's spiral)."""
    k = np.arange(count)
    r = radius * np.sqrt((k + 0.5) / count)
    theta = k * math.pi * (3.0 - math.sqrt(5.0))
    return np.column_stack([r * np.cos(theta), r * np.sin(theta)])


def open_grid(half_size: float) -> OccupancyGrid:
    cells = math.ceil(2.0 * half_size / RESOLUTION)
    return OccupancyGrid(np.zeros((cells, cells), dtype=bool), RESOLUTION,
                         (-half_size, -half_size))


class CrossingCrowd:
    """The state of the benchmark crowd and one engine-like step over it."""

    def __init__(self, count: int) -> None:
        radius = math.sqrt(count * AREA_PER_PERSON / math.pi)
        self.position = sunflower(count, radius)
        self.target = -self.position
        self.velocity = np.zeros_like(self.position)
        to_target = self.target - self.position
        self.heading = np.arctan2(to_target[:, 1], to_target[:, 0])
        self.radius = np.full(count, 0.2)
        self.shapes = ShapeArrays.from_shapes([Circle(0.5)] * count)
        self.is_robot = np.zeros(count, dtype=bool)
        ones = np.ones(count)
        self.drive = Drive(np.arange(count), self.target, np.full(count, 1.29),
                           np.full(count, 1.8), np.full(count, 0.54), ones, ones, ones,
                           np.full(count, 3.0), np.full(count, math.radians(200.0)))
        self.planner = SocialForcePlanner(open_grid(radius + 5.0),
                                          [SocialForceParams()] * count)

    def step(self) -> None:
        crowd = Crowd(self.position, self.velocity, self.heading, self.radius, self.shapes,
                      self.is_robot)
        self.velocity = self.planner.velocities(crowd, self.drive, DT)
        self.position = self.position + self.velocity * DT
        speed = np.hypot(self.velocity[:, 0], self.velocity[:, 1])
        self.heading = np.where(speed > 0.05,
                                np.arctan2(self.velocity[:, 1], self.velocity[:, 0]),
                                self.heading)


def measure(count: int, steps: int) -> tuple[float, float]:
    """(agent-steps per second, mean speed at the end) over `steps` timed steps."""
    crowd = CrossingCrowd(count)
    for _ in range(5):  # warm up: caches, the grid's distance field
        crowd.step()
    started = time.perf_counter()
    for _ in range(steps):
        crowd.step()
    elapsed = time.perf_counter() - started
    mean_speed = float(np.hypot(crowd.velocity[:, 0], crowd.velocity[:, 1]).mean())
    return count * steps / elapsed, mean_speed


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=at_least_one, default=200)
    parser.add_argument("--sizes", type=at_least_one, nargs="+", default=[10, 100, 1000, 3000])
    args = parser.parse_args()
    print(f"{'N':>6} {'agent-steps/s':>14} {'us/agent-step':>14} {'mean speed':>11}")
    for count in args.sizes:
        rate, mean_speed = measure(count, args.steps)
        print(f"{count:>6} {rate:>14,.0f} {1e6 / rate:>14.2f} {mean_speed:>9.2f} m/s")


if __name__ == "__main__":
    main()
