"""Someone pushed back behind a door's jamb after passing the corner of their path walks to
the corner again, instead of pressing into the wall (the social force's goal straight into
it, the jamb's corner pushing them back) until the run gives them up as stuck; someone pushed
off their path far from its corners plans anew; and of two who hold each other up at a narrow
way, one steps aside."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from hubero_dsl.pipeline import compile_source
from hubero_dsl.sim.arrays import PathPool
from hubero_dsl.sim.simulation import Simulation
from hubero_dsl.sim.status import TaskStatus
from hubero_dsl.world.mapfile import save_map
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


def test_who_is_sent_back_nowhere_is_told() -> None:
    pool = walking(THROUGH, 2)
    lost = pool.retreat(np.array([0]), np.array([(2.5, 3.5)]), DOOR.crosses_obstacle, REACH)
    assert lost.tolist() == [0] and pool.cursor[0] == 2   # the corner is out of reach
    lost = pool.retreat(np.array([0]), np.array([BEHIND_THE_JAMB]), DOOR.crosses_obstacle,
                        REACH)
    assert lost.size == 0 and pool.cursor[0] == 1         # sent back to the corner


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


# a room with a corridor 1 m wide (y 3.5 .. 4.5) from x = 8 to 14, its mouth flush with a wall
CORRIDOR = room_grid(20.0, 8.0, walls=((8.0, 0.0, 14.0, 3.5), (8.0, 4.5, 14.0, 8.0)))


def _through_the_corridor(tmp_path: Path, humans: str, goals: dict[str, float]) -> Simulation:
    """`humans` walking through CORRIDOR to x = 17 and their own `goals`' y."""
    save_map(CORRIDOR, tmp_path / "corridor.yaml")
    steps = "\n".join(f"{name} move_to (17.0, {y})" for name, y in goals.items())
    text = (f'scenario "mouth"\nmap "{tmp_path / "corridor.yaml"}"\ntime_limit 90 s\n'
            f"{humans}activity {{ parallel {{\n{steps}\n}} }}\n")
    return Simulation(compile_source(text, "mouth.hub"))


def _ends(sim: Simulation) -> list[tuple[str, TaskStatus, float]]:
    from hubero_dsl.sim.loop import run_program

    return sorted((e.human, e.status, e.time) for e in run_program(sim).events
                  if e.status.is_final)


@pytest.mark.parametrize("spacing", [0.35, 0.7])
def test_three_abreast_all_get_through_a_corridors_mouth(tmp_path: Path, spacing: float
                                                         ) -> None:
    # the middle one walks in; the two beside it, pushed off their paths as they set out,
    # stood as each other's mirror image at the jambs until both were given up as stuck
    humans = "".join(f"human {name} at (3.0, {4.0 + k * spacing})\n"
                     for name, k in (("a", -1), ("b", 0), ("c", 1)))
    ends = _ends(_through_the_corridor(tmp_path, humans, {"a": 3.0, "b": 4.0, "c": 5.0}))
    assert [status for _, status, _ in ends] == [TaskStatus.SUCCEEDED] * 3
    assert max(time for _, _, time in ends) < 30.0


def test_two_mirror_images_at_a_corridors_mouth_take_turns(tmp_path: Path) -> None:
    humans = "human a at (7.0, 3.6)\nhuman c at (7.0, 4.4)\n"
    ends = _ends(_through_the_corridor(tmp_path, humans, {"a": 3.0, "c": 5.0}))
    assert [status for _, status, _ in ends] == [TaskStatus.SUCCEEDED] * 2
    assert max(time for _, _, time in ends) < 30.0
