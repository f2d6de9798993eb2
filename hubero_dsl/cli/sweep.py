"""`hubero sweep FILE`: every variant x seed, in parallel, one MCAP log each, and an index.

    hubero sweep scenarios/parking_patrol.hub --seeds 1..20 --jobs 4 --out-dir out/
    hubero sweep x.hub --variant 'speed=1.0 m/s,avoidance_strength=0.5' --out-dir out/
    hubero sweep x.hub --variants 'circle;ellipse' --executor dask --scheduler tcp://h:8786 \\
        --out-dir /shared/out/

Writes DIR/runs/VARIANT/seed-N.mcap, DIR/index.json and DIR/index.csv (docs/sweeps.md).
Sweep variant names contain commas, so --variants separates names with ';' (or repeat
--variant NAME). Without --seeds every variant runs once with the scenario's own seed.

Exit 0 when every run completed and met its expectations, 1 when any did not (failed, timed
out, an error), 2 for bad input, 130 when interrupted (the index then lists the runs that had
finished and says "complete": false).
"""

from __future__ import annotations

import argparse
import math
import time
from collections import Counter
from pathlib import Path
from typing import TYPE_CHECKING, Any

from hubero_dsl.cli.main import EXIT_INTERRUPTED, EXIT_TERMINATED
from hubero_dsl.cli.run import refuse_live

if TYPE_CHECKING:
    from rich.console import Console

    from hubero_dsl.sweep.plan import SweepPlan
    from hubero_dsl.sweep.runner import SweepOutcome
    from hubero_dsl.sweep.worker import RunRecord

EXECUTORS = ("process", "serial", "dask")
MAX_CONNECT = 3600.0  # s: --connect-timeout at most an hour


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    parser: argparse.ArgumentParser = subparsers.add_parser(
        "sweep", help="run every variant x seed in parallel, with an index",
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("file", metavar="FILE", help="scenario file (.hub)")
    parser.add_argument("--out-dir", metavar="DIR", type=Path, required=True,
                        help="where the logs and the index go")
    which = parser.add_mutually_exclusive_group()
    which.add_argument("--variants", metavar="all|A;B",
                       help="'all' (the default) or variant names separated by ';'")
    which.add_argument("--variant", metavar="NAME", action="append",
                       help="run this variant (repeat for several)")
    parser.add_argument("--seeds", metavar="SEEDS",
                        help="seeds: 1..20, 3, 1,2,5 (default: the scenario's seed)")
    parser.add_argument("--executor", choices=EXECUTORS, default="process",
                        help="where runs execute (default: process)")
    parser.add_argument("--jobs", "-j", metavar="N", type=int,
                        help="worker processes for --executor process (default: the cores)")
    parser.add_argument("--scheduler", metavar="ADDR",
                        help="Dask scheduler address for --executor dask (tcp://HOST:8786)")
    parser.add_argument("--connect-timeout", metavar="S", type=float, default=5.0,
                        help="seconds to wait for the Dask scheduler (default 5)")
    parser.add_argument("--log-rate", metavar="HZ", type=float, default=10.0,
                        help="how often the logs record the humans' state (default 10 Hz)")
    refuse_live(parser, "a sweep runs many at once; watch one of its runs with hubero run "
                "FILE --live --variant NAME --seed N")
    parser.add_argument("--no-metrics", action="store_true",
                        help="do not compute metrics (faster; the index has none)")
    parser.add_argument("--quiet", "-q", action="store_true",
                        help="no progress bar and no table, only problems")
    return parser


def run(args: argparse.Namespace) -> int:
    from hubero_dsl.pipeline import compile_file
    from hubero_dsl.sweep.plan import parse_seeds, plan_sweep, select_variants

    _check_options(args)
    seeds = parse_seeds(args.seeds) if args.seeds is not None else None
    program = compile_file(args.file)
    variants = select_variants(list(program.variants), _variant_names(args))
    plan = plan_sweep(args.file, program, variants, seeds or (program.seed,))
    return _sweep(args, plan)


def _check_options(args: argparse.Namespace) -> None:
    from hubero_dsl.errors import InputError
    from hubero_dsl.sweep.executors import check_jobs

    check_jobs(args.jobs)
    if args.jobs is not None and args.executor != "process":
        raise InputError(f"--jobs is for --executor process, not {args.executor}")
    if args.executor == "dask" and not args.scheduler:
        raise InputError("--executor dask needs --scheduler ADDR (tcp://HOST:8786)")
    if args.scheduler and args.executor != "dask":
        raise InputError("--scheduler is for --executor dask")
    if not (math.isfinite(args.connect_timeout) and 0 < args.connect_timeout <= MAX_CONNECT):
        raise InputError(f"--connect-timeout must be a number of seconds above 0 and at most "
                         f"{MAX_CONNECT:g}, got {args.connect_timeout:g}")
    if not (math.isfinite(args.log_rate) and args.log_rate > 0):
        raise InputError("--log-rate must be a number of hertz above 0")


def _variant_names(args: argparse.Namespace) -> list[str] | None:
    from hubero_dsl.sweep.plan import split_variant_list

    if args.variant is not None:
        return list(args.variant)
    return split_variant_list(args.variants) if args.variants is not None else None


def _sweep(args: argparse.Namespace, plan: SweepPlan) -> int:
    from hubero_dsl.cli.console import make_console
    from hubero_dsl.files import check_output, check_output_folder
    from hubero_dsl.sweep.executors import (
        available_cores,
        open_executor,
        stopped_once,
    )
    from hubero_dsl.sweep.index import (
        INDEX_CSV,
        INDEX_JSON,
        earlier_logs,
        refuse_other_indexes,
        write_index,
    )
    from hubero_dsl.sweep.runner import prepare_out_dir, run_sweep
    from hubero_dsl.sweep.worker import standard_metrics

    refuse_other_indexes(args.out_dir)  # before any earlier log there is cleared away
    check_output_folder(args.out_dir, "logs")  # before any worker starts
    earlier = earlier_logs(args.out_dir)
    jobs = min(args.jobs or available_cores(), len(plan.runs))
    errors = make_console(stderr=True)
    started = time.monotonic()  # wall time for the terminal only, never for the index
    with stopped_once():  # once stopped, deaf until the index is written and said
        with open_executor(args.executor, jobs=jobs, scheduler=args.scheduler,
                           connect_timeout=args.connect_timeout) as executor, \
                _SweepProgress(errors, plan, quiet=args.quiet) as on_done:
            # after connecting: nothing for nothing
            folder = prepare_out_dir(plan, args.out_dir, earlier)
            for index in (INDEX_JSON, INDEX_CSV):  # before any run, not after them all
                check_output(folder / index)
            outcome = run_sweep(plan, args.out_dir, executor, log_rate=args.log_rate,
                                metrics=None if args.no_metrics else standard_metrics,
                                on_done=on_done)
        elapsed = time.monotonic() - started
        json_path, csv_path = write_index(args.out_dir, plan, outcome)
        if not outcome.complete:
            stop = "terminated" if outcome.terminated else "interrupted"
            errors.print(f"hubero: {stop}: {len(outcome.records)} of {len(plan.runs)} runs "
                         f"finished; their index is in {json_path}", highlight=False,
                         soft_wrap=True)
            return EXIT_TERMINATED if outcome.terminated else EXIT_INTERRUPTED
    if not args.quiet:
        _print_table(plan, outcome)
        where = "inline" if args.executor == "serial" else (
            f"on {jobs} processes" if args.executor == "process" else "on Dask")
        make_console().print(f"{len(outcome.records)} runs {where} in {elapsed:.1f} s; index "
                        f"written to {json_path} and {csv_path}", highlight=False,
                        soft_wrap=True)
    return 0 if outcome.succeeded else 1


class _SweepProgress:
    """A rich progress bar over runs on stderr (only on a terminal) and a line per problem."""

    def __init__(self, console: Console, plan: SweepPlan, *, quiet: bool) -> None:
        from rich.progress import (
            BarColumn,
            MofNCompleteColumn,
            Progress,
            TextColumn,
            TimeElapsedColumn,
            TimeRemainingColumn,
        )

        from hubero_dsl.cli.console import shows_progress

        self._console = console
        self._progress = Progress(
            TextColumn("[bold]{task.description}"), BarColumn(), MofNCompleteColumn(),
            TextColumn("{task.fields[problems]}"), TimeElapsedColumn(), TimeRemainingColumn(),
            console=console, transient=True, disable=quiet or not shows_progress(console))
        self._task = self._progress.add_task(_escape(f"sweep {Path(plan.scenario).name}"),
                                             total=len(plan.runs), problems="")
        self._problems = 0

    def __enter__(self) -> Any:
        self._progress.__enter__()
        return self.on_done

    def __exit__(self, *exc: object) -> None:
        self._progress.__exit__(None, None, None)

    def on_done(self, record: RunRecord) -> None:
        if not record.succeeded:
            self._problems += 1
            self._progress.console.print(_problem_line(record), highlight=False,
                                         soft_wrap=True)
        problems = f"[red]{self._problems} not ok[/]" if self._problems else ""
        self._progress.update(self._task, advance=1, problems=problems)


def _problem_line(record: RunRecord) -> str:
    from hubero_dsl.sweep.plan import variant_label

    name = _escape(variant_label(record.variant))
    if record.status == "completed":
        status, detail = "[yellow]expectations fail[/]", "; ".join(record.failed_expectations)
    else:
        status = {"error": "[red]error[/]", "timed_out": "[yellow]timed out[/]"}.get(
            record.status, "[red]failed[/]")
        detail = record.reason
    return f"{name} seed {record.seed}: {status}: {_escape(detail)}"


def _print_table(plan: SweepPlan, outcome: SweepOutcome) -> None:
    from rich import box
    from rich.table import Table

    from hubero_dsl.cli.console import make_console
    from hubero_dsl.sweep.plan import variant_label

    table = Table(title="sweep", title_justify="left", box=box.SIMPLE_HEAD)
    table.add_column("variant", overflow="fold")  # long sweep names wrap, never cut
    for heading in ("runs", "ok", "expect fails", "failed", "timed out", "error", "mean time"):
        table.add_column(heading, justify="right", no_wrap=True)
    for variant in plan.variants:
        records = [r for r in outcome.records if r.variant == variant]
        states = Counter(r.status for r in records)
        durations = [r.duration for r in records if r.duration is not None]
        mean = f"{sum(durations) / len(durations):.2f} s" if durations else "-"
        table.add_row(_escape(variant_label(variant)), str(len(records)),
                      str(sum(r.succeeded for r in records)),
                      str(sum(r.status == "completed" and not r.succeeded for r in records)),
                      str(states["failed"]),
                      str(states["timed_out"]), str(states["error"]), mean)
    console = make_console()
    if not console.is_terminal:  # a file or a pipe: as wide as the names, never wrapped
        longest = max(len(variant_label(v)) for v in plan.variants)
        console.width = max(console.width, longest + 80)
    console.print(table)


def _escape(text: str) -> str:
    from rich.markup import escape

    return escape(text)
