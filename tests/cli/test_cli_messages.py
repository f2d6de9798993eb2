"""Messages a new user meets: quiet runs that fail, classic Mac line endings, output to pipes
and files, and files with hundreds of errors."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pytest

from tests.cli.conftest import Outcome

ROOM = Path(__file__).resolve().parents[1] / "hostile" / "room.yaml"


def _scenario(folder: Path, body: str, name: str = "s.hub", newline: str = "\n") -> str:
    text = f'scenario "s"\nmap "{ROOM}"\nhuman a at (1, 1)\n{body}'
    path = folder / name
    path.write_bytes(text.replace("\n", newline).encode())
    return str(path)


def test_quiet_hides_progress_not_failures(cli: Callable[..., Outcome], tmp_path: Path) -> None:
    path = _scenario(tmp_path, "time_limit 1 s\nactivity { a stand for 5 s }\n"
                               "expect a reaches (5, 5) eventually\n")
    outcome = cli("run", path, "--quiet", "--no-log")
    assert outcome.status == 1 and outcome.out == ""
    assert "timed_out at t = 1.00 s: time limit of 1 s reached" in outcome.err
    assert "expectation fails: a reaches (5, 5) eventually" in outcome.err
    passed = cli("run", _scenario(tmp_path, "activity { a stand for 0.2 s }\n", "ok.hub"),
                 "--quiet", "--no-log")
    assert (passed.status, passed.out, passed.err) == (0, "", "")


def test_classic_mac_line_endings_read_as_lines(cli: Callable[..., Outcome],
                                                tmp_path: Path) -> None:
    body = "activity { a stand for 1 s }\nactivity { a sit_dwn for 1 s }\n"
    unix = cli("check", _scenario(tmp_path, body, "unix.hub"))
    mac = cli("check", _scenario(tmp_path, body, "mac.hub", newline="\r"))
    assert mac.status == unix.status == 1
    assert mac.out.replace("mac.hub", "unix.hub") == unix.out
    assert "unix.hub:5:14" in unix.out


def test_output_to_a_pipe_is_neither_wrapped_nor_cut(cli: Callable[..., Outcome],
                                                     tmp_path: Path) -> None:
    long_area = "rect((0.5, 0.5), (9.5, 7.5)) and a in rect((0.6, 0.6), (9.4, 7.4))"
    path = _scenario(tmp_path, "activity { a stand for 0.2 s }\n"
                               f"expect a in {long_area} always\n")
    outcome = cli("test", path)
    assert outcome.status == 0
    assert any(len(line) > 100 and long_area in line for line in outcome.out.splitlines()) or \
        "1 passed, 0 failed" in outcome.out
    ran = cli("run", path, "--no-log")
    assert f"a in {long_area} always" in ran.out  # the table cell on one line, whole


def test_hundreds_of_errors_are_cut_to_the_first_fifty(cli: Callable[..., Outcome],
                                                       tmp_path: Path) -> None:
    # on one spot: besides the 456 errors, W504 names ten overlapping pairs and counts the rest
    body = "".join(f"human h{i} at (1, 1) {{ sped 1 m/s }}\n" for i in range(456))
    outcome = cli("check", _scenario(tmp_path, body))
    assert outcome.status == 1
    assert outcome.out.count("unknown parameter 'sped'") + outcome.out.count("[W504]") == 50
    assert "... and " in outcome.out and "more in" in outcome.out
    listed = cli("check", "--format", "json", _scenario(tmp_path, body, "j.hub"))
    assert listed.out.count('"unknown parameter \'sped\'"') == 456


def test_control_characters_never_reach_the_terminal(cli: Callable[..., Outcome],
                                                     tmp_path: Path) -> None:
    evil = tmp_path / "evil.hub"
    evil.write_text('scenario "evil \x1b[2J\x1b]0;pwned\x07 title"\nmap "x.yaml"\n',
                    encoding="utf-8")
    outcome = cli("check", str(evil))
    assert outcome.status == 1
    assert "E002" in outcome.out and "control character U+001B" in outcome.out
    assert "evil.hub:1:16" in outcome.out
    assert "\x1b" not in outcome.out + outcome.err and "\x07" not in outcome.out + outcome.err
    missing = cli("check", str(tmp_path / "no\x1b[31mred.hub"))
    assert missing.status == 2 and "\x1b" not in missing.out + missing.err


@pytest.mark.parametrize(("value", "shown"), [(-0.004, "0.00 m"), (0.004, "0.00 m"),
                                              (-0.13, "-0.13 m"), (float("inf"), "-")])
def test_a_gap_that_rounds_to_zero_reads_zero_not_minus_zero(value: float, shown: str) -> None:
    # "min distance -0.00 m" in the summary of a robot touching a person
    from hubero_dsl.cli.summary import _finite

    assert _finite(value, "m") == shown
