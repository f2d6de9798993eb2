"""The Python API refuses what a scenario file may not say, when it is said, in words: a
`SimulationError` at the call, never a numpy or Python error a tick later, nor a task that
turns for ever."""

from __future__ import annotations

import math
from collections.abc import Callable
from decimal import Decimal
from fractions import Fraction
from pathlib import Path
from typing import Any

import pytest

from hubero_dsl.errors import InputError, SimulationError
from hubero_dsl.pipeline import compile_file
from hubero_dsl.sim.handles import HumanHandle
from hubero_dsl.sim.loop import run_program
from hubero_dsl.sim.simulation import Simulation

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def program() -> Any:
    return compile_file(ROOT / "scenarios" / "living_room.hub")


@pytest.fixture
def sim(program: Any) -> Simulation:
    return Simulation(program, activities=False)


MISUSES: dict[str, tuple[Callable[[HumanHandle], object], str]] = {
    "a heading of nan": (lambda a: a.move_to((5.5, 2.4), heading=math.nan),
                         "heading must be a finite number of at most 10000 rad"),
    "a heading in words": (lambda a: a.move_to((5.5, 2.4), heading="north"), "heading must"),
    "a duration of inf": (lambda a: a.stand(duration=math.inf), "at most 1e\\+06 s"),
    "a duration of 1e300": (lambda a: a.stand(duration=1e300), "at most 1e\\+06 s"),
    "a duration in words": (lambda a: a.stand(duration="5"), "duration must"),
    "a speed of 1e6": (lambda a: a.move_to((0.6, -2.0), speed=1e6), "at most 100 m/s"),
    "a point near 1e308": (lambda a: a.move_to((1e308, -1e308)), "a point \\(x, y\\)"),
    "a number for a point": (lambda a: a.move_to(5), "a point \\(x, y\\)"),
    "three numbers": (lambda a: a.move_to((1, 2, 3)), "a point \\(x, y\\)"),
    "complex numbers": (lambda a: a.move_to((1j, 2)), "a point \\(x, y\\)"),
    "a list for an area": (lambda a: a.move_around(area=[(0, 0), (1, 0), (1, 1)]),
                           "shapely Polygon"),
    "times of 2.5": (lambda a: a.move_around(times=2.5), "whole number"),
    "a velocity in words": (lambda a: a.set_velocity("1", 0), "two finite numbers"),
    "a velocity of truth values": (lambda a: a.set_velocity(True, 0), "two finite numbers"),
    "a Decimal NaN": (lambda a: a.set_velocity(Decimal("NaN"), 0), "two finite numbers"),
    "a Fraction beyond a float": (lambda a: a.stand(duration=Fraction(10 ** 400)),
                                  "at most 1e\\+06 s"),
    "a place to follow": (lambda a: a.follow("sofa"), "needs a human or robot, not a place"),
    "talking to oneself": (lambda a: a.talk(to="actor1"), "actor1 cannot talk to itself"),
}


@pytest.mark.parametrize(("misuse", "said"), MISUSES.values(), ids=MISUSES.keys())
def test_a_misused_call_is_refused_in_words_when_made(
        sim: Simulation, misuse: Callable[[HumanHandle], object], said: str) -> None:
    with pytest.raises(SimulationError, match=said):
        misuse(sim.human("actor1"))
    sim.step()  # nothing was half given: the world goes on


def test_numbers_of_any_real_type_are_taken_as_a_file_takes_numbers(sim: Simulation) -> None:
    # a Fraction or a Decimal was refused as no finite number
    actor = sim.human("actor1")
    walk = actor.move_to((Fraction(11, 2), Decimal("2.4")), speed=Decimal("0.8"))
    assert walk.status.value == "ACTIVE" and walk.description == "move_to (5.5, 2.4)"
    stand = actor.stand(duration=Fraction(3, 2), facing="sofa")
    assert stand.status.value == "ACTIVE" and stand.description == "stand facing sofa"
    actor.set_velocity(Decimal("0.1"), Fraction(1, 3))
    sim.step()


def test_a_removed_human_takes_no_more_tasks_and_a_typo_is_no_removal(sim: Simulation) -> None:
    sim.remove("actor1")
    with pytest.raises(SimulationError, match="actor1 was removed"):
        sim.human("actor1").move_to((0.6, -2.0))
    with pytest.raises(SimulationError, match="no human or robot named 'nobody'"):
        sim.remove("nobody")


@pytest.mark.parametrize("seed", [-1, 1.5, "x", True, 10 ** 18])
def test_a_seed_that_is_no_seed_is_refused(program: Any, seed: object) -> None:
    with pytest.raises(SimulationError, match="a seed is a whole number"):
        Simulation(program, seed=seed)  # type: ignore[arg-type]


def test_running_the_activities_of_a_simulation_made_without_them_is_refused(
        sim: Simulation) -> None:
    with pytest.raises(SimulationError, match="activities=False"):
        run_program(sim)


def test_a_controller_that_is_no_controller_is_refused_when_handed_over() -> None:
    program = compile_file(ROOT / "scenarios" / "robot_among_guests.hub")
    robot = program.robots[0].name
    with pytest.raises(InputError, match="command\\(observation\\) method"):
        Simulation(program, controllers={robot: 5})  # type: ignore[dict-item]
