"""What a robot's controller is held to: a unicycle drives along its heading, sensors reach
surface to surface, and whatever user code answers or raises is the controller's error."""

from __future__ import annotations

import asyncio
import math
import sys
from decimal import Decimal
from fractions import Fraction
from pathlib import Path

import numpy as np
import pytest

from hubero_dsl.controllers.base import ControllerParams, Observation
from hubero_dsl.errors import InputError
from hubero_dsl.sim.robots import ControllerError
from hubero_dsl.sim.simulation import Simulation
from tests.sim.conftest import ScenarioFactory
from tests.sim.test_robots_under_test import Recorder, _hubero, _scenario_file

UNICYCLE = """robot r at (3, 4) heading 0 deg {
    controller external; kinematics unicycle; max_speed 1 m/s; max_acceleration 0.5;
    max_angular_speed 1.0
}
"""


def test_a_unicycle_turning_as_it_speeds_up_never_moves_sideways(
        scenario: ScenarioFactory) -> None:
    recorder = Recorder(None, None, (0.8, 1.0))  # 0.8 m/s forward, turning at 1 rad/s
    sim = Simulation(scenario(UNICYCLE), activities=False, controllers={"r": recorder})
    forward = []
    for _ in range(40):
        sim.step()
        robot = sim.robot("r")
        vx, vy = robot.velocity
        heading = robot.heading
        assert abs(-vx * math.sin(heading) + vy * math.cos(heading)) < 1e-12  # no sideways
        forward.append(vx * math.cos(heading) + vy * math.sin(heading))
    # the forward speed grows by the acceleration limit to what was asked, and stays there
    assert np.allclose(np.diff([0.0, *forward])[:32], 0.5 * sim.dt)
    assert forward[-1] == pytest.approx(0.8)


def test_a_robot_sees_as_far_as_its_sensor_range_from_its_surface(
        scenario: ScenarioFactory) -> None:
    # robot radius 0.3 m, person 0.2 m: surfaces 2.99 m and 3.01 m apart
    program = scenario("""
    human near at (5.49, 4)
    human far at (2, 0.49)
    robot r at (2, 4) heading 0 deg { controller external; radius 0.3 m; sensor_range 3 m }
    """)
    recorder = Recorder(None, None)
    sim = Simulation(program, activities=False, controllers={"r": recorder})
    sim.step()
    assert [p.name for p in recorder.seen[0].people] == ["near"]


class Answering:
    """Answers what the test puts in `ANSWER` (or raises it)."""

    ANSWER: object = None

    def __init__(self, body: object, params: object) -> None:
        pass

    def command(self, observation: Observation) -> object:
        if isinstance(self.ANSWER, BaseException):
            raise self.ANSWER
        return self.ANSWER


class _UntoldError(Exception):
    def __str__(self) -> str:
        raise RuntimeError("no message either")


class _OwnBase(BaseException):
    """Raised by user code that derives from BaseException: still the controller's failure."""


class _Unreadable:
    def __iter__(self) -> object:
        raise RuntimeError("cannot be read")

    def __repr__(self) -> str:
        raise RuntimeError("cannot be shown either")


@pytest.mark.parametrize(("answer", "message"), [
    (SystemExit(0), "raised SystemExit"),
    (("0.5", "0.1"), r"returned \('0.5', '0.1'\), not a velocity"),
    ("12", "returned '12', not a velocity"),
    (_Unreadable(), "returned a _Unreadable, not a velocity"),
    ((1.0, complex(1, 1)), "not a velocity"),
    (asyncio.CancelledError("planner task cancelled"), "raised CancelledError: planner task"),
    (GeneratorExit(), "raised GeneratorExit"),
    (_OwnBase("custom"), "raised _OwnBase: custom"),
    (_UntoldError(), r"raised _UntoldError: \(its message cannot be shown\)"),
    ({0: 0.1, 1: 0.0}, r"returned \{0: 0.1, 1: 0.0\}, not a velocity"),   # its keys: no velocity
    ((True, False), r"returned \(True, False\), not a velocity"),
    (iter([0.1, 0.0]), "not a velocity"),
    # shortened, not cut off in the middle of a number with its parenthesis left open
    ((10 ** 400, 0), r"returned \(a whole number of 401 digits, 0\), not a velocity"),
    ((-10 ** 5000, 0), r"returned \(a negative whole number of more than \d+ digits, 0\), not"),
    ([0.123456789] * 40, r"returned \[0.123456789, (0.123456789, ){4}0.123456789…\], not a"),
    ((("x" * 100,), 0), r"returned \(\('x{70,}…'\)\), not a velocity"),
])
def test_whatever_a_controller_answers_or_raises_is_its_error(
        scenario: ScenarioFactory, answer: object, message: str) -> None:
    controller = type("Answering", (Answering,), {"ANSWER": answer})
    sim = Simulation(scenario("robot r at (2, 4) { controller external }\n"), activities=False,
                     controllers={"r": controller})
    with pytest.raises(ControllerError, match=f"robot 'r' at t = 0 s: .*{message}"):
        sim.step()


@pytest.mark.parametrize("answer", [
    np.array([0.5, 0.25], np.float32), (np.int8(1) / 2, np.float16(0.25)),
    (Fraction(1, 2), Decimal("0.25")), [Decimal("0.5"), Fraction(1, 4)]],
    ids=["float32 array", "numpy scalars", "Fraction, Decimal", "Decimal, Fraction list"])
def test_numbers_of_any_real_type_are_a_velocity(scenario: ScenarioFactory,
                                                 answer: object) -> None:
    # a Decimal is no numbers.Real, and a pair with one was refused: exit 1 from `hubero run`
    controller = type("Answering", (Answering,), {"ANSWER": answer})
    sim = Simulation(scenario("robot r at (2, 4) { controller external }\n"), activities=False,
                     controllers={"r": controller})
    sim.step()
    assert sim.robot("r").velocity == pytest.approx((0.5, 0.25))


@pytest.mark.parametrize("answer", [
    (Decimal("NaN"), 0), (Decimal("sNaN"), 0), (0, Decimal("-Infinity")),
    (Decimal("1e400"), 0), (Fraction(10 ** 400, 3), 0), (np.True_, 0), (0.1, np.complex64(1))],
    ids=["NaN", "signalling NaN", "infinity", "beyond a float", "a fraction beyond a float",
         "numpy's True", "numpy's complex"])
def test_a_real_number_that_is_not_finite_or_no_real_number_is_no_velocity(
        scenario: ScenarioFactory, answer: object) -> None:
    controller = type("Answering", (Answering,), {"ANSWER": answer})
    sim = Simulation(scenario("robot r at (2, 4) { controller external }\n"), activities=False,
                     controllers={"r": controller})
    with pytest.raises(ControllerError, match=r"robot 'r' at t = 0 s: .*, not a velocity"):
        sim.step()


@pytest.mark.parametrize("kinematics", ["holonomic", "unicycle"])
def test_an_absurd_but_finite_speed_keeps_the_robot_on_the_map(
        scenario: ScenarioFactory, kinematics: str) -> None:
    # no max_speed: the command is taken as it is, and the walls stop it (on a 2 cm grid a
    # step of 1e308 * 0.05 m is more cells than a float holds)
    living_room = Path(__file__).resolve().parents[2] / "maps" / "living_room.yaml"
    sim = Simulation(scenario(f"robot r at (-4.4, 4.8) {{ controller external; kinematics "
                              f"{kinematics} }}\n", living_room), activities=False)
    robot = sim.robot("r")
    if kinematics == "holonomic":
        robot.set_velocity(1e308, 1e308)
    else:
        robot.drive(1e308, 0.0)
    for _ in range(3):
        sim.step()
    assert sim.engine.grid.is_free(robot.position)


class Tuned:
    """A controller with a parameter of its own, handed over for a robot whose scenario sets
    it."""

    class Params(ControllerParams):
        gain: float = 1.0

    def __init__(self, body: object, params: Tuned.Params) -> None:
        self.gain = params.gain

    def command(self, observation: Observation) -> tuple[float, float]:
        return (0.1 * self.gain, 0.0)


def test_a_class_handed_over_takes_the_parameters_it_declares(tmp_path: Path) -> None:
    from tests.plugin_controller import install_straight_drive

    site = install_straight_drive(tmp_path / "site")
    (site / "tuned.py").write_text(
        "from hubero_dsl.controllers.base import ControllerParams\n"
        "class Params(ControllerParams):\n    gain: float = 1.0\n"
        "class Tuned:\n    Params = Params\n"
        "    def __init__(self, body, params):\n        self.gain = params.gain\n"
        "    def command(self, observation):\n        return (0.1 * self.gain, 0.0)\n",
        encoding="utf-8")
    file = _scenario_file(tmp_path, "robot r at (2, 4) { controller straight_drive; "
                                    "straight_drive.gain 20 }\n")
    done = _hubero("run", str(file), "--controller", "r=tuned:Tuned", "--no-log", "-q",
                   cwd=tmp_path, pythonpath=site)
    assert done.returncode == 0, done.stderr
    # a class whose Params do not declare the file's gain: they do not fit, which is bad input
    (site / "other.py").write_text(
        "from hubero_dsl.controllers.base import ControllerParams\n"
        "class Params(ControllerParams):\n    lead: float = 1.0\n"
        "class Other:\n    Params = Params\n"
        "    def __init__(self, body, params):\n        pass\n"
        "    def command(self, observation):\n        return (0.0, 0.0)\n", encoding="utf-8")
    refused = _hubero("run", str(file), "--controller", "r=other:Other", "--no-log", "-q",
                      cwd=tmp_path, pythonpath=site)
    assert refused.returncode == 2 and "does not take the scenario's `straight_drive.gain`" \
        in refused.stderr, refused.stderr
    # at 2 m/s (0.1 x the scenario's gain of 20, not the default 1) from x = 2 to x = 6
    assert "completed at t = 2." in done.stdout + done.stderr or done.returncode == 0


def test_check_reports_an_installed_plugin_that_cannot_be_loaded(tmp_path: Path) -> None:
    from tests.plugin_controller import install_straight_drive

    site = install_straight_drive(tmp_path / "site")
    (site / "straight_drive" / "__init__.py").write_text("import not_installed_anywhere\n",
                                                         encoding="utf-8")
    file = _scenario_file(tmp_path, "robot r at (2, 4) { controller straight_drive }\n")
    done = _hubero("check", str(file), cwd=tmp_path, pythonpath=site)
    assert done.returncode == 1
    assert "E110" in done.stdout and "straight_drive' cannot be loaded" in done.stdout
    assert "robot.hub:3:" in done.stdout


def test_hubero_test_reports_a_runs_controller_error_and_runs_the_others(
        tmp_path: Path) -> None:
    (tmp_path / "my_nav.py").write_text(
        "class Broken:\n    def __init__(self, body, params):\n        pass\n"
        "    def command(self, observation):\n        raise RuntimeError('boom')\n",
        encoding="utf-8")
    broken = _scenario_file(tmp_path, "robot r at (2, 4) { controller external }\n")
    fine = tmp_path / "fine.hub"
    fine.write_text('scenario "fine"\nmap "room.yaml"\nhuman a at (2, 2)\n'
                    "activity { a move_to (4, 2) }\n", encoding="utf-8")
    done = _hubero("test", str(broken), str(fine), "--controller", "r=my_nav:Broken",
                   cwd=tmp_path, pythonpath=tmp_path)
    assert done.returncode == 1, done.stderr
    assert "ERROR" in done.stdout and "its controller Broken raised RuntimeError: boom" in \
        done.stdout
    assert "PASS" in done.stdout and "fine.hub" in done.stdout
    assert done.stdout.rstrip().endswith("1 passed, 1 failed")


def test_a_robot_given_two_classes_is_refused(tmp_path: Path) -> None:
    (tmp_path / "my_nav.py").write_text(
        "class A:\n    def __init__(self, body, params):\n        pass\n"
        "    def command(self, observation):\n        return (0.0, 0.0)\n", encoding="utf-8")
    file = _scenario_file(tmp_path, "robot r at (2, 4) { controller external }\n")
    done = _hubero("run", str(file), "--controller", "r=my_nav:A", "--controller", "r=my_nav:A",
                   "--no-log", cwd=tmp_path, pythonpath=tmp_path)
    assert done.returncode == 2 and "robot 'r' is given a class twice" in done.stderr


if sys.platform == "win32":  # pragma: no cover - the subprocess tests name POSIX paths
    pytestmark = pytest.mark.skip


def test_a_class_handed_over_without_a_parameter_the_scenario_gives_is_told_which(
        scenario: ScenarioFactory) -> None:
    program = scenario("robot r at (2, 4) { controller navigator; navigator.safety_margin 0.25 m "
                       "}\n")
    with pytest.raises(InputError, match=(
            r"test.hub:3:1: robot 'r': controller Tuned does not take the scenario's "
            r"`navigator.safety_margin` \(declare safety_margin in Tuned.Params, or leave it "
            r"out\)$")) as refused:
        Simulation(program, activities=False, controllers={"r": Tuned})
    span = refused.value.span  # the robot's statement, where its parameters are written
    assert span is not None and (span.line, span.column) == (3, 1)
