"""Renderings of diagnostics (rustc-style text, JSON, GitHub annotations), on fake diagnostics."""

from __future__ import annotations

import io
import json

import pytest

from hubero_dsl.cli.diagnostic_formats import (
    FileReport,
    Printer,
    SourceLines,
    diagnostic_lines,
    escape_github_data,
    escape_github_property,
    exit_status,
    github_annotation,
    github_report,
    json_report,
    plain,
    summary_line,
    text_report,
    wants_colour,
)
from hubero_dsl.diagnostics import Related, Span, error, warning

SOURCE = 'scenario "x"\nhuman a at (1, 2) {\n    sped 1.2 m/s\n}\n'
UNKNOWN_PARAM = error(
    "E101", "unknown parameter 'sped'", Span("x.hub", 3, 5, 3, 9), "did you mean 'speed'?",
    (Related("'a' is declared here", Span("x.hub", 2, 7, 2, 8)),))


def render(diagnostic_text: str, span: Span, message: str = "bad") -> str:
    sources = SourceLines({span.file: diagnostic_text})
    return plain(diagnostic_lines(error("E1", message, span), sources))


def underline_row(rendered: str) -> str:
    return rendered.splitlines()[4]


def source_row(rendered: str) -> str:
    return rendered.splitlines()[3]


def test_known_diagnostic_renders_as_rustc_does() -> None:
    report = FileReport("x.hub", SOURCE, (UNKNOWN_PARAM, warning("W201", "no activity", None)))
    assert plain(text_report([report])) == (
        "error[E101]: unknown parameter 'sped'\n"
        " --> x.hub:3:5\n"
        "  |\n"
        "3 |     sped 1.2 m/s\n"
        "  |     ^^^^\n"
        "  |\n"
        "  = help: did you mean 'speed'?\n"
        "note: 'a' is declared here\n"
        " --> x.hub:2:7\n"
        "  |\n"
        "2 | human a at (1, 2) {\n"
        "  |       ^\n"
        "\n"
        "warning[W201]: no activity\n"
        "\n"
        "1 error, 1 warning in 1 file\n"
    )


def test_gutter_widens_for_the_largest_line_number() -> None:
    text = "\n" * 11 + "    sped 1\n"
    rendered = render(text, Span("x.hub", 12, 5, 12, 9))
    assert rendered.splitlines()[1:5] == ["  --> x.hub:12:5", "   |", "12 |     sped 1",
                                          "   |     ^^^^"]


def test_tabs_keep_the_underline_under_the_span() -> None:
    rendered = render("\tspeed\t\tfast\n", Span("x.hub", 1, 9, 1, 13))
    shown, underline = source_row(rendered), underline_row(rendered)
    assert "\t" not in shown
    assert shown.index("fast") == underline.index("^^^^")
    assert underline.endswith("^^^^")


def test_wide_characters_are_measured_in_cells() -> None:
    rendered = render("name 漢字 = 5 @\n", Span("x.hub", 1, 13, 1, 14))
    underline = underline_row(rendered)
    # "1 | name 漢字 = 5 " is 4 + 5 + 4 (two double-width characters) + 5 cells wide.
    assert underline.index("^") == len("1 | ") + len("name ") + 4 + len(" = 5 ")


def test_a_wide_span_gets_an_underline_as_wide_as_it_shows() -> None:
    rendered = render("x 漢字\n", Span("x.hub", 1, 3, 1, 5))
    assert underline_row(rendered).endswith(" ^^^^")


def test_multi_line_span_underlines_to_the_end_of_its_first_line() -> None:
    rendered = render("activity {\n  a stand\n}\n", Span("x.hub", 1, 10, 3, 2))
    assert underline_row(rendered) == "  |          ^"
    rendered = render("parallel {\n}\n", Span("x.hub", 1, 1, 2, 2))
    assert underline_row(rendered) == "  | " + "^" * len("parallel {")


def test_span_at_the_end_of_the_line_gets_one_caret() -> None:
    rendered = render("seed\n", Span("x.hub", 1, 5, 1, 5))
    assert underline_row(rendered) == "  |     ^"


def test_control_characters_are_shown_visibly_and_keep_alignment() -> None:
    rendered = render("a\x1b[31m b @\n", Span("x.hub", 1, 10, 1, 11))
    assert "\x1b" not in rendered
    assert source_row(rendered).index("@") == underline_row(rendered).index("^")


def test_carriage_returns_and_form_feeds_do_not_shift_lines() -> None:
    rendered = render("one\r\n\x0ctwo\r\nthree @\r\n", Span("x.hub", 3, 7, 3, 8))
    assert source_row(rendered) == "3 | three @"
    assert underline_row(rendered) == "  |       ^"


def test_a_very_long_line_is_shown_as_a_window_around_the_span() -> None:
    line = "x" * 5000 + " @ " + "y" * 5000
    rendered = render(line + "\n", Span("x.hub", 1, 5002, 1, 5003))
    shown, underline = source_row(rendered), underline_row(rendered)
    assert len(shown) < 200
    assert shown[underline.index("^")] == "@"
    assert "..." in shown


def test_missing_source_shows_only_the_location() -> None:
    lines = diagnostic_lines(error("E9", "gone", Span("/nonexistent/x.hub", 3, 1, 3, 2)),
                             SourceLines())
    assert plain(lines) == "error[E9]: gone\n --> /nonexistent/x.hub:3:1\n"


def test_related_spans_in_other_files_are_read_from_disk(tmp_path: pytest.TempPathFactory) -> None:
    other = tmp_path / "map.yaml"  # type: ignore[operator]
    other.write_text("image: missing.pgm\n", encoding="utf-8")
    diagnostic = error("E401", "no map", Span("x.hub", 1, 1, 1, 4), None,
                       (Related("named here", Span(str(other), 1, 8, 1, 19)),))
    rendered = plain(diagnostic_lines(diagnostic, SourceLines({"x.hub": "map\n"})))
    assert "1 | image: missing.pgm\n  |        ^^^^^^^^^^^\n" in rendered


def test_multi_line_hints_are_aligned() -> None:
    lines = diagnostic_lines(error("E1", "m", None, "first\nsecond"), SourceLines())
    assert plain(lines) == "error[E1]: m\n  = help: first\n          second\n"


def test_summary_counts_and_pluralises() -> None:
    clean = FileReport("a.hub", "")
    broken = FileReport("b.hub", "", (UNKNOWN_PARAM, UNKNOWN_PARAM))
    warned = FileReport("c.hub", "", (warning("W1", "w", None),))
    assert summary_line([clean, broken, warned]) == "2 errors, 1 warning in 3 files"
    assert summary_line([clean]) == "0 errors, 0 warnings in 1 file"
    unreadable = FileReport("d.hub", None, input_error="d.hub: no such file")
    assert summary_line([clean, unreadable]).endswith("in 2 files; 1 could not be read")


@pytest.mark.parametrize(("reports", "strict", "status"), [
    ([FileReport("a", "")], False, 0),
    ([FileReport("a", "", (warning("W1", "w", None),))], False, 0),
    ([FileReport("a", "", (warning("W1", "w", None),))], True, 1),
    ([FileReport("a", ""), FileReport("b", "", (UNKNOWN_PARAM,))], False, 1),
    ([FileReport("a", "", (UNKNOWN_PARAM,)), FileReport("b", None, input_error="x")], False, 2),
])
def test_exit_status(reports: list[FileReport], strict: bool, status: int) -> None:
    assert exit_status(reports, strict=strict) == status


def test_json_report_has_the_documented_fields() -> None:
    reports = [FileReport("x.hub", SOURCE, (UNKNOWN_PARAM, warning("W2", "w", None))),
               FileReport("y.hub", None, input_error="y.hub: no such file")]
    document = json.loads(json_report(reports, strict=True))
    assert document["version"] == 1
    first, second = document["files"]
    assert first["path"] == "x.hub" and first["status"] == "errors"
    assert first["input_error"] is None
    diagnostic = first["diagnostics"][0]
    assert diagnostic == {
        "severity": "error", "code": "E101", "message": "unknown parameter 'sped'",
        "file": "x.hub", "line": 3, "column": 5, "end_line": 3, "end_column": 9,
        "hint": "did you mean 'speed'?",
        "related": [{"message": "'a' is declared here", "file": "x.hub", "line": 2,
                     "column": 7, "end_line": 2, "end_column": 8}],
    }
    spanless = first["diagnostics"][1]
    assert spanless["file"] == "x.hub" and spanless["line"] is None
    assert spanless["severity"] == "warning"
    assert second == {"path": "y.hub", "status": "unreadable",
                      "input_error": "y.hub: no such file", "diagnostics": []}
    assert document["summary"] == {"files": 2, "errors": 1, "warnings": 1, "unreadable": 1,
                                   "strict": True, "exit_status": 2}


def test_github_escaping_follows_the_workflow_command_rules() -> None:
    assert escape_github_data("50% done\r\nnext: a, b") == "50%25 done%0D%0Anext: a, b"
    assert escape_github_property("C:\\a,b%\n") == "C%3A\\a%2Cb%25%0A"


def test_github_annotation() -> None:
    assert github_annotation(UNKNOWN_PARAM, "x.hub") == (
        "::error file=x.hub,line=3,col=5,endLine=3,endColumn=9,title=E101::"
        "unknown parameter 'sped'%0Ahelp: did you mean 'speed'?"
        "%0Anote: 'a' is declared here (x.hub:2:7)")
    odd = warning("W1", "100%: a, b", Span("dir,1/a:b.hub", 1, 2, 1, 3))
    assert github_annotation(odd, "ignored") == (
        "::warning file=dir%2C1/a%3Ab.hub,line=1,col=2,endLine=1,endColumn=3,title=W1::"
        "100%25: a, b")


def test_github_report_annotates_unreadable_files_and_ends_with_the_summary() -> None:
    lines = github_report([FileReport("y.hub", None, input_error="y.hub: no such file")])
    assert lines == ["::error file=y.hub::y.hub: no such file",
                     "0 errors, 0 warnings in 1 file; 1 could not be read"]


class FakeTerminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_colour_only_for_a_terminal_and_never_under_no_color(
        monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("FORCE_COLOR", raising=False)
    monkeypatch.delenv("NO_COLOR", raising=False)
    monkeypatch.setenv("TERM", "xterm")
    assert wants_colour(FakeTerminal())
    assert not wants_colour(io.StringIO())
    monkeypatch.setenv("NO_COLOR", "1")
    assert not wants_colour(FakeTerminal())
    monkeypatch.setenv("FORCE_COLOR", "1")
    assert wants_colour(io.StringIO())


def test_coloured_output_has_the_same_text() -> None:
    lines = diagnostic_lines(UNKNOWN_PARAM, SourceLines({"x.hub": SOURCE}))
    stream = FakeTerminal()
    Printer(stream, colour=True).lines(lines)
    coloured = stream.getvalue()
    assert "\x1b[" in coloured
    import re

    assert re.sub(r"\x1b\[[0-9;]*m", "", coloured) == plain(lines)
