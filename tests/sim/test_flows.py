"""Flows: people who arrive at Poisson times, walk to a target and leave the scene there."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from hubero_dsl.model.program import flow_bound
from hubero_dsl.pipeline import check_source, compile_source
from hubero_dsl.sim.flows import OFF_MAP
from hubero_dsl.sim.loop import run_program
from hubero_dsl.sim.simulation import Simulation
from hubero_dsl.sim.status import TaskStatus

HEADER = 'scenario "flow"\nmap "{map}"\n'


def _text(room_map: Path, body: str, seed: int = 1) -> str:
    return HEADER.format(map=room_map) + f"seed {seed}\n" + body


def _arrivals(sim: Simulation, flow: str) -> list[tuple[int, str]]:
    """(tick, member) of every arrival: when each member's walk became active."""
    return [(e.tick, e.human) for e in sim.events
            if e.status is TaskStatus.ACTIVE and e.human.startswith(f"{flow}_")]


def test_people_arrive_at_the_rate_walk_to_the_target_and_leave(room_map: Path) -> None:
    program = compile_source(_text(room_map, """
    time_limit 10 min
    flow f from rect((0.5, 0.5), (2.5, 7.5)) to (9.0, 4.0) rate 30 /min for 4 min
    """), "t.hub")
    sim = Simulation(program)
    result = run_program(sim)
    arrived = _arrivals(sim, "f")
    # a Poisson count with mean 120 (sd 11): its seeded draw lies well within 4 sd
    assert 120 - 44 <= len(arrived) <= 120 + 44
    assert [name for _, name in arrived] == [f"f_{i}" for i in range(1, len(arrived) + 1)]
    assert max(tick for tick, _ in arrived) * program.step < 240.0
    finals = [e for e in result.events if e.status.is_final]
    assert len(finals) == len(arrived)  # everyone who came has left, and the run waited
    assert result.state.value == "completed" and result.time > 240.0
    humans = sim.engine.humans
    assert humans.present is not None and not humans.present.any()
    assert (humans.position[:, 0] == OFF_MAP).all()
    done = [e for e in finals if e.status is TaskStatus.SUCCEEDED]
    assert len(done) >= len(arrived) - 2


def test_arrivals_depend_on_the_seed_and_the_flow_only(room_map: Path) -> None:
    def arrivals(seed: int, other: str = "") -> list[tuple[int, str]]:
        program = compile_source(_text(room_map, f"""
        time_limit 1 min
        flow f from rect((0.5, 0.5), (2.5, 7.5)) to (9.0, 4.0) rate 1 /s for 20 s
        {other}
        """, seed), "t.hub")
        sim = Simulation(program)
        run_program(sim)
        return _arrivals(sim, "f")

    first = arrivals(3)
    assert first == arrivals(3)
    assert first != arrivals(4)
    # another flow elsewhere changes neither the times nor the order of this one's people
    other = "flow g from rect((7.5, 0.5), (9.5, 7.5)) to (1.0, 4.0) rate 2 /s for 5 s"
    assert [t for t, _ in arrivals(3, other)][:5] == [t for t, _ in first][:5]


def test_nobody_appears_inside_another_body_and_a_full_area_makes_arrivals_wait(
        room_map: Path) -> None:
    # an area where one body fits at a time: arrivals must wait for the last to walk off
    program = compile_source(_text(room_map, """
    time_limit 40 s
    flow f from rect((0.5, 3.5), (1.1, 4.5)) to (9.0, 4.0) rate 5 /s for 10 s
    """), "t.hub")
    sim = Simulation(program)
    humans = sim.engine.humans
    seen: set[int] = set()
    drawn = len(sim.flows.states[0].arrival_ticks) if sim.flows else 0
    while sim.time < 40.0 and sim.scheduler and sim.scheduler.state.value == "running":
        sim.step()
        assert humans.present is not None
        here = np.flatnonzero(humans.present)
        for row in set(here.tolist()) - seen:
            others = here[here != row]
            gaps = np.hypot(*(humans.position[others] - humans.position[row]).T)
            assert (gaps >= humans.radius[others] + humans.radius[row] - 0.05).all()
        seen |= set(here.tolist())
    # about 50 were due in 10 s; a one-body doorway lets them through one by one, later
    assert len(seen) == drawn > 30
    last = max(tick for tick, _ in _arrivals(sim, "f")) * program.step
    assert last > 10.0 + 2.0


def test_until_stops_the_flow_and_a_flow_without_end_does_not_keep_the_run(
        room_map: Path) -> None:
    program = compile_source(_text(room_map, """
    time_limit 2 min
    human h at (5, 7)
    flow f from rect((0.5, 0.5), (2.5, 7.5)) to (9.0, 4.0) rate 1 /s until time > 10 s
    flow g from rect((7.5, 0.5), (9.5, 7.5)) to (1.0, 4.0) rate 1 /s
    activity { h stand for 5 s }
    """), "t.hub")
    sim = Simulation(program)
    result = run_program(sim)
    f_ticks = [t for t, _ in _arrivals(sim, "f")]
    assert f_ticks and max(f_ticks) * program.step <= 10.0 + program.step
    # f keeps the run until its people have left; g, with no end, does not keep it
    finals = {e.human for e in result.events if e.status.is_final and e.human.startswith("f_")}
    assert finals == {name for _, name in _arrivals(sim, "f")}
    assert result.state.value == "completed" and 10.0 < result.time < 60.0


def test_conditions_count_the_people_present(room_map: Path) -> None:
    program = compile_source(_text(room_map, """
    time_limit 1 min
    flow f from rect((0.5, 0.5), (2.5, 7.5)) to (9.0, 4.0) rate 1 /s for 10 s
    expect count(f in rect((0.2, 0.2), (9.8, 7.8))) <= 12 always
    expect any f reaches (9.0, 4.0) within 20 s
    expect count(f in rect((0.2, 0.2), (9.8, 7.8))) >= 1 eventually
    """), "t.hub")
    result = run_program(Simulation(program))
    assert all(e.held for e in result.expectations), [e.text for e in result.expectations]


def _verdicts(room_map: Path, body: str) -> dict[str, bool]:
    result = run_program(Simulation(compile_source(_text(room_map, body), "t.hub")))
    return {e.text: e.held for e in result.expectations}


def test_all_and_any_count_the_people_who_came_where_they_left(room_map: Path) -> None:
    # everyone walks to the target and leaves there: when the last has left, all reached it
    assert _verdicts(room_map, """
    time_limit 1 min
    flow f from rect((0.5, 0.5), (2.5, 7.5)) to (9.0, 4.0) rate 1 /s for 6 s
    expect all f reach (9.0, 4.0) eventually
    expect any f reaches (9.0, 4.0) eventually
    expect not (all f reach (9.0, 4.0)) within 6 s
    expect all f reach (2.0, 4.0) eventually
    """) == {"all f reach (9.0, 4.0) eventually": True,
             "any f reaches (9.0, 4.0) eventually": True,
             "not (all f reach (9.0, 4.0)) within 6 s": True,
             "all f reach (2.0, 4.0) eventually": False}


def test_all_never_holds_while_people_may_still_come(room_map: Path) -> None:
    # a flow without `for` or `until` brings people until the time limit, however many of
    # the arrivals drawn fall before it
    assert _verdicts(room_map, """
    time_limit 40 s
    human h at (5, 7)
    flow f from rect((0.5, 0.5), (2.5, 7.5)) to (9.0, 4.0) rate 0.2 /s
    activity { h stand for 35 s }
    expect all f reach (9.0, 4.0) eventually
    expect any f reaches (9.0, 4.0) eventually
    """) == {"all f reach (9.0, 4.0) eventually": False,
             "any f reaches (9.0, 4.0) eventually": True}


def test_a_flow_for_a_time_keeps_the_run_until_that_time_is_over(room_map: Path) -> None:
    # seed 3 draws two arrivals before 30 s, the second gone by 20.35 s: the run completed
    # then, while someone might still have come, and `all f reach` failed for it
    program = compile_source(_text(room_map, """
    time_limit 1 min
    flow f from rect((0.5, 0.5), (2.5, 7.5)) to (9.0, 4.0) rate 6 /min for 30 s
    expect all f reach (9.0, 4.0) eventually
    """, seed=3), "t.hub")
    result = run_program(Simulation(program))
    departures = [e.time for e in result.events if e.status.is_final]
    assert len(departures) == 2 and max(departures) < 25.0
    assert result.state.value == "completed" and result.time == pytest.approx(30.0)
    (reached,) = result.expectations
    assert reached.held and reached.decided_at == pytest.approx(30.0)


def test_a_walker_who_stopped_short_did_not_reach(room_map: Path) -> None:
    # someone stands on the target: the walkers stop short of it and leave where they stood
    result = run_program(Simulation(compile_source(_text(room_map, """
    time_limit 2 min
    human h at (9.0, 4.0)
    flow f from rect((0.5, 0.5), (2.5, 7.5)) to (9.0, 4.0) rate 1 /s for 2 s
    activity { h stand for 100 s }
    expect all f reach (9.0, 4.0) eventually
    expect any f reaches (9.0, 4.0) eventually
    """), "t.hub")))
    assert {e.reason for e in result.events if e.human.startswith("f_")
            and e.status.is_final} == {"stopped short of a goal taken by h"}
    assert [e.held for e in result.expectations] == [False, False]


def test_a_flow_that_would_stop_once_all_its_people_arrived_never_stops(room_map: Path
                                                                       ) -> None:
    base = "flow f from rect((0.5, 0.5), (2.5, 7.5)) to (9.0, 4.0) rate 1 /s until "
    result = check_source(_text(room_map, base + "all f reach (9.0, 4.0)\n"), "t.hub")
    (found,) = result.errors
    assert found.code == "E313" and "would never stop" in found.message
    assert found.span is not None and found.span.line == 4
    for fine in ("all f reach (9.0, 4.0) or time > 20 s", "any f reaches (9.0, 4.0)"):
        assert not check_source(_text(room_map, base + fine + "\n"), "t.hub").errors


def test_a_variant_sets_the_parameters_of_a_whole_flow(room_map: Path) -> None:
    program = compile_source(_text(room_map, """
    flow f from rect((0.5, 0.5), (2.5, 7.5)) to (9.0, 4.0) rate 1 /s for 5 s { speed 1.1 m/s }
    variant fast { f.speed 1.6 m/s }
    """), "t.hub")
    assert {float(v["speed"]) for v in Simulation(program).params.values()} == {1.1}
    fast = Simulation(program, variant="fast").params
    assert {float(v["speed"]) for v in fast.values()} == {1.6}


def test_the_bound_covers_the_poisson_count() -> None:
    assert flow_bound(1.0, 600.0) == math.ceil(600 + 6 * math.sqrt(600) + 6)
    assert flow_bound(0.001, 1.0) == 7


@pytest.mark.parametrize(("body", "code"), [
    # a rate in the wrong unit, a rate of zero, a duration that is not a time
    ("flow f from rect((1, 1), (3, 3)) to (9, 4) rate 5 s for 5 s", "E201"),
    ("flow f from rect((1, 1), (3, 3)) to (9, 4) rate 0 /s for 5 s", "E203"),
    ("flow f from rect((1, 1), (3, 3)) to (9, 4) rate 1 /s for 5 m", "E201"),
    ("flow f from rect((1, 1), (3, 3)) to nowhere rate 1 /s", "E101"),
    # more people than a scenario may have
    ("time_limit 10 h\nflow f from rect((1, 1), (3, 3)) to (9, 4) rate 10 /s", "E203"),
    # tasks are not given to a flow
    ("flow f from rect((1, 1), (3, 3)) to (9, 4) rate 1 /s\nactivity { f stand for 1 s }",
     "E103"),
    ("flow f from rect((1, 1), (3, 3)) to (9, 4) rate 1 /s until nothing done", "E101"),
])
def test_flow_mistakes_are_reported(room_map: Path, body: str, code: str) -> None:
    codes = {d.code for d in check_source(_text(room_map, body), "t.hub").errors}
    assert code in codes, codes


@pytest.mark.parametrize(("body", "line"), [
    # a human, a place or a crowd after the flow takes a member's name: the later definition
    ("flow f from rect((1, 1), (3, 3)) to (9, 4) rate 1 /s for 5 s\nhuman f_3 at (5, 5)", 5),
    ("flow f from rect((1, 1), (3, 3)) to (9, 4) rate 1 /s for 5 s\nplace f_1 (5, 5)", 5),
    ("crowd f_2 2 in rect((5, 5), (7, 7))\n"
     "flow f from rect((1, 1), (3, 3)) to (9, 4) rate 1 /s for 5 s", 5),
    ("flow f from rect((1, 1), (3, 3)) to (9, 4) rate 1 /s for 5 s\n"
     "flow f_1 from rect((1, 1), (3, 3)) to (9, 4) rate 1 /s for 5 s", 5),
])
def test_a_name_a_flows_member_would_take_is_an_error_at_the_later_definition(
        room_map: Path, body: str, line: int) -> None:
    errors = check_source(_text(room_map, body), "t.hub").errors
    assert [d.code for d in errors] == ["E102"]
    assert errors[0].span is not None and errors[0].span.line == line
    assert "f_1 ... f_" in errors[0].message


def test_a_name_past_a_flows_last_possible_member_is_free(room_map: Path) -> None:
    body = ("flow f from rect((1, 1), (3, 3)) to (9, 4) rate 1 /s for 5 s\n"
            "human f_999 at (5, 5)\nhuman f_0 at (6, 6)\nhuman f_x at (7, 7)")
    assert not check_source(_text(room_map, body), "t.hub").errors


def test_a_flow_needs_a_way_from_its_area_to_its_target(walled_map: Path) -> None:
    body = "flow f from rect((1, 1), (3, 3)) to (8, 4) rate 1 /s for 5 s"
    errors = check_source(_text(walled_map, body), "t.hub").errors
    assert [d.code for d in errors] == ["E407"]
    assert errors[0].span is not None and errors[0].span.line == 4


def test_a_flow_with_an_end_is_an_activity_of_its_own(room_map: Path) -> None:
    body = "flow f from rect((1, 1), (3, 3)) to (9, 4) rate 1 /s for 5 s"
    assert [d.code for d in check_source(_text(room_map, body), "t.hub").diagnostics] == []
    endless = "flow f from rect((1, 1), (3, 3)) to (9, 4) rate 1 /s"
    assert [d.code for d in check_source(_text(room_map, endless), "t.hub").diagnostics] == [
        "W502"]


def test_a_flow_members_parameter_in_a_variant_points_at_the_flow(room_map: Path) -> None:
    body = ("flow f from rect((1, 1), (3, 3)) to (9, 4) rate 1 /s for 5 s\n"
            "variant v { f_2.speed 1 m/s }")
    (error,) = check_source(_text(room_map, body), "t.hub").errors
    assert error.code == "E105" and "'f_2' is a member of flow 'f'" in error.message


def test_a_rate_in_an_unknown_unit_lists_the_rate_units(room_map: Path) -> None:
    body = "flow f from rect((1, 1), (3, 3)) to (9, 4) rate 2 /day for 5 s"
    (error,) = check_source(_text(room_map, body), "t.hub").errors
    assert error.code == "E002" and error.hint is not None and "/s, /min, /h" in error.hint


def test_a_robots_metrics_count_a_flows_people_only_while_they_are_there(
        room_map: Path) -> None:
    # people come 1 m from the robot and walk away from it, then leave: waiting off the map,
    # they were counted 1e6 m away (max and average distances of 1e6 m) and their jump there
    # and back read as a collision course (a time to collision of 0 s)
    program = compile_source(_text(room_map, """
    time_limit 30 s
    flow visitors from rect((2.3, 1.7), (2.7, 2.1)) to (8.5, 6.5) rate 60 /min for 3 s
    robot cart at (1.0, 0.6) { controller navigator; goal (1.0, 3.0) }
    activity { cart move_to (1.0, 3.0); cart stand for 20 s }
    expect min_time_to_collision(cart) >= 1 s
    expect max_distance(cart) <= 20 m
    expect avg_distance(cart) <= 20 m
    """), "t.hub")
    result = run_program(Simulation(program))
    assert any(e.human.startswith("visitors_") for e in result.events)
    assert [(v.text, v.held) for v in result.expectations] == [
        (v.text, True) for v in result.expectations]
