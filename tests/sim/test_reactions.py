"""Humans' reactions to robots, each tested for the behaviour it names: a robot drives along
y = 4 while a person crosses its way (from (5, 7) to (5, 1)) or walks at it head-on."""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import pytest

from hubero_dsl.pipeline import check_source, compile_source
from hubero_dsl.sim.loop import run_program
from hubero_dsl.sim.simulation import Simulation

CROSSING = ("human h at (5, 7)\n", "h move_to (5, 1)")
HEAD_ON = ("human h at (9, 4.2)\n", "h move_to (1, 4.2)")


def _run(room_map: Path, reaction: str, setup: tuple[str, str]
         ) -> list[tuple[float, float, float, float]]:
    """(surface gap, speed, heading error towards the robot, time) at every tick."""
    human, task = setup
    text = (f'scenario "r"\nmap "{room_map}"\ntime_limit 15 s\n{human}'
            "robot r at (1, 4) { speed 0.8 m/s; path (1, 4) -> (9, 4); radius 0.3 m }\n"
            f"defaults {{ robot_reaction {reaction} }}\nactivity {{ {task} }}\n")
    sim = Simulation(compile_source(text, str(room_map.parent / "t.hub")))
    samples = []

    def observe(s: Simulation) -> None:
        (hx, hy), (rx, ry) = s.human("h").position, s.robot("r").position
        bearing = math.atan2(ry - hy, rx - hx)
        error = abs(math.remainder(bearing - s.human("h").heading, math.tau))
        samples.append((math.hypot(rx - hx, ry - hy) - 0.5,
                        math.hypot(*s.human("h").velocity), error, s.time))

    run_program(sim, [observe])
    return samples


def _closest(samples: list[tuple[float, float, float, float]]) -> float:
    return min(gap for gap, *_ in samples)


@pytest.mark.parametrize("setup", [CROSSING, HEAD_ON], ids=["crossing", "head-on"])
def test_a_scared_person_keeps_a_wider_distance(room_map: Path,
                                                setup: tuple[str, str]) -> None:
    assert _closest(_run(room_map, "scared", setup)) > \
        _closest(_run(room_map, "regular", setup)) + 0.5


def test_an_impassive_person_ignores_the_robot_until_contact(room_map: Path) -> None:
    regular, impassive = (_closest(_run(room_map, r, HEAD_ON)) for r in ("regular",
                                                                           "impassive"))
    assert impassive < regular and impassive > -0.05  # close to contact, no overlap


def test_a_surprised_person_stops_and_faces_the_robot(room_map: Path) -> None:
    samples = _run(room_map, "surprised", CROSSING)
    first = next(i for i, (gap, *_) in enumerate(samples) if gap < 1.5)
    stopped = samples[first + 1:first + 35]        # the 2 s that follow, but the last tick
    assert all(speed < 1e-9 for _, speed, _, _ in stopped)
    assert stopped[-1][2] < 0.3                     # turned to look at the robot
    assert max(speed for _, speed, _, _ in samples[first + 60:]) > 0.5  # then carries on


def test_a_curious_person_approaches_the_robot(room_map: Path) -> None:
    assert _closest(_run(room_map, "curious", CROSSING)) < \
        _closest(_run(room_map, "regular", CROSSING)) - 0.5


def test_a_threatening_person_steps_into_the_robots_way(room_map: Path) -> None:
    regular = _closest(_run(room_map, "regular", CROSSING))
    threatening = _run(room_map, "threatening", CROSSING)
    assert _closest(threatening) < regular - 0.8
    assert _closest(threatening) > -0.05


@pytest.mark.parametrize("reaction", ["curious", "threatening"])
@pytest.mark.parametrize("setup", [CROSSING, HEAD_ON], ids=["crossing", "head-on"])
def test_a_reaction_changes_a_walk_as_a_person_could(room_map: Path, reaction: str,
                                                     setup: tuple[str, str]) -> None:
    """Out of contact, a person sent somewhere by its reaction speeds up, turns and stops at
    a walker's accelerations: set outright, the velocity a threatening person wanted ahead of
    a turning robot reversed within a tick, at tens of m/s^2."""
    human, task = setup
    text = (f'scenario "r"\nmap "{room_map}"\ntime_limit 15 s\n{human}'
            "robot r at (1, 4) { speed 0.8 m/s; path (1, 4) -> (9, 4); radius 0.3 m }\n"
            f"defaults {{ robot_reaction {reaction} }}\nactivity {{ {task} }}\n")
    sim = Simulation(compile_source(text, str(room_map.parent / "t.hub")))
    samples: list[tuple[float, tuple[float, float]]] = []

    def observe(s: Simulation) -> None:
        gap = math.dist(s.human("h").position, s.robot("r").position) - 0.5
        samples.append((gap, s.human("h").velocity))

    run_program(sim, [observe])
    for (gap, (vx, vy)), (next_gap, (wx, wy)) in itertools.pairwise(samples):
        if min(gap, next_gap) > 0.3:  # a touch, or the robot's push at close range, aside
            # m/s^2: a walker's pace, and the social force's push from the robot near it
            assert math.hypot(wx - vx, wy - vy) / sim.dt < 5.0


def test_an_unknown_reaction_is_reported(room_map: Path) -> None:
    text = f'scenario "r"\nmap "{room_map}"\nhuman h at (5, 5) {{ robot_reaction scard }}\n'
    (error,) = check_source(text, "t.hub").errors
    assert error.code == "E201" and error.hint == "did you mean 'scared'?"


def test_a_threatening_person_gives_up_after_a_while(room_map: Path) -> None:
    """Against a robot that drives on whatever is in its way, a threatening person blocks it
    for 40 s of the encounter (HuNavSim's timer), then walks its own way again."""
    text = (f'scenario "r"\nmap "{room_map}"\ntime_limit 90 s\nhuman h at (2, 6)\n'
            "robot r at (1, 4) { speed 0.3 m/s; path (1, 4) -> (9, 4) -> (1, 4) loop; "
            "radius 0.3 m }\n"
            "defaults { robot_reaction threatening }\nactivity { h move_to (8, 7) }\n")
    result = run_program(Simulation(compile_source(text, str(room_map.parent / "t.hub"))))
    (done,) = [e for e in result.events if e.human == "h" and e.status.is_final]
    assert done.status.value == "SUCCEEDED" and done.time > 40.0
