"""Pictures of runs, drawn with matplotlib's Agg canvas (no display, no pyplot state).

    plot_run(load_run("run.mcap"), "run.png")          # map, paths, starts, goals, personal spaces
    plot_overlay(run_a, run_b, "diff.png", epsilon=0.1)  # two runs of a scenario on one map

The map is drawn in grey (free space white, obstacles grey, unknown cells light grey). Every
human gets one colour; its personal space is drawn in its own shape and heading at points spaced
`spacing` metres apart along its path (as in the HuBeRo paper's figures), plus where it starts
and a star wherever one of its navigation tasks (move_to, run_to, sit_down, lie_down)
succeeded; one whose navigation never succeeded (cut off by the time limit, aborted, or it
only stood) gets a diamond where it ended instead, so that no star claims a goal not reached.
The members of a crowd or flow share their crowd's colour and one legend entry, with thin paths
and no personal spaces, so that a picture of a thousand people stays readable. Robots' paths
are dotted, each robot in a dark colour of its own, a cross at its declared goal. The view is
the region the actors used (and the robots' goals), with a margin, unless `whole_map` is asked
for.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Polygon

from hubero_dsl.errors import InputError
from hubero_dsl.files import write_replacing
from hubero_dsl.model.tasks import TASKS
from hubero_dsl.sim.status import TaskStatus
from hubero_dsl.world.personal_space import outline
from hubero_dsl.world.shapes import Circle, Ellipse, Rectangle, Shape

if TYPE_CHECKING:
    from hubero_dsl.log.reader import HumanTrack, LoggedRun
    from hubero_dsl.world.grid import OccupancyGrid

FloatArray = npt.NDArray[np.float64]

DPI = 120
MAP_INCHES = (8.0, 9.0)  # the largest the map is drawn (width, height)
LEGEND_INCHES = 2.6      # the narrowest column to the right of the map for the legend
LEGEND_FONT = 9
_LEGEND_CHAR_INCHES = 0.62 * LEGEND_FONT / 72  # a generous average advance of DejaVu Sans
_LEGEND_HANDLE_INCHES = 0.75                  # the line sample, its padding and the frame
_LEGEND_ROW_INCHES = 1.7 * LEGEND_FONT / 72    # a row: its text and the 0.8 em between rows
_LEGEND_FRAME_INCHES = 0.25                    # the frame's padding, above and below
_LEGEND_FOOT_INCHES = 0.2                      # below the legend, to the figure's edge
MARGIN = 1.5        # metres of map shown around what the actors used
SPACING = 1.5       # metres along a path between two drawn personal spaces
FREE, OCCUPIED, UNKNOWN = 1.0, 0.55, 0.82  # grey levels of the map
# a robot's path: dotted; a comparison's second run's, dash-dotted
ROBOT_LINE: Any = ":"
ROBOT_LINE_B: Any = (0, (4, 2, 1, 2))
_NAVIGATION = tuple(kind.name for kind in TASKS.values() if kind.marks_goal)


def colours(names: Sequence[str]) -> dict[str, Any]:
    """One distinct colour per human, in sorted-name order, the same in every picture."""
    from matplotlib import colormaps

    palette = colormaps["tab10"](np.arange(10))
    return {name: palette[i % len(palette)] for i, name in enumerate(sorted(names))}


@dataclass(frozen=True)
class View:
    """The map rectangle shown: (xmin, xmax, ymin, ymax) in metres."""

    x0: float
    x1: float
    y0: float
    y1: float

    @staticmethod
    def around(runs: Sequence[LoggedRun], whole_map: bool, margin: float = MARGIN) -> View:
        bx0, by0, bx1, by1 = runs[0].grid.bounds
        points = [position for run in runs for position in _positions(run) if len(position)]
        if whole_map or not points:
            return View(bx0, bx1, by0, by1)
        low, high = np.vstack(points).min(axis=0), np.vstack(points).max(axis=0)
        return View(max(bx0, low[0] - margin), min(bx1, high[0] + margin),
                    max(by0, low[1] - margin), min(by1, high[1] + margin))

    def figure(self, legend: Sequence[str] | None = ()) -> tuple[Figure, Axes]:
        """A figure sized to the view, so the map keeps equal aspect with no blank bands, and a
        column on the right wide enough for the legend's labels (None: no legend)."""
        width, height = max(self.x1 - self.x0, 1e-3), max(self.y1 - self.y0, 1e-3)
        scale = min(MAP_INCHES[0] / width, MAP_INCHES[1] / height)
        map_w, map_h = width * scale, height * scale
        left, right, bottom, top = 0.8, 0.25, 0.6, 0.45
        extra = 0.0 if legend is None else legend_inches(legend)
        # tall enough for the legend, which hangs from the map's top edge: a long, narrow
        # map (a corridor) left its lower entries cut off
        tall = 0.0 if legend is None else legend_height(legend) + _LEGEND_FOOT_INCHES
        fig_w, fig_h = left + map_w + right + extra, max(bottom + map_h, tall) + top
        figure = Figure(figsize=(fig_w, fig_h), dpi=DPI)
        axes = figure.add_axes((left / fig_w, (fig_h - top - map_h) / fig_h, map_w / fig_w,
                                map_h / fig_h))
        axes.set_xlim(self.x0, self.x1)
        axes.set_ylim(self.y0, self.y1)
        axes.set_aspect("equal", adjustable="box")
        axes.set_xlabel("x [m]")
        axes.set_ylabel("y [m]")
        return figure, axes


def legend_inches(labels: Sequence[str]) -> float:
    longest = max((len(label) for label in labels), default=0)
    return max(LEGEND_INCHES, _LEGEND_HANDLE_INCHES + longest * _LEGEND_CHAR_INCHES)


def legend_height(labels: Sequence[str]) -> float:
    """The legend's height (inches): a row per label, `labelspacing` apart, and its frame."""
    return _LEGEND_FRAME_INCHES + len(labels) * _LEGEND_ROW_INCHES


def _positions(run: LoggedRun) -> list[FloatArray]:
    return ([track.position for track in run.humans.values()]
            + [track.position for track in run.robots.values()]
            + [np.array([goal]) for goal in robot_goals(run).values()])


def robot_goals(run: LoggedRun) -> dict[str, tuple[float, float]]:
    """Each robot's declared goal, by name (robots without one left out)."""
    goals = {name: run.metadata.robot_goal(name)[0] for name in run.robots}
    return {name: goal for name, goal in goals.items() if goal is not None}


def draw_map(axes: Axes, grid: OccupancyGrid) -> None:
    shade = np.where(grid.occupied, OCCUPIED, FREE)
    if grid.unknown is not None:
        shade = np.where(grid.unknown, UNKNOWN, shade)
    x0, y0, x1, y1 = grid.bounds
    axes.imshow(shade, cmap="gray", vmin=0.0, vmax=1.0, origin="lower",
                extent=(x0, x1, y0, y1), interpolation="nearest", zorder=0)


def personal_space_of(run: LoggedRun, name: str) -> Shape:
    shape = run.metadata.params.get(name, {}).get("personal_space")
    if isinstance(shape, Circle | Ellipse | Rectangle):
        return shape
    radius = run.metadata.params.get(name, {}).get("radius", 0.2)
    return Circle(float(radius) if isinstance(radius, int | float) else 0.2)


def spaced_frames(position: FloatArray, spacing: float) -> npt.NDArray[np.intp]:
    """Frames about `spacing` metres apart along the path, with the first and the last."""
    if len(position) == 0:
        return np.zeros(0, dtype=np.intp)
    steps = np.linalg.norm(np.diff(position, axis=0), axis=1)
    travelled = np.concatenate([[0.0], np.cumsum(steps)])
    if travelled[-1] >= spacing * len(position):  # marks closer than the frames: every frame
        return np.arange(len(position), dtype=np.intp)
    marks = np.arange(0.0, travelled[-1], spacing)
    frames = np.searchsorted(travelled, marks)
    return np.unique(np.concatenate([[0], frames, [len(position) - 1]]).astype(np.intp))


def goal_frames(run: LoggedRun, track: HumanTrack) -> npt.NDArray[np.intp]:
    """Frames at which the human's navigation tasks succeeded."""
    times = [e.time for e in run.events if e.human == track.name and e.kind in _NAVIGATION
             and e.status is TaskStatus.SUCCEEDED]
    if not times or len(track.time) == 0:
        return np.zeros(0, dtype=np.intp)
    frames = np.searchsorted(track.time, np.array(times) - 1e-9)
    return np.unique(np.minimum(frames, len(track.time) - 1)).astype(np.intp)


def draw_human(axes: Axes, run: LoggedRun, name: str, colour: Any, *, spacing: float,
               dashed: bool = False, spaces: bool = True) -> None:
    track = run.humans[name]
    if len(track.position) == 0:
        return
    style = (0, (5, 3)) if dashed else "-"
    axes.plot(track.position[:, 0], track.position[:, 1], color=colour, linestyle=style,
              linewidth=1.8, zorder=3)
    if spaces:
        shape = personal_space_of(run, name)
        for frame in spaced_frames(track.position, spacing):
            ring = outline(shape, track.position[frame], float(track.heading[frame]), n=48)
            axes.add_patch(Polygon(ring, closed=True, facecolor=colour,
                                   alpha=0.10 if not dashed else 0.0, zorder=2))
            axes.add_patch(Polygon(ring, closed=True, fill=False, edgecolor=colour,
                                   linewidth=0.9, linestyle=style, alpha=0.8, zorder=2))
    start, end = track.position[0], track.position[-1]
    axes.plot(*start, marker="o", markersize=8, color=colour, markeredgecolor="black", zorder=5)
    goals = track.position[goal_frames(run, track)]
    if len(goals) == 0:  # where it ended without reaching a goal: not a goal's star
        axes.plot(*end, marker=NO_GOAL_MARKER, markersize=7, color=colour,
                  markeredgecolor="black", zorder=5)
        return
    axes.plot(goals[:, 0], goals[:, 1], linestyle="none", marker="*", markersize=13,
              color=colour, markeredgecolor="black", zorder=5)


NO_GOAL_MARKER = "D"
FEW_HUMANS = 10  # asked for by name, members are drawn in full like named humans
MEMBER_PATH: dict[str, Any] = {"linewidth": 0.8, "alpha": 0.55}  # a crowd's member: thin, faint
ROBOT_COLOURS = ("black", "saddlebrown", "navy", "darkgreen", "indigo", "darkred")


def robot_colours(names: Sequence[str]) -> dict[str, str]:
    """One dark colour per robot, in sorted-name order, so that several robots are told apart."""
    return {name: ROBOT_COLOURS[i % len(ROBOT_COLOURS)] for i, name in enumerate(sorted(names))}


def draw_robots(axes: Axes, run: LoggedRun, dashed: bool = False) -> None:
    palette = robot_colours(list(run.robots))
    for name, robot in run.robots.items():
        if len(robot.position):
            axes.plot(robot.position[:, 0], robot.position[:, 1], color=palette[name],
                      linestyle=ROBOT_LINE if not dashed else ROBOT_LINE_B, linewidth=1.4,
                      zorder=3)
            axes.plot(*robot.position[0], marker="s", markersize=7, color=palette[name],
                      zorder=5)
    draw_robot_goals(axes, run, palette)


def draw_robot_goals(axes: Axes, run: LoggedRun, palette: dict[str, Any]) -> None:
    """Each robot's declared goal: a cross in its colour."""
    for name, goal in robot_goals(run).items():
        axes.plot(*goal, marker="X", markersize=10, color=palette[name],
                  markeredgecolor="black", zorder=5)


def draw_member(axes: Axes, run: LoggedRun, name: str, colour: Any,
                dashed: bool = False) -> None:
    """A crowd's or flow's member: a thin path and a small start, no personal spaces."""
    track = run.humans[name]
    if len(track.position):
        axes.plot(track.position[:, 0], track.position[:, 1], color=colour, zorder=3,
                  linestyle=(0, (5, 3)) if dashed else "-", **MEMBER_PATH)
        axes.plot(*track.position[0], marker="o", markersize=3, color=colour, zorder=4)


def set_colours(run: LoggedRun) -> dict[str, Any]:
    """One colour per crowd and flow (not tab10's, which the named humans use)."""
    from matplotlib import colormaps

    names = sorted(n for n, (kind, _) in run.metadata.sets.items() if kind != "group")
    palette = colormaps["Dark2"](np.arange(8))
    return {name: palette[i % len(palette)] for i, name in enumerate(names)}


def people_legend(run: LoggedRun, palette: dict[str, Any], crowds: dict[str, Any]
                  ) -> list[Any]:
    """The legend's entries for a run's bodies: each named human (`palette`, from `colours`)
    with its personal space, each crowd and flow once (`crowds`, from `set_colours`) with the
    people it brought, each robot."""
    return [*_human_handles(run, palette), *_set_handles(run, crowds), *_robot_handles(run)]


def _marker_handles(humans: Sequence[tuple[LoggedRun, str]]) -> list[Line2D]:
    """The legend's start, and the ends that the named `humans` (run, name) show: a star
    where a navigation task succeeded, a diamond where one ended without any."""
    reached = [len(goal_frames(run, run.humans[name])) > 0 for run, name in humans
               if len(run.humans[name].position)]
    handles = [Line2D([], [], linestyle="none", marker="o", color="white",
                      markeredgecolor="black", markersize=8, label="start")]
    if any(reached):
        handles.append(Line2D([], [], linestyle="none", marker="*", color="white",
                              markeredgecolor="black", markersize=12, label="goal reached"))
    if not all(reached):
        handles.append(Line2D([], [], linestyle="none", marker=NO_GOAL_MARKER, color="white",
                              markeredgecolor="black", markersize=7, label="end, no goal reached"))
    return handles


def _human_handles(run: LoggedRun, palette: dict[str, Any]) -> list[Any]:
    return [Line2D([], [], color=palette[name], linewidth=2.5,
                   label=f"{name}: {short_shape(personal_space_of(run, name))}")
            for name in sorted(palette)]


def short_shape(shape: Shape) -> str:
    """A legend-sized description: `circle r 0.2 m`, `ellipse 1.1 x 0.8 m`, `square 0.25 m`."""
    if isinstance(shape, Circle):
        return f"circle r {shape.radius:g} m"
    if isinstance(shape, Ellipse):
        behind = f", {shape.offset:g} m back" if shape.offset else ""
        return f"ellipse {shape.semi_major:g} x {shape.semi_minor:g} m{behind}"
    if shape.length == shape.width:
        return f"square {shape.length:g} m"
    return f"rectangle {shape.length:g} x {shape.width:g} m"


def _robot_handles(run: LoggedRun, sides: tuple[str, str] | None = None) -> list[Line2D]:
    """A robot's entry (with `sides`, the two runs' line styles of a comparison) and its
    goal's."""
    palette = robot_colours(list(run.robots))
    styles = [(ROBOT_LINE, "s", "")] if sides is None else [
        (ROBOT_LINE, "s", f", {sides[0]}"), (ROBOT_LINE_B, "", f", {sides[1]}")]
    handles = [Line2D([], [], color=palette[name], linestyle=line, marker=marker,
                      markersize=6, label=f"robot {name}{side}")
               for line, marker, side in styles for name in sorted(run.robots)]
    if robot_goals(run):
        handles.append(Line2D([], [], linestyle="none", marker="X", color="white",
                              markeredgecolor="black", markersize=9, label="robot's goal"))
    return handles


def _set_handles(run: LoggedRun, palette: dict[str, Any]) -> list[Line2D]:
    sets = run.metadata.sets

    def label(name: str) -> str:  # a flow's people who came, not all it might have brought
        kind, members = sets[name]
        count = sum(1 for m in members if m in run.humans and len(run.humans[m].position))
        return f"{kind} {name} ({count} {'person' if count == 1 else 'people'})"

    return [Line2D([], [], color=palette[name], linewidth=1.5, label=label(name))
            for name in sorted(palette)]


def place_legend(figure: Figure, axes: Axes, handles: list[Any]) -> None:
    """The legend in its column right of the map."""
    box = axes.get_position()
    figure.legend(handles=handles, loc="upper left", bbox_to_anchor=(box.x1 + 0.01, box.y1),
                  fontsize=LEGEND_FONT, frameon=True, labelspacing=0.8, handlelength=2.6,
                  borderaxespad=0.0)


def run_title(run: LoggedRun) -> str:
    variant = f" [{run.metadata.variant}]" if run.metadata.variant else ""
    return f"{run.metadata.title}{variant}, seed {run.metadata.seed}"


def save(figure: Figure, out: str | Path) -> Path:
    """Write the figure as PNG, whole or not at all (a file there before is kept when the
    write fails); InputError if the file cannot be written."""
    return write_replacing(Path(out), lambda temp: figure.savefig(temp, format="png", dpi=DPI))


def plot_run(run: LoggedRun, out: str | Path, *, spacing: float = SPACING,
             whole_map: bool = False, view: View | None = None) -> Path:
    """The run on its map: paths, starts, goals and personal spaces along the paths. `view`
    fixes the region shown (to draw several runs at the same scale)."""
    _check_spacing(spacing)
    crowds = set_colours(run)
    named = [name for name in run.humans if run.metadata.set_of(name) is None]
    palette = colours(named)
    handles = [*people_legend(run, palette, crowds),
               *_marker_handles([(run, name) for name in named])]
    figure, axes = (view or View.around([run], whole_map)).figure(_labels(handles))
    draw_map(axes, run.grid)
    for name in sorted(run.humans):
        crowd = run.metadata.set_of(name)
        if crowd is None:
            draw_human(axes, run, name, palette[name], spacing=spacing)
        else:
            draw_member(axes, run, name, crowds[crowd])
    draw_robots(axes, run)
    axes.set_title(run_title(run), fontsize=11)
    place_legend(figure, axes, handles)
    return save(figure, out)


def plot_overlay(a: LoggedRun, b: LoggedRun, out: str | Path, *, epsilon: float | None = None,
                 spacing: float = SPACING, whole_map: bool = False,
                 labels: tuple[str, str] | None = None, humans: Sequence[str] | None = None,
                 view: View | None = None) -> Path:
    """Two runs on one map: A solid with filled personal spaces, B dashed with outlines. With
    `epsilon`, a cross marks where each human's two paths first part by more than it.
    `humans` limits the picture to those humans (default: all). A crowd's or flow's members
    are thin paths in its colour, one legend entry for it, unless at most FEW_HUMANS humans
    were asked for by name."""
    from hubero_dsl.analysis.diff import divergence

    _check_spacing(spacing)
    chosen = sorted(humans) if humans is not None else sorted(a.humans)
    # a crowd's or flow's members are drawn as its own, unless a few humans were asked for
    in_set = {} if humans is not None and len(chosen) <= FEW_HUMANS else {
        name: crowd for name in chosen if (crowd := a.metadata.set_of(name)) is not None}
    named = [name for name in chosen if name not in in_set]
    palette = colours(named)
    crowds = {n: c for n, c in set_colours(a).items() if n in in_set.values()}
    label_a, label_b = labels or (_side_label(a, "A"), _side_label(b, "B"))
    handles = [*_overlay_handles(named, palette, (label_a, label_b), epsilon),
               *_set_handles(a, crowds), *_robot_handles(a, (label_a, label_b))]
    handles += _marker_handles([(run, name) for run in (a, b) for name in named
                                if name in run.humans])
    figure, axes = (view or View.around([a, b], whole_map)).figure(_labels(handles))
    draw_map(axes, a.grid)
    for name, crowd in in_set.items():
        draw_member(axes, a, name, crowds[crowd])
        if name in b.humans:
            draw_member(axes, b, name, crowds[crowd], dashed=True)
    for name in named:
        draw_human(axes, a, name, palette[name], spacing=spacing)
        if name in b.humans:
            draw_human(axes, b, name, palette[name], spacing=spacing, dashed=True)
            if epsilon is not None:
                _mark_divergence(axes, a.humans[name], b.humans[name], epsilon, palette[name],
                                 divergence)
    draw_robots(axes, a)
    draw_robots(axes, b, dashed=True)
    axes.set_title(f"{a.metadata.title}: {label_a} vs {label_b}", fontsize=11)
    place_legend(figure, axes, handles)
    return save(figure, out)


def _overlay_handles(humans: Sequence[str], palette: dict[str, Any], sides: tuple[str, str],
                     epsilon: float | None) -> list[Any]:
    handles: list[Any] = [Line2D([], [], color=palette[n], linewidth=2.5, label=n)
                          for n in humans]
    handles += [Line2D([], [], color="dimgray", linewidth=1.8, label=f"{sides[0]} (solid)"),
                Line2D([], [], color="dimgray", linewidth=1.8, linestyle=(0, (5, 3)),
                       label=f"{sides[1]} (dashed)")]
    if epsilon is not None:
        handles.append(Line2D([], [], linestyle="none", marker="X", color="white",
                              markeredgecolor="black", markersize=9,
                              label=f"paths > {epsilon:g} m apart"))
    return handles


def _labels(handles: Sequence[Any]) -> list[str]:
    return [str(handle.get_label()) for handle in handles]


def _side_label(run: LoggedRun, fallback: str) -> str:
    return run.metadata.variant or f"{fallback} (seed {run.metadata.seed})"


def _mark_divergence(axes: Axes, a: HumanTrack, b: HumanTrack, epsilon: float, colour: Any,
                     divergence: Any) -> None:
    _, when = divergence(a, b, epsilon)
    if when is None:
        return
    frame = int(np.searchsorted(a.time, when - 1e-9))
    x, y = a.position[min(frame, len(a.position) - 1)]
    axes.plot(x, y, marker="X", markersize=11, color=colour, markeredgecolor="black", zorder=6)


def _check_spacing(spacing: float) -> None:
    if not spacing > 0:
        raise InputError(f"the spacing of personal spaces must be positive, got {spacing!r}")
