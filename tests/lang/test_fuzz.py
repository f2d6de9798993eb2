"""Fuzzing the front end: mutated scenarios never make `check_source` raise.

Every property starts from a real scenario in `scenarios/` and breaks it: lines deleted,
duplicated or swapped; characters deleted; keywords, punctuation, numbers with units and names
inserted; the text cut short; random unicode; very long names; deep nesting. Whatever comes out,
`check_source` must return diagnostics (never raise), every span must point into the text
(line within the file, column at most one past the line's end, end not before start), and the
CLI renderers (text, JSON, GitHub) must render them.

The runs are derandomized (the same examples every time, so CI is reproducible) and bounded:
150 examples per property, a few seconds in all.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from hubero_dsl.cli.diagnostic_formats import (
    FileReport,
    github_report,
    json_report,
    plain,
    text_report,
)
from hubero_dsl.diagnostics import Span
from hubero_dsl.lang.symbols import VALUE_KEYWORDS, reserved_words
from hubero_dsl.pipeline import CheckResult, check_source

REPO_ROOT = Path(__file__).resolve().parents[2]
SCENARIOS = sorted((REPO_ROOT / "scenarios").glob("*.hub"))
TEXTS = {path: path.read_text(encoding="utf-8") for path in SCENARIOS}

FUZZ = settings(max_examples=150, deadline=None, derandomize=True, database=None,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])

PUNCTUATION = ["{", "}", "(", ")", "[", "]", ",", ";", ":", ".", "->", "<", "<=", ">", ">=",
               "\n", "#", '"', "\\\n", "\t", "=", "'"]
VALUES = ["0", "-1", "1.5", "1e309", "-0.0 s", "5 s", "250ms", "1.29 m/s", "9 km/h", "90 deg",
          "-3 rad", "2 min", "0 m", "1e-400 m", "5kg", "5 kg", "99999999999999999999",
          '"text"', '"a\\"b"', "circle(radius: 0 m)", "ellipse(semi_major: 1 m, semi_minor: 2 m)",
          "normal(1 m/s, 0 m/s)", "uniform(2 m/s, 1 m/s)", "rect((0, 0), (0, 0))",
          "polygon((0, 0), (1, 1), (2, 2))", "(1, 2)", "(100, 100)", "(0.75, -3.8)"]
NAMES = ["actor1", "actor2", "sofa", "x", "_", "social_force.A", "social_force.AA",
         "navfn.comfort_weight", "actor1.speed", "invite", "to_table", "unknown_name"]
TOKENS = sorted(reserved_words() | VALUE_KEYWORDS) + PUNCTUATION + VALUES + NAMES


def scenarios() -> st.SearchStrategy[Path]:
    return st.sampled_from(SCENARIOS)


def check_and_render(text: str, path: Path) -> CheckResult:
    """Check the text as if it were the file at `path`; assert spans and rendering are sane."""
    result = check_source(text, str(path))
    lines = text.split("\n")
    for diagnostic in result.diagnostics:
        spans = [diagnostic.span, *(related.span for related in diagnostic.related)]
        for span in spans:
            if span is not None:
                _assert_sane(span, lines if span.file == str(path) else None)
    report = FileReport(str(path), text, result.diagnostics)
    assert plain(text_report([report])).endswith("file\n")
    assert json.loads(json_report([report]))["summary"]["files"] == 1
    assert github_report([report])
    if any(d.is_error for d in result.diagnostics):
        assert result.program is None
    return result


def _assert_sane(span: Span, lines: list[str] | None) -> None:
    assert span.line >= 1 and span.column >= 1
    assert (span.end_line, span.end_column) >= (span.line, span.column)
    if lines is not None:  # a span into this text (not into the map's YAML file)
        assert span.end_line <= len(lines)
        assert span.column <= len(lines[span.line - 1]) + 1


def _splice(text: str, position: int, removed: int, inserted: str) -> str:
    position = min(position, len(text))
    return text[:position] + inserted + text[position + removed:]


# ---- the scenarios themselves -------------------------------------------------------------


@pytest.mark.parametrize("path", SCENARIOS, ids=lambda path: path.name)
def test_the_unmutated_scenarios_check_clean(path: Path) -> None:
    assert check_and_render(TEXTS[path], path).diagnostics == ()


# ---- mutations ----------------------------------------------------------------------------

LINE_EDIT = st.tuples(st.sampled_from(["delete", "duplicate", "swap"]),
                      st.integers(min_value=0), st.integers(min_value=0))


@FUZZ
@given(path=scenarios(), edits=st.lists(LINE_EDIT, min_size=1, max_size=4))
def test_deleted_duplicated_and_swapped_lines(path: Path,
                                              edits: list[tuple[str, int, int]]) -> None:
    lines = TEXTS[path].split("\n")
    for operation, first, second in edits:
        i, j = first % len(lines), second % len(lines)
        if operation == "delete" and len(lines) > 1:
            del lines[i]
        elif operation == "duplicate":
            lines.insert(i, lines[i])
        else:
            lines[i], lines[j] = lines[j], lines[i]
    check_and_render("\n".join(lines), path)


CHAR_EDIT = st.tuples(st.integers(min_value=0), st.integers(min_value=0, max_value=6),
                      st.sampled_from(TOKENS), st.sampled_from(["", " ", "\n"]))


@FUZZ
@given(path=scenarios(), edits=st.lists(CHAR_EDIT, min_size=1, max_size=5))
def test_deleted_characters_and_inserted_tokens(path: Path,
                                                edits: list[tuple[int, int, str, str]]) -> None:
    text = TEXTS[path]
    for position, removed, token, spacing in edits:
        text = _splice(text, position % (len(text) + 1), removed, spacing + token + spacing)
    check_and_render(text, path)


@FUZZ
@given(path=scenarios(), cut=st.floats(min_value=0.0, max_value=1.0))
def test_truncated_anywhere(path: Path, cut: float) -> None:
    text = TEXTS[path]
    check_and_render(text[: int(len(text) * cut)], path)


@FUZZ
@given(path=scenarios(), position=st.integers(min_value=0),
       noise=st.text(min_size=1, max_size=8), removed=st.integers(min_value=0, max_value=3))
def test_random_unicode(path: Path, position: int, noise: str, removed: int) -> None:
    text = TEXTS[path]
    check_and_render(_splice(text, position % (len(text) + 1), removed, noise), path)


@FUZZ
@given(path=scenarios(), length=st.integers(min_value=200, max_value=20_000),
       letter=st.sampled_from("a_Z9"), where=st.sampled_from(["human", "place", "label"]))
def test_very_long_names(path: Path, length: int, letter: str, where: str) -> None:
    name = "n" + letter * length
    statement = {"human": f"human {name} at (1.0, 1.0) {{ {name}.speed 1 m/s }}",
                 "place": f"place {name} (1.0, 1.0)",
                 "label": f"activity {{ {name}: wait 1 s; wait until {name} done }}"}[where]
    check_and_render(TEXTS[path] + "\n" + statement + "\n", path)


WRAPPERS = ["{ ", "parallel { ", "race { ", "repeat 2 { ", "r: { "]
CONDITION_WRAPPERS = ["not ", "(", "not (", "(time > 1 s) and (", "(time > 1 s) or "]


@FUZZ
@given(path=scenarios(), depth=st.integers(min_value=1, max_value=80),
       wrapper=st.sampled_from(WRAPPERS), condition=st.sampled_from(CONDITION_WRAPPERS),
       condition_depth=st.integers(min_value=1, max_value=400))
def test_deep_nesting(path: Path, depth: int, wrapper: str, condition: str,
                      condition_depth: int) -> None:
    opened = condition * condition_depth
    closed = ")" * opened.count("(")
    steps = wrapper * depth + f"wait until {opened}time > 1 s{closed}" + " }" * depth
    check_and_render(TEXTS[path] + f"\nactivity deep {{\n{steps}\n}}\n", path)
