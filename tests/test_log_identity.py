"""The logs of every variant of every shipped scenario, byte for byte, as recorded in
tests/cases/logs/digests.json.

A change that means to keep behaviour (a refactor, a speed-up) must keep these bytes. A change
that means to alter behaviour regenerates the digests on purpose and says why in its commit:

    HUBERO_REGENERATE_LOG_DIGESTS=1 python -m pytest tests/test_log_identity.py

A log names its scenario by the file's name and its map as the file writes it, so the
checkout's own files give the same bytes wherever it lies.
"""

from __future__ import annotations

import hashlib
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

REPO_ROOT = Path(__file__).resolve().parents[1]
DIGESTS = REPO_ROOT / "tests" / "cases" / "logs" / "digests.json"
REGENERATE = os.environ.get("HUBERO_REGENERATE_LOG_DIGESTS") == "1"

pytestmark = pytest.mark.slow


def _logs(out: Path) -> dict[str, str]:
    digests: dict[str, str] = {}
    scenarios = REPO_ROOT / "scenarios"
    # the benchmark suite's logs are pinned too, keyed benchmark/NAME/...
    for scenario in sorted([*scenarios.glob("*.hub"), *scenarios.glob("benchmark/*.hub")]):
        name = scenario.relative_to(scenarios).with_suffix("").as_posix()
        out_dir = out / name
        command = [sys.executable, "-m", "hubero_dsl", "run", f"scenarios/{name}.hub",
                   "--all-variants", "--quiet", "--out-dir", str(out_dir)]
        done = subprocess.run(command, cwd=REPO_ROOT, capture_output=True, text=True,
                              check=False, env={**os.environ, "PYTHONHASHSEED": "0"})
        assert done.returncode in (0, 1), done.stderr
        for log in sorted(out_dir.glob("*.mcap")):
            key = f"{name}/{log.name}"
            digests[key] = hashlib.sha256(log.read_bytes()).hexdigest()
    return digests


def test_logs_of_shipped_scenarios_are_unchanged(tmp_path: Path) -> None:
    digests = _logs(tmp_path)
    if REGENERATE:
        DIGESTS.write_text(json.dumps(digests, indent=2, sort_keys=True) + "\n")
    expected = json.loads(DIGESTS.read_text())
    assert sorted(digests) == sorted(expected), "the set of scenarios or variants changed"
    changed = [key for key in expected if digests[key] != expected[key]]
    assert not changed, f"these logs changed: {changed}"
