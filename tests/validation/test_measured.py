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
