"""`hubero` in-process: options, help, exit statuses, and no traceback whatever the input."""

from __future__ import annotations

import argparse
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from hubero_dsl import __version__
from hubero_dsl.cli import check as check_command
from hubero_dsl.cli.main import COMMANDS, build_parser
from hubero_dsl.diagnostics import Span, error, warning
from hubero_dsl.errors import CompileError, InputError
from hubero_dsl.lang import ast

Cli = Callable[..., Any]
Write = Callable[[str, "str | bytes"], Path]

SYNTAX_ERROR = "scenario 'x'\n"


def test_version(cli: Cli) -> None:
    outcome = cli("--version")
    assert outcome.status == 0
    assert outcome.out == f"hubero {__version__}\n"


@pytest.mark.parametrize("command", [(), *((name,) for name in COMMANDS)])
def test_help_for_every_command(cli: Cli, command: tuple[str, ...]) -> None:
    outcome = cli(*command, "--help")
    assert outcome.status == 0
    assert outcome.out.startswith(f"usage: hubero {' '.join(command)}".rstrip())
    assert "exit" in outcome.out.lower()  # every command says what its exit statuses mean


def test_every_command_module_has_the_command_interface() -> None:
    parser = build_parser()
    subparsers = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    assert sorted(subparsers.choices) == sorted(COMMANDS)
    for name in COMMANDS:
        assert callable(subparsers.choices[name].get_default("run"))


@pytest.mark.parametrize("argv", [(), ("frobnicate",), ("check",), ("check", "--format", "xml",
                                                                    "a.hub")])
def test_usage_errors_exit_2(cli: Cli, argv: tuple[str, ...]) -> None:
    outcome = cli(*argv)
    assert outcome.status == 2
    assert "usage: hubero" in outcome.err


# ---- check, with a fake checker: the exit status of each kind of outcome ---------------------


class FakeResult:
    def __init__(self, path: str, diagnostics: tuple[Any, ...]) -> None:
        self.source = ast.SourceFile(path, "scenario \"x\"\n")
        self.diagnostics = diagnostics


def fake_checker(monkeypatch: pytest.MonkeyPatch, **found: tuple[Any, ...]) -> None:
    def check_file(path: str) -> FakeResult:
        return FakeResult(path, found.get(Path(path).stem, ()))

    monkeypatch.setattr(check_command, "_checker", lambda: check_file)


WARNING = warning("W1", "suspicious", Span("warned.hub", 1, 1, 1, 9))
ERROR = error("E1", "wrong", Span("broken.hub", 1, 1, 1, 9))


@pytest.mark.parametrize(("files", "strict", "status"), [
    (["clean.hub"], False, 0),
    (["warned.hub"], False, 0),
    (["warned.hub"], True, 1),
    (["clean.hub", "broken.hub"], False, 1),
    (["clean.hub"], True, 0),
])
def test_check_exit_status(cli: Cli, monkeypatch: pytest.MonkeyPatch, files: list[str],
                           strict: bool, status: int) -> None:
    fake_checker(monkeypatch, warned=(WARNING,), broken=(ERROR,))
    outcome = cli("check", *files, *(["--strict"] if strict else []))
    assert outcome.status == status
    summary = outcome.out.splitlines()[-1]
    assert f" in {len(files)} file" in summary
    assert ("--strict" in summary) == (strict and status == 1)


def test_check_reports_every_file_before_exiting(cli: Cli, write: Write) -> None:
    first, second = write("a.hub", SYNTAX_ERROR), write("b.hub", SYNTAX_ERROR)
    missing = first.parent / "missing.hub"
    outcome = cli("check", str(first), str(missing), str(second))
    assert outcome.status == 2
    assert outcome.out.count("error[E002]") == 2
    assert f"error: {missing}: no such file" in outcome.out
    assert outcome.out.splitlines()[-1] == "2 errors, 0 warnings in 3 files; 1 could not be read"


def test_check_json_is_one_document(cli: Cli, write: Write) -> None:
    import json

    outcome = cli("check", "--format", "json", str(write("a.hub", SYNTAX_ERROR)))
    document = json.loads(outcome.out)
    assert outcome.status == 1
    assert document["summary"]["errors"] == 1
    assert document["files"][0]["diagnostics"][0]["code"] == "E002"


def test_check_github_format(cli: Cli, write: Write) -> None:
    path = write("a.hub", SYNTAX_ERROR)
    outcome = cli("check", "--format", "github", str(path))
    first = outcome.out.splitlines()[0]
    assert first.startswith("::error file=")
    assert ",line=1,col=10,endLine=1,endColumn=11,title=E002::unexpected character" in first


# ---- unreadable or hostile input ----------------------------------------------------------


@pytest.mark.parametrize(("name", "content", "status", "says"), [
    ("latin1.hub", b'scenario "caf\xe9"\n', 2, "invalid UTF-8"),
    ("binary.hub", bytes(range(256)) * 4, 2, "binary"),
    ("huge.hub", b"# " + b"x" * 10_000_000 + b"\n", 2, "MB"),
    ("deep.hub", b'scenario "x"\nexpect ' + b"(" * 100_000 + b"\n", 1, "E003"),
])
def test_bad_input_gives_a_clean_message(cli: Cli, write: Write, name: str, content: bytes,
                                         status: int, says: str) -> None:
    outcome = cli("check", str(write(name, content)))
    assert outcome.status == status
    assert says in outcome.out


def test_directory_and_missing_file_exit_2(cli: Cli, tmp_path: Path) -> None:
    assert cli("check", str(tmp_path)).status == 2
    assert cli("check", str(tmp_path / "nope.hub")).status == 2


# ---- the top-level handler ------------------------------------------------------------------


def raising_command(monkeypatch: pytest.MonkeyPatch, exception: BaseException) -> None:
    def run(args: argparse.Namespace) -> int:
        raise exception

    monkeypatch.setattr(check_command, "run", run)


def test_internal_error_is_reported_without_a_traceback(cli: Cli,
                                                        monkeypatch: pytest.MonkeyPatch) -> None:
    raising_command(monkeypatch, RuntimeError("boom"))
    outcome = cli("check", "a.hub")
    assert outcome.status == 3
    assert "internal error: RuntimeError: boom (please report)" in outcome.err
    assert "HUBERO_DEBUG=1" in outcome.err


def test_hubero_debug_shows_the_traceback(monkeypatch: pytest.MonkeyPatch,
                                          capsys: pytest.CaptureFixture[str]) -> None:
    from hubero_dsl.cli.main import main

    raising_command(monkeypatch, RuntimeError("boom"))
    monkeypatch.setenv("HUBERO_DEBUG", "1")
    assert main(["check", "a.hub"]) == 3
    err = capsys.readouterr().err
    assert "Traceback" in err and "RuntimeError: boom" in err


def test_interrupt_exits_130(cli: Cli, monkeypatch: pytest.MonkeyPatch) -> None:
    raising_command(monkeypatch, KeyboardInterrupt())
    outcome = cli("check", "a.hub")
    assert outcome.status == 130
    assert outcome.err == "hubero: interrupted\n"


def test_input_error_from_a_command_exits_2(cli: Cli, monkeypatch: pytest.MonkeyPatch) -> None:
    raising_command(monkeypatch, InputError("maps/x.yaml: no such file", hint="check the path"))
    outcome = cli("check", "a.hub")
    assert outcome.status == 2
    assert outcome.err.startswith("error: maps/x.yaml: no such file\n")
    assert "= help: check the path" in outcome.err


def test_compile_error_from_a_command_is_rendered(cli: Cli, monkeypatch: pytest.MonkeyPatch,
                                                  write: Write) -> None:
    path = write("a.hub", "speed 5 kg\n")
    diagnostic = error("E104", "unknown unit 'kg'", Span(str(path), 1, 9, 1, 11))
    raising_command(monkeypatch, CompileError([diagnostic]))
    outcome = cli("check", "a.hub")
    assert outcome.status == 1
    assert outcome.err.splitlines()[:5] == [
        "error[E104]: unknown unit 'kg'", f" --> {path}:1:9", "  |", "1 | speed 5 kg",
        "  |         ^^"]


def run_main_as_module(tmp_path: Path, dispatch: str) -> subprocess.CompletedProcess[str]:
    """`python -m` a module that runs `main` with `_dispatch` as `dispatch` (its source) says:
    how CPython ends such a process is what is tested, so it runs as a user's would."""
    (tmp_path / "patched_main.py").write_text(
        "import time, weakref\n"
        "from hubero_dsl.cli import main as cli\n"
        f"{dispatch}\n"
        "cli._dispatch = dispatch\n"
        "raise SystemExit(cli.main(['check', 'a.hub']))\n", encoding="utf-8")
    return subprocess.run([sys.executable, "-m", "patched_main"], cwd=tmp_path,
                          capture_output=True, text=True, timeout=60)


def test_an_interrupt_inside_an_imported_exec_still_exits_130(tmp_path: Path) -> None:
    # numpy's imports `exec` a string: a Ctrl-C during them passes through it, and CPython
    # then ended `python -m ...` by killing itself with SIGINT (-2) instead of exiting 130
    outcome = run_main_as_module(tmp_path, "def dispatch(argv):\n"
                                           "    exec('raise KeyboardInterrupt')")
    assert outcome.returncode == 130, outcome.stderr
    assert outcome.stderr == "hubero: interrupted\n"


@pytest.mark.parametrize(("interrupt", "in_a_sweep"), [
    # Python runs the Ctrl-C handler wherever the main thread is: in a weak reference's
    # callback its KeyboardInterrupt was printed as "Exception ignored" and the command went on
    ("raise KeyboardInterrupt", False),
    # a sweep hears one stop only: the first, raised in a callback and lost there, made the
    # stop sent again go unheard, and the sweep ran on
    ("os.kill(os.getpid(), signal.SIGINT)", True),
], ids=["raised", "sent-during-a-sweep"])
def test_an_interrupt_raised_in_a_callback_is_not_lost(tmp_path: Path, interrupt: str,
                                                       in_a_sweep: bool) -> None:
    waiting = ["held = Held()", "reference = weakref.ref(held, interrupt)", "del held",
               "time.sleep(30)"]
    if in_a_sweep:
        waiting = ["with stopped_once():", *(f"    {line}" for line in waiting)]
    outcome = run_main_as_module(tmp_path, "import os, signal\n"
                                           "from hubero_dsl.sweep.executors import stopped_once\n"
                                           "class Held: pass\n"
                                           f"def interrupt(reference): {interrupt}\n"
                                           "def dispatch(argv):\n"
                                           + "".join(f"    {line}\n" for line in waiting)
                                           + "    return 0")
    assert outcome.returncode == 130, outcome.stderr
    assert outcome.stderr == "hubero: interrupted\n"


def test_a_stop_pressed_again_as_a_stopped_command_ends_keeps_its_status(
        tmp_path: Path) -> None:
    # Ctrl-C pressed again while the stopped process ended killed it with SIGINT (-2)
    (tmp_path / "ending.py").write_text(
        "import os, signal\n"
        "from hubero_dsl.cli import main as cli\n"
        "def dispatch(argv):\n"
        "    raise KeyboardInterrupt\n"
        "cli._dispatch = dispatch\n"
        "status = cli.program()\n"
        "os.kill(os.getpid(), signal.SIGINT)\n"
        "raise SystemExit(status)\n", encoding="utf-8")
    outcome = subprocess.run([sys.executable, "-m", "ending"], cwd=tmp_path,
                             capture_output=True, text=True, timeout=60)
    assert outcome.returncode == 130, outcome.stderr
    assert outcome.stderr == "hubero: interrupted\n"


def test_an_unknown_option_is_told_with_its_commands_usage(cli: Cli) -> None:
    outcome = cli("check", "a.hub", "--bogus")
    assert outcome.status == 2
    assert "usage: hubero check" in outcome.err
    assert "hubero check: error: unrecognized arguments: --bogus" in outcome.err


@pytest.mark.parametrize("argv", [("run", "a.hub", "-o"), ("graph", "a.hub", "-o"),
                                  ("test", "a.hub", "--junit-xml")])
def test_an_output_named_empty_is_refused_as_naming_no_file(cli: Cli,
                                                            argv: tuple[str, ...]) -> None:
    # graph and test said ".: cannot be written (it is a directory)"
    outcome = cli(*argv, "")
    assert outcome.status == 2 and "'' names no file: give a file name" in outcome.err


def test_a_file_named_twice_is_checked_once(cli: Cli, tmp_path: Path,
                                            monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    Path("a.hub").write_text(SYNTAX_ERROR, encoding="utf-8")
    outcome = cli("check", "a.hub", "./a.hub", str(tmp_path / "a.hub"))
    assert outcome.status == 1 and outcome.out.count("error[E") == 1
    assert outcome.out.rstrip().endswith("1 error, 0 warnings in 1 file")
