"""A replay of a run as an animated GIF (matplotlib's animation with the Pillow writer).

    animate_run(load_run("run.mcap"), "run.gif", max_frames=120, fps=10)

Each frame shows the map, every human's path so far, its body and its personal space in its
shape and heading, robots, and the time. The members of a crowd or flow are drawn as `hubero
plot` draws them: their crowd's colour and one legend entry, thin paths, no personal spaces;
people a flow never brought are not drawn at all. At most `max_frames` frames are drawn,
spread evenly over the run, so a long run gives a file of bounded size; `fps` sets the replay
speed.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt
from matplotlib.artist import Artist
from matplotlib.lines import Line2D
from matplotlib.patches import Circle as CirclePatch
from matplotlib.patches import Polygon

from hubero_dsl.analysis.plot import (
    MEMBER_PATH,
    ROBOT_LINE,
    View,
    colours,
    draw_map,
    draw_robot_goals,
    people_legend,
    personal_space_of,
    place_legend,
    robot_colours,
    run_title,
    set_colours,
)
from hubero_dsl.analysis.socialnav_log import DEFAULT_ROBOT_RADIUS
from hubero_dsl.errors import InputError
from hubero_dsl.files import write_replacing
from hubero_dsl.world.personal_space import outline

if TYPE_CHECKING:
    from hubero_dsl.log.reader import LoggedRun

FloatArray = npt.NDArray[np.float64]

MAX_FRAMES = 120
FPS = 10
GIF_DPI = 70
_NAMED_TRAIL = {"linewidth": 1.6}
FIGURE_SPACE = "\u2007"


def frame_times(run: LoggedRun, max_frames: int) -> FloatArray:
    """Instants to draw: the logged frames, thinned evenly to at most `max_frames`."""
    times = [track.time for track in run.humans.values() if len(track.time)]
    times += [track.time for track in run.robots.values() if len(track.time)]
    if not times:
        return np.zeros(1)
    every = np.unique(np.concatenate(times))
    if len(every) <= max_frames:
        return every
    return np.linspace(every[0], every[-1], max_frames)


def clock_text(when: float, digits: int) -> str:
    """`when` to a tenth of a second, padded to `digits` characters with figure spaces (as
    wide as a digit), so that the centred title does not shift as the clock's digits grow."""
    return f"{when:.1f}".rjust(digits, FIGURE_SPACE)


def _at(time: FloatArray, values: FloatArray, when: float) -> FloatArray:
    """Position (or heading) at `when`: the last logged frame not after it."""
    index = max(int(np.searchsorted(time, when, side="right")) - 1, 0)
    return np.asarray(values[index])


class _Scene:
    """The artists of one replay, moved to each instant in turn."""

    def __init__(self, run: LoggedRun, axes: Any, palette: dict[str, Any],
                 crowds: dict[str, Any], last: float) -> None:
        self.run = run
        self.clock_digits = len(f"{last:.1f}")  # the widest time shown, the last frame's
        self.trails: dict[str, Line2D] = {}
        self.bodies: dict[str, CirclePatch] = {}
        self.spaces: dict[str, Polygon] = {}
        self.robots: dict[str, CirclePatch] = {}
        self.robot_trails: dict[str, Line2D] = {}
        for name in sorted(run.humans):
            if not len(run.humans[name].time):
                continue  # a flow's person who never came
            crowd = run.metadata.set_of(name)
            colour = palette[name] if crowd is None else crowds[crowd]
            self.trails[name], = axes.plot([], [], color=colour, zorder=3,
                                           **(_NAMED_TRAIL if crowd is None else MEMBER_PATH))
            if crowd is None:
                self.spaces[name] = axes.add_patch(Polygon(
                    np.zeros((3, 2)), closed=True, facecolor=colour, edgecolor=colour,
                    alpha=0.25, zorder=2))
            radius = run.metadata.params.get(name, {}).get("radius", 0.2)
            self.bodies[name] = axes.add_patch(CirclePatch(
                (0.0, 0.0), float(radius) if isinstance(radius, int | float) else 0.2,
                facecolor=colour, edgecolor="black", zorder=4))
        # robots as the picture draws them: a dotted trail, the body at its size, the goal
        palette = robot_colours(list(run.robots))
        for name, colour in palette.items():
            self.robot_trails[name], = axes.plot([], [], color=colour, linestyle=ROBOT_LINE,
                                                 linewidth=1.4, zorder=3)
            self.robots[name] = axes.add_patch(CirclePatch(
                (0.0, 0.0), run.robots[name].radius or DEFAULT_ROBOT_RADIUS, facecolor=colour,
                zorder=4))
        draw_robot_goals(axes, run, palette)
        # the run's title and the time, one text above the map: a clock over the map hid a
        # corner of it, and one beside the title ran into a long title
        self.title = run_title(run)
        self.clock = axes.set_title(self.title, fontsize=11)

    def show(self, when: float) -> list[Artist]:
        for name, trail in self.trails.items():
            track = self.run.humans[name]
            shown = track.time <= when
            trail.set_data(track.position[shown, 0], track.position[shown, 1])
            # a flow's person is in the scene from the first frame logged of them to the last
            here = bool(track.time[0] <= when <= track.time[-1])
            self.bodies[name].set_visible(here)
            where = _at(track.time, track.position, when)
            if name in self.spaces:
                self.spaces[name].set_visible(here)
                heading = float(_at(track.time, track.heading, when))
                self.spaces[name].set_xy(outline(personal_space_of(self.run, name), where,
                                                 heading))
            self.bodies[name].set_center((float(where[0]), float(where[1])))
        for name, robot in self.run.robots.items():
            if len(robot.time):
                shown = robot.time <= when
                self.robot_trails[name].set_data(robot.position[shown, 0],
                                                 robot.position[shown, 1])
                where = _at(robot.time, robot.position, when)
                self.robots[name].set_center((float(where[0]), float(where[1])))
        self.clock.set_text(f"{self.title}, t = {clock_text(when, self.clock_digits)} s")
        return [*self.trails.values(), *self.spaces.values(), *self.bodies.values(),
                *self.robot_trails.values(), *self.robots.values(), self.clock]


def animate_run(run: LoggedRun, out: str | Path, *, max_frames: int = MAX_FRAMES,
                fps: int = FPS, whole_map: bool = False) -> Path:
    """Write a GIF replay of the run; InputError if it cannot be written."""
    from matplotlib.animation import FuncAnimation, PillowWriter

    if max_frames < 1 or fps < 1:
        raise InputError("an animation needs at least one frame and one frame per second")
    crowds = set_colours(run)
    palette = colours([name for name in run.humans if run.metadata.set_of(name) is None])
    handles = people_legend(run, palette, crowds)
    figure, axes = View.around([run], whole_map).figure([str(h.get_label()) for h in handles])
    figure.set_dpi(GIF_DPI)
    draw_map(axes, run.grid)
    times = frame_times(run, max_frames)
    scene = _Scene(run, axes, palette, crowds, float(times[-1]))
    place_legend(figure, axes, handles)
    animation = FuncAnimation(figure, scene.show, frames=list(times), blit=False)
    # beside it first, then renamed: an interrupted animation leaves no half a GIF
    return write_replacing(Path(out), lambda temp: animation.save(
        str(temp), writer=PillowWriter(fps=fps), dpi=GIF_DPI))
