"""Fitting human parameters to measured people: `calibrate(train, test, fit=..., ...)`.

The error of a parameter set is the mean, over the training recordings and their counted
density bins, of the squared relative error of the simulated mean speed (`compare`); a
recording with no counted bin adds 1. With the parameters scaled to [0, 1], a Latin hypercube
of points (scipy.stats.qmc, with hubero's defaults) surveys the box, and scipy's Nelder-Mead
(with bounds) goes on from the best of them, for at most `evaluations` parameter sets in all.
Given `start` values (an earlier fit's, say, to refine it over more seeds), the search starts
from them instead and spends the whole budget there, without a survey.
Each set's recordings run in parallel on a sweep executor (`hubero_dsl.sweep.executors`); the
workers load and analyse each recording once. After the fit, the held-out recordings are run
with the defaults and with the fitted values, and their errors reported.

Every set is run with the same seeds (`seeds` of them, from `seed` on), so the error is a
deterministic function of the parameters and the fit is the same for the same inputs. A single
run's worst bin moves by several per cent with the seed, or with the fourth digit of a
parameter; over more seeds the error is an average over that noise rather than a fit to one
draw of it. The fitted values are written as they were run (to four decimals).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import Executor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from hubero_dsl.errors import InputError
from hubero_dsl.model.program import ParamValue
from hubero_dsl.world.shapes import Circle


@dataclass(frozen=True)
class Fittable:
    """A parameter the calibration can fit: its bounds, default and how it is written."""

    name: str
    low: float
    high: float
    default: float
    unit: str      # as a scenario writes it ("" for a plain number)
    doc: str

    def value(self, x: float) -> ParamValue:
        """The parameter value a program takes for `x` (a circle for personal_space)."""
        return Circle(x) if self.name == "personal_space" else x

    def written(self, x: float) -> str:
        """As a scenario writes it, with the value exactly as the calibration ran it."""
        if self.name == "personal_space":
            return f"personal_space circle(radius: {x:g} m)"
        return f"{self.name} {x:g}{' ' + self.unit if self.unit else ''}"


FITTABLE: dict[str, Fittable] = {f.name: f for f in (
    Fittable("relaxation_time", 0.2, 1.2, 0.54, "s", "how fast velocity adapts"),
    Fittable("social_force.A", 0.3, 5.0, 2.1, "", "push from people"),
    Fittable("social_force.B", 0.05, 0.6, 0.3, "m", "range of the push from people"),
    Fittable("social_force.B_wall", 0.03, 0.4, 0.08, "m", "range of the push from walls"),
    Fittable("personal_space", 0.2, 0.7, 0.5, "m", "radius of the personal-space circle"),
    Fittable("social_force.space_at_rest", 0.0, 1.0, 1.0, "",
             "share of the personal space kept standing still"),
    Fittable("social_force.time_gap", 0.0, 2.0, 0.0, "s",
             "time gap kept to whoever is in one's path"),
    Fittable("social_force.time_gap_lane", 0.25, 1.0, 1.0, "",
             "half-width of the lane ahead that sets the time gap, per two radii"),
    Fittable("social_force.kappa", 0.0, 3000.0, 3000.0, "", "sliding friction between bodies"),
    Fittable("speed_scale", 0.7, 1.4, 1.0, "", "factor on the measured desired speeds"),
)}
DEFAULT_FIT = ("relaxation_time", "social_force.A", "social_force.B", "personal_space")
SPEED_SCALE = "speed_scale"
SIMPLEX_STEP = 0.15   # the Nelder-Mead simplex's edge, in the [0, 1]-scaled parameters


def chosen(names: Sequence[str]) -> list[Fittable]:
    """The named parameters, or InputError naming the known ones."""
    unknown = [n for n in names if n not in FITTABLE]
    if unknown or not names:
        raise InputError(f"cannot fit {', '.join(unknown) or 'nothing'}: the parameters that "
                         f"can be fitted are {', '.join(FITTABLE)}")
    if len(set(names)) != len(names):
        raise InputError("a parameter to fit is named twice")
    return [FITTABLE[n] for n in names]


def starting_values(fit: Sequence[Fittable], text: str) -> dict[str, float]:
    """`NAME=VALUE,...` as the values the search starts from (InputError if unfit): each
    NAME one of those fitted, each VALUE a number within its bounds, in its unit."""
    by_name = {f.name: f for f in fit}
    values: dict[str, float] = {}
    for item in (part.strip() for part in text.split(",")):
        name, equals, number = (piece.strip() for piece in item.partition("="))
        if not equals or name not in by_name:
            raise InputError(f"--start takes NAME=VALUE for the parameters fitted "
                             f"({', '.join(by_name)}), got '{item}'")
        try:
            value = float(number)
        except ValueError:
            value = math.nan
        bounds = by_name[name]
        if not bounds.low <= value <= bounds.high:
            raise InputError(f"--start {name} must be a number from {bounds.low:g} to "
                             f"{bounds.high:g}, got '{number}'")
        if name in values:
            raise InputError(f"--start names {name} twice")
        values[name] = value
    return values


def program_params(values: Mapping[str, float]) -> tuple[dict[str, ParamValue], float]:
    """Fitted values as program parameters, and the factor on the desired speeds."""
    params = {name: FITTABLE[name].value(v) for name, v in values.items() if name != SPEED_SCALE}
    return params, float(values.get(SPEED_SCALE, 1.0))


@functools.lru_cache(maxsize=16)
def _measured(path: str) -> Any:
    from hubero_dsl.validation.experiments import experiment_for
    from hubero_dsl.validation.validate import measure

    return measure([experiment_for(Path(path))])[0]


def file_errors(path: str, seed: int, values: tuple[tuple[str, float], ...]) -> list[float]:
    """The relative speed errors of one recording's counted bins (a worker's job)."""
    from hubero_dsl.validation.validate import simulate_and_compare

    params, scale = program_params(dict(values))
    measured = _measured(path)
    result = simulate_and_compare(measured, seed=seed, params=params, speed_scale=scale)
    return result.comparison.errors


def loss(errors: Sequence[Sequence[float]]) -> float:
    """Mean squared relative error over every counted bin; 1 for a file with none."""
    squares = [e * e for file in errors for e in file] + [1.0 for file in errors if not file]
    return float(np.mean(squares)) if squares else 1.0


@dataclass(frozen=True)
class FileReport:
    name: str
    default_loss: float
    fitted_loss: float
    default_worst: float
    fitted_worst: float


@dataclass(frozen=True)
class Calibration:
    fitted: dict[str, float]
    train_loss: float
    evaluations: int
    train: tuple[FileReport, ...]
    test: tuple[FileReport, ...]

    def defaults_block(self, train_names: Sequence[str]) -> str:
        """The fitted values as a `defaults { }` block, with where they came from."""
        lines = [f"# fitted by hubero calibrate to {', '.join(train_names)}",
                 f"# mean squared relative speed error {self.train_loss:.4f} over "
                 f"{self.evaluations} evaluations"]
        scale = self.fitted.get(SPEED_SCALE)
        if scale is not None:
            lines.append(f"# desired speeds: the measured ones times {scale:.3f}")
        body = [f"    {FITTABLE[n].written(v)}" for n, v in self.fitted.items()
                if n != SPEED_SCALE]
        return "\n".join([*lines, "defaults {", *body, "}"]) + "\n"


def _worst(errors: Sequence[float]) -> float:
    return max((abs(e) for e in errors), default=math.nan)


def calibrate(train: Sequence[Path], test: Sequence[Path], *, fit: Sequence[Fittable],
              seed: int, evaluations: int, executor: Executor, seeds: int = 1,
              start: Mapping[str, float] | None = None,
              progress: Callable[[int, float], None] | None = None) -> Calibration:
    """Fit `fit` to the `train` recordings, then report on `train` and `test`; every set runs
    each recording with the seeds `seed` .. `seed + seeds - 1`. The search starts from
    hubero's defaults, or from `start` (for the parameters it names)."""
    from scipy.optimize import minimize
    from scipy.stats import qmc

    paths = [str(p) for p in train]
    cache: dict[tuple[float, ...], float] = {}

    run_seeds = range(seed, seed + seeds)

    def errors_for(files: Sequence[str], sets: Sequence[dict[str, float]]
                   ) -> list[list[list[float]]]:
        """Every set's errors on every file, the bins of all its seeds together: all runs
        submitted at once, so they share the executor's workers."""
        futures = [[[executor.submit(file_errors, f, s, tuple(sorted(v.items())))
                     for s in run_seeds] for f in files] for v in sets]
        return [[[e for future in per_seed for e in future.result()] for per_seed in row]
                for row in futures]

    def measure_points(points: Sequence[np.ndarray[Any, Any]]) -> None:
        fresh = [p for p in points if _key(p) not in cache]
        for point, errors in zip(fresh, errors_for(paths, [_values(fit, p) for p in fresh]),
                                 strict=True):
            cache[_key(point)] = loss(errors)
            if progress is not None:
                progress(len(cache), cache[_key(point)])

    def objective(x: np.ndarray[Any, Any]) -> float:
        measure_points([x])
        return cache[_key(x)]

    # A first look over the whole box (a Latin hypercube, with the defaults), measured in
    # parallel, then Nelder-Mead from the best point with what is left of the budget; from a
    # given start, Nelder-Mead from there with all of it.
    origin = {f.name: f.default for f in fit} | dict(start or {})
    points = [np.array([(origin[f.name] - f.low) / (f.high - f.low) for f in fit])]
    if not start:
        survey = min(max(evaluations // 2, 1), 4 * len(fit))
        points += list(qmc.LatinHypercube(d=len(fit), seed=seed).random(survey - 1))
    measure_points(points)
    best = min(points, key=lambda p: cache[_key(p)])
    simplex = [best] + [np.clip(best + SIMPLEX_STEP * np.sign(0.5 - best[i] + 1e-9)
                                * np.eye(len(fit))[i], 0.0, 1.0) for i in range(len(fit))]
    remaining = evaluations - len(cache)
    if remaining > 0:
        minimize(objective, best, method="Nelder-Mead", bounds=[(0.0, 1.0)] * len(fit),
                 options={"maxfev": remaining, "initial_simplex": np.array(simplex),
                          "xatol": 0.01, "fatol": 1e-4})
    # the best set measured, wherever the search was when its budget ran out
    best_key = min(cache, key=lambda key: (cache[key], key))
    result_x, result_fun = np.array(best_key), cache[best_key]
    fitted = _values(fit, result_x)
    defaults = {f.name: f.default for f in fit}

    def reports(files: Sequence[Path]) -> tuple[FileReport, ...]:
        names = [str(p) for p in files]
        before, after = errors_for(names, [defaults, fitted])
        return tuple(FileReport(Path(n).name.removesuffix(".xz").removesuffix(".txt"),
                                loss([b]), loss([a]), _worst(b), _worst(a))
                     for n, b, a in zip(names, before, after, strict=True))

    return Calibration(fitted=fitted, train_loss=result_fun, evaluations=len(cache),
                       train=reports(train), test=reports(test))


def _key(x: np.ndarray[Any, Any]) -> tuple[float, ...]:
    return tuple(round(float(v), 6) for v in np.clip(x, 0.0, 1.0))


def _values(fit: Sequence[Fittable], x: np.ndarray[Any, Any]) -> dict[str, float]:
    clipped = np.clip(x, 0.0, 1.0)
    return {f.name: round(f.low + float(v) * (f.high - f.low), 4)
            for f, v in zip(fit, clipped, strict=True)}
