"""A picture of a map: free, occupied and unknown space on metric axes, and what a scenario puts
on it (places, areas, where humans and robots start, flows' areas and targets).

    show_map("maps/station.yaml", "station.png", program=compile_file("scenarios/station.hub"))

The PNG is written beside its final name and renamed into place. Deterministic: the same map and
scenario give the same bytes (no date in the file).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from hubero_dsl.files import write_replacing
from hubero_dsl.world.mapfile import load_map

if TYPE_CHECKING:
    from hubero_dsl.model.program import HumanSpec, Program
    from hubero_dsl.world.grid import OccupancyGrid

FREE, OCCUPIED, UNKNOWN = (1.0, 1.0, 1.0), (0.0, 0.0, 0.0), (0.62, 0.62, 0.62)
MAX_LABELLED = 60  # humans outside crowds and flows named at their starts; those beyond are dots


def map_colours(grid: OccupancyGrid) -> np.ndarray:
    """(rows, cols, 3) RGB of each cell: white free, black occupied, grey unknown."""
    colours = np.empty((*grid.shape, 3))
    colours[:] = FREE
    colours[grid.occupied] = OCCUPIED
    if grid.unknown is not None:
        colours[grid.unknown] = UNKNOWN
    return colours


def show_map(yaml_path: str | Path, png_path: str | Path, *, program: Program | None = None,
             marks: Mapping[str, tuple[float, float]] | None = None,
             title: str | None = None) -> Path:
    """Draw the map in `yaml_path` (and the scenario `program`, the named `marks`) as a PNG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Patch

    grid = load_map(yaml_path)
    xmin, ymin, xmax, ymax = grid.bounds
    width, height = xmax - xmin, ymax - ymin
    scale = 9.0 / max(width, height)
    figure, axes = plt.subplots(figsize=(max(4.0, width * scale + 1.5),
                                         max(3.5, height * scale + 1.0)), dpi=100)
    axes.imshow(map_colours(grid), origin="lower", extent=(xmin, xmax, ymin, ymax),
                interpolation="nearest")
    legend: list[Any] = [Patch(facecolor=FREE, edgecolor="0.4", label="free"),
                         Patch(facecolor=OCCUPIED, label="occupied")]
    if grid.unknown is not None and grid.unknown.any():
        legend.append(Patch(facecolor=UNKNOWN, label="unknown"))
    if xmin <= 0 <= xmax and ymin <= 0 <= ymax:
        axes.plot(0, 0, "+", color="tab:orange", markersize=12, mew=2)
        legend.append(plt.Line2D([], [], marker="+", color="tab:orange", linestyle="",
                                 markersize=10, mew=2, label="origin (0, 0)"))
    for name, (x, y) in sorted((marks or {}).items()):
        axes.plot(x, y, "o", color="tab:red", markersize=4)
        axes.annotate(name, (x, y), xytext=(3, 3), textcoords="offset points", fontsize=7,
                      color="tab:red")
    if program is not None:
        legend += _scenario(axes, program)
    axes.set_xlabel("x (m)")
    axes.set_ylabel("y (m)")
    axes.set_xlim(xmin, xmax)
    axes.set_ylim(ymin, ymax)
    axes.set_aspect("equal")
    axes.grid(alpha=0.25)
    axes.set_title(title or f"{Path(yaml_path).name}: {grid.shape[1]} x {grid.shape[0]} cells "
                   f"of {grid.resolution:g} m, origin ({grid.origin[0]:g}, {grid.origin[1]:g})",
                   fontsize=9)
    axes.legend(handles=legend, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8)
    return _save(figure, Path(png_path))


def _scenario(axes: Any, program: Program) -> list[Any]:
    """Draw the scenario's areas, places, starts and flows; the legend entries they need."""
    import matplotlib.pyplot as plt

    for name, polygon in sorted(program.areas.items()):
        x, y = polygon.exterior.xy
        axes.fill(x, y, color="tab:blue", alpha=0.12)
        axes.plot(x, y, color="tab:blue", linewidth=1)
        centre = polygon.representative_point()
        axes.annotate(name, (centre.x, centre.y), fontsize=7, color="tab:blue", ha="center",
                      bbox=_LABEL_BOX)  # readable over the obstacles inside the area too
    for name, pose in sorted(program.places.items()):
        axes.plot(pose.x, pose.y, "D", color="tab:purple", markersize=4)
        axes.annotate(name, pose.xy, xytext=(3, 3), textcoords="offset points", fontsize=7,
                      color="tab:purple")
    members = {m for flow in program.flows for m in flow.members}
    starts = [h for h in program.humans if h.name not in members]
    for human in starts:
        axes.plot(human.start.x, human.start.y, "o", color="tab:green", markersize=4)
    for human in [h for h in starts if h.group is None][:MAX_LABELLED]:
        axes.annotate(human.name, human.start.xy, xytext=(3, -8), textcoords="offset points",
                      fontsize=7, color="tab:green")
    _label_crowds(axes, [h for h in starts if h.group is not None])
    for robot in program.robots:
        axes.plot(robot.start.x, robot.start.y, "s", color="tab:brown", markersize=6)
        axes.annotate(robot.name, robot.start.xy, xytext=(3, -8), textcoords="offset points",
                      fontsize=7, color="tab:brown")
    for flow in program.flows:
        x, y = flow.area.exterior.xy
        axes.plot(x, y, color="tab:olive", linewidth=1.5, linestyle="--")
        axes.annotate(f"{flow.name} ->", (min(x), max(y)), fontsize=7, color="tab:olive")
        axes.plot(*flow.target, "*", color="tab:olive", markersize=10)
    entry = lambda marker, colour, label: plt.Line2D(  # noqa: E731
        [], [], marker=marker, color=colour, linestyle="", label=label)
    # only what the picture shows: a legend listing robots and flows a scenario has not
    # has the reader look for them
    shown = [(program.places, entry("D", "tab:purple", "place")),
             (program.areas, entry("s", "tab:blue", "area")),
             (starts, entry("o", "tab:green", "human start")),
             (program.robots, entry("s", "tab:brown", "robot start")),
             (program.flows, entry("*", "tab:olive", "flow target (area dashed)"))]
    return [handle for drawn, handle in shown if drawn]


_LABEL_BOX = {"boxstyle": "round,pad=0.15", "facecolor": "white", "edgecolor": "none",
              "alpha": 0.7}


def _label_crowds(axes: Any, members: list[HumanSpec]) -> None:
    """Each crowd's name and size once, at the member nearest the crowd's middle: a name per
    member would cover the picture, and none left the reader to guess whose starts they are."""
    crowds: dict[str, list[HumanSpec]] = {}
    for member in members:
        crowds.setdefault(cast(str, member.group), []).append(member)
    for name, people in crowds.items():
        starts = np.array([person.start.xy for person in people])
        middle = starts[np.argmin(np.hypot(*(starts - starts.mean(axis=0)).T))]
        axes.annotate(f"{name} ({len(people)})", tuple(middle), xytext=(3, -8),
                      textcoords="offset points", fontsize=7, color="tab:green", bbox=_LABEL_BOX)


def _save(figure: Any, path: Path) -> Path:
    """Write the figure to `path` through a temporary file in the same folder."""
    import matplotlib.pyplot as plt

    try:
        return write_replacing(path, lambda temp: figure.savefig(
            temp, bbox_inches="tight", metadata={"Software": None}))
    finally:
        plt.close(figure)
