"""Someone pushed back behind a door's jamb after passing the corner of their path walks to
the corner again, instead of pressing into the wall (the social force's goal straight into
it, the jamb's corner pushing them back) until the run gives them up as stuck."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from hubero_dsl.pipeline import compile_source
from hubero_dsl.sim.arrays import PathPool
from hubero_dsl.sim.simulation import Simulation
from hubero_dsl.sim.status import TaskStatus
from tests.sim.conftest import room_grid

REPO_ROOT = Path(__file__).resolve().parents[2]

# a wall along y = 4 with a door from x = 4 to 6
DOOR = room_grid(walls=((0.0, 3.95, 4.0, 4.05), (6.0, 3.95, 10.0, 4.05)))
THROUGH = np.array([[2.0, 1.0], [4.4, 3.6], [4.5, 7.5]])  # start, the door's corner, goal
BEHIND_THE_JAMB = (3.7, 3.45)
REACH = 1.5


def walking(path: np.ndarray, cursor: int) -> PathPool:
    pool = PathPool(1)
    pool.set_path(0, path)
    pool.cursor[0] += cursor
    return pool


def sent_back(position: tuple[float, float]) -> PathPool:
    pool = walking(THROUGH, 2)
    pool.retreat(np.array([0]), np.array([position]), DOOR.crosses_obstacle, REACH)
    return pool


def test_a_hidden_target_sends_one_back_to_the_corner_nearby() -> None:
    assert sent_back(BEHIND_THE_JAMB).cursor[0] == 1
    assert sent_back(BEHIND_THE_JAMB).careful[0]
    assert sent_back((4.5, 3.5)).cursor[0] == 2       # the goal in sight: left as it is
    assert sent_back((2.5, 3.5)).cursor[0] == 2       # the corner 1.9 m away: out of reach


def test_nobody_is_sent_back_to_where_they_started() -> None:
    pool = walking(THROUGH[[0, 2]], 1)  # the goal straight from the start
    pool.retreat(np.array([0]), np.array([[2.0, 1.5]]), DOOR.crosses_obstacle, REACH)
    assert pool.cursor[0] == 1


def test_the_corner_gone_back_to_is_passed_once_past_it_is_in_sight() -> None:
    pool = sent_back(BEHIND_THE_JAMB)
    pool.advance(np.array([[3.9, 3.5]]), 0.6, DOOR.crosses_obstacle)
    assert pool.cursor[0] == 1           # within the look-ahead, the goal behind the wall
    pool.advance(np.array([[4.2, 3.5]]), 0.6, DOOR.crosses_obstacle)
    assert pool.cursor[0] == 2 and not pool.careful[0]


def test_a_corner_is_passed_within_the_look_ahead_by_whoever_was_not_sent_back() -> None:
    pool = walking(THROUGH, 1)
    pool.advance(np.array([[3.9, 3.5]]), 0.6, DOOR.crosses_obstacle)
    assert pool.cursor[0] == 2  # the crowds' way through doors, which the fitted values match


def behind_the_jamb(others: str = "") -> Simulation:
    """Someone walking north through the car park's dividing wall's door (x 1.0 .. 3.2),
    pushed behind its west jamb just after passing the door's corner, with `others`."""
    text = (f'scenario "jamb"\nmap "{REPO_ROOT / "maps" / "parking.yaml"}"\n'
            f"human h at (0, 2)\n{others}activity {{ h move_to (0.3, 18.8) }}\n")
    sim = Simulation(compile_source(text, "jamb.hub"))
    paths, humans = sim.engine.paths, sim.engine.humans
    sim.step()
    while paths.end[0] - paths.cursor[0] > 1:  # the door's corner passed
        sim.step()
    assert humans.position[0, 1] < 3.9
    humans.position[0] = (0.73, 3.42)  # as if pushed there by people coming through
    humans.velocity[0] = (0.0, 0.0)
    return sim


def test_someone_pushed_behind_the_jamb_walks_round_it() -> None:
    # the goal's pull (north-west, into the wall) slid them west along it: 29 of the 604
    # people of a 10-minute flow of 1/s through the door were aborted there
    sim = behind_the_jamb()
    ended = (TaskStatus.SUCCEEDED, TaskStatus.ABORTED)
    while sim.time < 40.0 and not any(e.status in ended for e in sim.events):
        sim.step()
    assert [e.status for e in sim.events if e.status in ended] == [TaskStatus.SUCCEEDED]
    assert sim.time < 25.0   # aborted as stuck at t = 22.2 s before


def test_in_a_crowd_nobody_is_sent_back() -> None:
    sim = behind_the_jamb("human a at (0.1, 3.2)\nhuman b at (0.7, 2.7)\n"
                          "human c at (1.3, 3.0)\n")
    start, engine = sim.time, sim.engine
    while sim.time < start + 8.0:
        sim.step()
        assert not engine.paths.careful[0]
    assert (engine.tick - engine.anchor_tick[0]) * engine.dt > 5.0  # stalled all along
