"""Robots under test: tasks, the reference navigator, kinematics and limits, what controllers
see, controller errors, and controllers handed over or installed as plugins."""

from __future__ import annotations

import math
import os
import subprocess
import sys
import sysconfig
from pathlib import Path

import numpy as np
import pytest

from hubero_dsl.controllers.base import Observation
from hubero_dsl.errors import SimulationError
from hubero_dsl.pipeline import check_source
from hubero_dsl.sim.loop import RunState, run_program
from hubero_dsl.sim.robots import ControllerError
from hubero_dsl.sim.simulation import Simulation
from hubero_dsl.sim.status import TaskStatus
from hubero_dsl.world.mapfile import save_map
from tests.plugin_controller import install_straight_drive
from tests.sim.conftest import ScenarioFactory, room_grid

REPO_ROOT = Path(__file__).resolve().parents[2]


class Recorder:
    """A controller that drives at a fixed command and keeps what it was shown."""

    def __init__(self, body: object, params: object, command: tuple[float, float] = (0.0, 0.0)
                 ) -> None:
        self.command_given = command
        self.seen: list[Observation] = []

    def command(self, observation: Observation) -> tuple[float, float]:
        self.seen.append(observation)
        return self.command_given


# ---- tasks and the navigator -------------------------------------------------------------------


def test_a_navigator_robot_plans_round_a_wall_and_its_task_keeps_the_run_alive(
        scenario: ScenarioFactory, tmp_path: Path) -> None:
    walled = tmp_path / "gap.yaml"  # a wall at x = 5 with a gap at the top
    save_map(room_grid(walls=((4.9, 0.0, 5.1, 6.0),)), walled)
    program = scenario("""
    human alice at (1, 1)
    robot cart at (2, 2) { controller navigator; speed 0.8 m/s }
    activity { alice stand for 1 s }
    activity { go: cart move_to (8, 2) within 60 s }
    expect cart reaches (8, 2) eventually
    """, map_path=walled)
    sim = Simulation(program)
    track = []
    result = run_program(sim, [lambda s: track.append(s.robot("cart").position)])
    assert result.state is RunState.COMPLETED and result.succeeded
    assert result.time > 10.0          # the robot's task, not alice's, ended the run
    assert max(y for _, y in track) > 6.0   # it went through the gap
    assert result.robots[0].tasks_done == 1 and result.robots[0].last_status == "SUCCEEDED"
    assert [e.status for e in result.events if e.human == "cart"] == [
        TaskStatus.ACTIVE, TaskStatus.SUCCEEDED]


def test_the_navigator_stops_rather_than_come_closer_than_its_margin(
        scenario: ScenarioFactory) -> None:
    """A person crosses the robot's way: it waits for them; no gap falls below the margin."""
    program = scenario("""
    human bob at (5, 7)
    robot cart at (1, 4) { controller navigator; speed 1 m/s; navigator.safety_margin 0.4 m }
    activity { bob move_to (5, 1) }
    activity { cart move_to (9, 4) within 40 s }
    """)
    sim = Simulation(program)
    gaps = []
    result = run_program(sim, [lambda s: gaps.append(
        math.dist(s.robot("cart").position, s.human("bob").position) - 0.3 - 0.2)])
    assert result.state is RunState.COMPLETED
    assert min(gaps) >= 0.4 - 0.05
    assert result.robots[0].last_status == "SUCCEEDED"


def test_robot_stand_follow_and_within(scenario: ScenarioFactory) -> None:
    program = scenario("""
    human alice at (2, 2)
    robot cart at (1, 6) { controller navigator; speed 1 m/s }
    activity { alice move_to (8, 2) }
    activity {
        cart stand for 2 s
        cart follow alice at 1 m for 6 s
        late: cart move_to (9, 7) within 0.5 s
    }
    """)
    result = Simulation(program)
    outcome = run_program(result)
    cart = [(e.kind, e.status, round(e.time, 2)) for e in outcome.events if e.human == "cart"]
    assert cart[:4] == [("stand", TaskStatus.ACTIVE, 0.0), ("stand", TaskStatus.SUCCEEDED, 2.0),
                        ("follow", TaskStatus.ACTIVE, 2.0),
                        ("follow", TaskStatus.SUCCEEDED, 8.0)]
    assert cart[-1][:2] == ("move_to", TaskStatus.ABORTED)
    assert outcome.state is RunState.FAILED
    assert "did not finish within 0.5 s" in outcome.reason


def test_robot_tasks_from_the_api(scenario: ScenarioFactory) -> None:
    sim = Simulation(scenario("robot cart at (2, 2) { controller navigator }\n"),
                     activities=False)
    cart = sim.robot("cart")
    task = cart.move_to((6.0, 2.0), speed=0.5)
    assert task.status is TaskStatus.ACTIVE and cart.task is task
    sim.run_until(lambda: sim.time >= 1.0)
    assert cart.velocity[0] == pytest.approx(0.5, abs=0.05)
    task.cancel()
    assert task.status is TaskStatus.PREEMPTED and cart.task is None
    with pytest.raises(SimulationError, match="robots take stand, move_to, follow, not talk"):
        cart.do("talk", duration=1.0)
    with pytest.raises(SimulationError, match="move_to takes no 'heading'"):
        cart.do("move_to", (3.0, 3.0), heading=1.0)


# ---- kinematics and limits ---------------------------------------------------------------------


def test_a_unicycle_turns_at_most_its_rate_and_drives_along_its_heading(
        scenario: ScenarioFactory) -> None:
    program = scenario("""robot r at (5, 4) heading 0 deg {
        controller external; kinematics unicycle; max_angular_speed 1.0; max_speed 0.5 m/s
    }\n""")
    recorder = Recorder(None, None, (2.0, 3.0))  # asks for 2 m/s and 3 rad/s
    sim = Simulation(program, activities=False, controllers={"r": recorder})
    headings = []
    for _ in range(10):
        sim.step()
        headings.append(sim.robot("r").heading)
    turns = np.diff([0.0, *headings])
    assert np.allclose(turns, 1.0 * sim.dt)
    vx, vy = sim.robot("r").velocity
    assert math.hypot(vx, vy) == pytest.approx(0.5)
    assert math.atan2(vy, vx) == pytest.approx(headings[-1])


def test_a_driven_robot_moves_as_its_controller_would_and_release_hands_it_back(
        scenario: ScenarioFactory) -> None:
    text = """robot r at (5, 4) heading 0 deg {
        controller external; kinematics unicycle; max_angular_speed 1.0; max_speed 0.5 m/s
    }\n"""
    recorder = Recorder(None, None, (0.4, 0.8))
    asked = Simulation(scenario(text), activities=False, controllers={"r": recorder})
    recorder_unused = Recorder(None, None, (0.0, 0.0))
    driven = Simulation(scenario(text), activities=False, controllers={"r": recorder_unused})
    driven.robot("r").drive(0.4, 0.8)
    for _ in range(15):
        asked.step()
        driven.step()
    # the same command through the same kinematics: the same motion, bit for bit
    assert driven.robot("r").position == asked.robot("r").position
    assert driven.robot("r").heading == asked.robot("r").heading
    assert recorder_unused.seen == []  # a driven robot's controller is not asked
    driven.robot("r").release()
    driven.step()
    assert len(recorder_unused.seen) == 1
    with pytest.raises(SimulationError, match="must be two finite numbers"):
        driven.robot("r").drive(math.nan, 0.0)


def test_a_velocity_set_moves_a_unicycle_as_given_facing_where_it_goes(
        scenario: ScenarioFactory) -> None:
    # it moved sideways at the velocity, its heading left at 0: a pose no unicycle can have
    def moved(kinematics: str) -> Simulation:
        sim = Simulation(scenario(f"""robot r at (5, 4) heading 0 deg {{
            controller external; kinematics {kinematics}; max_angular_speed 0.1
        }}\n"""), activities=False)
        sim.robot("r").set_velocity(0.0, 0.5)  # north, square to its heading
        for _ in range(10):
            sim.step()
        return sim

    sim = moved("unicycle")
    unicycle, holonomic = sim.robot("r"), moved("holonomic").robot("r")
    assert unicycle.position == holonomic.position == pytest.approx((5.0, 4.25))
    assert unicycle.heading == holonomic.heading == pytest.approx(math.pi / 2)
    assert unicycle.velocity == holonomic.velocity
    unicycle.release()
    unicycle.drive(0.5, 0.0)  # within its kinematics again: on along the heading it took
    sim.step()
    assert unicycle.position == pytest.approx((5.0, 4.25 + 0.5 * sim.dt))
    assert unicycle.heading == pytest.approx(math.pi / 2)


def test_a_robot_stuck_at_a_goal_someone_stands_on_says_who(
        scenario: ScenarioFactory) -> None:
    program = scenario("""
    human bob at (7, 4)
    robot cart at (2, 4) { controller navigator; speed 0.8 m/s }
    """)
    sim = Simulation(program, activities=False)
    sim.engine.stuck_time = 5.0
    sim.human("bob").stand(duration=100.0)
    task = sim.robot("cart").move_to((7.0, 4.0))
    sim.run_until(lambda: task.done, time_limit=60)
    # unlike a person, a robot does not count stopping beside its goal as arriving
    assert task.status is TaskStatus.ABORTED
    assert task.reason == "stuck: no progress for 5 s, its goal taken by bob"


def test_a_robot_waiting_on_its_way_is_no_one_gathered_at_a_walkers_goal(
        scenario: ScenarioFactory, tmp_path: Path) -> None:
    # face to face in a corridor, a robot that stopped to yield stood within 1.5 m of the
    # walker's goal: the walker "stopped short of a goal taken by cart", 2 m from its goal
    corridor = tmp_path / "corridor.yaml"
    save_map(room_grid(walls=((0.0, 0.0, 10.0, 3.5), (0.0, 4.5, 10.0, 8.0))), corridor)
    program = scenario("""
    human walker at (2, 4)
    robot cart at (7.4, 4) { controller external }
    """, corridor)
    sim = Simulation(program, activities=False)
    sim.engine.stuck_time = 30.0
    waiting = sim.robot("cart").move_to((1.0, 4.0))  # an external robot left at rest
    walk = sim.human("walker").move_to((8.0, 4.0))
    sim.run_until(lambda: sim.time >= 15.0)
    assert not walk.done and not waiting.done       # face to face, neither has got anywhere
    stand = sim.robot("cart").stand(duration=30.0)  # a robot standing is someone at the goal
    sim.run_until(lambda: walk.done, time_limit=25)
    assert not stand.done
    assert walk.reason == "stopped short of a goal taken by cart"


def test_acceleration_is_limited(scenario: ScenarioFactory) -> None:
    program = scenario("robot r at (2, 4) { controller external; max_acceleration 0.5 }\n")
    sim = Simulation(program, activities=False)
    sim.robot("r").set_velocity(1.0, 0.0)
    speeds = []
    for _ in range(20):
        sim.step()
        speeds.append(sim.robot("r").velocity[0])
    assert np.allclose(np.diff([0.0, *speeds]), 0.5 * sim.dt)


def test_no_robot_is_driven_through_a_wall(scenario: ScenarioFactory) -> None:
    sim = Simulation(scenario("robot r at (9, 4) { radius 0.3 m }\n"), activities=False)
    sim.robot("r").set_velocity(2.0, 0.0)  # straight at the east wall
    sim.run_until(lambda: sim.time >= 3.0)
    # as for people: the body may brush the wall, its centre keeps half its radius clear
    assert 9.0 < sim.robot("r").position[0] <= 10.0 - 0.05 - 0.3 / 2 + 1e-6


# ---- what a controller sees --------------------------------------------------------------------


def test_a_controller_sees_people_within_its_range_and_field_of_view(
        scenario: ScenarioFactory) -> None:
    program = scenario("""
    human ahead at (4, 4)
    human behind at (1, 4)
    human far at (9, 4)
    robot r at (2, 4) heading 0 deg {
        controller external; sensor_range 3 m; field_of_view 180 deg; goal (8, 6)
    }
    """)
    recorder = Recorder(None, None)
    sim = Simulation(program, activities=False, controllers={"r": recorder})
    sim.step()
    seen = recorder.seen[0]
    assert [p.name for p in seen.people] == ["ahead"]
    assert seen.people[0].radius == pytest.approx(0.2)
    assert seen.position == (2.0, 4.0) and seen.goal is None


# ---- errors in a controller are the controller's -----------------------------------------------


class Raising:
    def __init__(self, body: object, params: object) -> None:
        pass

    def command(self, observation: Observation) -> tuple[float, float]:
        if observation.time >= 1.0:
            raise ValueError("no map loaded")
        return (0.1, 0.0)


class Nonsense:
    def __init__(self, body: object, params: object) -> None:
        pass

    def command(self, observation: Observation) -> object:
        return "fast"


@pytest.mark.parametrize(("controller", "message"), [
    (Raising, r"robot 'r' at t = 1 s: its controller Raising raised ValueError: no map loaded"),
    (Nonsense, r"robot 'r' at t = 0 s: its controller Nonsense returned 'fast', not a velocity"),
])
def test_a_failing_controller_names_the_robot_the_time_and_the_cause(
        scenario: ScenarioFactory, controller: type, message: str) -> None:
    sim = Simulation(scenario("robot r at (2, 4) { controller external }\n"), activities=False,
                     controllers={"r": controller})
    with pytest.raises(ControllerError, match=message):
        sim.run_until(lambda: sim.time >= 3.0)


def _hubero(*args: str, cwd: Path, pythonpath: Path) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "PYTHONPATH": str(pythonpath)}
    return subprocess.run([sys.executable, "-m", "hubero_dsl", *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=120, check=False)


def _scenario_file(folder: Path, robot: str) -> Path:
    from hubero_dsl.world.mapfile import save_map

    save_map(room_grid(), folder / "room.yaml")
    file = folder / "robot.hub"
    file.write_text('scenario "plugin"\nmap "room.yaml"\n' + robot +
                    "activity { go: r move_to (6, 4) within 30 s }\n"
                    "expect go done eventually\n", encoding="utf-8")
    return file


def test_a_user_controller_that_raises_is_exit_1_not_an_internal_error(tmp_path: Path) -> None:
    (tmp_path / "my_nav.py").write_text(
        "class Broken:\n    def __init__(self, body, params):\n        pass\n"
        "    def command(self, observation):\n        raise RuntimeError('boom')\n")
    file = _scenario_file(tmp_path, "robot r at (2, 4) { controller external }\n")
    done = _hubero("run", str(file), "--controller", "r=my_nav:Broken", "-o",
                   str(tmp_path / "out.mcap"), cwd=tmp_path, pythonpath=tmp_path)
    assert done.returncode == 1, done.stderr
    assert "robot 'r' at t = 0 s: its controller Broken raised RuntimeError: boom" in done.stderr
    assert "internal error" not in done.stderr and "Traceback" not in done.stderr
    assert not (tmp_path / "out.mcap").exists()
    for where in ((), ("--out-dir", str(tmp_path / "logs"))):  # runs/, or the folder asked
        again = _hubero("run", str(file), "--controller", "r=my_nav:Broken", *where,
                        cwd=tmp_path, pythonpath=tmp_path)
        assert again.returncode == 1, again.stderr
    assert not (tmp_path / "runs").exists() and not (tmp_path / "logs").exists()


def test_a_plugin_controller_registered_by_entry_point_runs(tmp_path: Path) -> None:
    """A package that declares `[hubero.controllers] straight_drive = ...` in its metadata
    (as `pip install` would write it) is found by name, its parameters are checked, it runs."""
    site = install_straight_drive(tmp_path / "site")
    good = _scenario_file(tmp_path, "robot r at (2, 4) { controller straight_drive; "
                                    "straight_drive.gain 2 }\n")
    checked = _hubero("check", str(good), cwd=tmp_path, pythonpath=site)
    assert checked.returncode == 0, checked.stdout + checked.stderr
    ran = _hubero("test", str(good), cwd=tmp_path, pythonpath=site)
    assert ran.returncode == 0, ran.stdout + ran.stderr
    bad = _scenario_file(tmp_path, "robot r at (2, 4) { controller straight_drive; "
                                   "straight_drive.gain -1 }\n")
    refused = _hubero("check", str(bad), cwd=tmp_path, pythonpath=site)
    assert refused.returncode == 1 and "straight_drive.gain" in refused.stdout


# ---- the checker on robots' tasks and controllers -----------------------------------------------


@pytest.mark.parametrize(("body", "code"), [
    ("robot r at (2, 2) { controller navigator }\nactivity { r talk for 1 s }", "E109"),
    ("robot r at (2, 2) { path (2, 2) -> (3, 3) }\nactivity { r move_to (5, 5) }", "E109"),
    ("robot r at (2, 2) { controller navigator }\nactivity { r move_to (5, 5) heading 0 deg }",
     "E107"),
    ('robot r at (2, 2) { controller "os:system" }', "E110"),
    ("robot r at (2, 2) { controller navigatr }", "E110"),
    ("robot r at (2, 2) { kinematics tank }", "E201"),
])
def test_robot_mistakes_are_reported(room_map: Path, body: str, code: str) -> None:
    text = f'scenario "t"\nmap "{room_map}"\n{body}\n'
    assert code in {d.code for d in check_source(text, "t.hub").errors}


def test_a_robot_overlapping_a_person_never_pushes_them_through_a_wall(
        scenario: ScenarioFactory, tmp_path: Path) -> None:
    from hubero_dsl.world.mapfile import save_map

    thin = tmp_path / "thin.yaml"  # a 10 cm wall at x = 5
    save_map(room_grid(walls=((4.95, 0.0, 5.05, 8.0),)), thin)
    sim = Simulation(scenario("human alice at (5.3, 4)\nrobot r at (5.45, 4) { radius 0.4 m }\n",
                              map_path=thin), activities=False)
    xs = []
    for _ in range(20):
        sim.step()
        xs.append(sim.human("alice").position[0])
    assert min(xs) > 5.05


def test_a_scripted_path_through_a_wall_is_warned_about(room_map: Path, tmp_path: Path) -> None:
    from hubero_dsl.world.mapfile import save_map

    save_map(room_grid(walls=((4.9, 0.0, 5.1, 8.0),)), tmp_path / "walled.yaml")
    text = ('scenario "t"\nmap "walled.yaml"\n'
            "robot r at (2, 2) { path (2, 2) -> (8, 2) }\n")
    result = check_source(text, str(tmp_path / "t.hub"))
    (warning,) = [w for w in result.warnings if w.code == "W503"]
    assert "between (2, 2) and (8, 2)" in warning.message


@pytest.mark.parametrize(("y", "warned"), [(5.2, True), (5.4, False)])
def test_a_scripted_path_its_body_grazes_a_wall_along_is_warned_about(
        tmp_path: Path, y: float, warned: bool) -> None:
    from hubero_dsl.world.mapfile import save_map

    # a wall up to y = 5 and a robot of 0.3 m in radius driven along it at y
    save_map(room_grid(walls=((0.0, 4.0, 10.0, 5.0),)), tmp_path / "walled.yaml")
    text = ('scenario "t"\nmap "walled.yaml"\n'
            f"robot r at (2, 6.5) {{ radius 0.3 m; path (2, {y}) -> (8, {y}) }}\n")
    result = check_source(text, str(tmp_path / "t.hub"))
    assert result.program is not None
    found = [w.message for w in result.warnings if w.code == "W503"]
    assert bool(found) == warned, found
    if warned:
        assert f"less than its radius 0.3 m, between (2, 6.5) and (2, {y:g})" in found[0]


@pytest.mark.slow
def test_a_plugin_controller_installed_with_pip_in_a_venv(tmp_path: Path) -> None:
    """The whole way a user goes: a package declaring `[hubero.controllers]`, installed with
    pip into a virtual environment, named in a scenario and run by that environment's hubero."""
    package = tmp_path / "pkg"
    (package / "waypointer").mkdir(parents=True)
    (package / "pyproject.toml").write_text(
        '[build-system]\nrequires = ["setuptools"]\nbuild-backend = "setuptools.build_meta"\n'
        '[project]\nname = "waypointer"\nversion = "0.1"\n'
        '[project.entry-points."hubero.controllers"]\nwaypointer = "waypointer:Waypointer"\n')
    (package / "waypointer" / "__init__.py").write_text(
        "from hubero_dsl.controllers.base import ControllerParams\n"
        "class Waypointer:\n    Params = ControllerParams\n"
        "    def __init__(self, body, params):\n        self.body = body\n"
        "    def command(self, observation):\n"
        "        if observation.goal is None:\n            return (0.0, 0.0)\n"
        "        dx = observation.goal[0] - observation.position[0]\n"
        "        dy = observation.goal[1] - observation.position[1]\n"
        "        d = max((dx * dx + dy * dy) ** 0.5, 1e-9)\n"
        "        return (0.5 * dx / d, 0.5 * dy / d)\n")
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True, timeout=120)
    python = venv / "bin" / "python"
    # the new environment sees this one's packages (hubero among them) beneath its own
    purelib = subprocess.run([str(python), "-c", "import sysconfig; print(sysconfig."
                              "get_paths()['purelib'])"], capture_output=True, text=True,
                             check=True).stdout.strip()
    (Path(purelib) / "outer.pth").write_text(
        f"import site; site.addsitedir({sysconfig.get_paths()['purelib']!r})\n")
    installed = subprocess.run([str(python), "-m", "pip", "install", "--quiet", "--no-deps",
                                str(package)],
                               capture_output=True, text=True, timeout=300, check=False)
    if installed.returncode != 0:
        pytest.skip(f"the package could not be built here: {installed.stderr[-300:]}")
    file = _scenario_file(tmp_path, "robot r at (2, 4) { controller waypointer }\n")
    done = subprocess.run([str(python), "-m", "hubero_dsl", "test", str(file)], cwd=tmp_path,
                          capture_output=True, text=True, timeout=120, check=False)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "1 passed, 0 failed" in done.stdout


@pytest.mark.parametrize(("robot_at", "warned"), [("(2.0, 2.0)", True), ("(2.45, 2.0)", True),
                                                  ("(2.5, 2.0)", False)])
def test_bodies_placed_on_each_other_are_warned_about(room_map: Path, robot_at: str,
                                                      warned: bool) -> None:
    text = (f'scenario "t"\nmap "{room_map}"\nhuman h at (2.0, 2.0)\n'
            f"robot r at {robot_at} {{ radius 0.3 m }}\n")
    result = check_source(text, "t.hub")
    found = [w for w in result.warnings if w.code == "W504"]
    assert bool(found) == warned
    if warned:
        assert found[0].message.startswith("the start of robot 'r' overlaps the start of 'h'")
        assert found[0].span is not None and found[0].span.line == 4


@pytest.mark.parametrize(("declared", "warned"), [("", True), (" { controller external }", False),
                                                  (" { controller navigator }", False)])
def test_tasks_for_a_robot_that_names_no_controller_are_warned_about(
        room_map: Path, declared: str, warned: bool) -> None:
    text = (f'scenario "t"\nmap "{room_map}"\nrobot cart at (2, 2){declared}\n'
            "activity { cart move_to (6, 2) within 30 s; cart stand for 2 s }\n")
    found = [w for w in check_source(text, "t.hub").warnings if w.code == "W505"]
    assert len(found) == int(warned)   # once per robot, at its first task
    if warned:
        assert found[0].span is not None and found[0].span.line == 4


@pytest.mark.parametrize(("robot_at", "moving", "kept"), [
    ((6.5, 4.0), True, 1.0), ((5.0, 5.5), False, 1.0), ((9.0, 7.0), True, 0.2)])
def test_a_walker_squeezing_past_people_keeps_its_whole_push_near_a_robot(
        scenario: ScenarioFactory, robot_at: tuple[float, float], moving: bool, kept: float
        ) -> None:
    # squeezing past people standing, a walker keeps a fifth of its push from everyone: near a
    # robot, on the move or at rest, all of it, so that it never squeezes into the robot
    program = scenario(f"""
    human w at (5, 4)
    human t at (5.7, 4)
    robot r at {robot_at} {{ controller external }}
    """)
    sim = Simulation(program, activities=False)
    sim.human("t").stand(duration=60.0)
    sim.human("w").move_to((9.0, 4.0))
    sim.robot("r").set_velocity(0.0, 0.5 if moving else 0.0)
    sim.step()
    engine = sim.engine
    assert engine.squeeze_round_standing(0, 3.0, 3.0)
    drive = engine._drive(np.array([0]))
    assert drive.avoidance_strength[0] == pytest.approx(kept)
