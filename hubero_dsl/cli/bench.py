"""`hubero bench FOLDER`: the social-navigation benchmark (docs/benchmark.md).

    hubero bench scenarios/benchmark/ -o out/bench
    hubero bench scenarios/benchmark/ --controller cart=my_pkg:Planner -o out/bench --jobs 2
    hubero bench scenarios/benchmark/ --seeds 1..3 -o out/bench

Runs every scenario and variant of FOLDER with the reference controllers the scenarios name
and, with --controller, with yours beside them; with --seeds, every variant with each seed
(else with the scenario's own). Writes OUT/NAME.csv, OUT/NAME.md and
OUT/NAME.png per scenario, OUT/summary.csv and OUT/summary.md, and the logs under OUT/runs/.

Exit 0 when every run completed and met its expectations, 1 when any did not (a controller
that raises is reported in its run's row and the bench goes on), 2 for bad input.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any


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
    from hubero_dsl.cli.console import make_console
    from hubero_dsl.cli.run import handed_controllers
    from hubero_dsl.errors import InputError
    from hubero_dsl.sweep.bench import (
        find_suite,
        plot_paths,
        robots_of,
        run_bench,
        write_tables,
    )
    from hubero_dsl.sweep.executors import available_cores, check_jobs, open_executor
    from hubero_dsl.sweep.plan import parse_seeds, variant_label

    check_jobs(args.jobs)
    seeds = parse_seeds(args.seeds) if args.seeds is not None else ()
    scenarios = find_suite(args.folder)
    controllers = handed_controllers(args)
    unknown = sorted(set(controllers) - robots_of(scenarios))
    if unknown:
        raise InputError(f"--controller: no robot named '{unknown[0]}' in every scenario of "
                         f"{args.folder}")
    _refuse_writing_over_inputs(scenarios, args.out_dir)
    args.out_dir.mkdir(parents=True, exist_ok=True)
    with open_executor("process", jobs=args.jobs or available_cores()) as executor:
        rows = run_bench(scenarios, args.out_dir, executor, controllers=controllers,
                         seeds=seeds)
    written = write_tables(rows, args.out_dir) + plot_paths(rows, args.out_dir)
    console = make_console()
    for row in rows:
        if not row.succeeded:
            console.print(f"{row.scenario} [{variant_label(row.variant)}] seed {row.seed} "
                          f"{row.controller}: "
                          f"{row.status}: {row.reason or 'an expectation failed'}",
                          highlight=False, soft_wrap=True,
                          markup=False)
    console.print(f"{len(rows)} runs; {sum(r.succeeded for r in rows)} ok; wrote "
                  f"{len(written)} files to {args.out_dir}", highlight=False, soft_wrap=True)
    return 0 if all(r.succeeded for r in rows) else 1


def _refuse_writing_over_inputs(scenarios: list[Path], out_dir: Path) -> None:
    """The tables and pictures the bench writes (OUT/NAME.csv, .md, .png and the summary's)
    must not land on a scenario, its map or its map's image (a suite's folder as OUT)."""
    from hubero_dsl.files import check_output
    from hubero_dsl.pipeline import compile_file
    from hubero_dsl.world.mapfile import map_files

    if not out_dir.is_dir():
        return  # a new folder holds no input
    reads = [file for scenario in scenarios
             for file in (scenario, *map_files(compile_file(scenario).map_path))]
    for name in [*(scenario.stem for scenario in scenarios), "summary"]:
        for suffix in (".csv", ".md", ".png"):
            check_output(out_dir / f"{name}{suffix}", reads)
