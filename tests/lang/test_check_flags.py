"""Golden diagnostics under command-line flags: `NAME.FLAGS.txt` beside a case `NAME.hub`.

`tests/cli/test_cli_golden.py` checks every case in `tests/cases/diagnostics/` with no flags
(`NAME.txt`). A case may also have outputs under flags, named by the flags joined with `+`:
`unused_place.strict.txt` is `hubero check --strict unused_place.hub`, and
`unused_place.strict+json.txt` would be `--strict --format json`. Regenerate with
`HUBERO_UPDATE_GOLDEN=1` and read the diff before committing it.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from hubero_dsl.cli.main import main
from hubero_dsl.pipeline import check_file

REPO_ROOT = Path(__file__).resolve().parents[2]
CASES = REPO_ROOT / "tests" / "cases" / "diagnostics"
UPDATE = os.environ.get("HUBERO_UPDATE_GOLDEN") == "1"
FLAGS = {"strict": ["--strict"], "json": ["--format", "json"], "github": ["--format", "github"]}
GOLDENS = sorted(path for path in CASES.glob("*.*.txt"))


def _case_and_flags(golden: Path) -> tuple[Path, list[str]]:
    name, flags = golden.name.removesuffix(".txt").split(".", 1)
    argv = [flag for word in flags.split("+") for flag in FLAGS[word]]
    return golden.with_name(f"{name}.hub"), argv


def test_there_are_flag_goldens() -> None:
    assert any(path.name.endswith(".strict.txt") for path in GOLDENS)


@pytest.mark.parametrize("golden", GOLDENS, ids=lambda path: path.name)
def test_golden_output_under_flags(golden: Path, capsys: pytest.CaptureFixture[str],
                                   monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(REPO_ROOT)
    monkeypatch.delenv("FORCE_COLOR", raising=False)
    case, flags = _case_and_flags(golden)
    capsys.readouterr()
    status = main(["check", *flags, case.relative_to(REPO_ROOT).as_posix()])
    out = capsys.readouterr().out
    if UPDATE:
        golden.write_text(out, encoding="utf-8")
    assert out == golden.read_text(encoding="utf-8")
    result = check_file(case)
    failing = bool(result.errors) or ("--strict" in flags and bool(result.warnings))
    assert status == (1 if failing else 0)
