"""`check_source` on small texts: which diagnostic, exactly where, and what checks clean.

The header of `check(body)` is four lines (see conftest.py), so a body's first line is line 5.
Spans are (line, column, end column), 1-based, end exclusive.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path

import pytest

from hubero_dsl.lang.symbols import reserved_words
from hubero_dsl.model.program import Distribution
from hubero_dsl.pipeline import CheckResult, check_source
from hubero_dsl.world.shapes import Circle, Ellipse, Rectangle
from tests.lang.conftest import CASE_PATH, ROOM

Check = Callable[..., CheckResult]


def codes(result: CheckResult) -> list[str]:
    return [d.code for d in result.diagnostics]


def spans(result: CheckResult) -> list[tuple[str, int, int, int]]:
    found = []
    for diagnostic in result.diagnostics:
        span = diagnostic.span
        assert span is not None and span.end_line == span.line
        found.append((diagnostic.code, span.line, span.column, span.end_column))
    return found


def test_a_robots_limits_take_units_or_bare_numbers_in_si(check: Check) -> None:
    limits = {"max_acceleration 2 m/s^2; max_angular_speed 90 deg/s": (2.0, math.pi / 2),
              "max_acceleration 2; max_angular_speed 1.5": (2.0, 1.5)}
    for written, expected in limits.items():
        result = check(f"robot r at (5.5, 1.0) {{ kinematics unicycle; {written} }}\n"
                       "activity { actor1 stand for 1 s }")
        assert result.program is not None, result.diagnostics
        (robot,) = result.program.robots
        assert (robot.max_acceleration, robot.max_angular_speed) == pytest.approx(expected)
    wrong = check("robot r at (5.5, 1.0) { max_angular_speed 1 m/s }")
    assert [(d.code, d.message) for d in wrong.errors] == [
        ("E201", "'max_angular_speed' takes an angular speed (rad/s, deg/s), but 'm/s' is a "
                 "unit of speed")]


def test_metrics_of_acceleration_compare_with_accelerations(check: Check) -> None:
    body = ("robot r at (5.5, 1.0) { path (5.5, 1.0) -> (6, 1) }\n"
            "activity { actor1 stand for 1 s }\n")
    assert not check(body + "expect max_acceleration(r) <= 3 m/s^2\n"
                            "expect social_force(r) <= 1\n").errors
    assert codes(check(body + "expect avg_acceleration(r) <= 3 m/s\n")) == ["E201"]


def test_a_member_of_a_crowd_is_set_for_the_crowd_or_in_a_variant(check: Check) -> None:
    result = check("crowd u 3 in rect((5, 0.5), (6, 1.5)) { u_1.speed 1 m/s }")
    (error,) = result.errors
    assert (error.code, error.hint) == ("E105", "set it for all of crowd 'u' in its block as "
                                        "`speed`, or for u_1 alone in a variant")


def test_a_flows_people_are_in_no_group(check: Check) -> None:
    result = check("flow f from rect((5, 0.5), (6, 1.5)) to (6.3, 2.5) rate 1 /s for 3 s\n"
                   "group g of (f_1, actor1)")
    (error,) = result.errors
    assert error.code == "E103"
    assert error.message.startswith("'f_1' is one of the people flow 'f' brings")


def test_all_and_any_take_reach_and_reaches_alike(check: Check) -> None:
    body = ("crowd u 3 in rect((5, 0.5), (6, 1.5))\nactivity { u stand for 1 s }\n"
            "expect all u reaches (5.5, 1) eventually\nexpect any u reach (5.5, 1) eventually\n")
    assert not check(body).errors


def test_a_flow_whose_target_is_wrong_is_told_so_at_the_target_alone(check: Check) -> None:
    for target, code in (("(5.5, 0.0)", "E403"), ("(5.5, 0.38)", "E405")):
        flow = f"flow f from rect((2, 1), (3, 2)) to {target} rate 6 /min for 10 s"
        (error,) = check(flow).errors
        assert error.code == code and error.span is not None
        assert (error.span.line, error.span.column) == (5, flow.index(target) + 1)


def test_a_step_given_to_a_crowd_is_reported_once_not_per_member(check: Check) -> None:
    result = check("crowd c 5 in rect((2, 1), (3, 2))\n"
                   "activity { c move_around in rect((2, 1), (3, 2)) }")
    assert codes(result) == ["E306"]


def test_a_crowds_steps_that_clash_are_told_once_in_the_crowds_words(check: Check) -> None:
    # each member's steps were found alike: five E302 naming `c_1` to `c_5`, and an E308
    # quoting the first member's step
    result = check("crowd c 5 in rect((2, 1), (3, 2))\n"
                   "activity {\n"
                   "    parallel {\n"
                   "        c stand for 2 s\n"
                   "        c stand for 3 s\n"
                   "    }\n"
                   "    c stand forever\n"
                   "    c talk for 2 s\n"
                   "}")
    clash, forever = result.errors
    assert (clash.code, clash.message) == (
        "E302", "`c` is commanded by two steps that can run at the same time")
    assert clash.related[0].message == "this step also commands `c`"
    assert (forever.code, forever.message) == (
        "E308", "`c stand forever` runs forever, so the steps after it never run")
    assert forever.related[0].message == "`c talk for 2 s` never runs"


def test_a_member_commanded_on_its_own_is_told_by_its_name(check: Check) -> None:
    result = check("crowd c 3 in rect((2, 1), (3, 2))\n"
                   "activity { c stand for 5 s }\n"
                   "activity { c_2 stand for 1 s }")
    (clash,) = result.errors
    assert clash.code == "E301" and clash.message.startswith("`c_2` is commanded by two")
    assert clash.related[0].message.endswith("commands `c_2` here")


@pytest.mark.parametrize("order", ["member first", "crowd first"])
def test_a_member_on_a_step_of_its_own_keeps_its_name_whichever_comes_first(
        check: Check, order: str) -> None:
    steps = ["c_3 stand for 2 s", "c stand for 5 s"]
    steps = steps if order == "member first" else steps[::-1]
    result = check("crowd c 5 in rect((2, 1), (3, 2))\n"
                   "activity {\n    parallel {\n" + "".join(f"        {s}\n" for s in steps)
                   + "    }\n}")
    (clash,) = result.errors
    assert clash.message == "`c_3` is commanded by two steps that can run at the same time"
    assert clash.related[0].message == "this step also commands `c_3`"


def test_members_own_steps_keep_their_names_in_a_crowd_of_one_and_between_two(
        check: Check) -> None:
    one = check("crowd c 1 in rect((2, 1), (3, 2))\n"
                "activity { c stand for 1 s }\n"
                "activity { c_1 stand forever; actor1 stand for 1 s }")
    assert [d.message.split(" ")[0] for d in one.errors] == ["`c_1`", "`c_1"]
    two = check("crowd c 3 in rect((2, 1), (3, 2))\n"
                "activity { c_1 stand forever; c_2 stand for 1 s }")
    (forever,) = two.errors
    assert forever.message.startswith("`c_1 stand forever` runs forever")
    assert forever.related[0].message == "`c_2 stand for 1 s` never runs"


def test_a_crowds_step_is_quoted_as_written_where_others_wait_for_it(check: Check) -> None:
    # E312 at the wait quoted the first member's step: `c_1 stand forever`
    result = check("crowd c 3 in rect((2, 1), (3, 2))\n"
                   "activity { x: c stand forever }\n"
                   "activity { wait until x done; actor1 stand for 1 s }")
    (never,) = [d for d in result.errors if d.code == "E312"]
    assert "`x: c stand forever` runs forever" in never.message


def test_a_deadlock_with_a_crowds_step_is_told_once(check: Check) -> None:
    # once from each side: at the human's step, and (folded) at the crowd's
    result = check("crowd c 3 in rect((2, 1), (3, 2))\n"
                   "activity {\n    parallel {\n"
                   "        b: actor1 move_around in rect((2, 1), (3, 2)) until a done\n"
                   "        a: c move_around in rect((2, 1), (3, 2)) until b done\n"
                   "    }\n}")
    (deadlock,) = result.errors
    assert deadlock.code == "E305"
    assert "`a: c move_around in rect((2, 1), (3, 2)) until b done`" in deadlock.message


def test_a_group_of_some_of_a_crowds_members_is_named_by_the_group(check: Check) -> None:
    result = check("crowd c 4 in rect((2, 1), (3, 2))\n"
                   "group pair of (c_1, c_2)\n"
                   "activity {\n    parallel {\n        c stand for 2 s\n"
                   "        pair stand for 2 s\n    }\n}")
    (clash,) = result.errors
    assert clash.message == "`pair` is commanded by two steps that can run at the same time"


def test_some_of_a_crowds_members_commanded_by_another_activity_are_named_not_the_crowd(
        check: Check) -> None:
    # the crowd's task clashed with the group's only: it read "`c` is commanded by two ..."
    text = ("crowd c 4 in rect((2, 1), (3, 2))\n{}\n"
            "activity one {{ pals move_around in rect((2, 1), (3, 2)) for 10 s }}\n"
            "activity two {{ c move_to (2.5, 1.5) }}")
    (clash,) = check(text.format("group pals of (c_1, c_2)")).errors
    assert clash.message == ("`pals` is commanded by two activities, activity `one` and "
                             "activity `two`, which run at the same time")
    assert (clash.span.line, clash.span.column) == (8, 16)
    assert clash.related[0].message == "activity `one` commands `pals` here"
    mixed = check(text.format("group pals of (c_1, c_2, actor1)")).errors  # not all of c
    assert [(d.message.split(" ")[0], d.span.line) for d in mixed] == [("`c_1`", 8),
                                                                       ("`c_2`", 8)]


def test_a_slip_of_a_crowds_name_suggests_the_crowd(check: Check) -> None:
    (error,) = check("crowd shoppers 3 in rect((2, 1), (3, 2))\n"
                     "activity { shopers stand for 1 s }").errors
    assert (error.code, error.hint) == ("E101", "did you mean 'shoppers'?")


def test_a_groups_parameter_in_a_variant_is_set_for_its_members(check: Check) -> None:
    (error,) = check("group g of (actor1, actor2)\nvariant v { g.speed 1 m/s }").errors
    assert error.code == "E105" and error.message.startswith("'g' is a group")
    assert error.hint == "set it for each member: actor1.speed, actor2.speed"


def test_an_equals_sign_is_told_which_comparisons_there_are(check: Check) -> None:
    (error,) = check("activity { wait until count(actor1 in rect((2, 1), (3, 2))) == 1 }"
                     ).errors
    assert error.code == "E002" and error.hint is not None
    assert error.hint.startswith("a comparison is <, <=, > or >=")


def test_a_crowd_where_one_body_is_meant_is_shown_the_form_for_many(check: Check) -> None:
    crowd = "crowd c 3 in rect((2, 1), (3, 2))\nactivity { c stand for 1 s }\n"
    hints = {"expect c in rect((2, 1), (3, 2)) always": "count them: `count(c in AREA) >= N`",
             "expect c reaches (2.5, 1.5) eventually":
                 "of many: `all c reach ...`, `any c reaches ...`"}
    for expectation, hint in hints.items():
        (error,) = check(crowd + expectation).errors
        assert (error.code, error.hint) == ("E103", hint)


def test_a_task_without_its_target_is_shown_the_target_it_takes(check: Check) -> None:
    (follow,) = check("activity { actor1 follow for 3 s }").errors
    assert (follow.code, follow.hint) == ("E205", "write a human or robot: `actor1 follow NAME`")
    (move,) = check("activity { actor1 move_to speed 1 m/s }").errors
    assert move.hint == "write `actor1 move_to PLACE` or a point `(x, y)`"


def test_a_body_too_large_says_which_variant_makes_it_so(check: Check) -> None:
    result = check("variant big { actor1.radius 1.5 m }\nactivity { actor1 stand for 1 s }")
    (error,) = result.errors
    assert error.code == "E405"
    assert "a body of radius 1.5 m (variant 'big') does not fit" in error.message
    own = check("variant small { actor1.radius 0.1 m }\nactivity { actor1 stand for 1 s }")
    assert not own.errors  # the file's own radius fits: no variant to name



def test_a_humans_own_radius_is_checked_rather_than_the_defaults(check: Check) -> None:
    body = ("defaults {{ radius {defaults} }}\n"
            "human near_wall at (-4.95, 0.0) {{ radius {own} }}\n"  # 0.17 m from the wall
            "activity {{ near_wall stand for 1 s }}")
    fits = check(body.format(defaults="0.4 m", own="0.15 m"))
    assert not fits.errors, fits.errors  # its own 0.15 m is what it runs with
    (error,) = check(body.format(defaults="0.15 m", own="0.4 m")).errors
    assert error.code == "E405" and "a body of radius 0.4 m does not fit" in error.message

# ---- one diagnostic, pinned to its span ---------------------------------------------------

SINGLE = {
    "unknown human": ("activity { actor3 stand for 1 s }", ("E101", 5, 12, 18)),
    "duplicate name": ("place actor1 (5.5, 1.0)", ("E102", 5, 7, 13)),
    "keyword as a name": ("place wait (5.5, 1.0)", ("E104", 5, 7, 11)),
    "unknown parameter": ("defaults { sped 1 m/s }", ("E105", 5, 12, 16)),
    "per-human outside a variant": ("defaults { actor1.speed 1 m/s }", ("E105", 5, 12, 24)),
    "a robot's parameter in a variant": ("robot r at (5.5, 1.0)\nvariant v { r.speed 1 m/s }",
                                         ("E105", 6, 13, 20)),
    "duplicate parameter": ("defaults { speed 1 m/s; speed 2 m/s }", ("E106", 5, 25, 30)),
    "unknown planner parameter": ("defaults { social_force.AA 1 }", ("E105", 5, 12, 27)),
    "option not taken": ("activity { actor1 move_to (5.5, 1.0) for 5 s }", ("E107", 5, 38, 45)),
    "wrong dimension": ("defaults { speed 5 s }", ("E201", 5, 18, 21)),
    "unknown unit": ("defaults { speed 5kg }", ("E202", 5, 18, 21)),
    "zero radius": ("defaults { radius 0 m }", ("E203", 5, 19, 22)),
    "a seed of 19 digits": ("seed 1234567890123456789", ("E203", 5, 6, 25)),
    "an unknown unit glued to a task's time": (
        "activity { actor1 stand for 5kg }", ("E202", 5, 29, 32)),
    "an unknown unit glued to an area's corner": (
        "activity { actor1 move_around in rect((1kg, 0), (2, 2)) for 2 s }",
        ("E202", 5, 40, 43)),
    "a step's modifier given twice": (
        "activity { actor1 move_to (5.5, 1.0) within 8 s within 1 s }", ("E106", 5, 49, 59)),
    "a human's time to goal": ("expect time_to_goal(actor1) <= 60 s", ("E103", 5, 21, 27)),
    "another controller's parameter": (
        "robot r at (5.5, 1.0) { navigator.safety_margin 0.3 m }", ("E105", 5, 25, 48)),
    "a robot's goal its body does not fit at": (
        "robot r at (5.5, 1.0) { goal (-2.0, 2.95) }", ("E405", 5, 30, 42)),
    "planner parameter out of range": ("defaults { social_force.lambda 2 }",
                                       ("E203", 5, 32, 33)),
    "missing unit": ("defaults { speed 5 }", ("E204", 5, 18, 19)),
    "missing target": ("activity { actor1 move_to }", ("E205", 5, 19, 26)),
    "normal sd zero": ("defaults { speed normal(1 m/s, 0 m/s) }", ("E206", 5, 32, 37)),
    "seed not whole": ("seed 1.5", ("E207", 5, 6, 9)),
    "two branches": ("activity { parallel { actor1 stand for 1 s; actor1 stand for 2 s } }",
                     ("E302", 5, 45, 65)),
    "label after the wait": ("activity { wait until l done; l: actor1 stand for 1 s }",
                             ("E304", 5, 12, 29)),
    "no natural end": ("activity { actor1 stand }", ("E306", 5, 12, 24)),
    "forever with no effect": ("activity { actor1 move_to (5.5, 1.0) forever }",
                               ("E307", 5, 12, 45)),
    "forever blocks": ("activity { actor1 talk forever; actor1 stand for 1 s }",
                       ("E308", 5, 12, 31)),
    "repeat 0": ("activity { repeat 0 { actor1 stand for 1 s } }", ("E309", 5, 19, 20)),
    "empty parallel": ("activity { parallel { } }", ("E311", 5, 12, 24)),
    "until never holds": ("activity { actor1 stand until n done; n: actor2 stand for 1 s }",
                          ("E313", 5, 12, 37)),
    "unknown task": ("activity { actor1 move_too (5.5, 1.0) }", ("E108", 5, 19, 27)),
    "k above the step's cap": ("defaults { social_force.k 1000 }", ("W106", 5, 27, 31)),
    "unused place": ("place sofa (5.5, 1.0)", ("W501", 5, 7, 11)),
    "longer than its within": ("activity { actor1 talk for 5 s within 2 s }",
                               ("W506", 5, 39, 42)),
    "a huge duration": ("activity { actor1 stand for 1e308 s }", ("E203", 5, 29, 36)),
    "a step too small": ("step 1e-12 s", ("E203", 5, 6, 13)),
    "a flow of people for days": (
        "time_limit 200000 s\nflow f from rect((5.6, 1.8), (6.0, 2.2)) to (5.5, 1.0) rate 0.05 /s",
        ("E203", 5, 12, 20)),
    "a digit of another script": ("activity { actor1 move_to (\u0669\u0669, 1.0) }",
                                  ("E002", 5, 28, 29)),
    "an infinite coordinate": ("activity { actor1 move_to (1e999, 1.0) }", ("E203", 5, 28, 33)),
    "a coordinate too far": ("activity { actor1 move_to (2e5, 1.0) }", ("E203", 5, 28, 31)),
    "a heading of turns past counting": ("activity { actor1 move_to (5.5, 1.0) heading 1e17 rad }",
                                         ("E203", 5, 46, 54)),
    "a polygon of two corners": ("activity { actor1 move_around in polygon((0, 0), (1, 1)) "
                                 "for 1 s }", ("E203", 5, 34, 57)),
}


def test_a_scenario_without_activities_is_warned_about(check: Check) -> None:
    assert codes(check("")) == ["W502"]
    assert "W502" in codes(check_source(ROOM + "activity { }", CASE_PATH))
    assert codes(check("activity { actor1 stand for 1 s }")) == []


def test_a_task_that_may_end_in_time_is_no_warning(check: Check) -> None:
    assert codes(check("activity { actor1 stand for 2 s within 2 s }")) == []
    assert codes(check("activity { parallel { actor1 move_around for 9 s until t done "
                       "within 2 s; t: actor2 stand for 1 s } }")) == []


def test_k_within_the_cap_of_a_smaller_step_is_no_warning(check: Check) -> None:
    assert codes(check("step 10 ms\ndefaults { social_force.k 1000 }")) == []
    assert codes(check("step 10 ms\ndefaults { social_force.k 6000 }")) == ["W106"]


@pytest.mark.parametrize(("body", "expected"), SINGLE.values(), ids=SINGLE.keys())
def test_one_diagnostic_at_its_span(check: Check, body: str,
                                    expected: tuple[str, int, int, int]) -> None:
    assert spans(check(body)) == [expected]


def test_people_times_ticks_are_bounded_not_each_alone(check: Check) -> None:
    flow = "flow f from rect((5.6, 1.8), (6.0, 2.2)) to (5.5, 1.0) rate 1 /s\n"
    assert codes(check("time_limit 3000 s\n" + flow)) == []       # about 1.9e8 body-ticks
    found = check("time_limit 3000 s\nstep 0.01 s\n" + flow).diagnostics
    assert [d.code for d in found] == ["E203"]
    assert "for 300,000 ticks (a time limit of 3000 s at a step of 0.01 s)" in found[0].message
    assert found[0].hint is not None and "fewer people" in found[0].hint


def test_unknown_name_is_pointed_at_with_a_did_you_mean(check: Check) -> None:
    result = check("place sofa (5.5, 1.0)\nactivity { actor1 move_to sofaa }")
    assert spans(result) == [("W501", 5, 7, 11), ("E101", 6, 27, 32)]
    assert result.diagnostics[1].hint == "did you mean 'sofa'?"


def test_name_of_the_wrong_kind_points_at_the_use_and_its_definition(check: Check) -> None:
    result = check("area zone rect((4.0, 1.0), (7.0, 3.0))\nactivity { actor1 move_to zone }")
    (diagnostic,) = result.diagnostics
    assert spans(result) == [("E103", 6, 27, 31)]
    assert diagnostic.message.startswith("'zone' is an area, but the target of move_to needs")
    assert [(r.span.line, r.span.column) for r in diagnostic.related] == [(5, 6)]


def test_two_activities_point_at_the_second_with_the_first_as_related(check: Check) -> None:
    result = check("activity { actor1 stand for 1 s }\nactivity { actor1 stand for 2 s }")
    (diagnostic,) = result.diagnostics
    assert spans(result) == [("E301", 6, 12, 32)]
    assert diagnostic.related[0].span.line == 5


def test_deadlock_is_reported_once_for_the_cycle(check: Check) -> None:
    result = check("activity { wait until b done; a: actor1 stand for 1 s }\n"
                   "activity { wait until a done; b: actor2 stand for 1 s }")
    assert spans(result) == [("E305", 5, 12, 29)]


def test_wait_for_a_label_a_forever_task_holds(check: Check) -> None:
    result = check("activity { parallel { c: actor1 talk forever; "
                   "{ wait until c done; actor2 stand for 1 s } } }")
    assert spans(result) == [("E308", 5, 23, 45), ("E312", 5, 49, 66)]


def test_points_off_the_map_and_in_obstacles(check: Check) -> None:
    result = check("place far (20.0, 0.0)\nplace table (0.75, -3.8)\n"
                   "activity { actor1 move_to far; actor1 move_to table }")
    assert spans(result) == [("E402", 5, 11, 22), ("E403", 6, 13, 25)]
    assert result.diagnostics[0].hint == "the map spans x -5.75 .. 8.49 m, y -6.5 .. 6.5 m"
    assert result.diagnostics[1].hint == "the nearest free cell is 0.51 m away, at (0.74, -3.29)"


def test_labels_are_reported_by_the_name_checker_once(check: Check) -> None:
    """Unknown and duplicate labels are E101/E102 from the names, not also E303/E310."""
    result = check("activity { go: actor1 stand for 1 s; go: actor2 stand for 1 s\n"
                   "wait until gone done }")
    assert spans(result) == [("E102", 5, 38, 40), ("E101", 6, 12, 16)]
    assert result.diagnostics[1].message == "unknown label 'gone' (`gone done`)"


# ---- every error of a file, in order --------------------------------------------------------


def test_every_error_is_reported_in_source_order(check: Check) -> None:
    result = check("seed -1\n"
                   "defaults { speed 5 s; sped 1 m/s }\n"
                   "activity { actor1 stand; wait 0 s }\n"
                   "expect actor1 reaches (1.0, 1.0) within 5\n")
    assert spans(result) == [("E203", 5, 6, 8), ("E201", 6, 18, 21), ("E105", 6, 23, 27),
                             ("E306", 7, 12, 24), ("E203", 7, 31, 34), ("E204", 8, 41, 42)]
    assert result.program is None


@pytest.mark.parametrize(("text", "message", "line"), [
    ("", "the file is empty", 1),
    ("# only\n# comments\n", "the file is empty", 1),
    ('map "../../maps/living_room.yaml"\n', 'a scenario file must start with `scenario "TITLE"`',
     1),
    ('scenario "x"\n\nhuman actor1 at (6.3, 2.5)\n', "the scenario names no map", 1),
], ids=["empty", "only comments", "no scenario", "no map"])
def test_file_structure(check: Check, text: str, message: str, line: int) -> None:
    (diagnostic,) = check(text, header=False).diagnostics
    assert (diagnostic.code, diagnostic.message) == ("E404", message)
    assert diagnostic.span is not None and diagnostic.span.line == line


def test_scenario_and_map_are_given_once(check: Check) -> None:
    result = check('map "../../maps/living_room.yaml"\nscenario "again"')
    assert [(d.code, d.message) for d in result.diagnostics] == [
        ("E102", "'map' is given twice"), ("E102", "'scenario' is given twice")]


# ---- the map ------------------------------------------------------------------------------


def test_missing_map_names_the_path_as_written(tmp_path: Path) -> None:
    text = 'scenario "x"\nmap "maps/none.yaml"\n'
    (diagnostic,) = check_source(text, "case.hub").diagnostics
    assert diagnostic.code == "E401"
    assert diagnostic.message == "the map cannot be loaded: map file not found: maps/none.yaml"
    assert diagnostic.span is not None and (diagnostic.span.line, diagnostic.span.column) == (2, 5)


def test_bad_map_field_points_into_the_yaml_file(tmp_path: Path) -> None:
    (tmp_path / "bad.yaml").write_text(
        "image: x.pgm\nresolution: 0\norigin: [0, 0, 0]\nnegate: 0\noccupied_thresh: 0.65\n"
        "free_thresh: 0.196\n", encoding="utf-8")
    text = 'scenario "x"\nmap "bad.yaml"\n'
    (diagnostic,) = check_source(text, str(tmp_path / "case.hub")).diagnostics
    assert diagnostic.code == "E401"
    assert "'resolution'" in diagnostic.message
    (related,) = diagnostic.related
    assert (related.span.file, related.span.line) == (str(tmp_path / "bad.yaml"), 2)


def test_nul_in_the_map_path_is_a_diagnostic_not_an_exception() -> None:
    (diagnostic,) = check_source('scenario "x"\nmap "a\0b.yaml"\n', "case.hub").diagnostics
    assert diagnostic.code == "E002"  # a control character, found before any file is opened
    assert diagnostic.span is not None and (diagnostic.span.line, diagnostic.span.column) == (2, 7)


# ---- values ---------------------------------------------------------------------------------


@pytest.mark.parametrize(("param", "message"), [
    ("speed normal(-1 m/s, 0.2 m/s)", "the mean of 'speed' must be greater than zero"),
    ("max_speed uniform(-1 m/s, 2 m/s)",
     "'max_speed' must be greater than zero; uniform(...) starts at -1 m/s"),
    ("radius uniform(0.1 m, 3 m)", "'radius' may be at most 2 m; uniform(...) ends at 3 m"),
    ("avoidance_strength uniform(-1, 1)",
     "'avoidance_strength' must not be negative; uniform(...) starts at -1"),
    ("field_of_view normal(400 deg, 10 deg)", "the mean of 'field_of_view' may be at most 360 deg"),
    ("speed uniform(2 m/s, 1 m/s)", "uniform(low, high) needs low < high"),
])
def test_distributions_take_only_values_the_parameter_may_take(check: Check, param: str,
                                                               message: str) -> None:
    (diagnostic,) = check(f"defaults {{ {param} }}").diagnostics
    assert diagnostic.message == message


@pytest.mark.parametrize(("value", "dimension"), [
    ("5 s", "time"), ("2 m", "length"), ("90 deg", "angle"), ("1 m/s", "speed"),
])
def test_units_must_fit_the_dimension(check: Check, value: str, dimension: str) -> None:
    body = f"activity {{ actor1 move_to (5.5, 1.0) speed {value} }}"
    result = check(body)
    if dimension == "speed":
        assert codes(result) == []
    else:
        (diagnostic,) = result.diagnostics
        assert diagnostic.code == "E201"
        assert diagnostic.message.endswith(f"is a unit of {dimension}")


def test_planner_names_are_checked_against_their_kind(check: Check) -> None:
    result = check("defaults { global_planner social_force; local_planner navfn }")
    assert [d.message for d in result.diagnostics] == [
        "'social_force' is a local planner, not a global one",
        "'navfn' is a global planner, not a local one"]
    assert [d.message for d in check("defaults { global_planner nafvn }").diagnostics] == [
        "unknown global planner 'nafvn'"]
    assert codes(check("defaults { global_planner straight; local_planner direct }")) == []


def test_planner_parameters_take_the_units_their_planner_declares(check: Check) -> None:
    clean = check("defaults { social_force.B 30 cm; social_force.anticipation 500 ms; "
                  "social_force.A 2.5; navfn.comfort_weight 10 }")
    assert codes(clean) == []
    wrong = check("defaults { social_force.B 2 s; navfn.comfort_weight 3 m }")
    assert [(d.code, d.message) for d in wrong.diagnostics] == [
        ("E201", "'social_force.B' takes a length (m, cm, mm), but 's' is a unit of time"),
        ("E201", "'navfn.comfort_weight' takes a plain number, but 'm' is a unit of length")]


def test_shape_arguments(check: Check) -> None:
    result = check("defaults { personal_space ellipse(semi_major: 1 m, semi_minor: 2 m) }\n"
                   "variant a { personal_space circle(diameter: 1 m) }\n"
                   "variant b { personal_space square(side: 1 m, side: 2 m) }")
    assert spans(result) == [("E203", 5, 52, 67), ("E205", 6, 28, 49), ("E105", 6, 35, 43),
                             ("E106", 7, 46, 50)]


# ---- what checks clean --------------------------------------------------------------------

EVERY_CONSTRUCT = """\
seed 3; step 20 ms; time_limit 2 min
on_failure continue
bounds rect((-4.5, -1.5), (4.5, 5.0))

place door (4.5, -1.0) heading 180 deg
place hall at (1.0, -0.5)
place window (3.0, 4.5)
area lounge rect((-4.5, -1.5), (0.5, 4.0))
area dance polygon((0.5, -1.5), (3.5, -1.5),
                   (3.5, 2.0), (0.5, 2.0),)
area same_lounge lounge

defaults {
    speed normal(1.29 m/s, 0.10 m/s); max_speed uniform(1.6 m/s, 2.0 m/s)
    run_speed 9 km/h; radius 20 cm; goal_tolerance 250 mm; relaxation_time 540 ms
    personal_space ellipse(semi_major: 0.6 m, semi_minor: 0.4 m, offset: 0.1 m)
    goal_strength 1.0; avoidance_strength 0.5; obstacle_strength 0; interaction_range 3 m
    field_of_view 3.4 rad; follow_replan 0.5 s
    global_planner navfn; local_planner social_force; social_force.lambda 0.5
}

human actor3 at (2.0, 3.0) heading -90 deg { personal_space square(side: 0.5 m) }
human actor4 at hall { personal_space rectangle(length: 1 m, width: 0.6 m) }
robot vacuum at (-4.0, 1.0) { radius 0.17 m; speed 0.3 m/s; path (-4.0, 1.0) -> (-3.0, 0.0) loop }
robot buddy at (-3.0, 3.0) {
    controller navigator; kinematics unicycle; goal (1.0, 1.0); navigator.safety_margin 0.4 m
}
robot statue at (-4.0, -1.0)

variant circle { personal_space circle(radius: 0.2 m) }
variant normal { actor1.speed 1.0 m/s; actor1.social_force.A 3; speed 1.5 m/s }
sweep social_force.A in [1.0, 2.1, 3.0]
sweep actor2.radius in [0.2 m, 0.3 m]

activity host {
    greet: actor1 move_to door heading 180 deg speed 1.0 m/s within 60 s
    chat: parallel {
        actor1 talk to actor2 for 3 s
        actor2 stand facing actor1 for 3 s
    }
    walk: race {
        actor1 run_to window heading 90 deg
        { wait 2 s; wait until time >= 5 s }
    }
    actor2 follow actor1 at 1.2 m until actor1 reaches window or walk done
    rounds: repeat 2 {
        actor1 sit_down at (-3.8, 2.0) heading -90 deg for 2 s
        actor1 lie_down at hall for 1 s
    }
    actor2 sit_down for 1 s
    wait until rounds done and not chat failed
    actor1 stand forever
}

activity others {
    wait until greet started
    actor3 move_around in dance times 2
    actor3 move_around for 3 s
    actor3 teleop for 1 s
    wait until distance(actor3, door) <= 5 m or actor3 in same_lounge
    actor4 talk for 1 s
    actor4 move_to vacuum
    actor4 stand facing (0.0, 0.0) until (time > 30 s)
}

expect greet done within 30 s
expect distance(actor1, actor2) > 0.3 m always
expect actor3 in lounge eventually
expect not (rounds failed or chat failed) always
"""


def test_every_construct_checks_clean(check: Check) -> None:
    result = check(EVERY_CONSTRUCT)
    assert result.diagnostics == ()
    assert result.program is not None


def test_shape_and_distribution_names_are_not_reserved(check: Check) -> None:
    words = ("circle", "ellipse", "rectangle", "square", "normal", "uniform")
    assert not set(words) & reserved_words()
    body = "\n".join(f"variant {word} {{ radius 0.3 m }}" for word in words)
    assert check(body).diagnostics == ()


@pytest.mark.parametrize("word", sorted(reserved_words()))
def test_every_keyword_is_reserved(check: Check, word: str) -> None:
    result = check(f"variant {word} {{ radius 0.3 m }}")
    assert codes(result) in (["E104"], ["E001"])  # E001 where the parser already stops at it


# ---- what the checked program holds -------------------------------------------------------


def test_values_are_converted_to_si(check: Check) -> None:
    result = check(EVERY_CONSTRUCT)
    assert result.program is not None
    program = result.program
    assert (program.seed, program.step, program.time_limit) == (3, 0.02, 120.0)
    assert program.on_failure == "continue"
    defaults = program.defaults.values
    assert defaults["speed"] == Distribution("normal", 1.29, pytest.approx(0.10))
    assert defaults["run_speed"] == pytest.approx(2.5)
    assert defaults["radius"] == pytest.approx(0.2)
    assert defaults["goal_tolerance"] == pytest.approx(0.25)
    assert defaults["field_of_view"] == pytest.approx(3.4)
    assert defaults["personal_space"] == Ellipse(0.6, 0.4, 0.1)
    assert program.human("actor3").params.values["personal_space"] == Rectangle(0.5, 0.5)
    assert program.places["door"].heading == pytest.approx(math.pi)


def test_variants_and_sweeps_multiply(check: Check) -> None:
    result = check(EVERY_CONSTRUCT)
    assert result.program is not None
    names = list(result.program.variants)
    assert len(names) == 2 * 3 * 2
    assert names[0] == "circle,social_force.A=1.0,actor2.radius=0.2 m"
    assert names[-1] == "normal,social_force.A=3.0,actor2.radius=0.3 m"


def test_sweeps_alone_name_their_variants_by_value(check: Check) -> None:
    result = check("sweep speed in [1.0 m/s, 1.4 m/s]\nsweep avoidance_strength in [0.5, 1.5]")
    assert result.program is not None
    assert list(result.program.variants) == [
        "speed=1.0 m/s,avoidance_strength=0.5", "speed=1.0 m/s,avoidance_strength=1.5",
        "speed=1.4 m/s,avoidance_strength=0.5", "speed=1.4 m/s,avoidance_strength=1.5"]


def test_a_sweep_value_wrapped_over_lines_is_named_on_one_line(check: Check) -> None:
    result = check("sweep personal_space in [circle(radius: 0.2 m), ellipse(semi_major: 1 m,\n"
                   "    semi_minor: 0.5 m), ellipse(semi_major: 2 m,  # wider\n"
                   "    semi_minor: 0.5 m)]")
    assert result.program is not None
    assert list(result.program.variants) == [
        "personal_space=circle(radius: 0.2 m)",
        "personal_space=ellipse(semi_major: 1 m, semi_minor: 0.5 m)",
        "personal_space=ellipse(semi_major: 2 m, semi_minor: 0.5 m)"]


def test_sweep_names_survive_a_form_feed(case_path: str) -> None:
    text = ('scenario "x"\f\nmap "../../maps/living_room.yaml"\nhuman actor1 at (6.3, 2.5)\n'
            "sweep speed in [1 m/s, 2 m/s]\n")
    result = check_source(text, case_path)
    assert result.program is not None
    assert list(result.program.variants) == ["speed=1 m/s", "speed=2 m/s"]


def test_a_sweep_value_listed_twice(check: Check) -> None:
    result = check("sweep speed in [1 m/s, 1.2 m/s, 1 m/s]")
    assert spans(result) == [("E102", 5, 33, 38)]


@pytest.mark.parametrize("values", ["1.0 m/s, 1 m/s", "0.5 m/s, 0.50 m/s",
                                    "circle(radius: 0.2 m), circle(radius:0.2m)"])
def test_a_sweep_value_written_twice_in_two_ways(check: Check, values: str) -> None:
    param = "personal_space" if "circle" in values else "speed"
    (error,) = check(f"sweep {param} in [{values}]").errors
    assert error.code == "E102" and "twice (as '" in error.message


def test_a_sweep_of_values_in_error_is_not_said_to_repeat_them(check: Check) -> None:
    assert "E102" not in {d.code for d in check("sweep speed in [1 kg, 2 kg]").errors}


def test_a_sweep_of_an_unknown_parameter_is_one_error(check: Check) -> None:
    result = check("sweep sped in [1 m/s, 1.2 m/s, 1.4 m/s]")
    assert spans(result) == [("E105", 5, 7, 11)]


def test_a_sweep_of_the_seed_says_how_to_run_seeds(check: Check) -> None:
    result = check("sweep seed in [1, 2]")
    assert spans(result) == [("E105", 5, 7, 11)]
    assert "--seeds" in (result.diagnostics[0].hint or "")


def test_precedence_defaults_human_variant(check: Check) -> None:
    result = check("defaults { speed 1.0 m/s; radius 0.3 m }\n"
                   "human actor3 at (2.0, 3.0) { speed 1.1 m/s }\n"
                   "variant fast { speed 1.5 m/s; actor3.speed 1.7 m/s }")
    assert result.program is not None
    base = result.program.resolved_params()
    fast = result.program.resolved_params("fast")
    assert (base["actor1"]["speed"], base["actor3"]["speed"]) == (1.0, 1.1)
    assert (fast["actor1"]["speed"], fast["actor3"]["speed"]) == (1.5, 1.7)
    assert base["actor1"]["radius"] == fast["actor3"]["radius"] == 0.3
    assert base["actor2"]["personal_space"] == Circle(0.5)  # the built-in default


# ---- names used before their statement ----------------------------------------------------


def test_a_place_may_be_used_before_its_statement(check: Check) -> None:
    result = check("human actor3 at sofa\nrobot vacuum at sofa { path sofa -> (1.0, 1.0) }\n"
                   "bounds rect(seat, (7.0, 3.0))\nplace seat at sofa\nplace sofa (5.5, 1.0)")
    # both placed on the sofa: W504 says so, and nothing else is wrong
    assert [d.code for d in result.diagnostics] == ["W504"]
    assert result.program is not None
    program = result.program
    assert program.human("actor3").start.xy == (5.5, 1.0)
    assert program.robots[0].start.xy == (5.5, 1.0)
    assert program.robots[0].path == ((5.5, 1.0), (1.0, 1.0))
    assert program.places["seat"].xy == (5.5, 1.0)
    assert program.bounds is not None and program.bounds.bounds == (5.5, 1.0, 7.0, 3.0)


def test_a_chain_of_area_names_resolves_to_its_end(check: Check) -> None:
    result = check("area x y\narea y z\narea z rect((5.5, 1.0), (7.0, 3.0))\n"
                   "activity { actor1 move_around in x for 1 s }")
    assert result.program is not None
    areas = result.program.areas
    assert areas["x"] is areas["y"] is areas["z"]


def test_places_and_areas_defined_through_themselves(check: Check) -> None:
    result = check("place a at b\nplace b at a\nplace c at c\narea d e\narea e d\n"
                   "activity { actor1 move_to c; actor1 move_to a; actor1 move_around in d }")
    cycles = [(d.message, d.span.line if d.span else 0) for d in result.diagnostics
              if d.code == "E103"]
    assert cycles == [("place 'a' is defined through itself", 5),
                      ("place 'b' is defined through itself", 6),
                      ("place 'c' is defined through itself", 7),
                      ("area 'd' is defined through itself", 8),
                      ("area 'e' is defined through itself", 9)]


def test_follow_needs_a_body_not_a_point(check: Check) -> None:
    result = check("activity { actor1 follow (5.5, 1.0) for 5 s }")
    assert spans(result) == [("E201", 5, 26, 36)]


def test_a_share_written_as_a_fraction_is_hinted_in_percent(check: Check) -> None:
    result = check("activity { actor1 stand for 1 s }\n"
                   "expect path_efficiency(actor1) >= 0.9\n")
    (diagnostic,) = result.diagnostics
    assert diagnostic.code == "E204" and diagnostic.hint is not None
    assert diagnostic.hint.startswith("write `90 %`")


def test_social_work_is_compared_with_a_speed(check: Check) -> None:
    assert codes(check("activity { actor1 stand for 1 s }\n"
                       "expect social_work(actor1) <= 10 m/s\n")) == []
    assert codes(check("activity { actor1 stand for 1 s }\n"
                       "expect social_work(actor1) <= 10\n")) == ["E204"]


def test_a_seed_is_the_whole_number_written_however_large(check: Check) -> None:
    result = check("seed 9007199254740993\nactivity { actor1 stand for 1 s }\n")
    assert result.program is not None and result.program.seed == 9007199254740993


def test_a_seed_of_hundreds_of_digits_is_too_large_not_fractional(check: Check) -> None:
    # as a float it is infinite: it was "not a whole number"
    (diagnostic,) = check("seed " + "9" * 309 + "\nactivity { actor1 stand for 1 s }\n"
                          ).diagnostics
    assert (diagnostic.code, diagnostic.message) == ("E203",
                                                     "the seed has 309 digits: at most 18")


def test_a_value_out_of_range_is_shown_in_the_unit_it_was_written_in(check: Check) -> None:
    (diagnostic,) = check("flow f from rect((1, 1), (3, 3)) to (5, 5) rate 1001 /s "
                          "for 2 s\n").diagnostics
    assert diagnostic.message == "a flow's rate is 1001 /s; the most it may be is 1000 /s"


def test_a_flows_rate_is_one_rate_not_a_distribution(check: Check) -> None:
    # its values are rates: "a flow's rate takes a rate (/s, /min, /h)" told nothing
    (diagnostic,) = check("flow f from rect((1, 1), (3, 3)) to (5, 5) rate normal(10 /min, "
                          "2 /min) for 2 s\n").diagnostics
    assert (diagnostic.code, diagnostic.message) == (
        "E201", "a flow's rate takes one rate, not a distribution")
    assert diagnostic.hint == ("only people's parameters are drawn from normal(...) or "
                               "uniform(...); write one value, like `10 /min`")
    assert diagnostic.span is not None and diagnostic.span.column == 49


def test_a_metrics_expectation_with_a_mode_says_it_takes_none(check: Check) -> None:
    result = check("activity { actor1 stand for 1 s }\n"
                   "expect min_distance(actor1) >= 0.2 m always\n")
    (diagnostic,) = result.diagnostics
    assert diagnostic.code == "E001" and diagnostic.hint is not None
    assert "judged once, when the run ends" in diagnostic.hint
    # a condition's `distance(...)` takes a mode: no such hint
    assert not check("activity { actor1 stand for 1 s }\n"
                     "expect distance(actor1, actor2) > 0.5 m always\n").diagnostics


def test_a_flows_member_named_one_by_one_is_told_why_not(check: Check) -> None:
    result = check("flow f from rect((4.0, 1.0), (7.0, 3.0)) to (5.5, 1.0) rate 1 /s for 5 s\n"
                   "activity { actor1 follow f_1 for 2 s }\n"
                   "expect f_2 reaches (5.5, 1.0) eventually")
    assert [d.code for d in result.diagnostics] == ["E103", "E103"]
    first = result.diagnostics[0]
    assert first.message.startswith("'f_1' is one of the people flow 'f' brings")
    assert first.hint is not None and "count(f in AREA)" in first.hint


def test_a_condition_of_more_parts_than_anyone_writes_is_refused(check: Check) -> None:
    terms = " or ".join(["time > 1 h"] * 1001)   # judged every tick the wait lasts
    result = check(f"activity {{ wait until {terms}; actor1 stand for 1 s }}")
    assert [d.code for d in result.diagnostics] == ["E203"]
    assert "a condition of 1,002 parts; the most one may have is 1,000" in \
        result.diagnostics[0].message
