"""The index files: the format `hubero diff` reads, the CSV columns, atomic writing."""

from __future__ import annotations

import csv
import io
import json
import os
from pathlib import Path

import pytest

from hubero_dsl.errors import LogError
from hubero_dsl.sweep.index import build_index, index_csv, index_json, write_index
from hubero_dsl.sweep.plan import RunSpec, SweepPlan
from hubero_dsl.sweep.runner import SweepOutcome
from hubero_dsl.sweep.worker import RunRecord, error_record

PLAN = SweepPlan(
    scenario="scenarios/x.hub", scenario_path="/abs/scenarios/x.hub", source="...",
    source_sha256="ab" * 32, variants=("k=1,m=2 m/s", "slow"),
    parameters={"k=1,m=2 m/s": {"k": 1.0, "m": 2.0},
                "slow": {"speed": 0.5, "b.personal_space": {"shape": "circle", "radius": 0.3}}},
    runs=(RunSpec("k=1,m=2 m/s", 1, "runs/k=1,m=2m_s/seed-1.mcap"),
          RunSpec("slow", 1, "runs/slow/seed-1.mcap")))

DONE = RunRecord("k=1,m=2 m/s", 1, "completed", "", 12.5, True, (),
                 {"humans": {"a": {"path_length": 3.25, "gap": float("nan")}}},
                 {"a.path_length": 3.25, "a.gap": float("inf")}, "runs/k=1,m=2m_s/seed-1.mcap")
BROKEN = error_record("slow", 1, 'ValueError: bad "thing", really')


def test_the_index_has_the_agreed_keys_in_order() -> None:
    index = build_index(PLAN, SweepOutcome((DONE, BROKEN), complete=True))
    assert list(index) == ["version", "scenario", "source_sha256", "complete", "variants",
                           "runs"]
    assert (index["version"], index["scenario"], index["complete"]) == (
        1, "scenarios/x.hub", True)
    assert index["variants"] == ["k=1,m=2 m/s", "slow"]
    first, second = index["runs"]
    assert first == {"variant": "k=1,m=2 m/s", "seed": 1, "parameters": {"k": 1.0, "m": 2.0},
                     "status": "completed", "reason": "", "duration": 12.5, "succeeded": True,
                     "failed_expectations": [], "metrics": DONE.metrics,
                     "log": "runs/k=1,m=2m_s/seed-1.mcap"}
    assert (second["status"], second["metrics"], second["log"], second["duration"]) == (
        "error", None, None, None)


def test_json_is_strict_and_stable() -> None:
    text = index_json(build_index(PLAN, SweepOutcome((DONE,), complete=False)))
    assert text.endswith("}\n") and "NaN" not in text
    parsed = json.loads(text)
    assert parsed["runs"][0]["metrics"]["humans"]["a"]["gap"] is None
    assert parsed["complete"] is False
    assert index_json(build_index(PLAN, SweepOutcome((DONE,), complete=False))) == text


def test_csv_has_fixed_columns_then_parameters_then_metrics() -> None:
    rows = list(csv.reader(io.StringIO(index_csv(PLAN, SweepOutcome((DONE, BROKEN), True)))))
    assert rows[0] == ["variant", "seed", "status", "reason", "duration", "succeeded",
                       "failed_expectations", "log", "param:k", "param:m", "param:speed",
                       "param:b.personal_space", "a.path_length", "a.gap"]
    assert rows[1] == ["k=1,m=2 m/s", "1", "completed", "", "12.5", "true", "",
                       "runs/k=1,m=2m_s/seed-1.mcap", "1.0", "2.0", "", "", "3.25", ""]
    assert rows[2] == ["slow", "1", "error", 'ValueError: bad "thing", really', "", "false",
                       "", "", "", "", "0.5", '{"shape":"circle","radius":0.3}', "", ""]


def test_index_files_are_replaced_whole(tmp_path: Path) -> None:
    (tmp_path / "index.json").write_text("old")
    json_path, csv_path = write_index(tmp_path, PLAN, SweepOutcome((DONE,), complete=True))
    assert json.loads(json_path.read_text())["runs"][0]["seed"] == 1
    assert csv_path.read_text().startswith("variant,seed,")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["index.csv", "index.json"]


@pytest.mark.skipif(os.geteuid() == 0 if hasattr(os, "geteuid") else True,
                    reason="root writes into read-only folders")
def test_an_unwritable_folder_is_a_log_error(tmp_path: Path) -> None:
    tmp_path.chmod(0o500)
    try:
        with pytest.raises(LogError, match="cannot write"):
            write_index(tmp_path, PLAN, SweepOutcome((DONE,), complete=True))
    finally:
        tmp_path.chmod(0o700)


def test_a_folder_that_is_gone_is_a_log_error(tmp_path: Path) -> None:
    with pytest.raises(LogError, match=r"cannot write .*index\.json"):
        write_index(tmp_path / "gone", PLAN, SweepOutcome((DONE,), complete=True))
