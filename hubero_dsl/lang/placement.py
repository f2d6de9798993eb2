"""Checks that need the map: it loads, and every fixed point of the scenario is free on it.

Starts, places, goals, area corners and robot waypoints must lie inside the map and outside
occupied cells; a point in an obstacle is reported with the distance to the nearest free cell.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from hubero_dsl.diagnostics import Diagnostic, Related, Span, error
from hubero_dsl.errors import MapError
from hubero_dsl.lang import ast

if TYPE_CHECKING:
    from hubero_dsl.world.grid import OccupancyGrid


def map_path(source: ast.SourceFile, written: ast.String) -> Path:
    """The map's YAML path: relative paths are relative to the scenario file."""
    path = Path(written.value)
    if path.is_absolute():
        return path
    return Path(source.path).resolve().parent / path


def load_scenario_map(source: ast.SourceFile, written: ast.String,
                      diagnostics: list[Diagnostic]) -> OccupancyGrid | None:
    from hubero_dsl.world.mapfile import load_map

    if "\0" in written.value:  # no file system takes it (and pathlib raises ValueError)
        diagnostics.append(error("E401", "the map path contains a NUL character", written.span))
        return None
    # Loaded by the path as written next to the scenario's own path, not the resolved one, so
    # that messages name the files as the user sees them (and do not depend on the machine).
    path = Path(written.value)
    if not path.is_absolute():
        path = Path(source.path).parent / path
    try:
        return load_map(path)
    except MapError as exc:
        related = (Related("in the map file", exc.span),) if exc.span is not None else ()
        diagnostics.append(error("E401", f"the map cannot be loaded: {exc.message}",
                                 written.span, exc.hint or "the map is a ROS map_server YAML "
                                 "file with an `image:` next to it", related))
        return None


def check_positions(grid: OccupancyGrid, positions: list[tuple[str, tuple[float, float], Span]],
                    diagnostics: list[Diagnostic]) -> None:
    """Every fixed point must be inside the map and in a free cell."""
    xmin, ymin, xmax, ymax = grid.bounds
    for what, (x, y), span in positions:
        if not bool(grid.contains((x, y))):
            diagnostics.append(error(
                "E402", f"{what} ({x:g}, {y:g}) is outside the map", span,
                f"the map spans x {xmin:g} .. {xmax:g} m, y {ymin:g} .. {ymax:g} m"))
        elif not bool(grid.is_free((x, y))):
            (fx, fy), distance = grid.nearest_free((x, y))
            diagnostics.append(error(
                "E403", f"{what} ({x:g}, {y:g}) is inside an obstacle", span,
                f"the nearest free cell is {distance:.2f} m away, at ({fx:.2f}, {fy:.2f})"))
