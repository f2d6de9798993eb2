"""Golden diagnostics: `hubero check NAME.hub` must print exactly `NAME.txt`.

Every `tests/cases/diagnostics/NAME.hub` is a case. Regenerate the expected output after an
intended change with `HUBERO_UPDATE_GOLDEN=1 pytest tests/cli/test_cli_golden.py`, and read the
diff before committing it.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

REPO_ROOT = Path(__file__).resolve().parents[2]
CASES = REPO_ROOT / "tests" / "cases" / "diagnostics"
UPDATE = os.environ.get("HUBERO_UPDATE_GOLDEN") == "1"


@pytest.mark.parametrize("case", sorted(CASES.glob("*.hub")), ids=lambda path: path.stem)
def test_golden_diagnostics(cli: Callable[..., Any], monkeypatch: pytest.MonkeyPatch,
                            case: Path) -> None:
    monkeypatch.chdir(REPO_ROOT)
    outcome = cli("check", case.relative_to(REPO_ROOT).as_posix())
    expected_file = case.with_suffix(".txt")
    if UPDATE:
        expected_file.write_text(outcome.out, encoding="utf-8")
    assert expected_file.exists(), f"no {expected_file.name}: run with HUBERO_UPDATE_GOLDEN=1"
    assert outcome.out == expected_file.read_text(encoding="utf-8")
    has_errors = any(line.startswith("error") for line in outcome.out.splitlines())
    assert outcome.status == (1 if has_errors else 0)


def test_there_are_golden_cases() -> None:
    assert len(list(CASES.glob("*.hub"))) >= 5
