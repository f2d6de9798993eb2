"""Hostile and careless inputs (tests/hostile/, see its README), and hostile paths on the
command line: every one is answered with a clear message and the contract's exit status, never
a traceback, never unbounded output, and nothing is written or deleted outside what was asked.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

HOSTILE = Path(__file__).resolve().parent / "hostile"
CASES = sorted(HOSTILE.glob("*.hub"))
MOST_OUTPUT = 20_000  # characters a command may print about one bad file


def _hubero(*argv: str, cwd: Path, timeout: float = 60) -> subprocess.CompletedProcess[str]:
    env = {k: v for k, v in os.environ.items() if k != "HUBERO_DEBUG"}
    return subprocess.run([sys.executable, "-m", "hubero_dsl", *argv], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=timeout, check=False)


def _expectations(case: Path) -> tuple[dict[str, int], list[str]]:
    words = case.read_text(encoding="utf-8").splitlines()[0].removeprefix("# expect:").split()
    exits: dict[str, int] = {}
    forbidden: list[str] = []
    for keyword, value in zip(words[::2], words[1::2], strict=True):
        if keyword == "forbid":
            forbidden.append(value)
        else:
            exits[keyword] = int(value)
    return exits, forbidden


def _tree(folder: Path) -> set[str]:
    return {str(p.relative_to(folder)) for p in folder.rglob("*")}


@pytest.mark.parametrize("case", CASES, ids=lambda p: p.stem)
def test_a_hostile_file_is_answered_within_the_contract(case: Path, tmp_path: Path) -> None:
    scratch = tmp_path / "scratch"
    shutil.copytree(HOSTILE, scratch)
    (scratch / "r").mkdir()  # what `controller "shutil:rmtree"` would delete
    before = _tree(scratch)
    exits, forbidden = _expectations(case)
    for command, status in exits.items():
        done = _hubero(command, case.name, cwd=scratch)
        output = done.stdout + done.stderr
        assert done.returncode == status, output
        assert "Traceback" not in output and "internal error" not in output, output
        assert len(output) < MOST_OUTPUT
        for text in forbidden:
            assert text not in output
    written = _tree(scratch) - before
    assert all(path == "runs" or path.startswith("runs/") for path in written), written
    assert (scratch / "r").is_dir()


def test_a_device_or_a_fifo_is_no_scenario(tmp_path: Path) -> None:
    fifo = tmp_path / "pipe.hub"
    os.mkfifo(fifo)
    for path in ("/dev/zero", str(fifo)):
        done = _hubero("check", path, cwd=tmp_path, timeout=30)
        assert done.returncode == 2 and "not a regular file" in done.stdout + done.stderr


def test_a_fifo_as_the_map_image_does_not_hang(tmp_path: Path) -> None:
    shutil.copy(HOSTILE / "room.yaml", tmp_path / "room.yaml")
    os.mkfifo(tmp_path / "room.pgm")
    (tmp_path / "s.hub").write_text('scenario "s"\nmap "room.yaml"\nhuman a at (1, 1)\n'
                                    "activity { a stand for 1 s }\n")
    done = _hubero("check", "s.hub", cwd=tmp_path, timeout=30)
    assert done.returncode == 1
    assert "names a device, a FIFO or a socket, not an image" in done.stdout


@pytest.mark.parametrize("output", ["/dev/null", "s.hub", "room.yaml", "."])
def test_a_log_is_never_written_over_a_device_an_input_or_a_folder(tmp_path: Path,
                                                                   output: str) -> None:
    for name in ("room.yaml", "room.pgm"):
        shutil.copy(HOSTILE / name, tmp_path / name)
    scenario = tmp_path / "s.hub"
    scenario.write_text('scenario "s"\nmap "room.yaml"\nhuman a at (1, 1)\n'
                        "activity { a stand for 0.5 s }\n")
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir() if p.is_file()}
    done = _hubero("run", "s.hub", "-o", output, cwd=tmp_path)
    assert done.returncode == 2, done.stdout + done.stderr
    assert "Traceback" not in done.stderr
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir() if p.is_file()} == before
