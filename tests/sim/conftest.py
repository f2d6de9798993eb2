"""Small worlds for engine tests: a walled room map written to disk, and scenario builders."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from hubero_dsl.model.program import Program
from hubero_dsl.pipeline import compile_source
from hubero_dsl.world.grid import OccupancyGrid
from hubero_dsl.world.mapfile import save_map

RESOLUTION = 0.05


def room_grid(width: float = 10.0, height: float = 8.0,
              walls: tuple[tuple[float, float, float, float], ...] = ()) -> OccupancyGrid:
    """A room from (0, 0) to (width, height) with a one-cell wall around it and extra walls
    given as (xmin, ymin, xmax, ymax) rectangles."""
    cols, rows = round(width / RESOLUTION), round(height / RESOLUTION)
    occupied = np.zeros((rows, cols), dtype=bool)
    occupied[[0, -1], :] = True
    occupied[:, [0, -1]] = True
    for xmin, ymin, xmax, ymax in walls:
        occupied[round(ymin / RESOLUTION):round(ymax / RESOLUTION),
                 round(xmin / RESOLUTION):round(xmax / RESOLUTION)] = True
    return OccupancyGrid(occupied, RESOLUTION, (0.0, 0.0), "room")


@pytest.fixture
def room_map(tmp_path: Path) -> Path:
    path = tmp_path / "room.yaml"
    save_map(room_grid(), path)
    return path


@pytest.fixture
def walled_map(tmp_path: Path) -> Path:
    """A room split by a wall at x = 5 with no opening: the right half cannot be reached."""
    path = tmp_path / "walled.yaml"
    save_map(room_grid(walls=((4.9, 0.0, 5.1, 8.0),)), path)
    return path


ScenarioFactory = Callable[..., Program]


@pytest.fixture
def scenario(tmp_path: Path, room_map: Path) -> ScenarioFactory:
    """Compile a scenario body (everything after the header) on the room map."""
    def build(body: str, map_path: Path | None = None) -> Program:
        text = f'scenario "test"\nmap "{map_path or room_map}"\n{body}'
        file = tmp_path / "test.hub"
        file.write_text(text, encoding="utf-8")
        return compile_source(text, str(file))
    return build
