"""`hubero calibrate`: fit human parameters to measured people, check them on held-out runs.

    hubero calibrate                                  # fit on three shipped runs, test on two
    hubero calibrate --fit relaxation_time,social_force.B --evaluations 20 -o fitted.hub
    hubero calibrate --train uo-050-180-180.txt --test uo-100-180-180.txt --jobs 2 --json

Minimises the mean squared relative error of the simulated mean speed per density bin (as
`hubero validate` measures it) with scipy's Nelder-Mead, running each parameter set's
recordings in parallel (--jobs, default the cores; --executor serial runs them inline). Prints
the fitted values as a `defaults { }` block (-o writes it to a file, to paste into a scenario)
and the errors with hubero's defaults and with the fitted values, on the training runs and on
the held-out ones. --seeds N runs every recording N times per parameter set (seeds S, S+1,
...) and takes the error over all of them, so that the fit follows the model rather than one
draw of its noise. --start NAME=VALUE,... starts the search from those values (an earlier
fit's, to refine it over more seeds) rather than from hubero's defaults. Deterministic per
--seed and --seeds. Needs PedPy (pip install 'hubero[validate]').

Parameters that can be fitted: relaxation_time, social_force.A, social_force.B,
social_force.B_wall, social_force.space_at_rest, social_force.time_gap,
social_force.time_gap_lane, social_force.kappa, personal_space (the radius of a circle),
speed_scale (a factor on the measured desired speeds). Exit 0 when fitted, 2 for bad input
or a missing PedPy.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import TYPE_CHECKING, Any

from hubero_dsl.cli.outputs import named_file

if TYPE_CHECKING:
    from hubero_dsl.validation.calibrate import Calibration, FileReport

DEFAULT_TRAIN = ("uo-050-180-180", "uo-145-180-180", "uo-180-180-120")
DEFAULT_TEST = ("uo-100-180-180", "uo-180-180-070")
MAX_EVALUATIONS = 10_000
MAX_SEEDS = 100


def check_seeds(seed: int, seeds: int) -> None:
    """--seed and --seeds, as `calibrate` and `validate` take them (each seed is a rebuild of
    every recording)."""
    from hubero_dsl.errors import InputError

    if seed < 0:
        raise InputError(f"--seed must be a whole number of at least 0, got {seed}")
    if not 1 <= seeds <= MAX_SEEDS:
        raise InputError(f"--seeds must be from 1 to {MAX_SEEDS}, got {seeds}")


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    parser: argparse.ArgumentParser = subparsers.add_parser(
        "calibrate", help="fit human parameters to measured trajectories (PedPy, scipy)",
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--train", metavar="FILE", nargs="+", type=Path,
                        help=f"recordings to fit to (default: the shipped "
                             f"{', '.join(DEFAULT_TRAIN)})")
    parser.add_argument("--test", metavar="FILE", nargs="*", type=Path,
                        help=f"held-out recordings (default with the default --train: "
                             f"{', '.join(DEFAULT_TEST)})")
    parser.add_argument("--fit", metavar="A,B", default="relaxation_time,social_force.A,"
                        "social_force.B,personal_space",
                        help="parameters to fit, separated by commas (default: "
                             "relaxation_time,social_force.A,social_force.B,personal_space)")
    parser.add_argument("--evaluations", metavar="N", type=int, default=30,
                        help="parameter sets tried at most (default 30)")
    parser.add_argument("--seed", metavar="S", type=int, default=1,
                        help="seed of every run (default 1)")
    parser.add_argument("--seeds", metavar="N", type=int, default=1,
                        help="runs of each recording per parameter set, with the seeds S, "
                             "S+1, ...: the error is taken over all of them (default 1)")
    parser.add_argument("--start", metavar="NAME=VALUE,...",
                        help="start the search from these values of the fitted parameters, "
                             "in their units (default: hubero's defaults)")
    parser.add_argument("--executor", choices=("process", "serial"), default="process",
                        help="where the runs of a parameter set execute (default: process)")
    parser.add_argument("--jobs", "-j", metavar="N", type=int,
                        help="worker processes (default: the cores)")
    parser.add_argument("-o", "--output", metavar="FITTED.hub", type=named_file,
                        help="write the fitted defaults block here")
    parser.add_argument("--json", action="store_true", help="print the result as JSON")
    parser.add_argument("--quiet", "-q", action="store_true",
                        help="no progress lines on standard error")
    return parser


def _progress(evaluation: int, error: float) -> None:
    import sys

    print(f"evaluation {evaluation}: error {error:.4f}", file=sys.stderr, flush=True)


def run(args: argparse.Namespace) -> int:
    from hubero_dsl.errors import InputError
    from hubero_dsl.files import check_output
    from hubero_dsl.sweep.executors import check_jobs
    from hubero_dsl.validation.experiments import experiment_for, pedpy, shipped_path

    if not 1 <= args.evaluations <= MAX_EVALUATIONS:
        raise InputError(f"--evaluations must be from 1 to {MAX_EVALUATIONS}, "
                         f"got {args.evaluations}")
    check_seeds(args.seed, args.seeds)
    check_jobs(args.jobs)
    train = args.train or [shipped_path(n) for n in DEFAULT_TRAIN]
    test = args.test if args.test is not None else (
        [] if args.train else [shipped_path(n) for n in DEFAULT_TEST])
    for path in (*train, *test):
        experiment_for(Path(path))  # a name of no series is refused before any work
    if args.output is not None:
        check_output(args.output, (*train, *test))
    pedpy()
    from hubero_dsl.sweep.executors import available_cores, open_executor
    from hubero_dsl.validation.calibrate import calibrate, chosen, starting_values
    from hubero_dsl.validation.validate import measure

    fit = chosen([n.strip() for n in args.fit.split(",") if n.strip()])
    start = starting_values(fit, args.start) if args.start is not None else None
    measure([experiment_for(Path(p)) for p in (*train, *test)])  # unreadable files: exit 2
    jobs = args.jobs if args.jobs is not None else min(available_cores(), len(train))
    with open_executor(args.executor, jobs=jobs) as executor:
        result = calibrate(train, test, fit=fit, seed=args.seed, seeds=args.seeds, start=start,
                           evaluations=args.evaluations, executor=executor,
                           progress=None if args.quiet else _progress)
    block = result.defaults_block([r.name for r in result.train])
    if args.output is not None:
        _write(args.output, block)
    if args.json:
        print(json.dumps(_as_json(result, args.seed, args.seeds), indent=2))
    else:
        _print(result, block)
    return 0


def _write(path: Path, text: str) -> None:
    from hubero_dsl.files import write_replacing

    write_replacing(path, lambda temp: temp.write_text(text, encoding="utf-8"))


def _report(report: FileReport) -> dict[str, Any]:
    def num(value: float) -> float | None:
        return None if value != value else round(value, 4)

    return {"file": report.name, "default_loss": num(report.default_loss),
            "fitted_loss": num(report.fitted_loss),
            "default_worst_relative_error": num(report.default_worst),
            "fitted_worst_relative_error": num(report.fitted_worst)}


def _as_json(result: Calibration, seed: int, seeds: int) -> dict[str, Any]:
    return {"seed": seed, "seeds": seeds, "fitted": result.fitted,
            "train_loss": round(result.train_loss, 6),
            "evaluations": result.evaluations,
            "train": [_report(r) for r in result.train],
            "test": [_report(r) for r in result.test]}


def _print(result: Calibration, block: str) -> None:
    from rich.markup import escape
    from rich.table import Table

    from hubero_dsl.cli.console import make_console

    console = make_console()
    console.print(escape(block), end="")
    table = Table(title="mean squared relative speed error (worst bin)", title_justify="left")
    for heading in ("run", "set", "hubero defaults", "fitted"):
        table.add_column(heading, justify="right" if heading != "run" else "left")
    for role, reports in (("train", result.train), ("held out", result.test)):
        for r in reports:
            table.add_row(r.name, role, f"{r.default_loss:.4f} ({_pct(r.default_worst)})",
                          f"{r.fitted_loss:.4f} ({_pct(r.fitted_worst)})")
    console.print(table)


def _pct(value: float) -> str:
    return "-" if value != value else f"{value:.0%}"
