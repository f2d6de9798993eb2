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
