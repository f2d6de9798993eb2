"""Source spans and diagnostics: the one currency every stage uses to talk about bad input.

A `Span` points into a source file (1-based line and column, end exclusive). A `Diagnostic` is
one finding about the input; stages collect them and the CLI renders them. Library code never
prints.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable
from dataclasses import dataclass, field
from enum import StrEnum


@dataclass(frozen=True, slots=True)
class Span:
    """A region of a source file: 1-based lines and columns, end column exclusive."""

    file: str
    line: int
    column: int
    end_line: int
    end_column: int

    def __str__(self) -> str:
        return f"{self.file}:{self.line}:{self.column}"

    @staticmethod
    def whole_file(file: str) -> Span:
        return Span(file, 1, 1, 1, 1)


@dataclass(frozen=True, slots=True)
class SourceFile:
    """A scenario's text and where it came from."""

    path: str
    text: str

    def line(self, number: int) -> str:
        lines = self.text.split("\n")  # as the lexer counts lines: only at "\n"
        return lines[number - 1].rstrip("\r") if 0 < number <= len(lines) else ""



class Severity(StrEnum):
    ERROR = "error"
    WARNING = "warning"


@dataclass(frozen=True, slots=True)
class Related:
    """A secondary location that explains a diagnostic ("first defined here")."""

    message: str
    span: Span


@dataclass(frozen=True, slots=True)
class Diagnostic:
    """One finding about the input, with where it is and what to do about it."""

    severity: Severity
    code: str
    message: str
    span: Span | None
    hint: str | None = None
    related: tuple[Related, ...] = field(default_factory=tuple)

    @property
    def is_error(self) -> bool:
        return self.severity is Severity.ERROR

    def sort_key(self) -> tuple[str, int, int, str]:
        if self.span is None:
            return ("", 0, 0, self.code)
        return (self.span.file, self.span.line, self.span.column, self.code)


def error(code: str, message: str, span: Span | None, hint: str | None = None,
          related: tuple[Related, ...] = ()) -> Diagnostic:
    return Diagnostic(Severity.ERROR, code, message, span, hint, related)


def warning(code: str, message: str, span: Span | None, hint: str | None = None,
            related: tuple[Related, ...] = ()) -> Diagnostic:
    return Diagnostic(Severity.WARNING, code, message, span, hint, related)


def closest(word: str, candidates: Iterable[str]) -> str | None:
    """The candidate a slip of `word` most likely meant, for a "did you mean" hint (None when
    nothing is close): one rule for every such hint, whatever its wording."""
    close = difflib.get_close_matches(word, sorted(candidates), n=1, cutoff=0.6)
    return close[0] if close else None
