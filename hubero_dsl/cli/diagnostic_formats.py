"""Diagnostics -> text (rustc style), JSON and GitHub Actions annotations; and the one printer.

Rendering is pure: every function here turns `FileReport`s or `Diagnostic`s into lines or a
document. Text is built as styled segments (`Line`) so that the same rendering prints plain to a
pipe and in colour to a terminal; rich is imported only when colour is wanted, which keeps a cold
`hubero check` in a pipeline fast. Widths are measured in terminal cells (rich's cell widths),
with tabs shown as four spaces and control characters as visible symbols, so the underline stays
under the span whatever the line holds.
"""

from __future__ import annotations

import json
import os
import sys
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, TextIO

from rich.cells import cell_len

from hubero_dsl.diagnostics import Diagnostic, Related, Severity, Span

if TYPE_CHECKING:
    from hubero_dsl.errors import HuberoError

JSON_FORMAT_VERSION = 1
TAB_WIDTH = 4
# Longer source lines are shown as a window around the span: a minified or generated file must
# not flood the terminal with one megabyte-long line.
MAX_SHOWN_CHARS = 160
MAX_SHOWN_DIAGNOSTICS = 50  # per file, in text; JSON and GitHub annotations list them all
_WINDOW_BEFORE = 60
# Other files a diagnostic points into (related spans) are read for their snippet only when small.
_MAX_SNIPPET_SOURCE_BYTES = 2_000_000

Segment = tuple[str, str]  # (text, style name); style "" is plain
Line = tuple[Segment, ...]

STYLES: dict[str, str] = {
    "error": "bold red",
    "warning": "bold yellow",
    "note": "bold green",
    "help": "bold cyan",
    "gutter": "bold blue",
    "title": "bold",
}


@dataclass(frozen=True)
class FileReport:
    """What checking one file found: its diagnostics, or why it could not be read."""

    path: str
    text: str | None
    diagnostics: tuple[Diagnostic, ...] = ()
    input_error: str | None = None

    @property
    def errors(self) -> int:
        return sum(1 for d in self.diagnostics if d.is_error)

    @property
    def warnings(self) -> int:
        return sum(1 for d in self.diagnostics if not d.is_error)

    @property
    def status(self) -> str:
        if self.input_error is not None:
            return "unreadable"
        if self.errors:
            return "errors"
        return "warnings" if self.warnings else "clean"


def exit_status(reports: Sequence[FileReport], *, strict: bool) -> int:
    """2 if any file could not be read, else 1 if any has errors (or warnings if strict), else 0."""
    if any(r.input_error is not None for r in reports):
        return 2
    failing = any(r.errors or (strict and r.warnings) for r in reports)
    return 1 if failing else 0


# ---- source lines --------------------------------------------------------------------------


class SourceLines:
    """Source text by file name, for snippets. Files not given up front are read from disk once;
    a file that cannot be read simply gets no snippet."""

    def __init__(self, texts: Mapping[str, str] | None = None) -> None:
        self._lines: dict[str, list[str] | None] = {}
        for path, text in (texts or {}).items():
            self._lines[path] = _split_lines(text)

    def line(self, path: str, number: int) -> str | None:
        if path not in self._lines:
            self._lines[path] = _read_lines(path)
        lines = self._lines[path]
        if lines is None or not 0 < number <= len(lines):
            return None
        return lines[number - 1]


def _split_lines(text: str) -> list[str]:
    # Lines end at "\n" only, as the lexer counts them (str.splitlines would also split at form
    # feeds and U+2028 and disagree with the line numbers in spans).
    return [line.removesuffix("\r") for line in text.split("\n")]


def _read_lines(path: str) -> list[str] | None:
    try:
        file = Path(path)
        if not file.is_file() or file.stat().st_size > _MAX_SNIPPET_SOURCE_BYTES:
            return None
        data = file.read_bytes()
    except OSError:
        return None
    if b"\x00" in data:
        return None
    return _split_lines(data.decode("utf-8-sig", errors="replace"))


# ---- text ----------------------------------------------------------------------------------


def _visible(char: str) -> str:
    """How one source character is shown: tabs widen, control characters become symbols."""
    if char == "\t":
        return " " * TAB_WIDTH
    code = ord(char)
    if code < 0x20:
        return chr(0x2400 + code)  # the Unicode "control pictures" block: ␀ ␁ ... ␟
    if code == 0x7F:
        return "\u2421"
    if 0x80 <= code < 0xA0:
        return "\ufffd"
    return char


def _shown(text: str) -> str:
    return "".join(_visible(c) for c in text)


def printable(text: str) -> str:
    """`text` with its control characters (but line breaks) shown as symbols: a message that
    quotes a file name or a log's title must not move the cursor or retitle the terminal."""
    return "\n".join(_shown(line) for line in text.split("\n"))


def _underline(line: str, span: Span) -> tuple[str, int, int]:
    """The line as shown, and the cell offset and cell width of the span's underline on it."""
    start = max(0, span.column - 1)
    end = span.end_column - 1 if span.end_line == span.line else len(line)
    end = max(end, start + 1)
    prefix_marker = ""
    if len(line) > MAX_SHOWN_CHARS:
        first = max(0, start - _WINDOW_BEFORE)
        last = first + MAX_SHOWN_CHARS
        prefix_marker = "..." if first > 0 else ""
        suffix_marker = "..." if last < len(line) else ""
        line, start, end = line[first:last], start - first, min(end, last) - first
        shown_line = prefix_marker + _shown(line) + suffix_marker
    else:
        shown_line = _shown(line)
    offset = cell_len(prefix_marker) + cell_len(_shown(line[:start]))
    width = max(1, cell_len(_shown(line[start:end])))
    return shown_line, offset, width


def _gutter_width(diagnostic: Diagnostic) -> int:
    spans = [diagnostic.span] + [r.span for r in diagnostic.related]
    return max((len(str(s.line)) for s in spans if s is not None), default=1)


def _snippet(span: Span, sources: SourceLines, width: int, style: str) -> list[Line]:
    """` --> file:line:col`, then the source line in a numbered gutter with the span underlined."""
    pad = " " * width
    lines: list[Line] = [((f"{pad}--> ", "gutter"), (str(span), ""))]
    text = sources.line(span.file, span.line)
    if text is None:
        return lines
    shown, offset, underline_width = _underline(text, span)
    number = str(span.line).rjust(width)
    lines.append(((f"{pad} |", "gutter"),))
    lines.append(((f"{number} | ", "gutter"), (shown, "")))
    lines.append(((f"{pad} | ", "gutter"), (" " * offset, ""), ("^" * underline_width, style)))
    return lines


def _labelled(label: str, style: str, text: str, indent: str) -> list[Line]:
    """`= help: text` with continuation lines aligned under the text."""
    first, *rest = printable(text).split("\n")
    lines: list[Line] = [((f"{indent}= ", "gutter"), (f"{label}:", style), (f" {first}", ""))]
    align = " " * (len(indent) + len(label) + 4)
    lines.extend(((f"{align}{more}", ""),) for more in rest)
    return lines


def _header(severity: str, code: str, message: str) -> Line:
    tag = f"{severity}[{code}]" if code else severity
    return ((tag, severity), (f": {printable(message)}", "title"))


def diagnostic_lines(diagnostic: Diagnostic, sources: SourceLines) -> list[Line]:
    """One diagnostic in rustc style, followed by its related notes, each with its location."""
    severity = str(diagnostic.severity)
    width = _gutter_width(diagnostic)
    lines = [_header(severity, diagnostic.code, diagnostic.message)]
    if diagnostic.span is not None:
        lines.extend(_snippet(diagnostic.span, sources, width, severity))
    if diagnostic.hint:
        if diagnostic.span is not None:
            lines.append(((f"{' ' * width} |", "gutter"),))
        lines.extend(_labelled("help", "help", diagnostic.hint, " " * (width + 1)))
    for related in diagnostic.related:
        lines.extend(_related_lines(related, sources, width))
    return lines


def _related_lines(related: Related, sources: SourceLines, width: int) -> list[Line]:
    return [_header("note", "", related.message), *_snippet(related.span, sources, width, "note")]


def input_error_lines(message: str) -> list[Line]:
    return [_header("error", "", message)]


def _plural(count: int, noun: str) -> str:
    return f"{count} {noun}{'' if count == 1 else 's'}"


def summary_line(reports: Sequence[FileReport], *, strict: bool = False) -> str:
    """`2 errors, 1 warning in 3 files`, and how many could not be read."""
    errors = sum(r.errors for r in reports)
    warnings = sum(r.warnings for r in reports)
    unreadable = sum(1 for r in reports if r.input_error is not None)
    line = f"{_plural(errors, 'error')}, {_plural(warnings, 'warning')} in "
    line += _plural(len(reports), "file")
    if unreadable:
        line += f"; {unreadable} could not be read"
    if strict and warnings and not errors:
        line += " (--strict: warnings fail the check)"
    return line


def text_report(reports: Sequence[FileReport], *, strict: bool = False) -> list[Line]:
    """Every file's diagnostics (a blank line after each), then the summary line."""
    sources = SourceLines({r.path: r.text for r in reports if r.text is not None})
    lines: list[Line] = []
    for report in reports:
        if report.input_error is not None:
            lines.extend(input_error_lines(report.input_error))
            lines.append(())
        for diagnostic in report.diagnostics[:MAX_SHOWN_DIAGNOSTICS]:
            lines.extend(diagnostic_lines(diagnostic, sources))
            lines.append(())
        hidden = len(report.diagnostics) - MAX_SHOWN_DIAGNOSTICS
        if hidden > 0:
            lines += [((f"... and {hidden} more in {report.path} (--format json lists them "
                        "all)", "note"),), ()]
    lines.append(((summary_line(reports, strict=strict), "title"),))
    return lines


def plain(lines: Iterable[Line]) -> str:
    """Lines as plain text, each ending in a newline."""
    return "".join("".join(text for text, _ in line) + "\n" for line in lines)


# ---- JSON ----------------------------------------------------------------------------------


def _span_fields(span: Span | None, default_file: str) -> dict[str, Any]:
    if span is None:
        return {"file": default_file, "line": None, "column": None, "end_line": None,
                "end_column": None}
    return {"file": span.file, "line": span.line, "column": span.column,
            "end_line": span.end_line, "end_column": span.end_column}


def diagnostic_json(diagnostic: Diagnostic, default_file: str) -> dict[str, Any]:
    return {
        "severity": str(diagnostic.severity),
        "code": diagnostic.code,
        "message": diagnostic.message,
        **_span_fields(diagnostic.span, default_file),
        "hint": diagnostic.hint,
        "related": [{"message": r.message, **_span_fields(r.span, default_file)}
                    for r in diagnostic.related],
    }


def json_report(reports: Sequence[FileReport], *, strict: bool = False) -> str:
    """The whole check as one JSON document (format documented in docs/cli.md)."""
    document = {
        "version": JSON_FORMAT_VERSION,
        "files": [{
            "path": r.path,
            "status": r.status,
            "input_error": r.input_error,
            "diagnostics": [diagnostic_json(d, r.path) for d in r.diagnostics],
        } for r in reports],
        "summary": {
            "files": len(reports),
            "errors": sum(r.errors for r in reports),
            "warnings": sum(r.warnings for r in reports),
            "unreadable": sum(1 for r in reports if r.input_error is not None),
            "strict": strict,
            "exit_status": exit_status(reports, strict=strict),
        },
    }
    return json.dumps(document, indent=2, ensure_ascii=True)


# ---- GitHub Actions ------------------------------------------------------------------------


def escape_github_data(text: str) -> str:
    """Escape a workflow command's message: '%', CR and LF (as actions/toolkit's escapeData)."""
    return text.replace("%", "%25").replace("\r", "%0D").replace("\n", "%0A")


def escape_github_property(text: str) -> str:
    """Escape a property value: as data, plus ':' and ',' which delimit properties."""
    return escape_github_data(text).replace(":", "%3A").replace(",", "%2C")


def github_annotation(diagnostic: Diagnostic, default_file: str) -> str:
    """`::error file=F,line=L,col=C,endLine=..,endColumn=..,title=CODE::message`."""
    command = "error" if diagnostic.severity is Severity.ERROR else "warning"
    span = diagnostic.span
    properties = [("file", span.file if span else default_file)]
    if span is not None:
        properties += [("line", str(span.line)), ("col", str(span.column)),
                       ("endLine", str(span.end_line)), ("endColumn", str(span.end_column))]
    if diagnostic.code:
        properties.append(("title", diagnostic.code))
    message = diagnostic.message
    if diagnostic.hint:
        message += f"\nhelp: {diagnostic.hint}"
    for related in diagnostic.related:
        message += f"\nnote: {related.message} ({related.span})"
    joined = ",".join(f"{key}={escape_github_property(value)}" for key, value in properties)
    return f"::{command} {joined}::{escape_github_data(message)}"


def github_report(reports: Sequence[FileReport], *, strict: bool = False) -> list[str]:
    """One annotation per diagnostic (and per unreadable file), then the summary line."""
    lines: list[str] = []
    for report in reports:
        if report.input_error is not None:
            file = escape_github_property(report.path)
            lines.append(f"::error file={file}::{escape_github_data(report.input_error)}")
        lines.extend(github_annotation(d, report.path) for d in report.diagnostics)
    lines.append(summary_line(reports, strict=strict))
    return lines


# ---- printing ------------------------------------------------------------------------------


def wants_colour(stream: TextIO) -> bool:
    """Colour for a terminal, unless NO_COLOR (or TERM=dumb) says no; FORCE_COLOR says yes."""
    if os.environ.get("FORCE_COLOR"):
        return True
    if os.environ.get("NO_COLOR") or os.environ.get("TERM") == "dumb":
        return False
    try:
        return stream.isatty()
    except (AttributeError, ValueError):
        return False


@dataclass
class Printer:
    """Writes rendered lines to one stream, in colour when the stream wants it."""

    stream: TextIO
    colour: bool
    _console: Any = field(default=None, repr=False)

    @classmethod
    def to(cls, stream: TextIO) -> Printer:
        return cls(stream, wants_colour(stream))

    def lines(self, lines: Iterable[Line]) -> None:
        if not self.colour:
            self.stream.write(plain(lines))
            return
        from rich.text import Text

        console = self._rich_console()
        for line in lines:
            console.print(Text.assemble(*((text, STYLES.get(style, "")) for text, style in line)))

    def text(self, text: str) -> None:
        self.stream.write(text if text.endswith("\n") else text + "\n")

    def flush(self) -> None:
        self.stream.flush()

    def _rich_console(self) -> Any:
        if self._console is None:
            from rich.console import Console

            self._console = Console(file=self.stream, force_terminal=True, highlight=False,
                                    markup=False, emoji=False, soft_wrap=True)
        return self._console


def report_error(exc: HuberoError) -> None:
    """An error as the command line reports it on stderr: a scenario's diagnostics (at most
    MAX_SHOWN_DIAGNOSTICS), or the one message, with its place when it has one."""
    from hubero_dsl.diagnostics import error
    from hubero_dsl.errors import CompileError

    printer = Printer.to(sys.stderr)
    sources = SourceLines()
    if isinstance(exc, CompileError):
        for diagnostic in exc.diagnostics[:MAX_SHOWN_DIAGNOSTICS]:
            printer.lines([*diagnostic_lines(diagnostic, sources), ()])
        if len(exc.diagnostics) > MAX_SHOWN_DIAGNOSTICS:
            print(f"hubero: ... and {len(exc.diagnostics) - MAX_SHOWN_DIAGNOSTICS} more "
                  "(hubero check --format json lists them all)", file=sys.stderr)
    elif exc.span is None and exc.hint is None:
        printer.lines(input_error_lines(exc.message))
    else:
        printer.lines(diagnostic_lines(error("", exc.message, exc.span, exc.hint), sources))
