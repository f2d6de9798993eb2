"""The shipped recordings read and analysed by PedPy: geometry from names, known numbers."""

from __future__ import annotations

from pathlib import Path

import pytest

pedpy = pytest.importorskip("pedpy")

from hubero_dsl.errors import InputError  # noqa: E402
from hubero_dsl.validation.experiments import (  # noqa: E402
    SHIPPED,
    experiment_for,
    load_trajectory,
    shipped_path,
)
from hubero_dsl.validation.fundamental import fundamental_diagram  # noqa: E402
from hubero_dsl.validation.validate import measure  # noqa: E402

DATA = Path(__file__).resolve().parents[2] / "hubero_dsl" / "validation" / "data"


def test_every_shipped_recording_is_there_small_and_cited() -> None:
    for name in SHIPPED:
        assert shipped_path(name).stat().st_size < 600_000
    readme = (DATA / "README.md").read_text(encoding="utf-8")
    assert "CC BY 4.0" in readme and "Zhang" in readme


def test_the_name_gives_the_geometry() -> None:
    experiment = experiment_for(Path("runs/uo-180-180-070.txt"))
    assert (experiment.entrance_width, experiment.exit_width) == (1.8, 0.7)
    assert experiment.unit == "cm" and experiment.frame_rate == 16.0
    assert experiment.steady == (500, 1399)
    assert experiment.measurement_area.bounds == (0.0, -2.0, 1.8, 0.0)
    # the exit is 0.7 m wide and centred: a body passes at x = 0.9, not at x = 0.3
    assert experiment.room.contains(experiment.room.centroid)
    from shapely.geometry import Point

    assert experiment.room.contains(Point(0.9, -4.15))
    assert not experiment.room.contains(Point(0.3, -4.15))
    wide = experiment_for(Path("traj_UNI_CORR_500_01.txt"))
    assert wide.direction == (-1.0, 0.0) and wide.frame_rate == 25.0 and wide.unit == "m"


@pytest.mark.parametrize("name", ["corridor.txt", "uo-18-180-070.txt", "traj.txt"])
def test_a_name_of_no_series_is_refused(name: str) -> None:
    with pytest.raises(InputError, match="cannot tell which experiment"):
        experiment_for(Path(name))


def test_an_exit_wider_than_the_corridor_is_refused() -> None:
    with pytest.raises(InputError, match="no wider than the corridor"):
        experiment_for(Path("uo-180-180-200.txt"))


def test_the_free_flow_recording_has_the_published_speed_and_flow() -> None:
    experiment = experiment_for(shipped_path("uo-050-180-180"))
    trajectory = load_trajectory(experiment)
    assert isinstance(trajectory, pedpy.TrajectoryData)
    assert trajectory.frame_rate == 16.0
    assert trajectory.data["id"].nunique() == 61
    diagram = fundamental_diagram(trajectory, experiment)
    assert len(diagram.frames) == 480  # steady frames 211-800 with someone in the area
    assert diagram.frames["voronoi_speed"].mean() == pytest.approx(1.34, abs=0.01)
    assert diagram.frames["density"].mean() == pytest.approx(0.61, abs=0.01)
    assert diagram.line_flow == pytest.approx(1.25, abs=0.02)
    assert diagram.speeds.mean() == pytest.approx(1.34, abs=0.01)


def test_a_file_pedpy_cannot_read_is_an_input_error(tmp_path: Path) -> None:
    bad = tmp_path / "uo-050-180-180.txt"
    bad.write_text("1 2 not numbers\n", encoding="utf-8")
    with pytest.raises(InputError, match="not a trajectory file PedPy can read"):
        load_trajectory(experiment_for(bad))
    empty = tmp_path / "uo-100-180-180.txt"
    empty.write_text("# nothing\n", encoding="utf-8")
    with pytest.raises(InputError, match=str(empty)):
        load_trajectory(experiment_for(empty))


MALFORMED = {
    "nobody in the steady frames": ("uo-100-180-180", "# comment\n1 2 3 4 5\n",
                                    "nobody is measured in the steady frames 200-790"),
    "positions not finite or absurd": ("uo-100-180-180", "1 1 nan inf 0\n1 2 1e308 -1e308 0\n",
                                       "2 of its positions lie outside the uo-100-180-180 "
                                       "experiment's walkable area"),
    "a position beside the corridor": ("uo-100-180-180", "1 300 90 600 0\n1 301 900 590 0\n",
                                       "1 of its positions lie outside"),
    "a person twice in a frame": ("uo-100-180-180", "1 300 90 600 0\n1 300 90 590 0\n",
                                  "person 1 has two positions in frame 300"),
    "a frame a trillion on": ("uo-100-180-180", "1 300 90 600 0\n1 999999999999 90 590 0\n",
                              "its frames span 300 to 999999999999, more than 100,000"),
    "positions in metres where the series has centimetres": (
        "uo-100-180-180", "".join(f"{person} {frame} 0.3 {4 - frame / 100:.2f} 0\n"
                                  for person in range(1, 11) for frame in range(300, 700, 50)),
        "its people span only 0.035 m along the walking direction of a place 14.5 m long; are "
        "its coordinates in cm"),
}


@pytest.mark.parametrize("case", MALFORMED.values(), ids=MALFORMED.keys())
def test_a_malformed_recording_is_an_input_error(tmp_path: Path,
                                                 case: tuple[str, str, str]) -> None:
    name, text, message = case
    path = tmp_path / f"{name}.txt"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(InputError, match=f"not a trajectory file hubero can read: {message}"):
        load_trajectory(experiment_for(path))


@pytest.mark.parametrize("name", ["uo-050-180-180", "traj_UNI_CORR_500_01"])
def test_a_free_flow_recording_without_a_speed_is_an_input_error(tmp_path: Path,
                                                                 name: str) -> None:
    path = tmp_path / f"{name}.txt"
    path.write_text("1 300 90 -100 0\n" if name.startswith("uo") else "1 1 0 2 0\n",
                    encoding="utf-8")
    with pytest.raises(InputError, match=f"{path}: not a trajectory file hubero can read: "
                                         f"nobody in it is measured long enough for a speed"):
        measure([experiment_for(path)])
