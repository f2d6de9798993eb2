"""Groups: people who walk together, arrive side by side, and talk in a circle facing its
centre."""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import numpy as np
import pytest
from shapely.geometry import Point, box

from hubero_dsl.pipeline import check_source, compile_source
from hubero_dsl.sim.loop import RunResult, run_program
from hubero_dsl.sim.simulation import Simulation
from hubero_dsl.sim.status import TaskStatus
from hubero_dsl.world.drawing import grid_from_walkable
from hubero_dsl.world.mapfile import save_map
from tests.sim.conftest import room_grid

FAMILY = """\
human mum at (1.5, 4.0)
human dad at (1.5, 4.8)
human kid at (1.0, 4.4) { radius 0.15 m; speed 0.7 m/s }
"""


def _text(room_map: Path, body: str) -> str:
    return f'scenario "g"\nmap "{room_map}"\n' + body


def _run(map_path: Path, body: str) -> tuple[Simulation, RunResult]:
    """The scenario `body` on the map, run to its end: the simulation and its result."""
    sim = Simulation(compile_source(_text(map_path, body), "t.hub"))
    return sim, run_program(sim)


def _spread(room_map: Path, grouped: bool) -> tuple[float, list[tuple[float, float]]]:
    """The widest a member strays from the family's centre while they walk; where they end."""
    group = "group family of (mum, dad, kid)\n" if grouped else ""
    task = ("activity { family move_to (8, 4) }" if grouped else
            "activity { parallel { mum move_to (8, 4); dad move_to (8, 4.7); "
            "kid move_to (8, 3.3) } }")
    sim = Simulation(compile_source(_text(room_map, FAMILY + group + task + "\n"), "t.hub"))
    widest = [0.0]

    def observe(s: Simulation) -> None:
        h = s.engine.humans
        if h.moving.all():
            widest[0] = max(widest[0], float(np.hypot(*(h.position - h.position.mean(axis=0)
                                                       ).T).max()))

    result = run_program(sim, [observe])
    assert all(e.status is not TaskStatus.ABORTED for e in result.events)
    return widest[0], [sim.human(n).position for n in ("mum", "dad", "kid")]


def test_a_group_keeps_together_and_arrives_side_by_side(room_map: Path) -> None:
    together, ends = _spread(room_map, grouped=True)
    apart, _ = _spread(room_map, grouped=False)
    assert together < apart - 0.3      # the fast ones wait for the kid
    assert together < 1.5
    for a, b in ((0, 1), (0, 2), (1, 2)):
        assert math.dist(ends[a], ends[b]) > 0.5   # abreast, not on one point
    assert all(math.dist(end, (8.0, 4.0)) < 1.0 for end in ends)


def test_a_group_takes_places_in_the_order_it_stands_across_its_way(room_map: Path) -> None:
    # mum starts lowest, dad highest and the kid between them: nobody crosses another's way
    _, (mum, dad, kid) = _spread(room_map, grouped=True)
    assert mum[1] < kid[1] < dad[1]


PAIR = """\
human slow at (2, 5) {{ speed 0.7 m/s }}
human fast at (2, 5.7) {{ speed 1.5 m/s }}
group pair of (slow, fast)
activity {{ {task} }}
"""


def _pair_walk(map_path: Path, task: str) -> tuple[list[float], list[float], dict[str, float]]:
    """How far the fast one walks ahead of the slow one, and how far beside it, while both
    walk their middle stretch; when each finished."""
    sim = Simulation(compile_source(_text(map_path, PAIR.format(task=task)), "t.hub"))
    ahead: list[float] = []
    beside: list[float] = []

    def observe(s: Simulation) -> None:
        h = s.engine.humans
        if h.moving.all() and h.position[:, 0].min() > 8.0 and h.position[:, 0].max() < 20.0:
            ahead.append(float(h.position[1, 0] - h.position[0, 0]))
            beside.append(float(abs(h.position[1, 1] - h.position[0, 1])))

    result = run_program(sim, [observe])
    ended = {e.human: e.time for e in result.events if e.status is TaskStatus.SUCCEEDED}
    assert set(ended) == {"slow", "fast"}, [(e.human, e.status, e.reason)
                                            for e in result.events]
    return ahead, beside, ended


@pytest.fixture
def hall_map(tmp_path: Path) -> Path:
    path = tmp_path / "hall.yaml"
    save_map(room_grid(30.0, 10.0), path)
    return path


@pytest.fixture
def hall_corridor_map(tmp_path: Path) -> Path:
    """The hall with a corridor 1 m wide from x = 8 to 20: too narrow to walk two abreast."""
    path = tmp_path / "corridor.yaml"
    save_map(room_grid(30.0, 10.0, walls=((8.0, 0.0, 20.0, 4.5), (8.0, 5.5, 20.0, 10.0))),
             path)
    return path


def test_a_group_of_two_speeds_walks_side_by_side_where_there_is_room(
        hall_map: Path) -> None:
    ahead, beside, ended = _pair_walk(hall_map, "pair move_to (25, 5)")
    assert ahead and max(abs(a) for a in ahead) < 0.2     # level, not one after the other
    assert min(beside) > 0.6                              # in lanes side by side
    assert abs(ended["fast"] - ended["slow"]) < 0.5       # the fast one waited
    assert ended["slow"] < 23.0 / 0.7 + 1.5               # at the slow one's own pace


def test_a_group_walks_in_file_where_the_way_is_too_narrow(hall_corridor_map: Path) -> None:
    ahead, beside, ended = _pair_walk(hall_corridor_map, "pair move_to (25, 5)")
    assert ahead and min(abs(a) for a in ahead) > 0.5     # one after the other
    assert max(beside) < 0.4
    assert max(ended.values()) < 23.0 / 0.7 + 3.0         # nobody waits for the impossible


def test_a_group_passing_a_table_keeps_its_pace(tmp_path: Path) -> None:
    # the table parts them: those ahead used to wait for a companion held up in another's
    # wake, or for one in the middle of the line waiting on the one behind it, at a fifth of
    # their speed: 9.4 s for this walk (now 6.3 s)
    path = tmp_path / "table.yaml"
    room = box(0.65, 0.65, 11.35, 7.35).difference(Point(3.0, 3.0).buffer(0.5, 64))
    save_map(grid_from_walkable(room.difference(box(5.9, 0.6, 6.1, 3.55)), 0.02), path)
    sim, result = _run(path, "human ann at (1.5, 2.0)\nhuman ben at (1.5, 2.7)\n"
                             "human cat at (1.0, 2.35) { speed 1.0 m/s }\n"
                             "group friends of (ann, ben, cat)\n"
                             "activity { friends move_to (5.0, 2.4) }\n")
    ends = [e.time for e in result.events if e.status is TaskStatus.SUCCEEDED]
    assert len(ends) == 3 and max(ends) < 7.5          # 3.5 m at 1 m/s, and closing up
    assert all(math.dist(sim.human(name).position, (5.0, 2.4)) < 1.0
               for name in ("ann", "ben", "cat"))


def test_members_sent_on_tasks_of_their_own_do_not_keep_abreast(hall_map: Path) -> None:
    # each on its own errand: the fast one is only drawn back when it falls too far apart
    ahead, _, ended = _pair_walk(hall_map, "parallel { slow move_to (25, 5); "
                                           "fast move_to (25, 5.7) }")
    assert float(np.mean(ahead)) > 0.5
    assert ended["fast"] < ended["slow"] - 0.5


def _each_faces_the_centre(sim: Simulation, names: tuple[str, ...]) -> bool:
    """Whether each of `names` is turned to within 0.1 rad of their centre."""
    centre = np.mean([sim.human(name).position for name in names], axis=0)
    return all(abs(math.remainder(math.atan2(*(centre - sim.human(name).position)[::-1])
                                  - sim.human(name).heading, math.tau)) < 0.1
               for name in names)


def test_a_group_talks_facing_its_centre(room_map: Path) -> None:
    program = compile_source(_text(room_map, FAMILY + "group family of (mum, dad, kid)\n"
                                   "activity { family talk for 2 s }\n"), "t.hub")
    sim = Simulation(program)
    run_program(sim)
    assert _each_faces_the_centre(sim, ("mum", "dad", "kid"))


def test_a_group_in_a_line_steps_into_a_circle_to_talk(room_map: Path) -> None:
    """An F-formation: standing in a line, the four step to places evenly round their centre
    (neighbours as far apart as across the circle allows), face it, and talk the time asked."""
    line = ("human a at (3, 4)\nhuman b at (3.8, 4)\nhuman c at (4.6, 4)\n"
            "human d at (5.4, 4)\ngroup four of (a, b, c, d)\n"
            "activity { four talk for 6 s }\n")
    sim, result = _run(room_map, line)
    names = ("a", "b", "c", "d")
    assert {e.status for e in result.events if e.human in names} >= {TaskStatus.SUCCEEDED}
    assert result.time == pytest.approx(6.0, abs=0.1)  # the talk's time runs from its start
    places = np.array([sim.human(n).position for n in names])
    centre = places.mean(axis=0)
    radii = np.hypot(*(places - centre).T)
    assert radii.min() > 0.5 and radii.max() - radii.min() < 0.15  # on one circle
    bearings = np.sort(np.arctan2(*(places - centre).T[::-1]))
    gaps = np.diff(np.append(bearings, bearings[0] + math.tau))
    assert np.allclose(gaps, math.tau / 4, atol=0.35)  # round it (a line: 0 and pi)
    assert _each_faces_the_centre(sim, names)


def test_a_group_already_round_its_centre_keeps_its_places(room_map: Path) -> None:
    # three on a circle with one place left free (an open F-formation, as a scenario may
    # place them for a robot to join): they turn to the centre where they stand
    three = ("human a at (4.43, 4.57)\nhuman b at (5.57, 4.57)\nhuman c at (5.57, 3.43)\n"
             "group g of (a, b, c)\nactivity { g talk for 2 s }\n")
    sim, _ = _run(room_map, three)
    assert sim.human("a").position == pytest.approx((4.43, 4.57), abs=1e-9)
    assert sim.human("c").position == pytest.approx((5.57, 3.43), abs=1e-9)


def test_a_group_standing_far_apart_closes_into_a_circle_to_talk(room_map: Path) -> None:
    # round their centre, but 2.5 m from it: too far to talk; they step to a circle of 0.6 m
    far = ("human a at (2.5, 4.0)\nhuman b at (6.25, 6.17)\nhuman c at (6.25, 1.83)\n"
           "group g of (a, b, c)\nactivity { g talk for 8 s }\n")
    sim, _ = _run(room_map, far)
    places = np.array([sim.human(n).position for n in ("a", "b", "c")])
    assert np.hypot(*(places - places.mean(axis=0)).T).max() < 0.8
    assert _each_faces_the_centre(sim, ("a", "b", "c"))


def test_a_member_whose_place_is_in_a_wall_talks_from_where_it_stands(
        room_map: Path) -> None:
    # two against the room's south wall (y = 0): the circle's places would be 0.6 m from
    # their centre, across the wall for one of them
    pair = ("human a at (3, 0.4)\nhuman b at (3, 1.2)\ngroup two of (a, b)\n"
            "activity { two talk for 2 s }\n")
    sim, result = _run(room_map, pair)
    assert all(e.status is not TaskStatus.ABORTED for e in result.events)
    assert sim.human("a").position[1] > 0.2  # never pushed into the wall


@pytest.mark.parametrize(("body", "code"), [
    (FAMILY + "group a of (mum, dad)\ngroup b of (dad, kid)\n", "E113"),
    (FAMILY + "group a of (mum, nobody)\n", "E101"),
    (FAMILY + "group a of (mum)\n", "E203"),
])
def test_group_mistakes_are_reported(room_map: Path, body: str, code: str) -> None:
    assert code in {d.code for d in check_source(_text(room_map, body), "t.hub").errors}


def test_a_member_named_twice_is_told_so(room_map: Path) -> None:
    (error,) = check_source(_text(room_map, FAMILY + "group a of (mum, mum)\n"), "t.hub").errors
    assert (error.code, error.message) == ("E113", "'mum' is named twice in group 'a'")


def test_members_on_errands_of_their_own_are_not_held_to_each_other(hall_map: Path) -> None:
    # a group's pull is for a walk together: sent opposite ways, each gets where it was sent
    couple = ("human mum at (15, 5)\nhuman dad at (15.7, 5)\ngroup family of (mum, dad)\n"
              "activity { parallel { mum move_to (5, 5); dad move_to (25, 5) } }\n")
    sim, result = _run(hall_map, couple)
    assert all(e.status is not TaskStatus.ABORTED for e in result.events)
    assert sim.human("dad").position[0] > 24.5 and sim.human("mum").position[0] < 5.5


def test_a_group_sent_back_arrives_side_by_side_again(hall_map: Path) -> None:
    # each walk's places are drawn from where the members stand when it starts
    trio = ("human a at (9, 4.3)\nhuman b at (9, 5)\nhuman c at (9, 5.7)\ngroup g of (a, b, c)\n"
            "activity { g move_to (15, 5); g move_to (9, 5) }\n")
    sim, result = _run(hall_map, trio)
    assert not [e for e in result.events if e.status is TaskStatus.ABORTED or e.reason]
    ends = sorted(sim.human(n).position[1] for n in "abc")
    assert np.allclose(np.diff(ends), 0.7, atol=0.15)


def test_a_group_of_a_crowds_members_walks_abreast_and_talks_in_a_circle(
        hall_map: Path) -> None:
    drawn = ("crowd c 3 in rect((8, 4), (10, 6))\ngroup g of (c_1, c_2, c_3)\n"
             "activity { g move_to (15, 5); g talk for 3 s }\n")
    sim, _ = _run(hall_map, drawn)
    names = ("c_1", "c_2", "c_3")
    places = [sim.human(name).position for name in names]
    assert min(math.dist(p, q) for p, q in itertools.combinations(places, 2)) > 0.5
    assert _each_faces_the_centre(sim, names)


def test_a_group_sent_into_a_door_goes_there_when_its_places_are_in_the_walls(
        hall_corridor_map: Path) -> None:
    # the point is in the corridor 1 m wide: the places beside it are in its walls
    pair = ("human a at (4, 4.7)\nhuman b at (4, 5.4)\ngroup g of (a, b)\n"
            "activity { g move_to (12, 5) }\n")
    _, result = _run(hall_corridor_map, pair)
    assert [e.status for e in result.events if e.status is not TaskStatus.ACTIVE] == [
        TaskStatus.SUCCEEDED] * 2


@pytest.mark.parametrize("actor", ["family", "visitors"])
def test_a_crowds_or_groups_goal_where_its_largest_member_does_not_fit_is_e405(
        room_map: Path, actor: str) -> None:
    # the room's wall is at x = 10: a goal 0.1 m from it, and a crowd's members as large
    # as the block says
    text = _text(room_map, FAMILY + "group family of (mum, dad, kid)\n"
                 "crowd visitors 2 in rect((2, 1), (4, 3)) { radius 0.3 m }\n"
                 f"activity {{ {actor} move_to (9.85, 4) }}\n")
    (error,) = check_source(text, "t.hub").errors
    assert error.code == "E405" and f"the goal of {actor}'s move_to" in error.message
    assert (error.span.line, error.span.column) == (8, 12 + len(actor) + len(" move_to "))


def test_a_group_sent_into_a_dead_end_queues_in_it_without_waiting_out_the_stuck_time(
        tmp_path: Path) -> None:
    # a pocket 0.7 m wide and 4 m deep: one stands at the goal, the others stop behind
    pocket = tmp_path / "pocket.yaml"
    save_map(room_grid(walls=((0.0, 3.0, 4.0, 3.65), (0.0, 4.35, 4.0, 5.0))), pocket)
    trio = ("human a at (7, 3.3)\nhuman b at (7, 4.0)\nhuman c at (7, 4.7)\n"
            "group g of (a, b, c)\nactivity { g move_to (1, 4) }\n")
    _, result = _run(pocket, trio)
    done = [e for e in result.events if e.status is not TaskStatus.ACTIVE]
    assert [e.status for e in done] == [TaskStatus.SUCCEEDED] * 3
    assert sum(e.reason.startswith("stopped short") for e in done) == 2
    # within seconds of the first's arrival, not after the stuck time (20 s) each
    assert done[-1].time - done[0].time < 6.0, [(e.human, e.time) for e in done]


STATION = Path(__file__).resolve().parents[2] / "maps" / "station.yaml"


@pytest.mark.parametrize(("a", "b", "goal"), [
    ((16.4, 11.6), (23.9, 11.4), (8.8, 6.0)),   # planned round a pillar on either side
    ((2.0, 10.6), (15.3, 3.4), (25.7, 6.2)),
])
def test_a_group_drawn_off_its_plans_walks_on_instead_of_turning_back(
        a: tuple[float, float], b: tuple[float, float], goal: tuple[float, float]) -> None:
    # keeping together draws a member off its own plan's line, past a pillar its plan goes
    # round on the other side: it walks on to the waypoint after, which it can see
    sim, result = _run(STATION, f"time_limit 2 min\nhuman a at {a}\nhuman b at {b}\n"
                                f"group pair of (a, b)\nactivity {{ pair move_to {goal} }}\n")
    assert result.state.name == "COMPLETED", result.reason
    ends = [sim.human(name).position for name in ("a", "b")]
    assert all(math.dist(end, goal) < 1.0 for end in ends)
    assert 0.5 < math.dist(*ends) < 1.0                  # side by side at the goal


def test_all_of_a_group_reach_the_point_it_was_sent_to_though_they_stand_abreast() -> None:
    # side by side at the point, neither stands on it: both have reached it as a group can,
    # and stay there as they talk; the guard waiting for them goes
    sim, result = _run(STATION, """time_limit 3 min
human ann at (2.0, 7.0)
human bob at (2.0, 8.0)
human guard at (20.0, 12.0)
group pair of (ann, bob)
activity { pair move_to (10.0, 7.0); pair talk for 3 s }
activity { wait until all pair reach (10.0, 7.0); guard move_to (25.0, 12.0) }
expect any pair reaches (10.0, 7.0) eventually
expect bob reaches (10.0, 7.0) eventually
""")
    assert result.state.name == "COMPLETED", result.reason
    assert all(e.held for e in result.expectations)
    assert min(math.dist(sim.human(n).position, (10.0, 7.0)) for n in ("ann", "bob")) > 0.25


def test_a_group_told_to_wander_strolls_together() -> None:
    # each leg's goal is drawn once for the group: they walk it abreast, not each its own way
    sim = Simulation(compile_source(_text(STATION, """seed 5
human mia at (10.0, 7.0)
human leo at (10.0, 7.7)
group couple of (mia, leo)
activity { couple move_around in rect((2.0, 2.0), (28.0, 12.0)) for 30 s }
"""), "t.hub"))
    apart: list[float] = []
    result = run_program(sim, [lambda s: apart.append(
        math.dist(s.human("mia").position, s.human("leo").position))])
    assert result.state.name == "COMPLETED"
    assert max(apart) < 2.5 and np.mean(apart) < 1.2
    walked = {e.human for e in result.events if e.status is TaskStatus.SUCCEEDED}
    assert walked == {"mia", "leo"}


def test_a_group_of_mixed_speeds_slows_its_fast_members_at_a_walkers_pace() -> None:
    # held back by a cap set outright, they braked from 1.2 to 0.3 m/s within a tick, at up
    # to 25 m/s^2, every second or two as a companion came level and fell behind
    hall = Path(__file__).resolve().parents[2] / "maps" / "benchmark" / "hall.yaml"
    sim = Simulation(compile_source(_text(hall, """\
seed 3
human a at (1.5, 4.0) heading 0 deg
human b at (1.5, 5.0) heading 0 deg
human c at (1.0, 4.5) heading 0 deg { speed 1.0 m/s }
human d at (2.0, 6.0) heading 0 deg { speed 1.5 m/s }
group friends of (a, b, c, d)
activity { friends move_to (12.0, 6.0) }
"""), "t.hub"))
    speeds: list[list[float]] = []
    while sim.time < 8.0:
        sim.step()
        speeds.append([math.hypot(*sim.human(n).velocity) for n in "abcd"])
    drops = [before - after for was, now in itertools.pairwise(speeds[20:])
             for before, after in zip(was, now, strict=True)]
    assert max(drops) / sim.dt < 3.0  # m/s^2: 1.5 m/s over 0.54 s is 2.8


@pytest.mark.parametrize("ring", [0.75, 0.85])
def test_a_walker_a_group_stopped_round_to_talk_squeezes_out(room_map: Path, ring: float
                                                             ) -> None:
    # four talking round a walker, their personal spaces meeting in front of it: it was held
    # there until given up as stuck (0.75 m) or for 22 s (0.85 m), with room between them
    talkers = [(5.0 + ring * math.cos(k * math.pi / 2), 4.0 + ring * math.sin(k * math.pi / 2))
               for k in range(4)]
    people = "".join(f"human t{k} at ({x:.3f}, {y:.3f})\n" for k, (x, y) in enumerate(talkers))
    _, result = _run(room_map, "human w at (5, 4)\n" + people
                     + "group talkers of (t0, t1, t2, t3)\n"
                     "activity { talkers talk to w for 60 s }\nactivity { w move_to (9, 4) }\n")
    (walk,) = [e for e in result.events if e.human == "w" and e.status.is_final]
    assert walk.status is TaskStatus.SUCCEEDED and walk.time < 10.0, (walk.time, walk.reason)


def test_a_squeeze_lasts_its_time_and_a_new_walk_starts_without_one(room_map: Path) -> None:
    sim = Simulation(compile_source(_text(room_map, "human w at (5, 4)\nhuman t at (5.7, 4)\n"),
                                    "t.hub"), activities=False)
    sim.human("t").stand(duration=60.0)
    sim.human("w").move_to((9.0, 4.0))
    sim.step()
    engine = sim.engine

    def push_kept() -> float:
        return float(engine._drive(np.array([0])).avoidance_strength[0])

    assert engine.squeeze_round_standing(0, 3.0, 3.0) and push_kept() == pytest.approx(0.2)
    engine.tick += engine.ticks(3.0)
    assert push_kept() == 1.0
    assert engine.squeeze_round_standing(0, 3.0, 3.0) and push_kept() == pytest.approx(0.2)
    sim.human("w").move_to((9.0, 2.0))  # another walk: it squeezes past nobody yet
    assert push_kept() == 1.0
