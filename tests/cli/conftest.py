"""Helpers for the command-line tests: run `hubero` in-process or as a subprocess, write files."""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import pytest

from hubero_dsl.cli.main import main

REPO_ROOT = Path(__file__).resolve().parents[2]


@dataclass(frozen=True)
class Outcome:
    status: int
    out: str
    err: str


def assert_no_traceback(outcome: Outcome) -> None:
    assert "Traceback" not in outcome.out
    assert "Traceback" not in outcome.err


@pytest.fixture
def cli(capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch,
        tmp_path_factory: pytest.TempPathFactory) -> Callable[..., Outcome]:
    """`cli("check", "x.hub")` runs `hubero check x.hub` in this process, in a folder of its
    own unless the test changes to another (`hubero run` writes its log to ./runs/)."""
    monkeypatch.chdir(tmp_path_factory.mktemp("cwd"))
    monkeypatch.delenv("FORCE_COLOR", raising=False)
    monkeypatch.delenv("HUBERO_DEBUG", raising=False)

    def run(*argv: str) -> Outcome:
        capsys.readouterr()
        status = main(list(argv))
        captured = capsys.readouterr()
        outcome = Outcome(status, captured.out, captured.err)
        assert_no_traceback(outcome)
        return outcome

    return run


@pytest.fixture
def cli_subprocess() -> Callable[..., Outcome]:
    """`cli_subprocess("check", "x.hub")` runs `python -m hubero_dsl check x.hub`."""
    return _run_subprocess


def _run_subprocess(*argv: str, cwd: Path | None = None, **env: str) -> Outcome:
    if cwd is None:  # never the checkout: `hubero run` writes its log to ./runs/
        with tempfile.TemporaryDirectory(prefix="hubero-cli-") as folder:
            return _run_subprocess(*argv, cwd=Path(folder), **env)
    environment = {k: v for k, v in os.environ.items()
                   if k not in ("FORCE_COLOR", "HUBERO_DEBUG")}
    environment.update(env)
    completed = subprocess.run([sys.executable, "-m", "hubero_dsl", *argv], cwd=cwd,
                               env=environment, capture_output=True, text=True, timeout=60,
                               check=False)
    outcome = Outcome(completed.returncode, completed.stdout, completed.stderr)
    assert_no_traceback(outcome)
    return outcome


@pytest.fixture
def write(tmp_path: Path) -> Callable[[str, str | bytes], Path]:
    """`write("a.hub", text_or_bytes)` creates a file in a fresh temporary folder."""

    def make(name: str, content: str | bytes) -> Path:
        path = tmp_path / name
        path.parent.mkdir(parents=True, exist_ok=True)
        if isinstance(content, bytes):
            path.write_bytes(content)
        else:
            path.write_text(content, encoding="utf-8")
        return path

    return make
