"""`python -m hubero_dsl` as users run it: a fresh interpreter, real streams, real exit codes."""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from hubero_dsl import __version__

Run = Callable[..., Any]
Write = Callable[[str, "str | bytes"], Path]


def test_syntax_error_exits_1_with_a_plain_report(cli_subprocess: Run, write: Write) -> None:
    path = write("quotes.hub", "scenario 'x'\n")
    outcome = cli_subprocess("check", path.name, cwd=path.parent)
    assert outcome.status == 1
    assert outcome.out == (
        "error[E002]: unexpected character \"'\"\n"
        " --> quotes.hub:1:10\n"
        "  |\n"
        "1 | scenario 'x'\n"
        "  |          ^\n"
        "  |\n"
        "  = help: strings use double quotes\n"
        "\n"
        "1 error, 0 warnings in 1 file\n")
    assert "\x1b" not in outcome.out


def test_force_color_colours_a_pipe(cli_subprocess: Run, write: Write) -> None:
    path = write("quotes.hub", "scenario 'x'\n")
    assert "\x1b[" in cli_subprocess("check", str(path), FORCE_COLOR="1").out


def test_force_color_draws_no_progress_bar_into_a_pipe(cli_subprocess: Run) -> None:
    # FORCE_COLOR colours; a progress bar is for a terminal, not for a CI log
    scenario = str(Path(__file__).resolve().parents[2] / "scenarios" / "living_room.hub")
    outcome = cli_subprocess("run", scenario, "--no-log", FORCE_COLOR="1")
    assert outcome.status == 0 and outcome.err == ""


def test_a_terminal_that_cannot_show_the_source_does_not_crash(cli_subprocess: Run,
                                                              write: Write) -> None:
    path = write("wide.hub", 'scenario "x"\nplace 食卓 (1, 2)\n')
    outcome = cli_subprocess("check", str(path), PYTHONIOENCODING="ascii")
    assert outcome.status == 1
    assert "error[E002]: unexpected character '\\u98df'" in outcome.out


def test_unreadable_input_exits_2(cli_subprocess: Run, write: Write, tmp_path: Path) -> None:
    targets = [tmp_path / "missing.hub", tmp_path, write("b.hub", b"\x00\x01\x02")]
    outcome = cli_subprocess("check", *map(str, targets))
    assert outcome.status == 2
    assert [line for line in outcome.out.splitlines() if line.startswith("error: ")] == [
        f"error: {targets[0]}: no such file",
        f"error: {targets[1]}: is a directory, not a scenario file",
        f"error: {targets[2]}: is a binary file, not a scenario"]


def test_graph_png_without_output_is_a_usage_error(cli_subprocess: Run, write: Write) -> None:
    outcome = cli_subprocess("graph", str(write("a.hub", "scenario 'x'\n")), "--format", "png")
    assert outcome.status == 2
    assert "-o" in outcome.err


def test_broken_pipe_is_quiet(write: Write) -> None:
    files = [str(write(f"f{i}.hub", "scenario 'x'\n")) for i in range(200)]
    environment = {k: v for k, v in os.environ.items() if k != "FORCE_COLOR"}
    process = subprocess.Popen([sys.executable, "-m", "hubero_dsl", "check", *files],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=environment)
    assert process.stdout is not None and process.stderr is not None
    process.stdout.close()  # the reader goes away before anything is written, as `| head` does
    err = process.stderr.read().decode()
    status = process.wait(timeout=60)
    assert "Traceback" not in err
    assert "Exception ignored" not in err
    assert status == 141


def test_a_broken_pipe_of_its_own_is_no_closed_output(tmp_path: Path) -> None:
    # a pipe to a worker that could not start, while standard output is open: said, not 141
    script = ("import hubero_dsl.cli.main as m\n"
              "def broken(argv):\n    raise BrokenPipeError(32, 'Broken pipe')\n"
              "m._dispatch = broken\nraise SystemExit(m.main(['sweep']))\n")
    with (tmp_path / "out.txt").open("w") as out:
        completed = subprocess.run([sys.executable, "-c", script], stdout=out,
                                   stderr=subprocess.PIPE, text=True, timeout=60, check=False)
    assert completed.returncode == 3
    assert "internal error: BrokenPipeError" in completed.stderr


def test_console_script_prints_the_version() -> None:
    script = Path(sys.executable).parent / "hubero"
    if not script.exists():
        pytest.skip("the console script is not installed next to this interpreter")
    completed = subprocess.run([str(script), "--version"], capture_output=True, text=True,
                               timeout=60, check=False)
    assert completed.returncode == 0
    assert completed.stdout == f"hubero {__version__}\n"
