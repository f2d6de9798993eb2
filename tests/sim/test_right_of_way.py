"""Two streams jammed head-on in a narrow place take turns (`hubero_dsl.sim.right_of_way`)."""

from __future__ import annotations

import math
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

from hubero_dsl.log.reader import load_run
from hubero_dsl.model.program import Program
from hubero_dsl.pipeline import compile_source
from hubero_dsl.sim import right_of_way, ways_round
from hubero_dsl.sim.arrays import PathPool
from hubero_dsl.sim.loop import run_program
from hubero_dsl.sim.right_of_way import RightOfWay, _points_aside
from hubero_dsl.sim.simulation import Simulation
from hubero_dsl.sim.status import TaskStatus
from hubero_dsl.simulate import simulate
from hubero_dsl.world.mapfile import save_map
from tests.sim.conftest import room_grid

DT = 0.05
# two halls of 12 m x 10 m joined by a door 1.2 m wide (y 4.4 .. 5.6) in a wall 0.2 m thick
HALLS_WALLS = ((12.0, 0.0, 12.2, 4.4), (12.0, 5.6, 12.2, 10.0))


@pytest.fixture(scope="module")
def halls_map(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("halls") / "halls.yaml"
    save_map(room_grid(24.2, 10.0, HALLS_WALLS), path)
    return path


def _two_way(halls_map: Path) -> Program:
    return compile_source(f"""
    scenario "two streams through one door"
    map "{halls_map}"
    seed 1
    time_limit 5 min
    flow east from rect((0.5, 0.5), (3.0, 9.5)) to (23.0, 5.0) rate 20 /min for 1 min
    flow west from rect((21.2, 0.5), (23.7, 9.5)) to (1.0, 5.0) rate 20 /min for 1 min
    """, "two_way.hub")


def _finals(sim: Simulation) -> dict[str, TaskStatus]:
    return {e.human: e.status for e in sim.events if e.status.is_final}


def test_two_streams_through_a_door_take_turns_and_all_get_through(halls_map: Path,
                                                                    tmp_path: Path) -> None:
    seen = {"jams": 0, "waiting": 0}

    def watch(s: Simulation) -> None:
        turns = s.engine.right_of_way
        seen["jams"] = max(seen["jams"], len(turns._jams))
        seen["waiting"] = max(seen["waiting"], len(turns.waiting))

    log = tmp_path / "two_way.mcap"
    result = simulate(_two_way(halls_map), log=log, observers=[watch])
    finals = {e.human: e.status for e in result.events if e.status.is_final}
    came = {e.human for e in result.events if e.status is TaskStatus.ACTIVE}
    assert result.state.value == "completed"
    assert len(came) > 30 and set(finals) == came
    assert set(finals.values()) == {TaskStatus.SUCCEEDED}   # nobody given up as stuck
    assert seen["jams"] >= 1 and seen["waiting"] >= 3       # the streams met, and took turns
    # the log says who waited: their behaviour state reads giving_way meanwhile
    run = load_run(log)
    waited = [name for name, track in run.humans.items() if "giving_way" in track.fsm_state]
    assert len(waited) >= 3
    for name in waited:
        assert run.humans[name].fsm_state[-1] != "giving_way"   # and each walked on


def test_without_turns_the_two_streams_lock_up_in_the_door(
        halls_map: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # the case the turns are for: the social force alone holds both streams pressed together
    monkeypatch.setattr(RightOfWay, "look", lambda self, rows: None)
    sim = Simulation(_two_way(halls_map))
    run_program(sim)
    stuck = [h for h, status in _finals(sim).items() if status is TaskStatus.ABORTED]
    assert len(stuck) >= 10


# ---- one look at a time, on a stand-in engine --------------------------------------------

def _engine(positions: list[tuple[float, float]], goals: list[tuple[float, float]],
            stalled: bool = True,
            walls: tuple[tuple[float, float, float, float], ...] = HALLS_WALLS) -> Any:
    """An engine's worth of what taking turns reads and writes: walkers at `positions`, each
    with a straight path to its goal, stalled for longer than STALLED s when `stalled`, in
    the halls (or a room of the same size with `walls`)."""
    count = len(positions)
    grid = room_grid(24.2, 10.0, walls)
    paths = PathPool(count)
    for row, (here, goal) in enumerate(zip(positions, goals, strict=True)):
        paths.set_path(row, np.array([here, goal], dtype=np.float64))
    tick = 1000
    humans = SimpleNamespace(position=np.array(positions, dtype=np.float64),
                             goal=np.array(goals, dtype=np.float64),
                             radius=np.full(count, 0.25), with_group=np.zeros(count, bool),
                             moving=np.ones(count, bool), count=count)
    planned: list[int] = []

    def plan_path(index: int, goal: tuple[float, float],
                  via: tuple[float, float] | None = None) -> str | None:
        planned.append(index)
        paths.set_path(index, np.array([humans.position[index], goal]))
        return None

    def plan_to_goal(index: int) -> str | None:
        goal = humans.goal[index]
        return plan_path(index, (float(goal[0]), float(goal[1])))

    def in_sight(a: tuple[float, float], b: tuple[float, float]) -> bool:
        return not bool(grid.crosses_obstacle(np.array([a]), np.array([b]))[0])

    stalled_since = tick - round((ways_round.STALLED + 1.0) / DT) if stalled else tick
    return SimpleNamespace(
        humans=humans, paths=paths, grid=grid, tick=tick, planned=planned,
        anchor=humans.position.copy(), anchor_tick=np.full(count, stalled_since, np.int64),
        ticks=lambda seconds: max(0, round(seconds / DT)), plan_path=plan_path,
        plan_to_goal=plan_to_goal, groups={},
        fits=lambda index, point: grid.clearance_at_point(*point) > 0.25, in_sight=in_sight)


def _one_east_two_west() -> Any:
    """An engine with one eastbound walker stalled at the door's west side and two westbound
    in the doorway and behind it: the westbound go first, the eastbound one waits."""
    return _engine([(11.6, 5.0), (12.7, 5.0), (13.5, 4.6)],
                   [(23.0, 5.0), (1.0, 5.0), (1.0, 5.0)])


def test_head_on_in_a_door_is_a_jam_at_the_door_and_the_larger_stream_goes_first() -> None:
    # two stalled face to face in the door; two more behind the westbound one, one behind
    # the eastbound one
    engine = _engine([(11.6, 5.0), (12.7, 5.0), (13.5, 4.6), (14.2, 5.4), (10.8, 5.2)],
                     [(23.0, 5.0), (1.0, 5.0), (1.0, 5.0), (1.0, 5.0), (23.0, 5.0)])
    turns = RightOfWay(engine)
    turns.look(np.arange(5))
    (jam,) = turns._jams
    assert 12.0 <= jam.centre[0] <= 12.2 and 4.4 < jam.centre[1] < 5.6   # in the doorway
    assert jam.way[0] < -0.9                       # the westbound three go first
    assert set(jam.waiting) == {0, 4}              # the eastbound two wait
    for row in (0, 4):   # ... stepped back from the door, to their right (south)
        aside = engine.paths.waypoints(row)[-1]
        assert aside[0] < engine.humans.position[row, 0] and aside[1] < 5.0
    assert engine.paths.waypoints(1)[-1].tolist() == [1.0, 5.0]   # the others walk on


def test_a_wait_is_not_being_stuck_and_the_turn_passes_once_the_door_is_clear() -> None:
    engine = _one_east_two_west()
    turns = RightOfWay(engine)
    turns.look(np.arange(3))
    assert set(turns.waiting) == {0}
    engine.tick += engine.ticks(ways_round.LOOK_AGAIN)
    turns.look(np.arange(3))
    assert engine.anchor_tick[0] == engine.tick    # its stuck time starts again
    # the westbound two have come through and walk away west: the turn is the eastbound's
    engine.humans.position[1:] = [(9.0, 5.0), (8.0, 4.6)]
    engine.tick += engine.ticks(ways_round.LOOK_AGAIN)
    turns.look(np.arange(3))
    assert not turns.waiting and engine.planned == [0]
    assert engine.paths.waypoints(0)[-1].tolist() == [23.0, 5.0]


def test_the_next_stream_waits_until_the_last_of_the_other_has_come_out_of_the_door() -> None:
    engine = _one_east_two_west()
    turns = RightOfWay(engine)
    turns.look(np.arange(3))
    (jam,) = turns._jams
    assert set(turns.waiting) == {0}
    # the last westbound one has passed the middle of the door, but is still in it
    engine.humans.position[1:] = [(jam.centre[0] - 0.4, 5.0), (8.0, 4.6)]
    engine.tick += engine.ticks(ways_round.LOOK_AGAIN)
    turns.look(np.arange(3))
    assert jam.way[0] > 0.9 and set(jam.cleared) == {0} and not engine.planned
    engine.humans.position[1] = (jam.centre[0] - 1.5, 5.0)   # out, and walking away
    engine.tick += engine.ticks(ways_round.LOOK_AGAIN)
    turns.look(np.arange(3))
    assert not turns.waiting and engine.planned == [0]


def test_facing_each_other_through_a_wall_is_no_jam() -> None:
    engine = _engine([(11.6, 8.0), (12.6, 8.0)], [(23.0, 8.0), (1.0, 8.0)])
    turns = RightOfWay(engine)
    turns.look(np.arange(2))
    assert not turns._jams


def test_walkers_who_make_progress_are_no_jam() -> None:
    engine = _engine([(11.6, 5.0), (12.7, 5.0)], [(23.0, 5.0), (1.0, 5.0)], stalled=False)
    turns = RightOfWay(engine)
    turns.look(np.arange(2))
    assert not turns._jams


def test_the_places_to_wait_are_off_the_oncomings_line_to_ones_right_first() -> None:
    here, way, centre = np.array([10.0, 5.0]), np.array([1.0, 0.0]), np.array([12.0, 5.0])
    points = _points_aside(here, way, centre)
    first = points[0]
    assert first[0] < here[0] and first[1] < here[1]   # back, and to the right of going east
    assert math.dist(first, here) == pytest.approx(right_of_way.ASIDE)
    assert any(p[1] > here[1] for p in points)          # the left when the right is walled
    assert points[-1][1] == here[1] and points[-1][0] < here[0]   # straight back, last


def test_points_ahead_follow_a_path_through_its_waypoints() -> None:
    paths = PathPool(2)
    paths.set_path(0, np.array([[0.0, 0.0], [3.0, 0.0], [3.0, 4.0]]))
    paths.set_path(1, np.array([[0.0, 0.0], [1.0, 0.0]]))
    position = np.zeros((2, 2))
    assert paths.points_ahead(np.arange(2), position, 2.0).tolist() == [[2.0, 0.0],
                                                                          [1.0, 0.0]]
    assert paths.points_ahead(np.array([0]), position, 5.0).tolist() == [[3.0, 2.0]]
    assert paths.points_ahead(np.array([0]), position, 9.0).tolist() == [[3.0, 4.0]]


def test_in_the_open_a_jam_is_centred_between_the_two() -> None:
    engine = _engine([(5.0, 5.0), (6.0, 5.0)], [(23.0, 5.0), (1.0, 5.0)])
    turns = RightOfWay(engine)
    turns.look(np.arange(2))
    (jam,) = turns._jams
    assert jam.centre.tolist() == [5.5, 5.0]


def test_members_of_a_group_take_no_turns() -> None:
    engine = _one_east_two_west()
    engine.groups = {"family": np.array([0])}
    turns = RightOfWay(engine)
    turns.look(np.arange(3))
    assert not turns._jams and not turns.waiting


def test_one_who_finds_no_plan_after_waiting_walks_straight_at_its_goal() -> None:
    engine = _one_east_two_west()
    engine.plan_to_goal = lambda index: "no free path"
    turns = RightOfWay(engine)
    turns.look(np.arange(3))
    engine.humans.position[1:] = [(9.0, 5.0), (8.0, 4.6)]   # the westbound are through
    engine.tick += engine.ticks(ways_round.LOOK_AGAIN)
    turns.look(np.arange(3))
    assert not turns.waiting
    assert engine.paths.waypoints(0).tolist() == [engine.humans.position[0].tolist(),
                                                  [23.0, 5.0]]


def test_a_wait_outlasts_the_path_pool_being_compacted() -> None:
    engine = _one_east_two_west()
    turns = RightOfWay(engine)
    turns.look(np.arange(3))
    assert set(turns.waiting) == {0}
    engine.paths._compact()   # moves every path's start in the pool
    engine.tick += engine.ticks(ways_round.LOOK_AGAIN)
    turns.look(np.arange(3))
    assert set(turns.waiting) == {0} and engine.anchor_tick[0] == engine.tick


def test_a_paths_version_and_waypoints_passed_outlast_compacting() -> None:
    paths = PathPool(2)
    paths.set_path(0, np.array([[0.0, 0.0], [0.3, 0.0], [0.6, 0.0], [3.0, 0.0]]))
    paths.set_path(1, np.array([[5.0, 5.0], [6.0, 5.0]]))
    paths.advance(np.array([[0.4, 0.0], [5.0, 5.0]]), lookahead=0.6)
    version, passed = paths.version.copy(), paths.passed(0)
    assert passed == 3
    paths._compact()
    assert (paths.version == version).all() and paths.passed(0) == passed
    paths.set_path(0, np.array([[2.0, 0.0], [4.0, 0.0]]))
    assert paths.version[0] == version[0] + 1 and paths.passed(0) == 0


def test_inside_a_long_corridor_nobody_takes_turns() -> None:
    # a corridor 1.2 m wide from x = 4 to 20: stepping back there frees nothing
    corridor = ((4.0, 0.0, 20.0, 4.4), (4.0, 5.6, 20.0, 10.0))
    engine = _engine([(11.6, 5.0), (12.7, 5.0), (13.5, 4.8)],
                     [(23.0, 5.0), (1.0, 5.0), (1.0, 5.0)], walls=corridor)
    turns = RightOfWay(engine)
    turns.look(np.arange(3))
    assert not turns._jams


def test_one_whose_way_does_not_lead_through_the_door_is_not_held() -> None:
    # rows 0-2 jam in the door; row 3 is near it, eastbound, but walks off to the north
    engine = _engine([(11.6, 5.0), (12.7, 5.0), (13.5, 4.6), (9.2, 5.0)],
                     [(23.0, 5.0), (1.0, 5.0), (1.0, 5.0), (9.5, 9.5)])
    turns = RightOfWay(engine)
    turns.look(np.arange(4))
    assert set(turns.waiting) == {0}


def test_a_wait_lasts_at_most_so_long_and_then_one_walks_on() -> None:
    engine = _one_east_two_west()
    turns = RightOfWay(engine)
    turns.look(np.arange(3))
    assert set(turns.waiting) == {0}
    engine.tick += engine.ticks(right_of_way.WAIT_AT_MOST)   # the westbound still in the door
    turns.look(np.arange(3))
    assert 0 not in turns.waiting and engine.planned[0] == 0
    assert engine.paths.waypoints(0)[-1].tolist() == [23.0, 5.0]
    engine.tick += engine.ticks(ways_round.LOOK_AGAIN)
    turns.look(np.arange(3))
    assert 0 not in turns.waiting   # and is not held there again
