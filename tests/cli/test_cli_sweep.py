"""`hubero sweep`: exit statuses, variant selection, bad input, Dask, Ctrl-C."""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import pytest

from tests.cli.conftest import REPO_ROOT, Outcome, assert_no_traceback
from tests.sweep.conftest import OUTCOMES as OUTCOMES_TEMPLATE
from tests.sweep.conftest import wandering

MAP = REPO_ROOT / "maps" / "living_room.yaml"
Run = Callable[..., Outcome]

SWEPT = f"""\
scenario "sweep"
map "{MAP}"
seed 3
human a at (1, 1)
sweep speed in [1.0 m/s, 1.4 m/s]
activity {{ a move_to (2, 1) }}
"""
OUTCOMES = OUTCOMES_TEMPLATE.format(map=MAP)
PLAIN = f"""\
scenario "plain"
map "{MAP}"
seed 9
human a at (1, 1)
activity {{ a stand for 1 s }}
"""
LONG = wandering(MAP, 15)


def scenario(tmp_path: Path, text: str) -> str:
    path = tmp_path / "s.hub"
    path.write_text(text, encoding="utf-8")
    return str(path)


def index(folder: Path) -> dict:  # type: ignore[type-arg]
    loaded: dict = json.loads((folder / "index.json").read_text(encoding="utf-8"))  # type: ignore[type-arg]
    return loaded


def test_a_sweep_that_succeeds_exits_0(cli_subprocess: Run, tmp_path: Path) -> None:
    out = tmp_path / "out"
    outcome = cli_subprocess("sweep", scenario(tmp_path, SWEPT), "--seeds", "1..2",
                             "--jobs", "2", "--out-dir", str(out))
    assert outcome.status == 0, outcome.err
    assert outcome.err == ""  # no progress bar off a terminal, no problems
    assert "speed=1.0 m/s" in outcome.out and "4 runs on 2 processes in" in outcome.out
    runs = index(out)["runs"]
    assert [(r["variant"], r["seed"], r["status"]) for r in runs] == [
        ("speed=1.0 m/s", 1, "completed"), ("speed=1.0 m/s", 2, "completed"),
        ("speed=1.4 m/s", 1, "completed"), ("speed=1.4 m/s", 2, "completed")]
    assert all((out / r["log"]).is_file() for r in runs)
    assert (out / "index.csv").read_text().count("\n") == 5


def test_failed_runs_exit_1_and_are_reported(cli_subprocess: Run, tmp_path: Path) -> None:
    out = tmp_path / "out"
    outcome = cli_subprocess("sweep", scenario(tmp_path, OUTCOMES), "--executor", "serial",
                             "--out-dir", str(out), "--quiet")
    assert outcome.status == 1
    assert outcome.out == ""
    assert outcome.err.splitlines() == [
        "late seed 0: expectations fail: a reaches (2, 1) within 1.5 s",
        "slow seed 0: timed out: time limit of 3 s reached"]
    assert [r["status"] for r in index(out)["runs"]] == ["completed", "completed", "timed_out"]


def test_variants_with_commas_are_chosen_by_name(cli: Run, tmp_path: Path) -> None:
    path = scenario(tmp_path, SWEPT)
    one = tmp_path / "one"
    assert cli("sweep", path, "--variant", "speed=1.4 m/s", "--executor", "serial",
               "--out-dir", str(one), "-q").status == 0
    assert [r["variant"] for r in index(one)["runs"]] == ["speed=1.4 m/s"]
    both = tmp_path / "both"
    assert cli("sweep", path, "--variants", "speed=1.4 m/s;speed=1.0 m/s", "--executor",
               "serial", "--out-dir", str(both), "-q").status == 0
    assert [r["variant"] for r in index(both)["runs"]] == ["speed=1.0 m/s", "speed=1.4 m/s"]


def test_a_sweep_into_an_earlier_ones_folder_leaves_only_its_own_logs(cli: Run,
                                                                     tmp_path: Path) -> None:
    # seeds 0, then 1 and 2, then 1: the index named seed-1 only, and seed-0 and seed-2 stayed
    out = tmp_path / "out"
    file = scenario(tmp_path, PLAIN)
    for seeds in ("0", "1,2", "1"):
        assert cli("sweep", file, "--seeds", seeds, "--out-dir", str(out), "-q").status == 0
        if seeds == "1,2":  # a log of the user's own in the folder, which no index names
            mine = out / "runs" / "mine.mcap"
            mine.write_bytes((out / "runs" / "default" / "seed-1.mcap").read_bytes())
    logs = sorted(p.relative_to(out).as_posix() for p in out.glob("runs/**/*.mcap"))
    assert logs == ["runs/default/seed-1.mcap", "runs/mine.mcap"]
    assert [r["log"] for r in index(out)["runs"]] == ["runs/default/seed-1.mcap"]


def test_a_link_in_an_earlier_sweeps_folder_goes_but_not_the_file_it_names(
        cli: Run, tmp_path: Path) -> None:
    # the earlier log replaced by a link to a file of the user's: the file and its folder went
    out = tmp_path / "out"
    file = scenario(tmp_path, PLAIN)
    assert cli("sweep", file, "--seeds", "0", "--out-dir", str(out), "-q").status == 0
    mine = out / "runs" / "mine"
    mine.mkdir()
    earlier = out / "runs" / "default" / "seed-0.mcap"
    (mine / "important.mcap").write_bytes(earlier.read_bytes())
    earlier.unlink()
    earlier.symlink_to(Path("..") / "mine" / "important.mcap")
    assert cli("sweep", file, "--seeds", "1", "--out-dir", str(out), "-q").status == 0
    assert (mine / "important.mcap").is_file()
    assert not earlier.is_symlink() and not earlier.exists()


def test_a_scenario_without_variants_runs_as_written(cli: Run, tmp_path: Path) -> None:
    out = tmp_path / "out"
    outcome = cli("sweep", scenario(tmp_path, PLAIN), "--executor", "serial",
                  "--out-dir", str(out))
    assert outcome.status == 0
    assert "(as written)" in outcome.out
    (run,) = index(out)["runs"]
    assert (run["variant"], run["seed"], run["parameters"], run["log"]) == (
        None, 9, {}, "runs/default/seed-9.mcap")


@pytest.mark.parametrize(("options", "message"), [
    (["--seeds", "5..1"], "--seeds: the range 5..1 is empty"),
    (["--seeds", "1-3"], "--seeds: '1-3' is not a seed or a range"),
    (["--jobs", "0"], "--jobs must be from 1 to 256, got 0"),
    (["--jobs", "1000"], "--jobs must be from 1 to 256, got 1000"),
    (["--variant", "nope"], "unknown variant 'nope' (variants: speed=1.0 m/s; speed=1.4 m/s)"),
    (["--variants", "speed=1.0 m/s,speed=1.4 m/s"], "unknown variant 'speed=1.0 m/s,speed=1.4"),
    (["--executor", "dask"], "--executor dask needs --scheduler ADDR"),
    (["--scheduler", "tcp://127.0.0.1:1"], "--scheduler is for --executor dask"),
    (["--executor", "serial", "--jobs", "2"], "--jobs is for --executor process"),
    (["--log-rate", "0"], "--log-rate must be a number of hertz above 0"),
    (["--executor", "dask", "--scheduler", "tcp://x", "--connect-timeout", "nan"],
     "--connect-timeout must be"),
    (["--executor", "dask", "--scheduler", "foo"], "bad Dask scheduler address 'foo'"),
    (["--executor", "dask", "--scheduler", "tcp://"], "missing port number"),
    (["--executor", "dask", "--scheduler", "http://127.0.0.1:1"], "unknown protocol 'http'"),
    (["--executor", "dask", "--scheduler", "tcp://x", "--connect-timeout", "1e308"],
     "--connect-timeout must be a number of seconds above 0 and at most 3600, got 1e+308"),
])
def test_bad_options_exit_2(cli: Run, tmp_path: Path, options: list[str], message: str
                            ) -> None:
    outcome = cli("sweep", scenario(tmp_path, SWEPT), "--out-dir", str(tmp_path / "o"),
                  *options)
    assert outcome.status == 2
    assert message in outcome.out + outcome.err
    assert not (tmp_path / "o").exists()


def test_unusable_inputs_exit_2(cli: Run, tmp_path: Path) -> None:
    path = scenario(tmp_path, SWEPT)
    blocker = tmp_path / "file"
    blocker.write_text("")
    for out in (blocker, blocker / "sweep"):
        outcome = cli("sweep", path, "--out-dir", str(out))
        assert outcome.status == 2
        assert "is a file, not a directory" in outcome.out + outcome.err
    assert cli("sweep", str(tmp_path / "missing.hub"), "--out-dir", str(tmp_path)).status == 2
    assert cli("sweep", path).status == 2  # --out-dir is required


def test_an_out_dir_that_cannot_be_written_is_refused_before_any_worker_starts(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    from hubero_dsl.cli.main import main
    from hubero_dsl.sweep import executors

    locked = tmp_path / "locked"
    locked.mkdir()
    monkeypatch.setattr(os, "access", lambda path, mode: Path(path) != locked)
    monkeypatch.setattr(executors, "ProcessExecutor", None)  # started, it would fail at once
    assert main(["sweep", scenario(tmp_path, SWEPT), "--out-dir", str(locked / "s")]) == 2
    assert f"cannot write logs into {locked / 's'}: {locked} is not writable" in \
        capsys.readouterr().err


def test_worker_processes_that_cannot_start_are_reported_not_an_internal_error(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    # where the fork server cannot be reached (a user without a usable temporary folder), a
    # BrokenPipeError ended hubero as "internal error (please report)"
    from hubero_dsl.cli.main import main
    from hubero_dsl.sweep import executors

    def refused(*args: object, **kwargs: object) -> None:
        raise BrokenPipeError(32, "Broken pipe")

    monkeypatch.setattr(executors, "ProcessPoolExecutor", refused)
    assert main(["sweep", scenario(tmp_path, SWEPT), "--out-dir", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "cannot start worker processes: Broken pipe" in err
    assert "--executor serial" in err and "internal error" not in err


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port: int = probe.getsockname()[1]
        return port


def test_an_unreachable_dask_scheduler_is_reported_quickly(cli_subprocess: Run,
                                                           tmp_path: Path) -> None:
    pytest.importorskip("distributed")
    started = time.monotonic()
    outcome = cli_subprocess("sweep", scenario(tmp_path, SWEPT), "--out-dir",
                             str(tmp_path / "o"), "--executor", "dask", "--scheduler",
                             f"tcp://127.0.0.1:{free_port()}", "--connect-timeout", "1")
    assert outcome.status == 2
    assert "cannot reach the Dask scheduler at tcp://127.0.0.1:" in outcome.out + outcome.err
    assert time.monotonic() - started < 15
    assert not (tmp_path / "o").exists()


def _long_sweep(tmp_path: Path, out: Path, *, jobs: int) -> subprocess.Popen[str]:
    """`hubero sweep` of eight long runs, started in the background."""
    environment = {k: v for k, v in os.environ.items() if k != "HUBERO_DEBUG"}
    return subprocess.Popen(
        [sys.executable, "-m", "hubero_dsl", "sweep", scenario(tmp_path, LONG), "--seeds",
         "1..8", "--jobs", str(jobs), "--out-dir", str(out)],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=environment)


@pytest.mark.parametrize("presses", [1, 2])
def test_ctrl_c_stops_the_sweep_and_writes_the_finished_runs(tmp_path: Path,
                                                             presses: int) -> None:
    # pressed twice, the second came while the first was stopping the workers: no index was
    # written, and finished logs stayed that no index named
    out = tmp_path / "out"
    process = _long_sweep(tmp_path, out, jobs=1)
    deadline = time.monotonic() + 60
    # one worker: when the second log is there, the first run has been reported
    while len(list(out.glob("runs/*/seed-*.mcap"))) < 2 and time.monotonic() < deadline:
        time.sleep(0.02)
    for _ in range(presses):
        process.send_signal(signal.SIGINT)
        time.sleep(0.01)
    stdout, stderr = process.communicate(timeout=60)
    assert_no_traceback(Outcome(process.returncode, stdout, stderr))
    assert process.returncode == 130
    assert "hubero: interrupted:" in stderr and "runs finished" in stderr
    written = index(out)
    assert written["complete"] is False
    assert 1 <= len(written["runs"]) < 8
    logs = sorted(p.name for p in out.glob("runs/*/*"))
    assert logs == sorted(Path(r["log"]).name for r in written["runs"])  # no .part files left


def test_ctrl_c_to_the_process_group_as_the_sweep_starts_leaves_an_index_and_no_traceback(
        tmp_path: Path) -> None:
    # a terminal's Ctrl-C reaches the fork server and the workers too: as they start, the
    # fork server printed the traceback of its imports, a worker forked as the pool went
    # away printed its own, and with no run under way no index was written
    for wait in (0.9, 1.3, 1.8):
        out = tmp_path / f"out-{wait}"
        process = subprocess.Popen(
            [sys.executable, "-m", "hubero_dsl", "sweep", scenario(tmp_path, LONG), "--seeds",
             "1..8", "--jobs", "2", "--out-dir", str(out)], stdout=subprocess.PIPE,
            stderr=subprocess.PIPE, text=True, start_new_session=True)
        time.sleep(wait)
        os.killpg(process.pid, signal.SIGINT)
        _, stderr = process.communicate(timeout=60)
        assert "Traceback" not in stderr, stderr
        assert process.returncode == 130, stderr
        if out.exists():  # interrupted before its folder was made: nothing to index
            assert index(out)["complete"] is False


def test_sigterm_stops_the_sweep_as_terminated(tmp_path: Path) -> None:
    out = tmp_path / "out"
    process = _long_sweep(tmp_path, out, jobs=1)
    deadline = time.monotonic() + 60
    while not list(out.glob("runs/*/seed-*.mcap")) and time.monotonic() < deadline:
        time.sleep(0.02)
    process.send_signal(signal.SIGTERM)
    stdout, stderr = process.communicate(timeout=60)
    assert_no_traceback(Outcome(process.returncode, stdout, stderr))
    assert process.returncode == 143
    assert "hubero: terminated:" in stderr
    assert index(out)["complete"] is False


def test_a_users_file_at_a_log_path_or_an_index_that_cannot_be_written_is_refused_first(
        cli: Run, tmp_path: Path) -> None:
    out = tmp_path / "o"
    notes = out / "runs" / "speed=1.0m_s" / "seed-3.mcap"
    notes.parent.mkdir(parents=True)
    notes.write_text("my notes", encoding="utf-8")
    outcome = cli("sweep", scenario(tmp_path, SWEPT), "--out-dir", str(out), "-q")
    assert outcome.status == 2
    assert f"{notes} exists and is not an MCAP log" in outcome.err
    assert notes.read_text(encoding="utf-8") == "my notes"
    notes.unlink()
    notes.parent.rmdir()
    (out / "index.json").mkdir()
    outcome = cli("sweep", scenario(tmp_path, SWEPT), "--out-dir", str(out), "-q")
    assert outcome.status == 2 and "index.json: cannot be written (it is a directory)" in \
        outcome.err
    assert not list(out.glob("runs/*"))  # refused before any run, or any folder for one


def test_a_sweep_writes_over_its_own_index_but_not_over_a_users_file(cli: Run,
                                                                     tmp_path: Path) -> None:
    out = tmp_path / "o"
    text = scenario(tmp_path, SWEPT)
    assert cli("sweep", text, "--out-dir", str(out), "-q").status == 0
    assert cli("sweep", text, "--out-dir", str(out), "-q").status == 0  # its own, again
    for name in ("index.json", "index.csv"):
        kept = out / name
        earlier = kept.read_bytes()
        kept.write_text("my notes", encoding="utf-8")
        outcome = cli("sweep", text, "--out-dir", str(out), "-q")
        assert outcome.status == 2 and f"{kept} exists and is not a sweep's index" in outcome.err
        assert kept.read_text(encoding="utf-8") == "my notes"
        kept.write_bytes(earlier)


def test_workers_end_with_a_killed_sweep(tmp_path: Path) -> None:
    """SIGKILL cannot be passed on: the workers notice their sweep is gone and stop."""
    psutil = pytest.importorskip("psutil")
    out = tmp_path / "out"
    environment = {k: v for k, v in os.environ.items() if k != "HUBERO_DEBUG"}
    process = subprocess.Popen(  # no pipes: the workers would hold them open
        [sys.executable, "-m", "hubero_dsl", "sweep", scenario(tmp_path, LONG), "--seeds",
         "1..8", "--jobs", "2", "--out-dir", str(out)],
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=environment)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and not list(out.glob("runs/*/*.part")):
        time.sleep(0.1)  # the workers are in their runs
    family = psutil.Process(process.pid).children(recursive=True)
    assert len(family) >= 2
    process.kill()
    process.wait(timeout=30)
    _, alive = psutil.wait_procs(family, timeout=30)
    assert alive == []
    assert not list(out.glob("runs/*/*.part"))


def test_sigterm_to_a_run_removes_its_temporary_log(tmp_path: Path) -> None:
    output = tmp_path / "run.mcap"
    environment = {k: v for k, v in os.environ.items() if k != "HUBERO_DEBUG"}
    process = subprocess.Popen(
        [sys.executable, "-m", "hubero_dsl", "run", scenario(tmp_path, LONG), "--quiet",
         "-o", str(output)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        env=environment, cwd=tmp_path, start_new_session=True)
    deadline = time.monotonic() + 60
    while not list(tmp_path.glob("*.part")) and time.monotonic() < deadline:
        time.sleep(0.05)
    os.killpg(process.pid, signal.SIGTERM)  # what `timeout` sends to the process group
    _, stderr = process.communicate(timeout=30)
    assert process.returncode == 143 and "terminated" in stderr
    assert "Traceback" not in stderr
    assert not output.exists() and not list(tmp_path.glob("*.part"))
