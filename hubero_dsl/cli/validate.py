"""`hubero validate [FILE ...]`: simulated people against measured people.

    hubero validate                               # the shipped Jülich corridor recordings
    hubero validate uo-180-180-070.txt --json     # another run of the series, by path
    hubero validate -o fd.png --seed 2            # the fundamental diagram as a picture
    hubero validate --defaults fitted.hub         # with parameters hubero calibrate fitted
    hubero validate --seeds 4 --json              # four rebuilds a recording, frames pooled

Each recording is rebuilt as a scenario (its corridor drawn from its geometry, people placed
where they were measured at the first steady frame, desired speeds measured in free flow), run,
and both are analysed by PedPy: mean speed and specific flow per Voronoi-density bin, and the
distribution of individual speeds. Prints a table per file; --json prints, per file and bin, the
measured and simulated mean speed and their relative error. --seeds N rebuilds each recording
N times (seeds S, S+1, ...) and pools their frames, so that a bin stands for more than one
draw of who gets through a gap first. Deterministic per --seed and --seeds.

Files are named as the series names them (uo-AAA-BBB-CCC.txt in cm at 16 fps,
traj_UNI_CORR_500_NN.txt in m at 25 fps): the name gives the geometry. Needs PedPy
(pip install 'hubero[validate]'). Exit 0 when compared, 1 for a --defaults file with errors,
2 for bad input or a missing PedPy.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import TYPE_CHECKING, Any

from hubero_dsl.cli.calibrate import MAX_SEEDS, check_seeds
from hubero_dsl.cli.outputs import PNG

if TYPE_CHECKING:
    from hubero_dsl.validation.validate import Validation


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    parser: argparse.ArgumentParser = subparsers.add_parser(
        "validate", help="compare simulated people with measured trajectories (PedPy)",
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("files", metavar="FILE", nargs="*", type=Path,
                        help="trajectory files (default: the shipped recordings)")
    parser.add_argument("--json", action="store_true", help="print the comparison as JSON")
    parser.add_argument("-o", "--output", metavar="PLOT.png", type=PNG,
                        help="draw the fundamental diagram of data and simulation")
    parser.add_argument("--seed", metavar="S", type=int, default=1,
                        help="seed of the rebuilds (default 1)")
    parser.add_argument("--seeds", metavar="N", type=int, default=1,
                        help="rebuilds of each recording, with the seeds S, S+1, ..., their "
                             f"frames pooled (default 1, at most {MAX_SEEDS})")
    parser.add_argument("--defaults", metavar="FITTED.hub", type=Path,
                        help="a `defaults { }` block for every rebuilt person (as hubero "
                             "calibrate -o writes it)")
    return parser


def run(args: argparse.Namespace) -> int:
    from hubero_dsl.files import check_output
    from hubero_dsl.validation.experiments import pedpy

    check_seeds(args.seed, args.seeds)
    if args.output is not None:
        check_output(args.output, (*args.files, *([args.defaults] if args.defaults else [])))
    pedpy()  # a missing PedPy is told before any work (and before pandas is imported)
    from hubero_dsl.validation.validate import load_defaults, validate

    params = load_defaults(args.defaults) if args.defaults is not None else None
    results = validate(args.files, seed=args.seed, params=params, seeds=args.seeds)
    if args.output is not None:
        from hubero_dsl.validation.plot import plot_fundamental_diagram

        plot_fundamental_diagram(results, args.output)
    if args.json:
        print(json.dumps({"seed": args.seed, "seeds": args.seeds,
                          "files": [r.comparison.to_dict() for r in results]}, indent=2))
    else:
        _print_tables(results)
    return 0


def _print_tables(results: list[Validation]) -> None:
    from rich.table import Table

    from hubero_dsl.cli.console import make_console

    console = make_console()
    for result in results:
        c = result.comparison
        table = Table(title=f"{c.name}: mean speed and specific flow per Voronoi density",
                      title_justify="left")
        for heading in ("density 1/m²", "frames m/s", "speed measured", "speed hubero",
                        "error", "flow measured", "flow hubero"):
            table.add_column(heading, justify="right")
        for b in c.bins:
            table.add_row(f"{b.low:.1f}-{b.high:.1f}",
                          f"{b.measured_frames}/{b.simulated_frames}",
                          _fmt(b.measured_speed), _fmt(b.simulated_speed),
                          _percent(b.speed_error), _fmt(b.measured_flow), _fmt(b.simulated_flow))
        console.print(table)
        console.print(f"individual speeds: measured {_fmt(c.measured_speed)} m/s, hubero "
                      f"{_fmt(c.simulated_speed)} m/s (KS {_fmt(c.speed_ks)}); flow across the "
                      f"line: measured {_fmt(c.measured_line_flow)}/s, hubero "
                      f"{_fmt(c.simulated_line_flow)}/s; worst bin error "
                      f"{_percent(abs(c.worst_error)).lstrip('+')}\n")


def _fmt(value: float) -> str:
    return "-" if value != value else f"{value:.2f}"  # NaN: no frames on that side


def _percent(value: float) -> str:
    return "-" if value != value else f"{value:+.0%}"
