"""A log appears under its final name complete or not at all; write errors are LogErrors."""

from __future__ import annotations

import errno
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from hubero_dsl.cli.main import main
from hubero_dsl.errors import LogError
from hubero_dsl.log.container import McapContainer
from hubero_dsl.log.reader import load_run
from hubero_dsl.log.writer import RunLog
from hubero_dsl.pipeline import compile_file
from hubero_dsl.sim.loop import run_program
from hubero_dsl.sim.simulation import Simulation
from tests.conftest import earlier_run_log
from tests.log.conftest import ENDLESS, MEETING, REPO_ROOT, WAITING, World, hubero

# The first signal waits for the log's temporary file; the run lasts far longer than that.
START_TIMEOUT = 30.0


def part_files(folder: Path) -> list[Path]:
    return sorted(folder.glob(".*.part"))


def start_endless_run(world: World, folder: Path) -> tuple[subprocess.Popen[str], Path]:
    scenario = world.scenario("endless.hub", ENDLESS)
    output = folder / "endless.mcap"
    process = subprocess.Popen(
        [sys.executable, "-m", "hubero_dsl", "run", str(scenario), "-q", "-o", str(output)],
        cwd=REPO_ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + START_TIMEOUT
    while not part_files(folder):
        if process.poll() is not None or time.monotonic() > deadline:
            process.kill()
            _, err = process.communicate()
            pytest.fail(f"the run did not start writing its log: {err}")
        time.sleep(0.02)
    time.sleep(0.2)  # well into the run, frames being written
    return process, output


def test_killed_run_leaves_nothing_under_the_final_name(world: World, tmp_path: Path) -> None:
    process, output = start_endless_run(world, tmp_path)
    process.send_signal(signal.SIGKILL)
    process.communicate(timeout=30)
    assert process.returncode == -signal.SIGKILL
    assert not output.exists()
    # the writer process saw the run end without a finish and deleted its temporary file
    deadline = time.monotonic() + START_TIMEOUT
    while part_files(tmp_path) and time.monotonic() < deadline:
        time.sleep(0.02)
    assert list(tmp_path.iterdir()) == []


def test_interrupted_run_leaves_no_file_at_all(world: World, tmp_path: Path) -> None:
    process, output = start_endless_run(world, tmp_path)
    process.send_signal(signal.SIGINT)
    _, err = process.communicate(timeout=30)
    assert process.returncode == 130
    assert "interrupted" in err and "Traceback" not in err
    assert not output.exists()
    assert part_files(tmp_path) == []


def test_failing_run_leaves_no_file(world: World, tmp_path: Path) -> None:
    sim = Simulation(compile_file(world.scenario("waiting.hub", WAITING)))
    output = tmp_path / "failing.mcap"

    def fail_at_one_second(sim: Simulation) -> None:
        if sim.time >= 1.0:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt), RunLog(output, sim) as log:
        run_program(sim, [log.observe, fail_at_one_second])
    assert list(tmp_path.iterdir()) == []


def test_an_existing_log_is_replaced_only_when_the_new_one_is_complete(
        world: World, tmp_path: Path) -> None:
    output = tmp_path / "run.mcap"
    previous = earlier_run_log(output)  # a log, which a run may write over
    sim = Simulation(compile_file(world.scenario("waiting.hub", WAITING)))
    with pytest.raises(KeyboardInterrupt), RunLog(output, sim) as log:
        log.observe(sim)
        raise KeyboardInterrupt
    assert output.read_bytes() == previous
    sim = Simulation(compile_file(world.scenario("waiting.hub", WAITING)))
    with RunLog(output, sim) as log:
        log.close(run_program(sim, [log.observe]))
    assert output.read_bytes().startswith(b"\x89MCAP0\r\n")
    assert [p.name for p in tmp_path.iterdir()] == ["run.mcap"]


@pytest.mark.parametrize("writer_process", [False, True])
def test_full_disk_is_a_log_error_and_leaves_no_file(world: World, tmp_path: Path,
                                                     monkeypatch: pytest.MonkeyPatch,
                                                     writer_process: bool) -> None:
    sim = Simulation(compile_file(world.scenario("waiting.hub", WAITING)))
    output = tmp_path / "full.mcap"
    write = McapContainer._write

    def fill_up(self: McapContainer, data: bytes) -> None:  # the disk is full after 30 kB
        if self._offset + len(data) > 30_000:
            raise OSError(errno.ENOSPC, "No space left on device")
        write(self, data)

    monkeypatch.setattr(McapContainer, "_write", fill_up)
    with pytest.raises(LogError, match="no space left on the device"), \
            RunLog(output, sim, chunk_size=4096, writer_process=writer_process) as log:
        log.close(run_program(sim, [log.observe]))
    assert list(tmp_path.iterdir()) == []


def test_unwritable_path_is_exit_2_with_a_message(world: World, tmp_path: Path) -> None:
    scenario = world.scenario("waiting.hub", WAITING)
    done = hubero("run", str(scenario), "-q", "-o", str(tmp_path / "missing" / "run.mcap"),
                  cwd=REPO_ROOT)
    assert done.returncode == 2
    assert "cannot write log" in done.stderr and "does not exist" in done.stderr
    assert "Traceback" not in done.stderr and "internal error" not in done.stderr


@pytest.mark.parametrize(("where", "reason"), [("file.txt/run.mcap", "is not a directory"),
                                               (".", "it is a directory")])
def test_other_unwritable_paths(world: World, tmp_path: Path, where: str, reason: str,
                                capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "file.txt").write_text("not a folder")
    scenario = world.scenario("waiting.hub", WAITING)
    status = main(["run", str(scenario), "-q", "-o", str(tmp_path / where)])
    err = capsys.readouterr().err
    assert status == 2
    assert "cannot write log" in err and reason in err and "Traceback" not in err


def test_out_dir_is_created_and_holds_one_log_per_variant(
        world: World, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    scenario = world.scenario("meeting.hub", MEETING)
    folder = tmp_path / "logs" / "nested"
    assert main(["run", str(scenario), "-q", "--all-variants", "--out-dir", str(folder)]) == 0
    assert sorted(p.name for p in folder.iterdir()) == ["fast.mcap", "slow.mcap"]
    assert load_run(folder / "slow.mcap").metadata.variant == "slow"
    blocked = tmp_path / "file.txt"
    blocked.write_text("")
    status = main(["run", str(scenario), "-q", "--all-variants", "--out-dir", str(blocked)])
    err = capsys.readouterr().err
    assert status == 2 and "not a directory" in err and "Traceback" not in err


def test_a_rate_of_zero_is_refused(world: World, tmp_path: Path) -> None:
    sim = Simulation(compile_file(world.scenario("waiting.hub", WAITING)))
    for rate in (0.0, -1.0, float("nan"), float("inf")):
        with pytest.raises(LogError, match="log rate"):
            RunLog(tmp_path / "x.mcap", sim, rate_hz=rate)
