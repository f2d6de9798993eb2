"""Fixtures for the checker and parser tests: check scenario text on the living-room map.

Texts are checked as if they were a file in this folder, so `map "../../maps/living_room.yaml"`
names the project's living-room map and no file is written. `check(body)` puts a four-line
header before the body (the scenario, the map and two humans on free floor, actor1 and actor2),
so the body's first line is line 5.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from pathlib import Path

import pytest

from hubero_dsl.pipeline import CheckResult, check_source

REPO_ROOT = Path(__file__).resolve().parents[2]
CASE_PATH = str(REPO_ROOT / "tests" / "lang" / "case.hub")
HEADER = 'scenario "test"\nmap "../../maps/living_room.yaml"\n'
ROOM = HEADER + "human actor1 at (6.3, 2.5)\nhuman actor2 at (3.8, -5.3)\n"


@pytest.fixture
def check() -> Callable[..., CheckResult]:
    """`check(body)` checks the header + body; `check(text, header=False)` checks text alone.

    Most bodies are one statement with no activity, so the warning for a scenario without one
    (W502) is left out of the result unless the body has none at all (`check("")`)."""

    def run(text: str, *, header: bool = True) -> CheckResult:
        result = check_source(ROOM + text if header else text, CASE_PATH)
        if not text.strip():
            return result
        kept = tuple(d for d in result.diagnostics if d.code != "W502")
        return dataclasses.replace(result, diagnostics=kept)

    return run


@pytest.fixture
def case_path() -> str:
    """The path texts are checked under: `../../maps/...` from it is the project's maps."""
    return CASE_PATH
