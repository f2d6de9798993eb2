"""`hubero bench FOLDER`: the social-navigation benchmark (docs/benchmark.md).

    hubero bench scenarios/benchmark/ -o out/bench
    hubero bench scenarios/benchmark/ --controller cart=my_pkg:Planner -o out/bench --jobs 2
    hubero bench scenarios/benchmark/ --seeds 1..3 -o out/bench

Runs every scenario and variant of FOLDER with the reference controllers the scenarios name
and, with --controller, with yours beside them; with --seeds, every variant with each seed
(else with the scenario's own). Writes OUT/NAME.csv, OUT/NAME.md and
OUT/NAME.png per scenario, OUT/summary.csv and OUT/summary.md, and the logs under OUT/runs/.

Exit 0 when every run completed and met its expectations, 1 when any did not (a controller
that raises is reported in its run's row and the bench goes on), 2 for bad input, 130 when
interrupted (143 for SIGTERM): the tables are written with the runs that had not finished as
`interrupted`, so a summary never reads as whole when it is not.

The tables and pictures are written over earlier ones of `hubero bench` only, never over
other files, and never into the suite's own folder.
"""

from __future__ import annotations

import argparse
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from hubero_dsl.sweep.bench import BenchOutcome


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    parser: argparse.ArgumentParser = subparsers.add_parser(
        "bench", help="run a benchmark suite with your controller beside the reference",
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("folder", metavar="FOLDER", type=Path,
                        help="folder of scenarios (.hub), e.g. scenarios/benchmark/")
    parser.add_argument("--controller", metavar="ROBOT=MODULE:CLASS", action="append",
                        default=[], help="drive robot ROBOT with your own controller class")
    parser.add_argument("-o", "--out-dir", metavar="DIR", type=Path, default=Path("bench"),
                        help="where the tables, plots and logs go (default: bench/)")
    parser.add_argument("--seeds", metavar="SEEDS",
                        help="run every variant with each of these seeds: 1..3, 7, 1,2,5 "
                             "(default: each scenario's own seed)")
    parser.add_argument("--jobs", "-j", metavar="N", type=int,
                        help="worker processes (default: the cores)")
    return parser


def run(args: argparse.Namespace) -> int:
    from hubero_dsl.cli.run import handed_controllers
    from hubero_dsl.errors import InputError
    from hubero_dsl.sweep.bench import find_suite, plot_paths, robots_of, write_tables
    from hubero_dsl.sweep.executors import check_jobs, deaf_to_interrupts, stopped_once
    from hubero_dsl.sweep.plan import parse_seeds

    check_jobs(args.jobs)
    seeds = parse_seeds(args.seeds) if args.seeds is not None else ()
    scenarios = find_suite(args.folder)
    controllers = handed_controllers(args)
    unknown = sorted(set(controllers) - robots_of(scenarios))
    if unknown:
        raise InputError(f"--controller: no robot named '{unknown[0]}' in every scenario of "
                         f"{args.folder}")
    _check_out_dir(args.folder, scenarios, args.out_dir)
    args.out_dir.mkdir(parents=True, exist_ok=True)
    with stopped_once():  # once stopped, deaf until the tables are written and said
        outcome = _bench(args, scenarios, controllers, seeds)
        with deaf_to_interrupts():  # a first press now: the tables are still written whole
            written = (write_tables(outcome.rows, args.out_dir)
                       + plot_paths(outcome.rows, args.out_dir))
        return _report(outcome, len(written), args.out_dir)


def _bench(args: argparse.Namespace, scenarios: list[Path], controllers: dict[str, type],
           seeds: tuple[int, ...]) -> BenchOutcome:
    """The bench on a process pool; stopped as the pool shut down, after the runs, it is
    reported as stopped (with every run finished)."""
    from hubero_dsl.errors import Terminated
    from hubero_dsl.sweep.bench import run_bench
    from hubero_dsl.sweep.executors import available_cores, open_executor

    outcome: BenchOutcome | None = None
    try:
        with open_executor("process", jobs=args.jobs or available_cores()) as executor:
            outcome = run_bench(scenarios, args.out_dir, executor, controllers=controllers,
                                seeds=seeds)
    except KeyboardInterrupt as stop:  # Terminated too
        if outcome is None:
            raise  # as the workers started: nothing ran, nothing to tell of
        outcome = replace(outcome, complete=False, terminated=isinstance(stop, Terminated))
    return outcome


def _report(outcome: BenchOutcome, written: int, out_dir: Path) -> int:
    """Say the runs that failed, what was written, and whether the bench was stopped; the
    exit status."""
    from hubero_dsl.cli.console import make_console
    from hubero_dsl.cli.main import EXIT_INTERRUPTED, EXIT_TERMINATED
    from hubero_dsl.sweep.bench import INTERRUPTED
    from hubero_dsl.sweep.plan import variant_label

    rows = outcome.rows
    console = make_console()
    for row in rows:
        if not row.succeeded and row.status != INTERRUPTED:
            console.print(f"{row.scenario} [{variant_label(row.variant)}] seed {row.seed} "
                          f"{row.controller}: {row.status}: "
                          f"{row.reason or 'an expectation failed'}",
                          highlight=False, soft_wrap=True, markup=False)
    ran = sum(r.status != INTERRUPTED for r in rows)
    console.print(f"{ran} runs; {sum(r.succeeded for r in rows)} ok; wrote {written} files to "
                  f"{out_dir}", highlight=False, soft_wrap=True)
    if outcome.complete:
        return 0 if all(r.succeeded for r in rows) else 1
    stop = "terminated" if outcome.terminated else "interrupted"
    make_console(stderr=True).print(
        f"hubero: {stop}: {ran} of {len(rows)} runs finished; the tables mark the others "
        f"{INTERRUPTED}", highlight=False, soft_wrap=True)
    return EXIT_TERMINATED if outcome.terminated else EXIT_INTERRUPTED


def _check_out_dir(folder: Path, scenarios: list[Path], out_dir: Path) -> None:
    """The bench's tables and pictures (OUT/NAME.csv, .md, .png and the summary's) go into a
    folder that is not the suite's, over files of the bench's own only, and never onto a
    scenario, its map or its map's image; its runs' indexes only over earlier ones. All found
    before any run."""
    from hubero_dsl.errors import InputError
    from hubero_dsl.files import PNG_MAGIC, check_output, check_output_folder, refuse_other_kind
    from hubero_dsl.pipeline import compile_file
    from hubero_dsl.sweep.bench import COLUMNS, REFERENCE, YOURS, side_folder
    from hubero_dsl.sweep.index import refuse_other_indexes
    from hubero_dsl.world.mapfile import map_files

    # how each of the bench's own tables and pictures begins: it writes over these only
    own = {".csv": ",".join(COLUMNS[:4]).encode(),
           ".md": ("| " + " | ".join(COLUMNS[:4])).encode(), ".png": PNG_MAGIC}

    check_output_folder(out_dir, "the tables")
    if not out_dir.is_dir():
        return  # a new folder holds no input
    if out_dir.samefile(folder):
        raise InputError(f"{out_dir}: is the suite's own folder: give the tables another "
                         "with -o")
    reads = [file for scenario in scenarios
             for file in (scenario, *map_files(compile_file(scenario).map_path))]
    for name in [*(scenario.stem for scenario in scenarios), "summary"]:
        for suffix, beginning in own.items():
            check_output(out_dir / f"{name}{suffix}", reads)
            refuse_other_kind(out_dir / f"{name}{suffix}", beginning,
                              "a table or picture of hubero bench", "give another -o")
    for scenario in scenarios:
        for side in (REFERENCE, YOURS):
            refuse_other_indexes(side_folder(out_dir, scenario.stem, side))
