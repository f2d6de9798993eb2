"""The scheduler runs every step kind of the language with token semantics."""

from __future__ import annotations

import pytest

from hubero_dsl.sim.loop import RunResult, run_program
from hubero_dsl.sim.scheduler import RunState
from hubero_dsl.sim.simulation import Simulation
from hubero_dsl.sim.status import TaskStatus
from tests.sim.conftest import ScenarioFactory

HUMANS = """
human alice at (2, 2)
human bob at (8, 6)
"""


def run(scenario: ScenarioFactory, body: str, **kwargs: object) -> RunResult:
    return run_program(Simulation(scenario(HUMANS + body), **kwargs))  # type: ignore[arg-type]


def statuses(result: RunResult, human: str) -> list[tuple[str, TaskStatus]]:
    return [(e.kind, e.status) for e in result.events if e.human == human and e.status.is_final]


def started(result: RunResult, human: str, kind: str) -> list[float]:
    return [e.time for e in result.events
            if e.human == human and e.kind == kind and e.status is TaskStatus.ACTIVE]


def test_a_sequence_runs_in_order(scenario: ScenarioFactory) -> None:
    result = run(scenario, """activity {
        alice move_to (4, 2)
        alice stand for 1 s
        alice move_to (4, 4)
    }""")
    assert result.state is RunState.COMPLETED
    assert statuses(result, "alice") == [("move_to", TaskStatus.SUCCEEDED),
                                         ("stand", TaskStatus.SUCCEEDED),
                                         ("move_to", TaskStatus.SUCCEEDED)]


def test_parallel_starts_every_branch_and_waits_for_all(scenario: ScenarioFactory) -> None:
    result = run(scenario, """activity {
        parallel { alice stand for 2 s; bob stand for 4 s }
        alice stand for 1 s
    }""")
    assert started(result, "alice", "stand")[0] == started(result, "bob", "stand")[0] == 0.0
    assert started(result, "alice", "stand")[1] == pytest.approx(4.0, abs=0.06)


def test_race_ends_with_the_first_branch_and_preempts_the_others(
        scenario: ScenarioFactory) -> None:
    result = run(scenario, """activity {
        race { alice stand for 1 s; bob move_around forever }
    }""")
    assert result.state is RunState.COMPLETED
    assert result.time == pytest.approx(1.0, abs=0.06)
    assert statuses(result, "bob") == [("move_around", TaskStatus.PREEMPTED)]
    assert [e.reason for e in result.events if e.human == "bob" and e.status.is_final] == [
        "another branch of its race ended first"]


def test_repeat_runs_its_body_n_times(scenario: ScenarioFactory) -> None:
    result = run(scenario, """activity {
        repeat 3 { alice stand for 0.5 s; alice stand facing bob for 0.5 s }
    }""")
    assert len(statuses(result, "alice")) == 6
    assert result.time == pytest.approx(3.0, abs=0.1)


def test_wait_holds_the_flow(scenario: ScenarioFactory) -> None:
    result = run(scenario, "activity { wait 2 s; alice stand for 1 s }")
    assert started(result, "alice", "stand") == [pytest.approx(2.0, abs=0.06)]


def test_wait_until_a_label_of_another_activity(scenario: ScenarioFactory) -> None:
    result = run(scenario, """
    activity first { go: alice stand for 2 s }
    activity second { wait until go done; bob stand for 1 s }
    """)
    assert started(result, "bob", "stand") == [pytest.approx(2.0, abs=0.06)]


@pytest.mark.parametrize(("condition", "earliest"), [
    ("time >= 1.5 s", 1.5),
    ("alice in rect((3.5, 1), (5, 3))", 0.5),
    ("distance(alice, (4, 2)) < 0.5 m", 0.5),
    ("alice reaches (4, 2)", 0.5),
    ("not time < 1 s and (time > 100 s or time >= 1 s)", 1.0),
])
def test_wait_until_conditions(scenario: ScenarioFactory, condition: str,
                               earliest: float) -> None:
    result = run(scenario, f"""
    activity {{ alice move_to (4, 2) }}
    activity {{ wait until {condition}; bob stand for 0.1 s }}
    """)
    assert result.state is RunState.COMPLETED
    (when,) = started(result, "bob", "stand")
    assert when >= earliest - 0.06


def test_time_conditions_are_exact_at_the_tick_that_reaches_their_bound(
        scenario: ScenarioFactory) -> None:
    # 56 ticks of 0.05 s make 2.8000000000000003 s: `time <= 2.8 s` failed at the run's last
    # tick, and `time > 2.8 s` held there
    result = run(scenario, """activity { alice stand for 2.8 s }
    expect time <= 2.8 s always
    """)
    assert result.time == pytest.approx(2.8) and result.expectations[0].held
    result = run(scenario, "activity { bob stand until time > 2.8 s }")
    assert statuses(result, "bob") == [("stand", TaskStatus.PREEMPTED)]
    assert result.time == pytest.approx(2.85)     # the tick after 2.8 s, not the one at it


def test_until_preempts_and_counts_as_done(scenario: ScenarioFactory) -> None:
    result = run(scenario, """activity {
        w: alice move_around forever until time >= 2 s
        alice stand for 0.5 s
    }
    activity { wait until w done; bob stand for 0.1 s }""")
    assert statuses(result, "alice")[0] == ("move_around", TaskStatus.PREEMPTED)
    assert started(result, "bob", "stand") == [pytest.approx(2.0, abs=0.1)]
    ended = next(e for e in result.events if e.status is TaskStatus.PREEMPTED)
    assert ended.reason == "until time >= 2 s held"     # done, unlike a race's loser


def test_within_aborts_a_late_task_and_on_failure_stop_ends_the_run(
        scenario: ScenarioFactory) -> None:
    result = run(scenario, """activity {
        alice move_to (8, 2) within 1 s
        alice stand for 1 s
    }""")
    assert result.state is RunState.FAILED
    assert "within 1 s" in result.reason
    assert statuses(result, "alice") == [("move_to", TaskStatus.ABORTED)]


def test_on_failure_continue_goes_on_and_marks_the_label_failed(
        scenario: ScenarioFactory) -> None:
    result = run(scenario, """on_failure continue
    activity {
        late: alice move_to (8, 2) within 1 s
        alice stand for 1 s
    }
    activity { wait until late failed; bob stand for 0.1 s }""")
    assert result.state is RunState.COMPLETED
    assert statuses(result, "alice")[1] == ("stand", TaskStatus.SUCCEEDED)
    assert started(result, "bob", "stand") == [pytest.approx(1.0, abs=0.06)]


def test_time_limit_ends_the_run_as_timed_out(scenario: ScenarioFactory) -> None:
    result = run(scenario, "time_limit 2 s\nactivity { alice stand for 10 s }")
    assert result.state is RunState.TIMED_OUT
    assert result.time == pytest.approx(2.0)
    assert "time limit" in result.reason


def test_a_forever_task_does_not_keep_the_run_alive(scenario: ScenarioFactory) -> None:
    result = run(scenario, """
    activity { alice move_around forever }
    activity { bob stand for 1 s }
    """)
    assert result.state is RunState.COMPLETED
    assert result.time == pytest.approx(1.0, abs=0.06)


def test_labelled_composite_steps_report_started_and_done(scenario: ScenarioFactory) -> None:
    result = run(scenario, """
    human carol at (5, 5)
    activity { both: parallel { alice stand for 1 s; bob stand for 2 s } }
    activity { wait until both started; wait until both done; carol stand for 0.1 s }
    """)
    assert started(result, "carol", "stand") == [pytest.approx(2.0, abs=0.06)]


def test_expectations_are_judged(scenario: ScenarioFactory) -> None:
    result = run(scenario, """activity { alice move_to (4, 2) }
    expect alice reaches (4, 2) within 30 s
    expect alice reaches (9, 7) eventually
    expect distance(alice, bob) > 1 m always
    expect time < 0.5 s always
    """)
    held = [e.held for e in result.expectations]
    assert held == [True, False, True, False]
    assert not result.succeeded and result.state is RunState.COMPLETED


def test_the_same_seed_gives_the_same_run(scenario: ScenarioFactory) -> None:
    body = "activity { alice move_around for 5 s; bob follow alice for 5 s }"
    first, second = run(scenario, body, seed=4), run(scenario, body, seed=4)
    assert [(e.tick, e.human, e.status) for e in first.events] == \
        [(e.tick, e.human, e.status) for e in second.events]
    assert [h.path_length for h in first.humans] == [h.path_length for h in second.humans]


def test_a_task_still_on_when_the_run_ends_counts_its_time(scenario: ScenarioFactory) -> None:
    program = scenario("time_limit 4 s\nhuman a at (2, 2)\nhuman b at (3, 3)\n"
                       "activity { a stand for 1 s }\nactivity { b move_around forever }\n")
    result = run_program(Simulation(program))
    busy = {summary.name: summary.busy_time for summary in result.humans}
    assert result.time == pytest.approx(1.0)  # the run ends with a's activity
    assert busy["a"] == pytest.approx(1.0)
    assert busy["b"] == pytest.approx(1.0)  # wandering until the run ended, not 0


def test_a_within_shorter_than_the_step_gives_the_task_a_step(scenario: ScenarioFactory) -> None:
    # rounded to no step at all, the task was aborted as it started, at t = 0
    result = run(scenario, "activity { alice stand for 3 s within 0.01 s }")
    (ended,) = [e for e in result.events if e.status.is_final]
    assert ended.status is TaskStatus.ABORTED and ended.time == pytest.approx(0.05)


def test_tasks_reached_when_a_failure_stops_the_run_count_as_pending(
        scenario: ScenarioFactory) -> None:
    # at t = 1 s alice's walk is aborted, bob's first stand ends and his repeat begins
    result = run(scenario, """activity { alice move_to (8, 2) within 1 s }
    activity {
        bob stand for 1 s
        repeat 2 { bob stand for 1 s }
    }""")
    assert result.state is RunState.FAILED and result.time == pytest.approx(1.0)
    bob = next(summary for summary in result.humans if summary.name == "bob")
    assert (bob.tasks_done, bob.tasks_total, bob.last_status) == (1, 2, "PENDING")
    assert started(result, "bob", "stand") == [0.0]
