"""The sweep's index: `DIR/index.json` (for `hubero diff` and scripts) and `DIR/index.csv`
(for spreadsheets), one row per run.

    {"version": 1, "scenario": "scenarios/x.hub", "source_sha256": "...", "complete": true,
     "variants": ["fast", "slow"],
     "runs": [{"variant": "fast", "seed": 1, "parameters": {"speed": 1.6}, "status": "completed",
               "reason": "", "duration": 21.4, "succeeded": true, "failed_expectations": [],
               "metrics": {...}, "log": "runs/fast/seed-1.mcap"}, ...]}

Runs are in the order of the variants in the file, then by seed. Nothing in either file depends
on the executor or the wall clock: the same sweep gives the same bytes. Both files are written
to a temporary name and renamed, so a reader never sees half an index. `complete` is false
when the sweep was interrupted: the index then lists the runs that had finished.
"""

from __future__ import annotations

import contextlib
import csv
import io
import itertools
import json
import math
import os
import stat
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from hubero_dsl.errors import LogError
from hubero_dsl.files import check_output, refuse_other_kind
from hubero_dsl.sweep.plan import SweepPlan
from hubero_dsl.sweep.runner import SweepOutcome
from hubero_dsl.sweep.worker import RunRecord

INDEX_VERSION = 1
INDEX_JSON = "index.json"
INDEX_CSV = "index.csv"
CSV_FIRST_COLUMNS = ("variant", "seed", "status", "reason", "duration", "succeeded",
                     "failed_expectations", "log")
PARAM_PREFIX = "param:"  # a colon never appears in a name, so no metric column can clash
# How an index begins (`index_json`'s first key, the CSV's first columns): what tells an
# earlier sweep's index, written over, from a user's file of the same name, never touched.
_BEGINNINGS = {INDEX_JSON: b'{\n  "version": ', INDEX_CSV: ",".join(CSV_FIRST_COLUMNS).encode()}


def refuse_other_indexes(out_dir: str | Path) -> None:
    """InputError when `out_dir` holds an index.json or index.csv that is not a sweep's, or
    a folder, a device or a FIFO by that name: refused before any folder is made there."""
    for name, beginning in _BEGINNINGS.items():
        path = Path(out_dir) / name
        if path.parent.is_dir():
            check_output(path)
        refuse_other_kind(path, beginning, "a sweep's index", "give another --out-dir")


def earlier_logs(out_dir: str | Path) -> list[Path]:
    """The logs an earlier sweep into `out_dir` wrote, as its index names them: those that are
    MCAP files inside the folder's `runs/`, or links there (to be removed themselves, not what
    they name). None when there is no index, or a damaged one (what it names is not surely the
    sweep's own)."""
    if not (Path(out_dir) / INDEX_JSON).is_file():
        return []  # a first sweep into the folder: not worth importing the index's reader
    from hubero_dsl.analysis.diff import load_index
    from hubero_dsl.errors import InputError

    try:
        runs = load_index(out_dir).runs
    except InputError:
        return []
    folder = (Path(out_dir) / "runs").resolve()
    logs = []
    for run in runs:
        if run.log is None:
            continue
        try:
            # the folder's links resolved, not the file's own: a link is removed, never
            # what it points at
            log = run.log.parent.resolve() / run.log.name
            if log.is_relative_to(folder) and _an_earlier_log(log):
                logs.append(log)
        except (OSError, RuntimeError):  # RuntimeError: a loop of symbolic links
            continue
    return logs


def _an_earlier_log(path: Path) -> bool:
    """Whether `path` may go as an earlier sweep's log: a regular file that begins as an MCAP
    file does, or a symbolic link (the link goes, not the file it names)."""
    from hubero_dsl.files import MCAP_MAGIC

    mode = path.lstat().st_mode
    if stat.S_ISLNK(mode):
        return True
    if not stat.S_ISREG(mode):
        return False
    with path.open("rb") as stream:
        return stream.read(len(MCAP_MAGIC)) == MCAP_MAGIC


def build_index(plan: SweepPlan, outcome: SweepOutcome) -> dict[str, Any]:
    """The index as JSON values, in a fixed key order."""
    return {
        "version": INDEX_VERSION,
        "scenario": plan.scenario,
        "source_sha256": plan.source_sha256,
        "complete": outcome.complete,
        "variants": list(plan.variants),
        "runs": [_run_entry(plan, record) for record in outcome.records],
    }


def _run_entry(plan: SweepPlan, record: RunRecord) -> dict[str, Any]:
    return {
        "variant": record.variant,
        "seed": record.seed,
        "parameters": dict(plan.parameters.get(record.variant, {})),
        "status": record.status,
        "reason": record.reason,
        "duration": record.duration,
        "succeeded": record.succeeded,
        "failed_expectations": list(record.failed_expectations),
        "metrics": record.metrics,
        "log": record.log,
    }


def index_json(index: dict[str, Any]) -> str:
    """Stable text: two-space indent, UTF-8, non-finite numbers as null (JSON has none)."""
    return json.dumps(_finite(index), indent=2, ensure_ascii=False, allow_nan=False) + "\n"


def index_csv(plan: SweepPlan, outcome: SweepOutcome) -> str:
    """One row per run: the fixed columns, `param:NAME` per parameter, then every metric."""
    records = outcome.records
    params = _union(plan.parameters.get(r.variant, {}) for r in records)
    metrics = _union(r.flat_metrics or {} for r in records)
    header = [*CSV_FIRST_COLUMNS, *(PARAM_PREFIX + p for p in params), *metrics]
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(header)
    for record in records:
        values = plan.parameters.get(record.variant, {})
        flat = record.flat_metrics or {}
        row = [record.variant, record.seed, record.status, record.reason, record.duration,
               record.succeeded, "; ".join(record.failed_expectations), record.log,
               *(values.get(p) for p in params), *(flat.get(m) for m in metrics)]
        writer.writerow([_cell(value) for value in row])
    return buffer.getvalue()


def write_index(out_dir: str | Path, plan: SweepPlan, outcome: SweepOutcome
                ) -> tuple[Path, Path]:
    """Write index.json and index.csv atomically; their paths."""
    folder = Path(out_dir)
    json_path, csv_path = folder / INDEX_JSON, folder / INDEX_CSV
    write_atomically(json_path, index_json(build_index(plan, outcome)))
    write_atomically(csv_path, index_csv(plan, outcome))
    return json_path, csv_path


def _union(mappings: Iterable[dict[str, Any] | Any]) -> list[str]:
    """Every key, in the order first seen (runs are in plan order, so this is stable)."""
    return list(dict.fromkeys(itertools.chain.from_iterable(mappings)))


def _cell(value: Any) -> str:
    if value is None:
        return ""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return repr(value) if math.isfinite(value) else ""
    if isinstance(value, dict | list):
        return json.dumps(_finite(value), separators=(",", ":"), ensure_ascii=False)
    return str(value)


def _finite(value: Any) -> Any:
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {key: _finite(item) for key, item in value.items()}
    if isinstance(value, list | tuple):
        return [_finite(item) for item in value]
    return value


def write_atomically(path: Path, text: str) -> None:
    temp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        with open(temp, "w", encoding="utf-8", newline="") as stream:
            stream.write(text)
            stream.flush()
            os.fsync(stream.fileno())
        os.replace(temp, path)
    except OSError as exc:
        with contextlib.suppress(OSError):
            temp.unlink()
        raise LogError(f"cannot write {path}: {exc.strerror or exc}") from None
