"""Pictures of runs: real PNGs and GIFs of the expected size, with the map and the paths drawn."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from PIL import Image, ImageSequence

from hubero_dsl.analysis.animate import animate_run, frame_times
from hubero_dsl.analysis.plot import (
    DPI,
    LEGEND_INCHES,
    View,
    _marker_handles,
    colours,
    legend_inches,
    place_legend,
    plot_overlay,
    plot_run,
    short_shape,
    spaced_frames,
)
from hubero_dsl.errors import InputError
from hubero_dsl.log.reader import LoggedRun, load_run
from hubero_dsl.world.shapes import Circle, Ellipse, Rectangle, Square

Factory = Callable[..., Any]


def assert_expected_size(path: Path, runs: list[LoggedRun], whole_map: bool = False) -> None:
    """The picture is the view at DPI: its height exactly, its width with a legend column of
    at least the narrowest width (wider for long labels)."""
    figure, _ = View.around(runs, whole_map).figure()
    width, height = figure.get_size_inches() * DPI
    with Image.open(path) as image:
        assert image.height == round(height)
        assert round(width) <= image.width <= round(width) + 3 * DPI


def pixels(path: Path) -> np.ndarray:
    with Image.open(path) as image:
        assert image.format == "PNG"
        return np.asarray(image.convert("RGB"), dtype=np.int16)


def share_of_colour(image: np.ndarray, rgb: tuple[int, int, int], tolerance: int = 12) -> float:
    close = np.abs(image - np.array(rgb)).max(axis=2) <= tolerance
    return float(close.mean())


def tab10(name: str, names: list[str]) -> tuple[int, int, int]:
    r, g, b, _ = colours(names)[name]
    return round(r * 255), round(g * 255), round(b * 255)


def test_plot_run_png(tmp_path: Path, living_room_logs: dict[str, Path]) -> None:
    run = load_run(living_room_logs["ellipse"])
    out = plot_run(run, tmp_path / "run.png")
    image = pixels(out)
    assert_expected_size(out, [run])
    not_white = (image < 245).any(axis=2).mean()
    assert not_white > 0.15  # map, paths, personal spaces and text, not a blank page
    assert share_of_colour(image, (140, 140, 140)) > 0.02  # obstacles in grey
    for name in ("actor1", "actor2"):  # each human's colour is there
        assert share_of_colour(image, tab10(name, ["actor1", "actor2"])) > 0.001


def test_whole_map_is_larger_view(tmp_path: Path, living_room_logs: dict[str, Path]) -> None:
    run = load_run(living_room_logs["circle"])
    cropped, whole = View.around([run], False), View.around([run], True)
    assert whole.x1 - whole.x0 >= cropped.x1 - cropped.x0
    x0, y0, x1, y1 = run.grid.bounds
    assert (whole.x0, whole.x1, whole.y0, whole.y1) == (x0, x1, y0, y1)
    assert_expected_size(plot_run(run, tmp_path / "whole.png", whole_map=True), [run], True)


def test_overlay_png(tmp_path: Path, living_room_logs: dict[str, Path]) -> None:
    a, b = (load_run(living_room_logs[v]) for v in ("circle", "ellipse"))
    out = plot_overlay(a, b, tmp_path / "overlay.png", epsilon=0.1)
    image = pixels(out)
    assert_expected_size(out, [a, b])
    assert (image < 245).any(axis=2).mean() > 0.15
    only_one = pixels(plot_overlay(a, b, tmp_path / "one.png", humans=["actor1"]))
    actor2 = tab10("actor2", ["actor1", "actor2"])
    assert share_of_colour(only_one, actor2) < share_of_colour(image, actor2) / 5


def test_synthetic_run_with_robot(tmp_path: Path, build_run: Factory, track: Factory,
                                  robot: Factory) -> None:
    run = build_run([track("h", [0.0, 1.0, 2.0], [(0, 0), (1, 0), (2, 1)], [0.0, 0.0, 0.8])],
                    robots=[robot("bot", [0.0, 2.0], [(-2, -2), (-2, 2)])],
                    params={"h": {"personal_space": Rectangle(1.0, 0.6)}})
    out = plot_run(run, tmp_path / "s.png", spacing=0.5)
    assert_expected_size(out, [run])
    image = pixels(out)
    assert share_of_colour(image, (0, 0, 0), tolerance=30) > 0.001  # the robot's path


def test_a_comparison_names_its_robots_and_tells_their_runs_apart(
        tmp_path: Path, build_run: Factory, track: Factory, robot: Factory,
        monkeypatch: pytest.MonkeyPatch) -> None:
    # the robots were drawn, dotted both, and missing from the legend
    import hubero_dsl.analysis.plot as plot

    shown: list[list[str]] = []
    monkeypatch.setattr(plot, "place_legend", lambda figure, axes, handles: shown.append(
        [h.get_label() for h in handles]))
    run = build_run([track("h", [0.0, 2.0], [(0, 0), (2, 1)])],
                    robots=[robot("bot", [0.0, 2.0], [(-2, -2), (-2, 2)])])
    plot_overlay(run, run, tmp_path / "d.png", labels=("A", "B"))
    assert {"robot bot, A", "robot bot, B"} <= set(shown[0])
    assert plot.ROBOT_LINE != plot.ROBOT_LINE_B


def test_a_human_who_reached_no_goal_ends_in_a_diamond_not_a_star(
        build_run: Factory, track: Factory, living_room_logs: dict[str, Path]) -> None:
    stood = build_run([track("h", [0.0, 1.0], [(0, 0), (1, 0)])])   # no task succeeded
    labels = [h.get_label() for h in _marker_handles([(stood, "h")])]
    assert labels == ["start", "end, no goal reached"]
    walked = load_run(living_room_logs["circle"])
    labels = [h.get_label() for h in _marker_handles([(walked, n) for n in walked.humans])]
    assert labels == ["start", "goal reached"]
    both = [(stood, "h"), *((walked, n) for n in walked.humans)]
    assert [h.get_label() for h in _marker_handles(both)] == [
        "start", "goal reached", "end, no goal reached"]


def test_unwritable_output(tmp_path: Path, build_run: Factory, track: Factory) -> None:
    run = build_run([track("h", [0.0], [(0, 0)])])
    with pytest.raises(InputError, match="cannot be written"):
        plot_run(run, tmp_path / "missing" / "x.png")
    with pytest.raises(InputError, match="cannot be written"):
        plot_run(run, tmp_path)


def test_bad_spacing(tmp_path: Path, build_run: Factory, track: Factory) -> None:
    run = build_run([track("h", [0.0], [(0, 0)])])
    with pytest.raises(InputError, match="spacing"):
        plot_run(run, tmp_path / "x.png", spacing=0.0)


def test_a_failed_write_keeps_the_picture_that_was_there(
        tmp_path: Path, build_run: Factory, track: Factory,
        monkeypatch: pytest.MonkeyPatch) -> None:
    from matplotlib.figure import Figure

    run = build_run([track("h", [0.0, 1.0], [(0, 0), (1, 0)])])
    out = tmp_path / "run.png"
    out.write_bytes(b"an earlier picture")

    def half_then_full_disk(self: Figure, target: Path, **options: object) -> None:
        Path(target).write_bytes(b"\x89PNG half")
        raise OSError(27, "File too large")

    monkeypatch.setattr(Figure, "savefig", half_then_full_disk)
    with pytest.raises(InputError, match="cannot be written"):
        plot_run(run, out)
    assert out.read_bytes() == b"an earlier picture"
    assert [p.name for p in tmp_path.iterdir()] == ["run.png"]


def test_legend_column_grows_with_labels() -> None:
    assert legend_inches(["a"]) == LEGEND_INCHES
    long = legend_inches(["guest1: ellipse 0.6 x 0.4 m, 0.1 m back"])
    assert long > LEGEND_INCHES
    assert long > legend_inches(["guest1: circle r 0.4 m"])


@pytest.mark.parametrize("rows", [3, 10, 30])
def test_the_legend_fits_beside_a_long_narrow_map(rows: int) -> None:
    # a 40 m x 2 m corridor: the figure was as tall as the map, and the legend lost its rows
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.lines import Line2D

    labels = [f"walker {i}: circle r 0.5 m" for i in range(rows)]
    figure, axes = View(0.0, 40.0, 0.0, 2.0).figure(labels)
    place_legend(figure, axes, [Line2D([], [], label=label) for label in labels])
    canvas = FigureCanvasAgg(figure)
    canvas.draw()
    legend = figure.legends[0].get_window_extent(canvas.get_renderer())
    assert legend.y0 >= 0 and legend.y1 <= figure.bbox.height


def test_spaced_frames() -> None:
    path = np.column_stack([np.linspace(0.0, 5.0, 51), np.zeros(51)])  # 0.1 m apart
    assert spaced_frames(path, 2.0).tolist() == [0, 20, 40, 50]
    standing = np.zeros((10, 2))
    assert spaced_frames(standing, 1.0).tolist() == [0, 9]
    assert spaced_frames(np.zeros((0, 2)), 1.0).tolist() == []
    # marks closer than the frames: every frame (a 1e-9 m spacing tried to allocate 52 GiB)
    assert spaced_frames(path, 1e-9).tolist() == list(range(51))


def test_short_shapes() -> None:
    assert short_shape(Circle(0.2)) == "circle r 0.2 m"
    assert short_shape(Ellipse(1.1, 0.8)) == "ellipse 1.1 x 0.8 m"
    assert short_shape(Ellipse(1.1, 0.8, 0.2)) == "ellipse 1.1 x 0.8 m, 0.2 m back"
    assert short_shape(Square(0.25)) == "square 0.25 m"
    assert short_shape(Rectangle(1.2, 0.8)) == "rectangle 1.2 x 0.8 m"


def test_animation_gif(tmp_path: Path, build_run: Factory, track: Factory) -> None:
    times = np.arange(0.0, 10.0, 0.1)
    run = build_run([track("h", times, np.column_stack([times * 0.5 - 2, np.zeros_like(times)]))],
                    params={"h": {"personal_space": Ellipse(0.8, 0.5)}})
    assert len(frame_times(run, 6)) == 6
    out = animate_run(run, tmp_path / "run.gif", max_frames=6, fps=5)
    with Image.open(out) as image:
        assert image.format == "GIF"
        assert sum(1 for _ in ImageSequence.Iterator(image)) == 6
        image.seek(5)
        last = np.asarray(image.convert("RGB"), dtype=np.int16)
    assert share_of_colour(last, tab10("h", ["h"])) > 0.002  # the body and its space
    with pytest.raises(InputError, match="cannot be written"):
        animate_run(run, tmp_path / "no" / "x.gif", max_frames=2)


def test_an_interrupted_animation_leaves_the_gif_that_was_there(
        tmp_path: Path, build_run: Factory, track: Factory,
        monkeypatch: pytest.MonkeyPatch) -> None:
    from matplotlib.animation import PillowWriter

    times = np.arange(0.0, 10.0, 0.1)
    run = build_run([track("h", times, np.column_stack([times * 0.5 - 2, np.zeros_like(times)]))])
    out = tmp_path / "run.gif"
    out.write_bytes(b"GIF89a an earlier replay")
    frames = [0]
    grab = PillowWriter.grab_frame

    def grab_then_ctrl_c(self: PillowWriter, **options: object) -> None:
        frames[0] += 1
        if frames[0] == 3:
            raise KeyboardInterrupt
        grab(self, **options)

    monkeypatch.setattr(PillowWriter, "grab_frame", grab_then_ctrl_c)
    with pytest.raises(KeyboardInterrupt):
        animate_run(run, out, max_frames=6, fps=5)
    assert out.read_bytes() == b"GIF89a an earlier replay"
    assert [p.name for p in tmp_path.iterdir()] == ["run.gif"]


def test_a_replay_draws_robots_as_the_picture_does(build_run: Factory, track: Factory,
                                                  robot: Factory) -> None:
    # a 0.3 m disc whatever the robot, with no trail: not what the legend showed
    from dataclasses import replace

    from matplotlib.figure import Figure

    from hubero_dsl.analysis.animate import _Scene

    vacuum = replace(robot("vacuum", [0.0, 1.0, 2.0], [(0, 0), (1, 0), (2, 0)]), radius=0.17)
    run = build_run([track("h", [0.0, 2.0], [(0, 1), (2, 1)])], robots=[vacuum])
    axes = Figure().add_subplot()
    scene = _Scene(run, axes, {"h": "tab:blue"}, {}, 2.0)
    scene.show(1.0)
    assert scene.robots["vacuum"].radius == pytest.approx(0.17)
    assert np.asarray(scene.robot_trails["vacuum"].get_xdata()).tolist() == [0.0, 1.0]


def test_a_replays_clock_is_above_the_map_not_over_it(build_run: Factory,
                                                      track: Factory) -> None:
    # a boxed clock in the map's top-left corner hid whoever walked there
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from hubero_dsl.analysis.animate import _Scene

    run = build_run([track("h", [0.0, 2.0], [(0, 1), (2, 1)])])
    figure = Figure()
    canvas = FigureCanvasAgg(figure)
    axes = figure.add_subplot()
    scene = _Scene(run, axes, {"h": "tab:blue"}, {}, 2.0)
    scene.show(1.0)
    assert scene.clock.get_text().endswith(", t = 1.0 s")
    canvas.draw()  # the title's place is decided as the figure is drawn
    renderer = canvas.get_renderer()
    clock, map_area = scene.clock.get_window_extent(renderer), axes.get_window_extent(renderer)
    assert clock.y0 >= map_area.y1


def test_a_replays_title_keeps_its_place_as_the_clock_grows(build_run: Factory,
                                                            track: Factory) -> None:
    # a centred title whose clock went from 9.9 to 10.0 s moved half a digit to the left
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from hubero_dsl.analysis.animate import _Scene

    run = build_run([track("h", [0.0, 120.0], [(0, 1), (2, 1)])])
    figure = Figure()
    canvas = FigureCanvasAgg(figure)
    scene = _Scene(run, figure.add_subplot(), {"h": "tab:blue"}, {}, 120.0)
    extents = []
    for when in (0.0, 9.9, 10.0, 120.0):
        scene.show(when)
        canvas.draw()
        extents.append(scene.clock.get_window_extent(canvas.get_renderer()))
    assert {(round(e.x0, 3), round(e.x1, 3)) for e in extents} == {
        (round(extents[0].x0, 3), round(extents[0].x1, 3))}
    assert scene.clock.get_text().endswith(", t = 120.0 s")
