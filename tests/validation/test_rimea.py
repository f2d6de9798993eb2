"""RiMEA verification tests that apply to a 2-D simulator (RiMEA guideline 2.2.1, section 2:
tests 1, 4, 6, 7 and 12), each a scenario in scenarios/rimea/ with its pass criterion here.
Densities and speeds are measured by PedPy from the run's log, as for real people."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from scipy.stats import kstest

from hubero_dsl.log.reader import load_run
from hubero_dsl.pipeline import compile_file
from hubero_dsl.sim.loop import run_program
from hubero_dsl.sim.scheduler import RunState
from hubero_dsl.sim.simulation import Simulation
from hubero_dsl.simulate import simulate

pedpy = pytest.importorskip("pedpy")

from hubero_dsl.validation.rebuild import trajectory_from_log  # noqa: E402

RIMEA = Path(__file__).resolve().parents[2] / "scenarios" / "rimea"


def logged(name: str, tmp_path: Path) -> Any:
    log = tmp_path / "run.mcap"
    result = simulate(compile_file(RIMEA / name), log=log, writer_process=False)
    assert result.state is RunState.COMPLETED, result.reason
    return load_run(log)


def area_series(trajectory: Any, box: tuple[float, float, float, float]) -> tuple[Any, Any]:
    """PedPy's classic density and mean speed per frame in an axis-aligned box."""
    x0, y0, x1, y1 = box
    area = pedpy.MeasurementArea([(x0, y0), (x1, y0), (x1, y1), (x0, y1)])
    speed = pedpy.compute_individual_speed(
        traj_data=trajectory, frame_step=5,
        speed_calculation=pedpy.SpeedCalculation.BORDER_SINGLE_SIDED)
    density = pedpy.compute_classic_density(traj_data=trajectory, measurement_area=area)
    mean = pedpy.compute_mean_speed_per_frame(traj_data=trajectory, measurement_area=area,
                                              individual_speed=speed)
    return density.set_index("frame")["density"], mean.set_index("frame")["speed"]


def test_01_one_person_walks_40_m_in_26_to_34_s() -> None:
    sim = Simulation(compile_file(RIMEA / "test01_corridor.hub"))
    result = run_program(sim)
    assert result.state is RunState.COMPLETED
    (finished,) = [e for e in sim.events if e.status.value == "SUCCEEDED"]
    assert 26.0 <= finished.time <= 34.0
    assert 40.0 / finished.time == pytest.approx(1.33, rel=0.05)


def weidmann(density: float) -> float:
    """Weidmann's fundamental diagram (1993): speed in m/s at a density in 1/m²."""
    return 1.34 * (1.0 - math.exp(-1.913 * (1.0 / density - 1.0 / 5.4)))


def test_04_speed_falls_with_density_as_in_weidmanns_diagram(tmp_path: Path) -> None:
    trajectory = trajectory_from_log(logged("test04_fundamental_diagram.hub", tmp_path))
    speeds = []
    for corridor, nominal in enumerate((0.5, 1.0, 2.0, 3.0)):
        density, speed = area_series(trajectory, (14.0, 3.0 * corridor, 18.0,
                                                  3.0 * corridor + 2.0))
        window = (density.index >= 30) & (density.index <= 90)  # 3 to 9 s
        measured = float(density[window].mean())
        assert measured == pytest.approx(nominal, rel=0.35)  # the crowd spreads as it walks
        speeds.append(float(speed[window].mean()))
        assert speeds[-1] == pytest.approx(weidmann(measured), rel=0.15)
    assert speeds == sorted(speeds, reverse=True), speeds  # falls as the density rises


def test_06_twenty_people_round_a_corner_without_touching_its_walls() -> None:
    program = compile_file(RIMEA / "test06_corner.hub")
    sim = Simulation(program)
    clearances: list[float] = []

    def observe(sim: Simulation) -> None:
        clearances.append(float(program.grid.clearance_at(sim.engine.humans.position).min()))

    result = run_program(sim, [observe])
    assert result.state is RunState.COMPLETED
    assert all(e.held for e in result.expectations)  # all 20 past the corner
    radius = 0.2
    assert min(clearances) >= radius - 0.03  # within a grid step of the wall, never into it


def test_07_demographic_speeds_are_drawn_from_weidmanns_ranges(tmp_path: Path) -> None:
    ranges = {"under30": (0.58, 1.61), "from30to50": (1.41, 1.54), "over50": (0.68, 1.41)}
    sim = Simulation(compile_file(RIMEA / "test07_demography.hub"))
    assert len(sim.params) == 50
    for group, (low, high) in ranges.items():
        drawn = np.array([float(p["speed"]) for name, p in sim.params.items()
                          if name.startswith(f"{group}_")])
        assert ((drawn >= low) & (drawn <= high)).all()
        assert kstest(drawn, "uniform", args=(low, high - low)).pvalue > 0.01
    run = logged("test07_demography.hub", tmp_path)
    for name, track in run.humans.items():
        steps = np.diff(track.position, axis=0)
        walked = np.hypot(steps[:, 0], steps[:, 1]) / np.diff(track.time)
        # pushed by those behind a person may hurry for a moment, not for long
        assert np.median(walked) <= float(run.metadata.params[name]["speed"]) * 1.1 + 0.05


def test_12_a_jam_forms_in_front_of_the_bottleneck_not_where_it_ends(tmp_path: Path) -> None:
    trajectory = trajectory_from_log(logged("test12_bottleneck.hub", tmp_path))
    before, _ = area_series(trajectory, (8.0, 4.0, 10.0, 6.0))
    after, _ = area_series(trajectory, (12.0, 4.0, 14.0, 6.0))
    late = before.index >= 200  # once the crowd has reached the door
    assert before[late].mean() >= 1.5
    assert after[late].mean() <= 0.5 * before[late].mean()
    assert after.quantile(0.95) < before[late].quantile(0.95)
