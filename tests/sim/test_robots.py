"""Robots: scripted paths, Python controllers, and humans treating them as moving obstacles."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

from hubero_dsl.controllers.registry import import_controller
from hubero_dsl.errors import InputError, SimulationError
from hubero_dsl.sim.simulation import Simulation
from hubero_dsl.sim.status import TaskStatus
from tests.sim.conftest import ScenarioFactory


def test_a_robot_follows_its_looping_path(scenario: ScenarioFactory) -> None:
    sim = Simulation(scenario("""
    robot r at (2, 2) { speed 1 m/s; path (2, 2) -> (6, 2) -> (6, 5) loop }
    """), activities=False)
    seen = []
    for _ in range(round(20 / sim.dt)):
        sim.step()
        seen.append(sim.engine.robots.position[0].copy())
    track = np.array(seen)
    assert track[:, 0].max() == pytest.approx(6.0, abs=0.05)
    assert track[:, 1].max() == pytest.approx(5.0, abs=0.05)
    lap = 4 + 3 + 5  # the loop closes back to the first waypoint
    # a robot stops on each waypoint it reaches, which costs it at most one tick each
    assert np.linalg.norm(track[round(lap / sim.dt) - 1] - (2, 2)) <= 3 * 1.0 * sim.dt + 1e-9


def test_humans_keep_clear_of_a_robot_crossing_their_way(scenario: ScenarioFactory) -> None:
    sim = Simulation(scenario("""
    human alice at (1, 4)
    robot r at (5, 7) { radius 0.4 m; speed 0.6 m/s; path (5, 7) -> (5, 1) }
    """), activities=False)
    task = sim.human("alice").move_to((9.0, 4.0))
    gaps = []
    while not task.done:
        sim.step()
        gaps.append(math.dist(sim.human("alice").position, sim.engine.robots.position[0]))
    assert task.status is TaskStatus.SUCCEEDED
    assert min(gaps) > 0.6 - 0.02  # body radii 0.2 + 0.4 never overlap


def test_a_human_can_follow_a_robot(scenario: ScenarioFactory) -> None:
    sim = Simulation(scenario("""
    human alice at (1, 1)
    robot r at (3, 4) { speed 0.5 m/s; path (3, 4) -> (8, 4) }
    """), activities=False)
    follow = sim.human("alice").follow("r", distance=1.0, duration=25.0)
    sim.run_until(lambda: follow.done)
    assert follow.status is TaskStatus.SUCCEEDED
    assert math.dist(sim.human("alice").position, (8.0, 4.0)) < 1.8


def test_robot_velocity_from_python(scenario: ScenarioFactory) -> None:
    sim = Simulation(scenario("robot r at (2, 2)\n"), activities=False)
    sim.set_robot_velocity("r", 0.5, 0.0)
    sim.run_until(lambda: sim.time >= 2.0)
    assert sim.engine.robots.position[0] == pytest.approx((3.0, 2.0), abs=0.03)
    with pytest.raises(SimulationError):
        sim.set_robot_velocity("nobody", 0.0, 0.0)


def test_a_controller_class_handed_over_drives_a_robot(scenario: ScenarioFactory,
                                                       tmp_path: Path,
                                                       monkeypatch: pytest.MonkeyPatch) -> None:
    (tmp_path / "my_robots.py").write_text(
        "class Climber:\n"
        "    def __init__(self, body, params):\n        self.body = body\n"
        "    def command(self, observation):\n        return (0.0, 0.4)\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    program = scenario("robot r at (2, 2) { controller external }\n")
    sim = Simulation(program, activities=False,
                     controllers={"r": import_controller("my_robots:Climber")})
    sim.run_until(lambda: sim.time >= 1.0)
    assert sim.engine.robots.position[0] == pytest.approx((2.0, 2.4), abs=0.03)
    sys.modules.pop("my_robots", None)


def test_a_controller_that_cannot_be_imported_is_bad_input() -> None:
    with pytest.raises(InputError, match="cannot be imported"):
        import_controller("no_such_module:Thing")
    with pytest.raises(InputError, match="not of the form MODULE:CLASS"):
        import_controller("no_colon")


def test_a_controller_whose_params_are_no_parameter_model_is_bad_input(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    (tmp_path / "odd_robots.py").write_text(
        "import dataclasses\n"
        "@dataclasses.dataclass\nclass Gains:\n    gain: float = 1.0\n"
        "class Dataclassed:\n    Params = Gains\n"
        "    def command(self, observation):\n        return (0.0, 0.0)\n"
        "class NoneParams:\n    Params = None\n"
        "    def command(self, observation):\n        return (0.0, 0.0)\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    for name in ("Dataclassed", "NoneParams"):
        with pytest.raises(InputError, match=r"its `Params` must be a subclass of "
                                             r"hubero_dsl\.controllers\.base\.ControllerParams"):
            import_controller(f"odd_robots:{name}")
    sys.modules.pop("odd_robots", None)


def test_a_scenario_file_names_no_code(room_map: Path) -> None:
    from hubero_dsl.pipeline import check_source

    text = (f'scenario "t"\nmap "{room_map}"\n'
            'robot r at (2, 2) { controller "shutil:rmtree" }\n')
    (diagnostic,) = check_source(text, "t.hub").errors
    assert (diagnostic.code, diagnostic.message) == ("E110", "a scenario file names no Python code")
    assert diagnostic.span is not None and diagnostic.span.column == 32


@pytest.mark.parametrize("point", [(float("nan"), 0.0), (0.0, float("inf"))])
def test_a_target_that_is_no_finite_point_is_refused_when_given(
        scenario: ScenarioFactory, point: tuple[float, float]) -> None:
    sim = Simulation(scenario("robot r at (2, 2) { controller navigator }\n"
                              "human h at (5, 5)\n"), activities=False)
    for actor in (sim.robot("r"), sim.human("h")):
        with pytest.raises(SimulationError, match=r"a point \(x, y\) of finite numbers"):
            actor.move_to(point)


def test_a_robot_driven_into_a_wall_stops_at_its_surface_and_slides_along(
        scenario: ScenarioFactory) -> None:
    # its centre kept half its radius from walls, as a person's: 0.15 m of it into the wall
    sim = Simulation(scenario("robot r at (2, 1.5) { radius 0.3 m; max_speed 1.0 m/s }\n"),
                     activities=False)
    sim.set_robot_velocity("r", 0.3, -1.0)
    clearances = []
    for _ in range(60):
        sim.step()
        clearances.append(float(sim.engine.grid.clearance_at(sim.robot("r").position)))
    assert min(clearances) >= 0.3 - 1e-9
    assert sim.robot("r").position[0] == pytest.approx(2.9, abs=0.06)   # it slid on


@pytest.mark.parametrize("posture", ["sit_down", "lie_down"])
def test_a_robot_driven_at_someone_who_cannot_yield_stops_where_their_bodies_touch(
        scenario: ScenarioFactory, posture: str) -> None:
    # seated or lying, a person cannot yield, and a robot's command drove it through them
    sim = Simulation(scenario("human bob at (5, 4)\n"
                              "robot r at (2, 4) { radius 0.3 m; max_speed 1.0 m/s }\n"))
    getattr(sim.human("bob"), posture)(duration=30.0)
    sim.set_robot_velocity("r", 1.0, 0.0)
    gaps = []
    for _ in range(120):
        sim.step()
        gaps.append(math.dist(sim.robot("r").position, sim.human("bob").position) - 0.5)
    assert min(gaps) >= -1e-9 and gaps[-1] < 1e-6  # bodies of 0.3 + 0.2 m: touching
    assert sim.human("bob").position == pytest.approx((5.0, 4.0))  # who does not move
    assert sim.robot("r").velocity == pytest.approx((0.0, 0.0))


@pytest.mark.parametrize("task", ["stand", None])
def test_a_robot_driven_at_someone_standing_pushes_them_aside_and_drives_on(
        scenario: ScenarioFactory, task: str | None) -> None:
    # stopped where their bodies touched, neither moved again: the robot stood there for good
    sim = Simulation(scenario("human bob at (5, 4.1)\n"
                              "robot r at (2, 4) { radius 0.3 m; max_speed 1.0 m/s }\n"))
    if task is not None:
        sim.human("bob").stand(duration=30.0)
    sim.set_robot_velocity("r", 1.0, 0.0)
    for _ in range(120):
        sim.step()
    assert sim.robot("r").position[0] == pytest.approx(8.0, abs=0.01)  # 6 s at 1 m/s
    assert math.dist(sim.human("bob").position, (5.0, 4.1)) > 0.3     # pushed aside


def test_a_unicycle_driven_into_a_wall_at_an_angle_does_not_slide_sideways(
        scenario: ScenarioFactory) -> None:
    heading = -math.pi / 3
    sim = Simulation(scenario("robot r at (2, 1.5) heading -60 deg { radius 0.3 m; "
                              "kinematics unicycle; max_speed 1.0 m/s }\n"), activities=False)
    sim.robot("r").drive(1.0, 0.0)                        # (v, omega): straight ahead
    for _ in range(60):
        sim.step()
        x, y = sim.robot("r").position
        across = (x - 2.0) * math.sin(heading) - (y - 1.5) * math.cos(heading)
        assert abs(across) < 1e-9                         # still on the line it drove along
    assert sim.engine.grid.clearance_at(sim.robot("r").position) >= 0.3 - 1e-9
