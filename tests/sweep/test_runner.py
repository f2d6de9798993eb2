"""Running sweeps: the same bytes whichever executor ran them, failures recorded, Ctrl-C."""

from __future__ import annotations

import json
import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from hubero_dsl.log.reader import LoggedRun, load_run
from hubero_dsl.pipeline import compile_file
from hubero_dsl.sweep.executors import SerialExecutor, open_executor
from hubero_dsl.sweep.index import write_index
from hubero_dsl.sweep.plan import SweepPlan, plan_sweep
from hubero_dsl.sweep.runner import SweepOutcome, prepare_out_dir, run_sweep
from hubero_dsl.sweep.worker import RunRecord
from tests.conftest import earlier_run_log
from tests.sweep.conftest import ABORTED, MAP, OUTCOMES, SWEPT, Write, wandering


def plan_for(path: Path, seeds: tuple[int, ...] | None = None, variants: list[str] | None = None
             ) -> SweepPlan:
    program = compile_file(path)
    chosen: list[str | None] = list(variants or program.variants) or [None]
    return plan_sweep(path, program, chosen, seeds or (program.seed,))


def sweep(plan: SweepPlan, out: Path, kind: str = "serial", **options: Any) -> SweepOutcome:
    prepare_out_dir(plan, out)
    with open_executor(kind, **options) as executor:  # type: ignore[arg-type]
        outcome = run_sweep(plan, out, executor)
    write_index(out, plan, outcome)
    return outcome


def tree(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes()
            for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.fixture(scope="module")
def dask_scheduler() -> Iterator[str]:
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster:
        yield cluster.scheduler_address


def test_serial_process_and_dask_write_the_same_bytes(write_scenario: Write, tmp_path: Path,
                                                      dask_scheduler: str) -> None:
    plan = plan_for(write_scenario(SWEPT), seeds=(1, 2))
    serial = sweep(plan, tmp_path / "serial")
    sweep(plan, tmp_path / "process", "process", jobs=2)
    sweep(plan, tmp_path / "dask", "dask", scheduler=dask_scheduler)
    assert serial.complete and serial.succeeded and len(serial.records) == 4
    expected = tree(tmp_path / "serial")
    assert sorted(expected) == [
        "index.csv", "index.json",
        "runs/slow,avoidance_strength=0.5/seed-1.mcap",
        "runs/slow,avoidance_strength=0.5/seed-2.mcap",
        "runs/slow,avoidance_strength=1.5/seed-1.mcap",
        "runs/slow,avoidance_strength=1.5/seed-2.mcap"]
    assert tree(tmp_path / "process") == expected
    assert tree(tmp_path / "dask") == expected
    # the seed is what differs between the runs of one variant (speed is drawn per seed)
    logs = expected["runs/slow,avoidance_strength=0.5/seed-1.mcap"], \
        expected["runs/slow,avoidance_strength=0.5/seed-2.mcap"]
    assert logs[0] != logs[1]


def test_records_hold_outcomes_metrics_and_logs(write_scenario: Write, tmp_path: Path) -> None:
    plan = plan_for(write_scenario(OUTCOMES), seeds=(1,))
    outcome = sweep(plan, tmp_path / "out")
    quick, late, slow = outcome.records
    assert (quick.status, quick.succeeded, quick.failed_expectations) == ("completed", True, ())
    assert (late.status, late.succeeded) == ("completed", False)
    assert late.failed_expectations == ("a reaches (2, 1) within 1.5 s",)
    assert (slow.status, slow.reason, slow.duration) == (
        "timed_out", "time limit of 3 s reached", 3.0)
    assert not outcome.succeeded
    run = load_run(tmp_path / "out" / quick.log)  # type: ignore[operator]
    assert (run.metadata.variant, run.metadata.seed) == ("quick", 1)
    assert quick.metrics is not None and quick.flat_metrics is not None
    assert quick.metrics["humans"]["a"]["final_status"] == "SUCCEEDED"
    assert quick.flat_metrics["a.final_status"] == "SUCCEEDED"


def test_an_aborted_scenario_is_failed_with_its_reason(write_scenario: Write,
                                                       tmp_path: Path) -> None:
    (record,) = sweep(plan_for(write_scenario(ABORTED)), tmp_path / "out").records
    assert record.status == "failed" and "within 0.5 s" in record.reason
    assert record.log == "runs/default/seed-0.mcap" and record.metrics is not None


def test_an_exception_in_the_worker_is_an_error_and_the_sweep_goes_on(
        write_scenario: Write, tmp_path: Path) -> None:
    plan = plan_for(write_scenario(OUTCOMES), seeds=(1, 2), variants=["quick"])
    out = tmp_path / "out"
    prepare_out_dir(plan, out)
    (out / "runs" / "quick" / "seed-1.mcap").mkdir()  # the worker cannot write this log
    with open_executor("process", jobs=2) as executor:
        outcome = run_sweep(plan, out, executor)
    broken, fine = outcome.records
    assert broken.status == "error" and "is a directory" in broken.reason
    assert (broken.log, broken.metrics, broken.duration) == (None, None, None)
    assert fine.status == "completed" and fine.succeeded
    assert outcome.complete and not outcome.succeeded
    assert not [p for p in out.rglob("*") if p.name.endswith(".part")]


def die(run: LoggedRun) -> Any:
    """A metrics function that kills its worker process."""
    os._exit(9)


def explode(run: LoggedRun) -> Any:
    raise ZeroDivisionError("metrics went wrong")


def test_a_worker_process_that_dies_is_an_error(write_scenario: Write, tmp_path: Path) -> None:
    plan = plan_for(write_scenario(OUTCOMES), seeds=(1,), variants=["quick"])
    prepare_out_dir(plan, tmp_path)
    with open_executor("process", jobs=1) as executor:
        (record,) = run_sweep(plan, tmp_path, executor, metrics=die).records
    assert record.status == "error"
    assert record.reason.startswith("the worker failed: BrokenProcessPool")


def test_failing_metrics_are_an_error_but_the_log_is_kept(write_scenario: Write,
                                                          tmp_path: Path) -> None:
    plan = plan_for(write_scenario(OUTCOMES), seeds=(1,), variants=["quick"])
    prepare_out_dir(plan, tmp_path)
    (record,) = run_sweep(plan, tmp_path, SerialExecutor(), metrics=explode).records
    assert record.status == "error"
    assert record.reason == "computing the metrics failed: ZeroDivisionError: metrics went wrong"
    assert record.log is not None and (tmp_path / record.log).is_file()
    assert record.duration == 1.1


def test_stale_logs_of_an_earlier_sweep_are_removed(write_scenario: Write,
                                                    tmp_path: Path) -> None:
    plan = plan_for(write_scenario(OUTCOMES), seeds=(1,), variants=["quick"])
    stale = tmp_path / "runs" / "quick" / "seed-1.mcap"
    stale.parent.mkdir(parents=True)
    earlier_run_log(stale)
    prepare_out_dir(plan, tmp_path)
    assert not stale.exists()


@pytest.mark.parametrize("kind", ["serial", "process"])
def test_ctrl_c_keeps_the_finished_runs_and_stops_the_workers(
        kind: str, write_scenario: Write, tmp_path: Path) -> None:
    plan = plan_for(write_scenario(OUTCOMES), seeds=(1, 2, 3))
    prepare_out_dir(plan, tmp_path)
    seen: list[RunRecord] = []

    def interrupt_after_two(record: RunRecord) -> None:
        seen.append(record)
        if len(seen) == 2:
            raise KeyboardInterrupt

    with open_executor(kind, jobs=2) as executor:  # type: ignore[arg-type]
        outcome = run_sweep(plan, tmp_path, executor, on_done=interrupt_after_two)
        workers = executor.workers() if hasattr(executor, "workers") else []
    assert not outcome.complete and not outcome.succeeded
    assert 2 <= len(outcome.records) < len(plan.runs)
    assert all(not process.is_alive() for process in workers)
    write_index(tmp_path, plan, outcome)
    index = json.loads((tmp_path / "index.json").read_text())
    assert index["complete"] is False and len(index["runs"]) == len(outcome.records)
    order = [(r.variant, r.seed) for r in plan.runs]
    listed = [(r["variant"], r["seed"]) for r in index["runs"]]
    assert listed == sorted(listed, key=order.index)
    assert not [p for p in tmp_path.rglob("*") if p.name.endswith((".part", ".tmp"))]




def test_a_worker_that_dies_fails_the_runs_in_flight_and_the_rest_go_on(
        tmp_path: Path) -> None:
    import signal
    import threading
    import time

    scenario = tmp_path / "wandering.hub"
    scenario.write_text(wandering(MAP, 40), encoding="utf-8")
    plan = plan_for(scenario, seeds=(1, 2, 3, 4, 5, 6))
    out = tmp_path / "out"
    prepare_out_dir(plan, out)
    with open_executor("process", jobs=2) as executor:  # type: ignore[arg-type]
        def kill_a_worker() -> None:
            deadline = time.monotonic() + 60
            while len(list(out.rglob(".*.part"))) < 2 and time.monotonic() < deadline:
                time.sleep(0.01)  # both workers are in a run, writing its log
            os.kill(executor.workers()[0].pid, signal.SIGKILL)  # type: ignore[attr-defined]

        killer = threading.Thread(target=kill_a_worker)
        killer.start()
        outcome = run_sweep(plan, out, executor)
        killer.join()
    failed = [r for r in outcome.records if r.status == "error"]
    assert outcome.complete
    # the killed one, and the other worker's when it was stopped with the pool before it
    # could remove its log (else that run goes again)
    assert 1 <= len(failed) <= 2 and all("the worker failed" in r.reason for r in failed)
    assert sum(r.status == "completed" for r in outcome.records) == 6 - len(failed)
    assert not list(out.rglob("*.part"))  # the dead worker's log is not left half written


UNGUARDED_SCRIPT = """\
import json
from hubero_dsl.pipeline import compile_file
from hubero_dsl.sweep.executors import open_executor
from hubero_dsl.sweep.plan import plan_sweep
from hubero_dsl.sweep.runner import prepare_out_dir, run_sweep

program = compile_file({scenario!r})
plan = plan_sweep({scenario!r}, program, list(program.variants), (1, 2))
prepare_out_dir(plan, {out!r})
with open_executor("process", jobs=2) as executor:
    outcome = run_sweep(plan, {out!r}, executor)
print(json.dumps([r.reason for r in outcome.records]))
"""


def test_a_script_without_a_main_guard_ends_with_a_reason_instead_of_restarting_for_ever(
        write_scenario: Write, tmp_path: Path) -> None:
    # each worker of a process pool imports the script that started it as `__mp_main__`:
    # unguarded, it starts the sweep again and dies; pool after pool would die the same way
    import subprocess
    import sys

    from hubero_dsl.sweep.runner import WORKERS_DIE

    script = tmp_path / "sweep_script.py"
    script.write_text(UNGUARDED_SCRIPT.format(scenario=str(write_scenario(OUTCOMES)),
                                              out=str(tmp_path / "out")), encoding="utf-8")
    done = subprocess.run([sys.executable, str(script)], capture_output=True, text=True,
                          timeout=300, check=False, cwd=tmp_path)
    assert done.returncode == 0, done.stderr[-2000:]
    reasons = json.loads(done.stdout.strip().splitlines()[-1])
    assert reasons and set(reasons) == {WORKERS_DIE}
    assert not [p for p in (tmp_path / "out").rglob("*") if p.name.endswith(".part")]


def test_a_worker_whose_stop_was_lost_removes_its_own_temporary_log_as_it_ends(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # a sweep killed outright: the worker's stop can be lost (raised where it cannot be) or
    # slow, and it ended without its clean-up, its `.part` left behind
    import os

    from hubero_dsl.sweep import worker

    log = tmp_path / "seed-1.mcap"
    mine = tmp_path / f".seed-1.mcap.{os.getpid()}.0.part"
    another = tmp_path / f".seed-1.mcap.{os.getpid() + 1}.0.part"  # another worker's
    for temp in (mine, another):
        temp.write_bytes(b"")
    monkeypatch.setitem(worker._state, "log", str(log))
    worker._drop_own_temporary_log()
    assert not mine.exists() and another.exists()
