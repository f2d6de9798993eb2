"""The parser: syntax diagnostics (E001-E003) with their spans and hints, and the AST it builds.

The lexical rules checked here are the ones docs/language.md describes: separators, comments,
wrapped lines, quantities with and without a space, strings with escapes.
"""

from __future__ import annotations

import math

import pytest

from hubero_dsl.diagnostics import Diagnostic
from hubero_dsl.errors import CompileError
from hubero_dsl.lang import ast
from hubero_dsl.lang.parse import MAX_NESTING, MAX_TREE_DEPTH, parse_source
from hubero_dsl.pipeline import check_source

HEADER = 'scenario "x"\n'


def syntax_error(text: str) -> Diagnostic:
    with pytest.raises(CompileError) as raised:
        parse_source(text, "case.hub")
    (diagnostic,) = raised.value.diagnostics
    return diagnostic


def where(diagnostic: Diagnostic) -> tuple[int, int, int, int]:
    span = diagnostic.span
    assert span is not None
    return span.line, span.column, span.end_line, span.end_column


def statements(text: str) -> tuple[ast.Statement, ...]:
    return parse_source(HEADER + text, "case.hub").statements[1:]


def only_step(text: str) -> ast.Step:
    (activity,) = statements(text)
    assert isinstance(activity, ast.ActivityDecl)
    (step,) = activity.steps
    return step


# ---- E001: unexpected tokens --------------------------------------------------------------


def test_unexpected_word_hints_only_what_can_follow() -> None:
    diagnostic = syntax_error(HEADER + "expect a reaches (1, 1) sometimes\n")
    assert (diagnostic.code, diagnostic.message) == ("E001", "unexpected 'sometimes'")
    assert where(diagnostic) == (2, 25, 2, 34)
    assert diagnostic.hint == ("expected one of: 'and', 'or', "
                               "how it must hold (always, eventually, within)")


def test_a_step_without_a_task_lists_the_tasks() -> None:
    diagnostic = syntax_error(HEADER + "activity {\n    actor1 (1, 1)\n}\n")
    assert where(diagnostic) == (3, 12, 3, 13)
    assert diagnostic.hint == ("expected one of: ':', a task (stand, move_to, run_to, "
                               "move_around, follow, talk, sit_down, lie_down, teleop)")


def test_an_unknown_task_is_named_at_the_word_with_the_closest_kind() -> None:
    for text, word, guess in (("actor1 move_too (15.0, 6.0)", "move_too", "move_to"),
                              ("actor1 stands for 3 s", "stands", "stand")):
        result = check_source(HEADER + 'map "m.yaml"\nhuman actor1 at (1, 1)\n'
                              f"activity {{\n    {text}\n}}\n", "case.hub")
        (diagnostic,) = [d for d in result.errors if d.code == "E108"]
        assert diagnostic.message == f"unknown task '{word}'"
        assert where(diagnostic) == (5, 12, 5, 12 + len(word))
        assert diagnostic.hint == f"did you mean '{guess}'?"


def test_a_word_after_a_number_is_called_an_unknown_unit() -> None:
    diagnostic = syntax_error(HEADER + "human a at (1, 1) { speed 5 kg }\n")
    assert where(diagnostic) == (2, 29, 2, 31)
    assert diagnostic.hint is not None
    assert diagnostic.hint.startswith("'kg' is not a unit; units are m cm mm")


def test_a_word_after_a_name_ending_in_a_digit_is_no_unit() -> None:
    result = check_source(HEADER + "activity { actor1 walk_to (1, 1) }\n", "case.hub")
    assert "E108" in {d.code for d in result.errors}
    assert all("not a unit" not in (d.hint or "") for d in result.diagnostics)


def test_missing_value_at_end_of_line() -> None:
    diagnostic = syntax_error(HEADER + "seed\n")
    assert diagnostic.message == "unexpected end of line"
    assert where(diagnostic) == (2, 5, 2, 6)
    assert diagnostic.hint == "expected a number"


def test_unclosed_block_at_end_of_file() -> None:
    diagnostic = syntax_error(HEADER + "activity {\n    a stand for 1 s\n")
    assert diagnostic.message == "unexpected end of file"
    assert where(diagnostic)[:2] == (4, 1)


def test_a_missing_keyword() -> None:
    diagnostic = syntax_error(HEADER + "human a (1, 1)\n")
    assert where(diagnostic) == (2, 9, 2, 10)
    assert diagnostic.hint == "expected 'at'"


def test_a_path_needs_arrows() -> None:
    diagnostic = syntax_error(HEADER + "robot r at (1, 1) { path (1, 1) (2, 2) }\n")
    assert diagnostic.hint == "expected '->'"


# ---- E002: unexpected characters ----------------------------------------------------------


def test_single_quotes_hint_at_double_quotes() -> None:
    diagnostic = syntax_error("scenario 'x'\n")
    assert (diagnostic.code, where(diagnostic)) == ("E002", (1, 10, 1, 11))
    assert diagnostic.hint == "strings use double quotes"


def test_an_unknown_escape_in_a_string_is_pointed_at() -> None:
    # a Windows path: the backslashes were dropped (`C:mapsx.yaml`), and the map not found
    diagnostic = syntax_error('scenario "x"\nmap "C:\\maps\\x.yaml"\n')
    assert (diagnostic.code, where(diagnostic)) == ("E002", (2, 8, 2, 10))
    assert diagnostic.message == "unknown escape '\\m' in a string"
    assert diagnostic.hint is not None and "a path with /" in diagnostic.hint


def test_the_two_escapes_a_string_knows() -> None:
    (title,) = parse_source('scenario "a \\"quote\\" and a \\\\ backslash"\n',
                            "case.hub").statements
    assert isinstance(title, ast.ScenarioDecl)
    assert title.title.value == 'a "quote" and a \\ backslash'


def test_a_string_left_open_at_the_end_of_its_line() -> None:
    diagnostic = syntax_error('scenario "x\\\nmap "m.yaml"\n')
    assert (diagnostic.code, where(diagnostic)) == ("E002", (1, 10, 1, 11))
    assert diagnostic.hint == 'a string ends with a " on the line it starts on'


def test_columns_count_characters_not_bytes_or_cells() -> None:
    diagnostic = syntax_error(HEADER + "\tplace\t食卓 (1, 1)\n")
    assert (diagnostic.code, where(diagnostic)) == ("E002", (2, 8, 2, 9))


# ---- E003: nesting ------------------------------------------------------------------------


def test_nesting_up_to_the_limit_parses() -> None:
    depth = MAX_NESTING - 1  # the activity's own brace is one level
    text = "activity { " + "{ " * depth + "a stand for 1 s" + " }" * depth + " }\n"
    assert len(statements(text)) == 1


def test_nesting_beyond_the_limit_is_refused_where_it_happens() -> None:
    text = HEADER + "activity { " + "{" * MAX_NESTING + " }\n"
    diagnostic = syntax_error(text)
    assert diagnostic.code == "E003"
    assert where(diagnostic)[:2] == (2, 12 + MAX_NESTING - 1)


@pytest.mark.parametrize("count", [MAX_TREE_DEPTH, 5000])
def test_a_long_run_of_not_is_refused_not_a_recursion_error(count: int) -> None:
    diagnostic = syntax_error(HEADER + "expect " + "not " * count + "time > 1 s always\n")
    assert diagnostic.code == "E003"
    assert where(diagnostic)[0] == 2


def test_a_short_run_of_not_parses() -> None:
    (expect,) = statements("expect not not not time > 1 s always\n")
    assert isinstance(expect, ast.ExpectDecl)
    assert isinstance(expect.condition, ast.NotCondition)


# ---- lexical rules ------------------------------------------------------------------------


def test_separators_comments_and_wrapped_lines() -> None:
    found = statements("seed 1; step 50 ms   # a comment\n"
                       "# a whole-line comment\n"
                       "area a polygon((0, 0),\n    (1, 0),   # wrapped inside brackets\n"
                       "    (1, 1))\n"
                       "time_limit \\\n  2 min\n")
    assert [type(s).__name__ for s in found] == ["SettingDecl", "SettingDecl", "AreaDecl",
                                                 "SettingDecl"]
    area = found[2]
    assert isinstance(area, ast.AreaDecl) and isinstance(area.area, ast.PolygonArea)
    assert len(area.area.vertices) == 3


def test_windows_line_endings_keep_columns(case_path: str) -> None:
    text = 'scenario "x"\r\nmap "../../maps/living_room.yaml"\r\nhuman a at (1, 1) { speed 5 }\r\n'
    (diagnostic,) = check_source(text, case_path).diagnostics
    assert (diagnostic.code, where(diagnostic)) == ("E204", (3, 27, 3, 28))


@pytest.mark.parametrize(("written", "magnitude", "unit", "si"), [
    ("1.29 m/s", 1.29, "m/s", 1.29),
    ("1.29m/s", 1.29, "m/s", 1.29),
    ("250ms", 250.0, "ms", 0.25),
    ("-90 deg", -90.0, "deg", -math.pi / 2),
    ("1e-3 s", 1e-3, "s", 1e-3),
    (".5 m", 0.5, "m", 0.5),
    ("2 min", 2.0, "min", 120.0),
    ("9 km/h", 9.0, "km/h", 2.5),
    ("30 cm", 30.0, "cm", 0.3),
    ("1.5 rad", 1.5, "rad", 1.5),
    ("2 m/s^2", 2.0, "m/s^2", 2.0),
    ("0.5m/s^2", 0.5, "m/s^2", 0.5),
    ("1.5 rad/s", 1.5, "rad/s", 1.5),
    ("90 deg/s", 90.0, "deg/s", math.pi / 2),
])
def test_quantities(written: str, magnitude: float, unit: str, si: float) -> None:
    (setting,) = statements(f"time_limit {written}\n")
    assert isinstance(setting, ast.SettingDecl)
    value = setting.value
    assert isinstance(value, ast.Quantity)
    assert (value.magnitude, value.unit) == (pytest.approx(magnitude), unit)
    assert value.si == pytest.approx(si)


def test_a_glued_unknown_unit_is_kept_for_the_checker() -> None:
    (setting,) = statements("time_limit 5kg\n")
    assert isinstance(setting, ast.SettingDecl) and isinstance(setting.value, ast.Quantity)
    assert (setting.value.unit, setting.value.known_unit) == ("kg", False)


def test_strings_with_escapes() -> None:
    module = parse_source('scenario "a \\"quoted\\" \\\\ title"\n', "case.hub")
    (scenario,) = module.statements
    assert isinstance(scenario, ast.ScenarioDecl)
    assert scenario.title.value == 'a "quoted" \\ title'


# ---- the AST ------------------------------------------------------------------------------


def test_a_task_step_with_every_part() -> None:
    step = only_step("activity { go: a move_to sofa heading 90 deg speed 1 m/s "
                     "until b done within 30 s }\n")
    assert isinstance(step, ast.TaskStep)
    assert step.label is not None and step.label.name == "go"
    assert (step.human.name, step.task.kind) == ("a", "move_to")
    assert isinstance(step.task.target, ast.NameRef)
    assert [o.keyword for o in step.task.options] == ["heading", "speed"]
    assert isinstance(step.until, ast.LabelCondition)
    assert isinstance(step.within, ast.Quantity)
    assert step.span.column == 12  # the span of a labelled step starts at its label


def test_labels_on_composite_steps() -> None:
    (activity,) = statements("activity {\n  p: parallel { a stand for 1 s }\n"
                             "  r: race { a stand for 1 s }\n  n: repeat 2 { a stand for 1 s }\n"
                             "  s: { a stand for 1 s }\n  w: wait 1 s\n  u: wait until p done\n}\n")
    assert isinstance(activity, ast.ActivityDecl)
    kinds = [(type(s).__name__, s.label.name if s.label else None) for s in activity.steps]
    assert kinds == [("ParallelStep", "p"), ("RaceStep", "r"), ("RepeatStep", "n"),
                     ("SequenceStep", "s"), ("WaitStep", "w"), ("WaitUntilStep", "u")]


def test_not_binds_tighter_than_and_tighter_than_or() -> None:
    step = only_step("activity { wait until not a done and b started or c failed }\n")
    assert isinstance(step, ast.WaitUntilStep)
    condition = step.condition
    assert isinstance(condition, ast.AnyOf)
    first, second = condition.operands
    assert isinstance(first, ast.AllOf) and isinstance(second, ast.LabelCondition)
    assert isinstance(first.operands[0], ast.NotCondition)
    assert second.event is ast.LabelEvent.FAILED


def test_conditions_of_every_kind() -> None:
    # A condition wraps over lines inside brackets only.
    step = only_step("activity { wait until ((a reaches sofa and distance(a, (1, 2)) <= 1 m)\n"
                     "    or (a in rect((0, 0), (1, 1)) and time > 5 s)) }\n")
    assert isinstance(step, ast.WaitUntilStep)
    kinds = {type(c).__name__ for c in ast.walk_conditions(step.condition)}
    assert kinds == {"AnyOf", "AllOf", "ReachesCondition", "DistanceCondition",
                     "InsideCondition", "TimeCondition"}


def test_shape_and_distribution_words_are_names_outside_values() -> None:
    found = statements("variant circle { personal_space circle(radius: 0.2 m) }\n"
                       "human normal at (1, 1) { speed normal(1.2 m/s, 0.1 m/s) }\n")
    variant, human = found
    assert isinstance(variant, ast.VariantDecl) and variant.name.name == "circle"
    assert isinstance(human, ast.HumanDecl) and human.name.name == "normal"
    assert isinstance(human.params[0].value, ast.Distribution)


def test_a_robot_block() -> None:
    (robot,) = statements("robot r at (1, 1) heading 90 deg {\n  radius 0.3 m\n"
                          "  path (1, 1) -> (2, 1) -> (2, 2) loop\n}\n")
    assert isinstance(robot, ast.RobotDecl)
    assert robot.path is not None and robot.path.loop
    assert len(robot.path.waypoints) == 3
    assert [p.dotted for p in robot.params] == ["radius"]


def test_an_unexpected_first_token() -> None:
    diagnostic = syntax_error("hello world\n")
    assert (diagnostic.code, where(diagnostic)) == ("E001", (1, 1, 1, 6))
