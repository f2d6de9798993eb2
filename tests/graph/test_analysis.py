"""The E3xx analyses: each one on a scenario that has the problem and on one that does not."""

from __future__ import annotations

import pytest

from hubero_dsl.diagnostics import Diagnostic, Related, Severity
from hubero_dsl.graph.build import build_activity_graph
from hubero_dsl.graph.verify import verify_activities
from hubero_dsl.lang.parse import parse_source
from hubero_dsl.model.conditions import required_labels
from hubero_dsl.pipeline import lower_activities


def analyse(text: str, **options: bool) -> list[Diagnostic]:
    module = parse_source(text, "t.hub")
    activities = lower_activities(module)
    return verify_activities(activities, build_activity_graph(activities), **options)


def at(finding: Diagnostic | Related) -> tuple[int, int]:
    assert finding.span is not None
    return (finding.span.line, finding.span.column)


def found(text: str) -> list[tuple[str, int, int]]:
    """(code, line, column) of every diagnostic."""
    return [(d.code, d.span.line, d.span.column) for d in analyse(text) if d.span]


def only(text: str, code: str) -> Diagnostic:
    matching = [d for d in analyse(text) if d.code == code]
    assert len(matching) == 1, matching
    return matching[0]


CLEAN = """\
activity dinner {
    invite: actor2 move_to sofa
    actor2 talk to actor1 for 5 s
    parallel {
        actor2 move_to (2.0, -2.8)
        { wait until invite done; actor1 move_to (0.6, -2.0) }
    }
    race { actor1 stand forever; wait 10 s }
    repeat 2 { actor1 move_around times 3 }
    actor2 stand forever
}
activity robots {
    wait until invite started
    actor3 follow actor2 for 30 s
}
"""


def test_a_clean_scenario_has_no_findings() -> None:
    assert analyse(CLEAN) == []


# ---- E301/E302: one controller per human at a time ----------------------------------------


def test_human_in_two_activities() -> None:
    diagnostic = only("activity a { actor1 stand for 1 s }\n"
                      "activity { wait 1 s; actor1 move_to (1, 1) }\n", "E301")
    assert at(diagnostic) == (2, 22)
    assert "activity `a` and the activity at line 2" in diagnostic.message
    assert diagnostic.related[0].span.line == 1
    assert diagnostic.hint


def test_human_in_two_activities_is_reported_once_per_activity() -> None:
    text = ("activity a { actor1 stand for 1 s; actor1 stand for 2 s }\n"
            "activity b { actor1 stand for 1 s; actor1 stand for 2 s }\n")
    assert found(text) == [("E301", 2, 14)]


def test_two_parallel_branches_command_one_human() -> None:
    text = ("activity a {\n    parallel {\n        h stand for 1 s\n        h move_to (1, 1)\n"
            "    }\n}\n")
    diagnostic = only(text, "E302")
    assert at(diagnostic) == (4, 9)
    assert diagnostic.related[0].span.line == 3


def test_two_race_branches_command_one_human() -> None:
    assert found("activity a {\n    race { h stand forever; { wait 5 s; h run_to (1, 1) } }\n}\n"
                 ) == [("E302", 2, 41)]


def test_sequential_steps_and_ordered_branches_are_fine() -> None:
    assert found("activity a {\n    h stand for 1 s\n    h move_to (1, 1)\n"
                 "    repeat 2 { h stand for 1 s; h move_to (0, 0) }\n}\n") == []
    # the second branch waits until the first is done: never at the same time
    assert found("activity a {\n    parallel {\n        go: h move_to (1, 1)\n"
                 "        { wait until go done; h stand for 1 s }\n    }\n}\n") == []
    # a nested parallel after a race: the race's losers are preempted before it starts
    assert found("activity a {\n    race { h stand forever; wait 1 s }\n"
                 "    parallel { h stand for 1 s; g stand for 1 s }\n}\n") == []


def test_waiting_only_until_started_still_overlaps() -> None:
    text = ("activity a {\n    parallel {\n        go: h move_to (1, 1)\n"
            "        { wait until go started; h stand for 1 s }\n    }\n}\n")
    assert found(text) == [("E302", 4, 34)]


# ---- E303/E304/E305/E312: waits ------------------------------------------------------------


def test_wait_for_unknown_label() -> None:
    diagnostic = only("activity a {\n    wait until nobody done or time > 5 s\n}\n", "E303")
    assert at(diagnostic) == (2, 16)
    assert analyse("activity a { wait until nobody done }", label_names=False) == []


def test_wait_for_a_label_later_in_the_same_sequence() -> None:
    diagnostic = only("activity a {\n    wait until go done\n    go: h move_to (1, 1)\n}\n",
                      "E304")
    assert at(diagnostic) == (2, 5)
    assert "`go` can only finish after this wait" in diagnostic.message
    assert at(diagnostic.related[0]) == (3, 5)


def test_wait_inside_the_step_it_waits_for() -> None:
    diagnostic = only("activity a {\n    outer: { h stand for 1 s; wait until outer done }\n}\n",
                      "E304")
    assert at(diagnostic) == (2, 31)
    assert "part of `outer`" in diagnostic.message
    assert found("activity a {\n    outer: { h stand for 1 s; wait until outer started }\n}\n"
                 ) == []


def test_wait_in_a_branch_for_a_label_after_the_parallel() -> None:
    text = ("activity a {\n    parallel {\n        wait until later started\n"
            "        h stand for 1 s\n    }\n    later: wait 1 s\n}\n")
    assert found(text) == [("E304", 3, 9)]


def test_wait_for_a_label_earlier_or_beside_is_fine() -> None:
    assert found("activity a {\n    go: h move_to (1, 1)\n    wait until go done\n}\n") == []
    assert found("activity a {\n    parallel {\n        wait until go done and go started\n"
                 "        go: h move_to (1, 1)\n    }\n}\n") == []


def test_deadlock_across_activities_names_the_cycle() -> None:
    text = ("activity a {\n    wait until b1 done\n    a1: h move_to (1, 1)\n}\n"
            "activity b {\n    wait until a1 done\n    b1: g move_to (1, 1)\n}\n")
    diagnostic = only(text, "E305")
    assert at(diagnostic) == (2, 5)
    assert diagnostic.message == (
        "deadlock: `wait until b1 done` needs `b1 done`, which can only happen after "
        "`wait until a1 done` (line 6, in activity `b`), which needs `a1 done`, which can only "
        "happen after this wait")
    assert [at(r) for r in diagnostic.related] == [(6, 5), (7, 5), (3, 5)]


def test_deadlock_between_branches_of_one_parallel() -> None:
    text = ("activity a {\n    parallel {\n        { wait until y done; x: wait 1 s }\n"
            "        { wait until x done; y: wait 1 s }\n    }\n}\n")
    assert found(text) == [("E305", 3, 11)]


def test_three_way_deadlock_is_one_finding() -> None:
    text = ("activity a { wait until c1 done; a1: wait 1 s }\n"
            "activity b { wait until a1 done; b1: wait 1 s }\n"
            "activity c { wait until b1 done; c1: wait 1 s }\n")
    diagnostic = only(text, "E305")
    assert at(diagnostic)[0] == 1
    assert diagnostic.message.count("needs") == 3


def test_only_what_a_condition_needs_orders_a_wait() -> None:
    # `or` and `not` may hold without the label, so they make no cycle
    assert found("activity a {\n    wait until b1 done or time > 5 s\n    b1: wait 1 s\n}\n") == []
    assert found("activity a {\n    wait until not b1 done\n    b1: wait 1 s\n}\n") == []
    assert [c.code for c in analyse("activity a {\n    wait until time > 1 s and b1 done\n"
                                    "    b1: wait 1 s\n}\n")] == ["E304"]


@pytest.mark.parametrize("wait", ["y done or y failed", "not (not y done)",
                                  "(y done and time > 1 s) or y started"])
def test_a_deadlock_behind_or_and_double_not_is_found(wait: str) -> None:
    # both sides of the `or` need `y` to have started: they hung until the time limit
    text = (f"activity a {{\n    wait until {wait}\n    x: h stand for 1 s\n}}\n"
            "activity b {\n    wait until x done\n    y: g stand for 1 s\n}\n")
    diagnostic = only(text, "E305")
    assert at(diagnostic)[0] == 2 and "which needs `x done`" in diagnostic.message


def test_a_wait_for_a_label_inside_a_race_branch_is_warned_of() -> None:
    race = ("activity a {\n    race {\n        h stand for 2 s\n"
            "        { wait 5 s; toast: g stand for 1 s%s }\n    }\n}\n")
    diagnostic = only(race % "" + "activity b { wait until toast started }\n", "E314")
    assert at(diagnostic) == (7, 14) and "race` at line 2" in diagnostic.message
    assert at(diagnostic.related[0]) == (4, 21)
    # inside its own branch, or with a way out, the wait is sure to end
    assert found(race % "; wait until toast done") == []
    assert found(race % "" + "activity b { wait until toast started or time > 9 s }\n") == []


def test_wait_for_a_label_that_runs_forever() -> None:
    text = ("activity a {\n    idle: h stand forever\n}\n"
            "activity b {\n    wait until idle done\n    wait until idle started\n}\n")
    diagnostic = only(text, "E312")
    assert at(diagnostic) == (5, 5)
    assert diagnostic.related[0].span.line == 2


def test_wait_for_a_block_held_open_by_a_forever_task() -> None:
    text = ("activity a {\n    both: parallel { h stand forever; g move_to (1, 1) }\n}\n"
            "activity b { wait until both done }\n")
    assert [d.code for d in analyse(text)] == ["E308", "E312"]


# ---- E306/E307/E308/E313: how tasks end -----------------------------------------------------


@pytest.mark.parametrize("task", ["stand", "move_around", "follow b", "talk to b", "sit_down",
                                  "lie_down", "teleop", "stand within 5 s"])
def test_task_without_end(task: str) -> None:
    diagnostic = only(f"activity a {{\n    x: h {task}\n}}\n", "E306")
    assert at(diagnostic) == (2, 5)
    assert diagnostic.hint == "add `for 10 s`, `until ...`, or `forever`"


@pytest.mark.parametrize("task", ["stand for 2 s", "move_around times 3", "move_around for 5 s",
                                  "follow b for 1 min", "talk until b reaches (1, 1)",
                                  "move_to (1, 1)", "run_to b", "teleop forever"])
def test_task_with_an_end(task: str) -> None:
    assert analyse(f"activity a {{\n    h {task}\n}}\n") == []


def test_forever_on_a_task_that_ends_by_itself_is_a_warning() -> None:
    for task in ("move_to (1, 1) forever", "stand for 2 s forever"):
        diagnostic = only(f"activity a {{\n    h {task}\n}}\n", "E307")
        assert diagnostic.severity is Severity.WARNING
        assert at(diagnostic) == (2, 5)


def test_forever_task_followed_by_steps() -> None:
    diagnostic = only("activity a {\n    h stand forever\n    h move_to (1, 1)\n}\n", "E308")
    assert at(diagnostic) == (2, 5)
    assert "steps after it never run" in diagnostic.message
    assert diagnostic.related[0].span.line == 3


def test_forever_task_in_a_parallel_branch() -> None:
    text = ("activity a {\n    parallel {\n        h stand forever\n        g move_to (1, 1)\n"
            "    }\n}\n")
    diagnostic = only(text, "E308")
    assert at(diagnostic) == (3, 9)
    assert "`parallel` around it never ends" in diagnostic.message
    assert diagnostic.related[0].span.line == 2


def test_forever_task_in_a_repeat() -> None:
    assert found("activity a {\n    repeat 2 { h stand forever }\n}\n") == [("E308", 2, 16)]
    assert found("activity a {\n    repeat 1 { h stand forever }\n}\n") == []


def test_forever_task_where_it_is_fine() -> None:
    assert found("activity a {\n    h move_to (1, 1)\n    h stand forever\n}\n") == []
    assert found("activity a {\n    l: { h stand forever }\n}\n") == []
    assert found("activity a {\n    race { h stand forever; wait 5 s }\n    h stand for 1 s\n}\n"
                 ) == []
    assert found("activity a {\n    race { parallel { h stand forever; g move_to (1, 1) }\n"
                 "           wait 5 s }\n    g stand for 1 s\n}\n") == []
    assert found("activity a {\n    h stand forever until g reaches (1, 1)\n"
                 "    h move_to (1, 1)\n}\n") == []


def test_race_of_forever_tasks_never_ends() -> None:
    text = "activity a {\n    race { h stand forever; g stand forever }\n    wait 1 s\n}\n"
    assert found(text) == [("E308", 2, 12), ("E308", 2, 29)]
    assert "`race` around it never ends" in analyse(text)[0].message
    assert found("activity a {\n    race { h stand forever; g stand forever }\n}\n") == []


def test_until_that_cannot_hold_while_the_task_runs() -> None:
    text = "activity a {\n    h stand until later done\n    later: wait 1 s\n}\n"
    diagnostic = only(text, "E313")
    assert diagnostic.severity is Severity.ERROR and "never ends" in diagnostic.message
    assert at(diagnostic) == (2, 5)
    warning = only("activity a {\n    me: h move_to (1, 1) until me done\n}\n", "E313")
    assert warning.severity is Severity.WARNING
    assert found("activity a {\n    parallel {\n        h stand until other done\n"
                 "        other: g move_to (1, 1)\n    }\n}\n") == []


# ---- E309/E310/E311: counts, labels, empty blocks --------------------------------------------


@pytest.mark.parametrize(("count", "column"), [("0", 12), ("-2", 12), ("2.5", 12), ("1e1", 12)])
def test_bad_repeat_count(count: str, column: int) -> None:
    diagnostic = only(f"activity a {{\n    repeat {count} {{ wait 1 s }}\n}}\n", "E309")
    assert at(diagnostic) == (2, column)


def test_good_repeat_count() -> None:
    assert analyse("activity a {\n    repeat 1 { wait 1 s }\n    repeat 10 { wait 1 s }\n}\n") == []


def test_duplicate_label() -> None:
    text = "activity a {\n    go: wait 1 s\n}\nactivity b {\n    go: { wait 1 s }\n}\n"
    diagnostic = only(text, "E310")
    assert at(diagnostic) == (5, 5)
    assert at(diagnostic.related[0]) == (2, 5)
    assert analyse(text, label_names=False) == []


def test_empty_blocks() -> None:
    text = ("activity a {\n    parallel { }\n    parallel { wait 1 s; { } }\n"
            "    race { wait 1 s; { } }\n    race { { } }\n}\n")
    assert [(d.code, d.severity.value, *at(d)) for d in analyse(text)] == [
        ("E311", "warning", 2, 5), ("E311", "warning", 3, 26), ("E311", "error", 4, 22),
        ("E311", "warning", 5, 12)]


# ---- helpers ------------------------------------------------------------------------------


def test_required_labels_are_the_conjuncts() -> None:
    module = parse_source("activity a { wait until a done and (b started and time > 1 s) or c "
                          "done }\nactivity b { wait until a done and (b started and not c "
                          "failed) }", "t.hub")
    conditions = [a.steps[0].condition for a in lower_activities(module)]  # type: ignore[union-attr]
    assert required_labels(conditions[0]) == []
    assert [(c.label.name, c.event.value) for c in required_labels(conditions[1])] == [
        ("a", "done"), ("b", "started")]


def test_findings_come_in_source_order_with_hints() -> None:
    diagnostics = analyse("activity a {\n    h stand\n    repeat 0 { h stand }\n}\n")
    assert [d.span.line for d in diagnostics if d.span] == sorted(
        d.span.line for d in diagnostics if d.span)
    assert all(d.hint for d in diagnostics)
