"""Argument types the benchmark scripts share."""

from __future__ import annotations

import argparse


def at_least_one(text: str) -> int:
    """A count of runs, steps or copies: a whole number of at least 1 (a best of no runs, or a
    rate over no steps, is no measurement)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"{value} is not at least 1")
    return value
