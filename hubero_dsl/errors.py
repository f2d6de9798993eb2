"""The one exception tree of hubero.

Every error a user can cause is a `HuberoError`. The CLI maps them to exit statuses:
`InputError` (unreadable files, bad maps, usage) -> 2, `CompileError` (a scenario that does not
check) -> 1. Anything else escaping the library is a bug.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence

from hubero_dsl.diagnostics import Diagnostic, Span


class HuberoError(Exception):
    """Base of every error hubero raises on purpose."""

    exit_status = 2

    def __init__(self, message: str, span: Span | None = None, hint: str | None = None) -> None:
        message = shortened(message)
        super().__init__(message)
        self.message = message
        self.span = span
        self.hint = hint

    def __str__(self) -> str:
        where = f"{self.span}: " if self.span else ""
        return f"{where}{self.message}"


MAX_MESSAGE = 2_000  # characters: a message quotes names from a file, which may be any length


def shortened(text: str, limit: int = MAX_MESSAGE) -> str:
    """`text`, its middle left out when it is longer than `limit` (a file name of a megabyte
    in a message must not flood the terminal)."""
    if len(text) <= limit:
        return text
    keep = (limit - 5) // 2
    return f"{text[:keep]} ... {text[-keep:]}"


class InputError(HuberoError):
    """Input that cannot be read at all: a missing file, bad bytes, a directory, a usage error."""


class MapError(InputError):
    """A map that cannot be loaded: missing or unreadable YAML or image, bad fields."""


class CompileError(HuberoError):
    """A scenario with errors; carries every diagnostic found, not just the first."""

    exit_status = 1

    def __init__(self, diagnostics: Sequence[Diagnostic]) -> None:
        self.diagnostics = tuple(diagnostics)
        first = next((d for d in self.diagnostics if d.is_error), None)
        super().__init__(first.message if first else "scenario has errors",
                         first.span if first else None)


class SimulationError(HuberoError):
    """A run that cannot go on: an impossible request made through the Python API."""

    exit_status = 1


class LogError(InputError):
    """A log file that cannot be written or read back."""


class Terminated(KeyboardInterrupt):
    """SIGTERM (what `timeout` and process managers send): stopped like Ctrl-C, so a run's
    temporary log is removed and a sweep stops its workers, but reported as terminated."""


class Stopped(BaseException):
    """A run stopped from outside by one of hubero's signal handlers (a sweep's worker told to
    end its run): like KeyboardInterrupt, never the failure of the user code it interrupts."""


# What user code may be interrupted by without having failed: everything else it raises,
# whatever its class (asyncio.CancelledError, GeneratorExit, SystemExit, ...), is its failure.
OUTSIDE_STOPS = (KeyboardInterrupt, Stopped)


SHOWN = 80  # characters of what user code returned, in a message
_LONG_NUMBER = 20  # digits: a longer whole number is told by its length


def shown(value: object) -> str:
    """What user code returned, as its repr cut short: a whole number of more than 20 digits
    told by its length, a tuple's or list's items as far as SHOWN characters go, and a longer
    text cut between words, its brackets and quotes closed after the `…`; a placeholder when
    even that fails."""
    try:
        return _cut(_text(value, SHOWN), SHOWN)
    except Exception:  # user code again
        return f"a {type(value).__name__}"


def _text(value: object, room: int) -> str:
    """`value`'s repr (on one line), but as `shown` tells long whole numbers, and a tuple's or
    list's items only until they pass `room` characters."""
    if isinstance(value, int) and not isinstance(value, bool):
        digits = _digits(value)
        if digits is None or digits > _LONG_NUMBER:
            counted = f"more than {sys.get_int_max_str_digits()}" if digits is None else digits
            return f"{'a negative' if value < 0 else 'a'} whole number of {counted} digits"
    if isinstance(value, tuple | list) and type(value) in (tuple, list):  # not a namedtuple
        items: list[str] = []
        length = 2
        for item in value:
            if length > room:
                items.append("…")
                break
            items.append(_text(item, room - length))
            length += len(items[-1]) + 2
        lone = "," if type(value) is tuple and len(items) == 1 and items != ["…"] else ""
        inner = ", ".join(items) + lone
        return f"({inner})" if type(value) is tuple else f"[{inner}]"
    text = repr(value)
    return " ".join(text.split()) if type(value).__module__ == "numpy" else text


def _digits(value: int) -> int | None:
    """How many digits a whole number has; None past what Python writes out
    (`sys.get_int_max_str_digits()`)."""
    try:
        return len(str(abs(value)))
    except ValueError:
        return None


_CLOSING = {"(": ")", "[": "]", "{": "}"}


def _cut(text: str, limit: int) -> str:
    """`text` when it is at most `limit` characters; else its beginning, cut between words
    where it can be, then `…` and whatever brackets and quote it had left open, closed."""
    if len(text) <= limit:
        return text
    kept = text[:limit - 1]
    space = kept.rfind(" ")
    if space > limit // 2:  # not in the middle of a number or a word
        kept = kept[:space].rstrip(",")
    opened: list[str] = []
    quote = ""
    escaped = False
    for character in kept:
        if quote:
            if escaped:
                escaped = False
            elif character == "\\":
                escaped = True
            elif character == quote:
                quote = ""
        elif character in "'\"":
            quote = character
        elif character in _CLOSING:
            opened.append(_CLOSING[character])
        elif opened and character == opened[-1]:
            opened.pop()
    return kept + "…" + quote + "".join(reversed(opened))


def failure_of(exc: BaseException) -> str:
    """`Type: message` of an exception user code raised; its message may itself fail."""
    try:
        text = str(exc)
    except Exception:  # a __str__ of the user's that raises
        text = "(its message cannot be shown)"
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__
