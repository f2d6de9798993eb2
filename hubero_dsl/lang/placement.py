"""Checks that need the map: it loads, and every fixed point of the scenario is free on it.

Starts, places, goals, area corners and robot waypoints must lie inside the map and outside
occupied cells; a point in an obstacle is reported with the distance to the nearest free cell.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from hubero_dsl.diagnostics import Diagnostic, Related, Span, error, warning
from hubero_dsl.errors import MapError
from hubero_dsl.lang import ast
from hubero_dsl.world.scatter import crowd_places

if TYPE_CHECKING:
    from shapely.geometry import Polygon

    from hubero_dsl.model.program import RobotSpec
    from hubero_dsl.world.grid import FloatArray, IntArray, OccupancyGrid


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


OVERLAP_SLACK = 0.01  # m: bodies written a centimetre too close to each other only touch
OVERLAP_REPORTS = 10  # pairs of overlapping bodies named one by one


def check_bodies(grid: OccupancyGrid,
                 bodies: list[tuple[str, tuple[float, float], float, Span]],
                 diagnostics: list[Diagnostic], origins: Mapping[str, str] | None = None
                 ) -> bool:
    """Every body must fit where it starts and where it is sent: its whole radius clear of
    obstacles, as the planners require (points outside the map or in an obstacle are reported
    by `check_positions`). `origins`: where a body's radius comes from, by its words (a
    variant's), said after the radius. Whether every body stands on free space and fits."""
    from hubero_dsl.errors import MapError

    all_fit = True
    # each body judged from the cells around it, while those are fewer than the map's: for
    # more, the map's distance field, built once, costs less
    reach = math.ceil(max((b[2] for b in bodies), default=0.0) / grid.resolution)
    by_window = len(bodies) * (2 * reach + 3) ** 2 < grid.occupied.size
    for what, (x, y), radius, span in bodies:
        if not (bool(grid.contains((x, y))) and bool(grid.is_free((x, y)))):
            all_fit = False
            continue
        if by_window and grid.body_fits((x, y), radius):
            continue
        try:
            (fx, fy), distance = grid.nearest_free((x, y), radius)
        except MapError:
            diagnostics.append(error("E405", f"no place on the map fits a body of radius "
                                     f"{radius:g} m ({what})", span))
            all_fit = False
            continue
        if distance > 0:
            all_fit = False
            # the clearance that decided: its cell's centre's (between cells' centres, the
            # point's own could read more than the radius, beside "does not fit")
            row, col = (int(i) for i in grid.world_to_cell((x, y)))
            clearance = float(grid.clearance[row, col])
            origin = (origins or {}).get(what, "")
            diagnostics.append(error(
                "E405", f"{what} ({x:g}, {y:g}) is {clearance:.2f} m from an obstacle at its "
                f"cell's centre; a body of radius {radius:g} m{origin} does not fit", span,
                f"the nearest point where it fits is {distance:.2f} m away, at "
                f"({fx:.2f}, {fy:.2f})"))
    return all_fit


def check_overlapping_starts(starts: list[tuple[str, tuple[float, float], float, Span]],
                             diagnostics: list[Diagnostic]) -> None:
    """W504: two humans or robots placed so that their bodies overlap (by more than
    OVERLAP_SLACK): the run's first tick pushes them apart, and a metric counts a collision at
    t = 0 that the scenario wrote, not the people did. Each body is judged against its nearest
    neighbour, and the first OVERLAP_REPORTS pairs are named, the rest counted."""
    if len(starts) < 2:
        return
    radii = np.array([radius for _, _, radius, _ in starts])
    apart, other = _nearest_others(np.array([xy for _, xy, _, _ in starts]))
    close = np.flatnonzero(apart < radii + radii[other] - OVERLAP_SLACK)
    pairs = sorted({(min(i, j), max(i, j)) for i, j in zip(close.tolist(),
                                                          other[close].tolist(), strict=True)})
    for i, j in pairs[:OVERLAP_REPORTS]:
        (first, a, ra, _), (second, b, rb, span) = starts[i], starts[j]
        diagnostics.append(warning(
            "W504", f"{second} overlaps {first}: {math.dist(a, b):.2f} m apart, where their "
            f"bodies need {ra + rb:.2f} m", span, "move one of them away from the other"))
    if len(pairs) > OVERLAP_REPORTS:
        diagnostics.append(warning(
            "W504", f"{len(pairs) - OVERLAP_REPORTS} more pairs of bodies overlap where they "
            "are placed", starts[pairs[OVERLAP_REPORTS][1]][3]))


PAIRWISE_AT_MOST = 1000  # bodies whose distances are all taken; beyond, a k-d tree's


def _nearest_others(centres: FloatArray) -> tuple[FloatArray, IntArray]:
    """Each body's distance to its nearest other body, and that body's index. Every distance,
    for the few bodies of most scenarios: importing scipy.spatial would cost a cold `hubero
    check` more than that. A k-d tree for more: thousands of people on one spot cost no more
    than spread out."""
    count = len(centres)
    if count <= PAIRWISE_AT_MOST:
        offsets = centres[:, None, :] - centres[None, :, :]
        gaps = np.hypot(offsets[..., 0], offsets[..., 1])
        np.fill_diagonal(gaps, np.inf)
        other = gaps.argmin(axis=1)
        return gaps[np.arange(count), other], other
    from scipy.spatial import cKDTree

    apart, nearest = cKDTree(centres).query(centres, k=2)
    # the nearest other: a body sharing its spot with another may come second to it
    own = nearest[:, 0] == np.arange(count)
    return apart[:, 1], np.where(own, nearest[:, 1], nearest[:, 0])


def check_robot_paths(grid: OccupancyGrid, robots: Sequence[RobotSpec],
                      diagnostics: list[Diagnostic]) -> None:
    """W503: a scripted route along which the robot's body meets an obstacle (the robot would
    stop at it: no body is moved through a wall): its centre line crosses one, or passes
    closer to one than the robot's radius."""
    for robot in robots:
        if not robot.path:
            continue
        stops = [robot.start.xy, *robot.path] + ([robot.path[0]] if robot.loop else [])
        crossed = grid.crosses_obstacle(stops[:-1], stops[1:])
        for (a, b), blocked in zip(itertools.pairwise(stops), crossed,
                                   strict=True):
            room = _narrowest(grid, a, b)
            if blocked or room < robot.radius:
                between = f"between ({a[0]:g}, {a[1]:g}) and ({b[0]:g}, {b[1]:g})"
                what = ("crosses an obstacle" if blocked else
                        f"passes {room:.2f} m from an obstacle, less than its radius "
                        f"{robot.radius:g} m,")
                diagnostics.append(warning(
                    "W503", f"the path of robot '{robot.name}' {what} {between}", robot.span,
                    "the robot stops at the obstacle: add a waypoint around it" if blocked
                    else "its body meets the obstacle there: move the path away from it"))
                break


def _narrowest(grid: OccupancyGrid, a: tuple[float, float], b: tuple[float, float]) -> float:
    """The least clearance along the segment from `a` to `b`, sampled every half a cell, as
    the engine measures whether a body fits (`OccupancyGrid.clearance_at`)."""
    samples = max(2, math.ceil(2 * math.dist(a, b) / grid.resolution) + 1)
    return float(grid.clearance_at(np.linspace(a, b, samples)).min())


def place_crowd(grid: OccupancyGrid, name: str, count: int, area: Polygon, radius: float,
                taken: list[tuple[float, float, float]], seed: int, span: Span,
                diagnostics: list[Diagnostic]) -> list[tuple[float, float]]:
    """Seeded random places in `area` where `count` bodies of `radius` fit, clear of the
    obstacles and of every body already placed (`taken`: x, y, radius; extended here), all in
    the largest part of the area a body can walk through. Fewer than `count` places is error
    E406."""
    placed = crowd_places(grid, name, count, area, radius, taken, seed)
    if len(placed) == count:
        return placed
    diagnostics.append(error("E406", f"only {len(placed)} of the {count} people of crowd "
                             f"'{name}' fit in its area, as bodies of radius {radius:g} m "
                             "(the largest the crowd has in any variant)", span,
                             "make the area larger, or the crowd smaller"))
    return placed


def check_positions(grid: OccupancyGrid, positions: list[tuple[str, tuple[float, float], Span]],
                    diagnostics: list[Diagnostic],
                    bodies: Sequence[tuple[str, tuple[float, float], float, Span]] = ()
                    ) -> None:
    """Every fixed point must be inside the map and in a free cell; for a point where a body
    stands, the suggested free point is one where that body fits."""
    from hubero_dsl.errors import MapError

    xmin, ymin, xmax, ymax = grid.bounds
    radius_at = {span: radius for _, _, radius, span in bodies}
    for what, (x, y), span in positions:
        if not bool(grid.contains((x, y))):
            diagnostics.append(error(
                "E402", f"{what} ({x:g}, {y:g}) is outside the map", span,
                f"the map spans x {xmin:g} .. {xmax:g} m, y {ymin:g} .. {ymax:g} m"))
        elif not bool(grid.is_free((x, y))):
            radius = radius_at.get(span)
            try:
                (fx, fy), distance = grid.nearest_free((x, y), radius or 0.0)
                hint = (f"the nearest point where a body of radius {radius:g} m fits is "
                        if radius else "the nearest free cell is ")
                hint += f"{distance:.2f} m away, at ({fx:.2f}, {fy:.2f})"
            except MapError as exc:
                hint = exc.message
            diagnostics.append(error(
                "E403", f"{what} ({x:g}, {y:g}) is inside an obstacle", span, hint))
