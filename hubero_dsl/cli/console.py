"""The rich console the commands print tables with.

rich's own answer to a closed pipe (`hubero run x | head`) is to exit with status 1; hubero
reports a broken pipe the same way for every command (status 141, see `main.py`), so this
console hands the error on instead.
"""

from __future__ import annotations

import sys
from typing import Any

from rich.console import Console


class _PipeAwareConsole(Console):
    def on_broken_pipe(self) -> None:
        raise BrokenPipeError


def make_console(**options: Any) -> Console:
    """A console; written to a pipe or a file it neither wraps nor cuts lines (CI logs are
    read with grep), on a terminal it fits the terminal."""
    stream = sys.stderr if options.get("stderr") else sys.stdout
    if not stream.isatty():
        options.setdefault("width", 100_000)
        options.setdefault("soft_wrap", True)
    return _PipeAwareConsole(**options)


def shows_progress(console: Console) -> bool:
    """Whether a progress bar is drawn on `console`: only when it writes to a terminal, for a
    person to watch. FORCE_COLOR makes rich take any output for a terminal, and a CI log was
    filled with bars."""
    isatty = getattr(console.file, "isatty", None)
    return bool(isatty is not None and isatty())
