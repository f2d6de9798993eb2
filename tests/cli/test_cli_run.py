"""`hubero run` and `hubero test`: exit statuses, summaries, interruption."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import junitparser
import pytest

from tests.cli.conftest import REPO_ROOT, Outcome

LIVING_ROOM = str(REPO_ROOT / "scenarios" / "living_room.hub")
MAP = REPO_ROOT / "maps" / "living_room.yaml"


def scenario(tmp_path: Path, body: str) -> str:
    path = tmp_path / "s.hub"
    path.write_text(f'scenario "t"\nmap "{MAP}"\nhuman a at (1, 1)\n{body}', encoding="utf-8")
    return str(path)


def test_run_prints_a_summary_and_exits_0(cli: Callable[..., Outcome]) -> None:
    outcome = cli("run", LIVING_ROOM, "--variant", "ellipse")
    assert outcome.status == 0
    assert "completed" in outcome.out and "actor1" in outcome.out and "SUCCEEDED" in outcome.out
    assert "holds" in outcome.out


def test_all_variants_and_quiet(cli: Callable[..., Outcome]) -> None:
    outcome = cli("run", LIVING_ROOM, "--all-variants", "--quiet")
    assert outcome.status == 0
    assert outcome.out == ""


def test_a_failing_expectation_exits_1(cli: Callable[..., Outcome], tmp_path: Path) -> None:
    path = scenario(tmp_path, "activity { a stand for 1 s }\nexpect time > 5 s eventually\n")
    outcome = cli("run", path)
    assert outcome.status == 1
    assert "FAILS" in outcome.out


def test_a_timed_out_run_exits_1(cli: Callable[..., Outcome], tmp_path: Path) -> None:
    outcome = cli("run", scenario(tmp_path, "time_limit 1 s\nactivity { a stand for 5 s }\n"))
    assert outcome.status == 1
    assert "timed_out" in outcome.out and "time limit" in outcome.out


def test_an_aborted_task_exits_1_with_the_reason(cli: Callable[..., Outcome],
                                                 tmp_path: Path) -> None:
    outcome = cli("run", scenario(tmp_path, "activity { a move_to (3, 1) within 0.5 s }\n"))
    assert outcome.status == 1
    assert "within 0.5 s" in outcome.out


def test_bad_input_exits_2_or_1(cli: Callable[..., Outcome], tmp_path: Path) -> None:
    assert cli("run", str(tmp_path / "missing.hub")).status == 2
    assert cli("run", LIVING_ROOM, "--variant", "nope").status == 2
    assert "unknown variant 'nope'" in cli("run", LIVING_ROOM, "--variant", "nope").err
    assert cli("run", LIVING_ROOM, "--log-rate", "0").status == 2
    negative = cli("run", LIVING_ROOM, "--seed", "-3")
    assert negative.status == 2 and "invalid seed '-3'" in negative.err
    huge = cli("run", LIVING_ROOM, "--seed", "9" * 5000)  # as many digits as a sweep takes
    assert huge.status == 2 and "(5000 characters)': give a whole number from 0 on, of at " \
        "most 18 digits" in huge.err and len(huge.err) < 1000
    broken = cli("run", scenario(tmp_path, "activity { a move_to nowhere }\n"))
    assert broken.status == 1 and "unknown" in broken.err


def test_seed_changes_a_wandering_run(cli: Callable[..., Outcome], tmp_path: Path) -> None:
    path = scenario(tmp_path, "activity { a move_around for 5 s }\n")
    first, again, other = (cli("run", path, "--seed", s) for s in ("1", "1", "2"))
    assert first.out == again.out
    assert first.out != other.out


def test_run_writes_its_log_to_runs_by_default(cli: Callable[..., Outcome],
                                               tmp_path: Path) -> None:
    outcome = cli("run", LIVING_ROOM, "--variant", "circle")
    log = Path("runs") / "living_room-circle.mcap"
    assert outcome.status == 0 and f"log written to {log}" in outcome.out
    assert log.read_bytes().startswith(b"\x89MCAP0\r\n")
    assert cli("run", LIVING_ROOM, "--variant", "circle", "--no-log").status == 0
    Path("runs/living_room.mcap").write_text("my notes")  # not a log: never written over
    refused = cli("run", LIVING_ROOM, "--quiet")
    assert refused.status == 2 and "is not an MCAP log" in refused.err
    assert Path("runs/living_room.mcap").read_text() == "my notes"


def test_o_and_out_dir_never_write_over_a_file_that_is_not_a_log(
        cli: Callable[..., Outcome], tmp_path: Path) -> None:
    notes = tmp_path / "data.csv"
    notes.write_text("precious data")
    refused = cli("run", LIVING_ROOM, "--variant", "circle", "-o", str(notes), "-q")
    assert refused.status == 2 and f"{notes} exists and is not an MCAP log" in refused.err
    assert notes.read_text() == "precious data"
    out = tmp_path / "out"
    out.mkdir()
    (out / "circle.mcap").write_text("junk")
    refused = cli("run", LIVING_ROOM, "--all-variants", "--out-dir", str(out), "-q")
    assert refused.status == 2 and "is not an MCAP log" in refused.err
    assert (out / "circle.mcap").read_text() == "junk"
    log = tmp_path / "run.mcap"  # a log is written over: a run again
    assert cli("run", LIVING_ROOM, "--variant", "circle", "-o", str(log), "-q").status == 0
    assert cli("run", LIVING_ROOM, "--variant", "circle", "-o", str(log), "-q").status == 0


def test_o_never_writes_over_another_tools_mcap_file(cli: Callable[..., Outcome],
                                                     tmp_path: Path) -> None:
    from mcap.writer import Writer

    bag = tmp_path / "bag.mcap"  # a ROS 2 bag, say: an MCAP file, but no run's log
    with bag.open("wb") as stream:
        writer = Writer(stream)
        writer.start(profile="ros2")
        writer.finish()
    kept = bag.read_bytes()
    refused = cli("run", LIVING_ROOM, "--variant", "circle", "-o", str(bag), "-q")
    assert refused.status == 2
    assert f"{bag} is an MCAP file but not a hubero run log: not writing over it" in refused.err
    assert bag.read_bytes() == kept


def test_o_with_a_trailing_slash_names_a_folder_not_a_file(cli: Callable[..., Outcome],
                                                          tmp_path: Path) -> None:
    refused = cli("run", LIVING_ROOM, "-o", f"{tmp_path / 'outdir'}/", "-q")
    assert refused.status == 2 and "names no file: give a file name" in refused.err
    assert not (tmp_path / "outdir").exists()


def test_hubero_test_reports_a_file_that_does_not_compile_and_runs_the_others(
        cli: Callable[..., Outcome], tmp_path: Path) -> None:
    broken = tmp_path / "broken.hub"
    broken.write_text(f'scenario "t"\nmap "{MAP}"\nhuman a at (1, 1)\n'
                      "activity { a move_to nowhere }\n", encoding="utf-8")
    outcome = cli("test", str(broken), LIVING_ROOM)
    assert outcome.status == 1
    assert "broken.hub:4:" in outcome.err and "unknown" in outcome.err
    assert f"ERROR {broken}: does not compile" in outcome.out
    assert outcome.out.rstrip().endswith("2 passed, 1 failed")
    missing = cli("test", str(tmp_path / "missing.hub"), LIVING_ROOM)
    assert missing.status == 2 and "2 passed, 1 failed" in missing.out
    assert f"ERROR {tmp_path / 'missing.hub'}: cannot be read" in missing.out


def test_hubero_test_reports_a_file_its_handed_controller_refuses_and_runs_the_others(
        cli: Callable[..., Outcome], tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # the cart's file sets `navigator.safety_margin`, which the class handed over does not
    # declare: the whole command stopped (exit 2), before the other files, with no report
    (tmp_path / "go_straight.py").write_text(
        "from pydantic import Field\n"
        "from hubero_dsl.controllers.base import ControllerParams\n"
        "class Params(ControllerParams):\n    gain: float = Field(default=1.0, gt=0)\n"
        "class GoStraight:\n    Params = Params\n"
        "    def __init__(self, body, params):\n        self.gain = params.gain\n"
        "    def command(self, observation):\n        return (0.0, 0.0)\n", encoding="utf-8")
    monkeypatch.syspath_prepend(str(tmp_path))
    guests = str(REPO_ROOT / "scenarios" / "robot_among_guests.hub")
    report = tmp_path / "report.xml"
    outcome = cli("test", guests, LIVING_ROOM, "--controller", "cart=go_straight:GoStraight",
                  "--junit-xml", str(report))
    assert outcome.status == 1
    refusal = ("robot 'cart': controller GoStraight does not take the scenario's "
               "`navigator.safety_margin` (declare safety_margin in GoStraight.Params, or "
               "leave it out)")
    assert f"ERROR {guests}: does not fit the controller\n" in outcome.out
    assert "robot_among_guests.hub:17:1" in outcome.err and refusal in outcome.err
    assert outcome.out.rstrip().endswith("2 passed, 1 failed")
    read = junitparser.JUnitXml.fromfile(str(report))
    assert (read.tests, read.failures, read.errors) == (3, 0, 1)
    cases = {(suite.name, case.name): case for suite in read for case in suite}
    assert set(cases) == {(guests, "(does not fit the controller)"), (LIVING_ROOM, "circle"),
                          (LIVING_ROOM, "ellipse")}
    (error,) = cases[guests, "(does not fit the controller)"].result
    assert isinstance(error, junitparser.Error)
    assert error.text == f"{guests}:17:1: {refusal}"
    sys.modules.pop("go_straight", None)


def test_a_controllers_answer_of_a_number_too_long_to_show_is_told_by_its_length(
        cli: Callable[..., Outcome], tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # the message was cut off in the middle of the number: `returned (1000...000, not a`
    (tmp_path / "huge_answer.py").write_text(
        "class Huge:\n    def __init__(self, body, params):\n        pass\n"
        "    def command(self, observation):\n        return (10 ** 400, 0)\n",
        encoding="utf-8")
    monkeypatch.syspath_prepend(str(tmp_path))
    outcome = cli("run", str(REPO_ROOT / "scenarios" / "robot_among_guests.hub"), "--no-log",
                  "--controller", "cart=huge_answer:Huge")
    assert outcome.status == 1
    assert ("robot 'cart' at t = 0 s: its controller Huge returned (a whole number of 401 "
            "digits, 0), not a velocity (two finite numbers)") in outcome.err
    sys.modules.pop("huge_answer", None)


def test_hubero_test_judges_every_variant(cli: Callable[..., Outcome], tmp_path: Path) -> None:
    outcome = cli("test", LIVING_ROOM)
    assert outcome.status == 0
    assert "2 passed, 0 failed" in outcome.out
    failing = scenario(tmp_path, "activity { a stand for 1 s }\nexpect time > 5 s eventually\n")
    outcome = cli("test", LIVING_ROOM, failing)
    assert outcome.status == 1
    assert "2 passed, 1 failed" in outcome.out
    assert "expectation fails: time > 5 s eventually" in outcome.out


def test_hubero_test_writes_a_junit_report_its_readers_read(
        cli: Callable[..., Outcome], tmp_path: Path) -> None:
    failing = scenario(tmp_path, "activity { a stand for 1 s }\nexpect time > 5 s eventually\n")
    broken = tmp_path / "broken.hub"
    broken.write_text(f'scenario "t"\nmap "{MAP}"\nactivity {{ b stand for 1 s }}\n',
                      encoding="utf-8")
    report = tmp_path / "report.xml"
    outcome = cli("test", LIVING_ROOM, failing, str(broken), "--junit-xml", str(report))
    assert outcome.status == 1
    read = junitparser.JUnitXml.fromfile(str(report))
    assert (read.tests, read.failures, read.errors) == (4, 1, 1)
    cases = {(suite.name, case.name): case for suite in read for case in suite}
    assert set(cases) == {(LIVING_ROOM, "circle"), (LIVING_ROOM, "ellipse"),
                          (failing, "as written"), (str(broken), "(does not compile)")}
    assert cases[LIVING_ROOM, "circle"].is_passed
    (failure,) = cases[failing, "as written"].result
    assert isinstance(failure, junitparser.Failure)
    assert "expectation fails: time > 5 s eventually" in failure.text
    (error,) = cases[str(broken), "(does not compile)"].result
    assert isinstance(error, junitparser.Error) and "unknown human 'b'" in error.text
    again = cli("test", LIVING_ROOM, "--junit-xml", str(report))  # its own report it replaces
    assert again.status == 0 and junitparser.JUnitXml.fromfile(str(report)).tests == 2


def test_a_report_holds_any_name_and_a_variant_may_be_called_read(
        cli: Callable[..., Outcome], tmp_path: Path) -> None:
    # a variant named `read` was taken for a file that could not be read (exit 2); a file
    # name with a control character or a byte that is not UTF-8 made the report unreadable
    odd = tmp_path / "caf\udce9 \x1b[31m.hub"
    odd.write_text(f'scenario "t"\nmap "{MAP}"\nhuman a at (1, 1)\n'
                   "variant read { speed 1.2 m/s }\nactivity { a stand for 1 s }\n",
                   encoding="utf-8")
    report = tmp_path / "report.xml"
    outcome = cli("test", str(odd), "--junit-xml", str(report))
    assert outcome.status == 0, outcome.out + outcome.err
    (suite,) = junitparser.JUnitXml.fromfile(str(report))
    assert suite.name == str(odd).replace("\udce9", "\\udce9").replace("\x1b", "\\x1b")
    assert [case.name for case in suite] == ["read"]


def test_hubero_test_never_writes_its_report_over_another_file(
        cli: Callable[..., Outcome], tmp_path: Path) -> None:
    notes = tmp_path / "notes.xml"
    notes.write_text("<?xml version='1.0'?><project/>", encoding="utf-8")
    refused = cli("test", LIVING_ROOM, "--junit-xml", str(notes))
    assert refused.status == 2 and "not a JUnit XML report of hubero test" in refused.err
    assert notes.read_text(encoding="utf-8") == "<?xml version='1.0'?><project/>"
    over_input = cli("test", LIVING_ROOM, "--junit-xml", LIVING_ROOM)
    assert over_input.status == 2 and "PASS" not in over_input.out  # refused before any run
    nowhere = cli("test", LIVING_ROOM, "--junit-xml", str(tmp_path / "no" / "r.xml"))
    assert nowhere.status == 2 and "does not exist" in nowhere.err


def test_ctrl_c_during_a_run_stops_cleanly(tmp_path: Path) -> None:
    path = scenario(tmp_path, "time_limit 2 h\nactivity { a move_around for 1 h }\n")
    process = subprocess.Popen([sys.executable, "-m", "hubero_dsl", "run", path, "--quiet"],
                               cwd=tmp_path,
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                               env={**os.environ, "HUBERO_DEBUG": ""})
    time.sleep(2.5)
    process.send_signal(signal.SIGINT)
    out, err = process.communicate(timeout=30)
    assert process.returncode == 130
    assert "interrupted" in err
    assert "Traceback" not in out + err


def test_a_closed_pipe_is_reported_as_for_every_command(tmp_path: Path) -> None:
    # two runs: the second's summary is written after `head` has read a line and gone
    command = f'"{sys.executable}" -m hubero_dsl run "{LIVING_ROOM}" --all-variants | head -1'
    completed = subprocess.run(["bash", "-c", command + "; echo ${PIPESTATUS[0]}"],
                               capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert completed.stdout.splitlines()[-1] == "141"
    assert "Traceback" not in completed.stderr


def test_the_summary_has_a_row_per_crowd_or_every_member_with_members(
        cli: Callable[..., Outcome]) -> None:
    scenario = str(REPO_ROOT / "scenarios" / "lounge_crowd.hub")
    grouped = cli("run", scenario, "--no-log")
    assert "visitors (crowd)" in grouped.out and "visitors_1 " not in grouped.out
    listed = cli("run", scenario, "--no-log", "--members")
    assert "visitors_1 " in listed.out and "visitors (crowd)" not in listed.out
    assert cli("test", scenario, "--members").status == 2  # a summary option of run only


def test_hubero_test_checks_its_options_against_every_file_before_running_any(
        cli: Callable[..., Outcome], tmp_path: Path) -> None:
    plain = scenario(tmp_path, "activity { a stand for 1 s }\n")
    variant = cli("test", LIVING_ROOM, plain, "--variant", "circle")
    assert variant.status == 2
    assert (f"{plain}: unknown variant 'circle' (variants: none (this scenario has no "
            "variants))") in variant.err
    assert "PASS" not in variant.out
    robot = cli("test", LIVING_ROOM, "--controller",
                "robot9=tests.sweep.bench_controllers:Raising")
    assert robot.status == 2
    assert "--controller: no robot named 'robot9' in any of the files" in robot.err
    assert "PASS" not in robot.out


def test_members_lists_a_flows_people_who_came_only(cli: Callable[..., Outcome],
                                                    tmp_path: Path) -> None:
    path = tmp_path / "flow.hub"
    path.write_text(f'scenario "f"\nmap "{REPO_ROOT / "maps" / "parking.yaml"}"\nseed 2\n'
                    "time_limit 40 s\nflow walkers from rect((14, 0), (16, 3)) to (12.0, 7.0) "
                    "rate 20 /min for 10 s\n", encoding="utf-8")
    listed = cli("run", str(path), "--no-log", "--members")
    assert listed.status == 0, listed.err
    rows = [line for line in listed.out.splitlines() if "walkers_" in line]
    assert rows and all("SUCCEEDED" in row for row in rows)  # none of those who never came


def test_hubero_test_runs_a_file_named_twice_once(cli: Callable[..., Outcome]) -> None:
    twice = cli("test", LIVING_ROOM, str(Path(LIVING_ROOM).parent / "." / "living_room.hub"))
    once = cli("test", LIVING_ROOM)
    assert twice.status == once.status == 0
    assert twice.out.rstrip().splitlines()[-1] == once.out.rstrip().splitlines()[-1] == (
        "2 passed, 0 failed")  # its two variants


def test_a_robot_nobody_came_near_shows_no_distance(cli: Callable[..., Outcome],
                                                    tmp_path: Path) -> None:
    path = tmp_path / "alone.hub"
    path.write_text(f'scenario "t"\nmap "{MAP}"\nrobot r at (1, 1) {{ controller navigator }}\n'
                    "activity { r stand for 1 s }\n", encoding="utf-8")
    outcome = cli("run", str(path), "--no-log")
    assert outcome.status == 0
    metrics = outcome.out.split("robots among people")[1]
    row = next(line for line in metrics.splitlines() if line.strip("│ ").startswith("r "))
    assert "inf" not in row and row.split("│")[2].strip() == "-"


def test_tasks_a_failure_stopped_before_they_started_are_counted_and_pending(
        cli: Callable[..., Outcome], tmp_path: Path) -> None:
    path = tmp_path / "stopped.hub"
    path.write_text(
        f'scenario "t"\nmap "{REPO_ROOT / "maps" / "station.yaml"}"\n'
        "area hall rect((2.0, 2.0), (12.0, 12.0))\n"
        "human h at (5.0, 5.0)\nhuman g at (6.0, 5.0)\nhuman k at (7.0, 5.0)\n"
        "human m at (8.0, 5.0)\ncrowd c 2 in hall\n"
        "activity one { h move_to (3.0, 18.0) }\n"  # behind the walls: aborted at t = 0
        "activity two { g stand for 3 s }\n"
        "activity three { c stand for 3 s }\n"
        "activity four { parallel {\n k stand for 3 s\n m stand for 3 s\n } }\n",
        encoding="utf-8")

    def rows(outcome: Outcome) -> dict[str, list[str]]:
        cells = [[c.strip() for c in line.split("│")[1:-1]] for line in outcome.out.splitlines()
                 if line.startswith("│")]
        return {row[0]: row[1:] for row in cells}

    grouped = cli("run", str(path), "--no-log")
    assert grouped.status == 1 and "failed at t = 0.00 s" in grouped.out
    humans = rows(grouped)
    assert humans["h"][:2] == ["0/1", "ABORTED"] and humans["g"][:2] == ["0/1", "ACTIVE"]
    assert humans["k"][:2] == humans["m"][:2] == ["0/1", "PENDING"]
    assert humans["c (crowd)"][:3] == ["2", "0/2", "2 PENDING"]
    members = rows(cli("run", str(path), "--no-log", "--members"))
    assert members["c_1"][:2] == members["c_2"][:2] == ["0/1", "PENDING"]
