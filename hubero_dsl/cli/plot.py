"""`hubero plot RUN.mcap [-o OUT.png]`: a run drawn on its map; `--animate OUT.gif` replays it.

    hubero plot run.mcap                  # writes run.png beside the log
    hubero plot run.mcap -o run.png
    hubero plot run.mcap -o run.png --spacing 1 --whole-map
    hubero plot run.mcap --animate run.gif --frames 100 --fps 10

The picture shows the map in grey, every human's path, where it started (circle) and the goals
it reached (stars), and its personal space in its own shape and heading every --spacing metres
along the path. Exit 0 when written, 2 for an unreadable log or an unwritable output.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from hubero_dsl.cli.outputs import GIF, PNG

FRAMES = 120  # at most this many frames in a GIF, unless --frames says otherwise
FPS = 10


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    parser: argparse.ArgumentParser = subparsers.add_parser(
        "plot", help="draw a run's paths and personal spaces on its map", description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("log", metavar="RUN.mcap", help="a run log written by hubero run")
    parser.add_argument("-o", "--output", metavar="OUT.png", type=PNG,
                        help="write the PNG here (default: RUN.png beside the log, unless "
                             "--animate alone is asked)")
    parser.add_argument("--animate", metavar="OUT.gif", type=GIF,
                        help="write an animated GIF replay")
    parser.add_argument("--spacing", metavar="M", type=float, default=1.5,
                        help="metres along a path between drawn personal spaces (default 1.5)")
    parser.add_argument("--whole-map", action="store_true",
                        help="show the whole map, not only the part the actors used")
    parser.add_argument("--frames", metavar="N", type=int,
                        help=f"at most this many frames in the GIF (default {FRAMES})")
    parser.add_argument("--fps", metavar="N", type=int,
                        help=f"GIF frames per second (default {FPS})")
    return parser


def run(args: argparse.Namespace) -> int:
    from hubero_dsl.cli.outputs import check_picture, refuse_run_inputs
    from hubero_dsl.errors import InputError

    defaulted = args.output is None and args.animate is None
    if defaulted:
        args.output = Path(args.log).with_suffix(".png")  # RUN.png beside RUN.mcap
    if not args.spacing > 0:
        raise InputError(f"--spacing must be a positive distance in metres, got {args.spacing}")
    if args.animate is None and (args.frames, args.fps) != (None, None):
        raise InputError("--frames and --fps shape the GIF of --animate OUT.gif: give it too")
    args.frames = FRAMES if args.frames is None else args.frames
    args.fps = FPS if args.fps is None else args.fps
    if args.frames < 1 or args.fps < 1:
        raise InputError("--frames and --fps must be at least 1")
    for out in (args.output, args.animate):
        if out is not None:
            check_picture(out, (Path(args.log),))

    from hubero_dsl.log.reader import load_run

    logged = load_run(args.log)
    for out in (args.output, args.animate):  # nor over the scenario or map it was run from
        if out is not None:
            refuse_run_inputs(out, logged)
    if args.output is not None:
        from hubero_dsl.analysis.plot import plot_run

        plot_run(logged, args.output, spacing=args.spacing, whole_map=args.whole_map)
        if defaulted:  # say where it went, since nobody said where it should
            print(f"picture written to {args.output}")
    if args.animate is not None:
        from hubero_dsl.analysis.animate import animate_run

        animate_run(logged, args.animate, max_frames=args.frames, fps=args.fps,
                    whole_map=args.whole_map)
    return 0
