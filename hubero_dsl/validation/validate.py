"""`validate`: recordings of real people against their rebuilds, file by file.

    results = validate([Path("uo-180-180-070.txt")], seed=1)   # [] for the shipped recordings
    for result in results:
        print(result.comparison.worst_error)

Each recording is loaded and analysed by PedPy, its steady state rebuilt with everyone
arriving when and where they were measured and run (`rebuild`), the run analysed the same way,
and the two compared per density bin (`compare`). Desired speeds come from the free-flow
recording of the file's series (shipped), so that a congested recording does not lend its own
slowness to the people who rebuild it. Deterministic: same files, seed and parameters,
same results.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy.typing as npt

from hubero_dsl.diagnostics import Diagnostic, Span
from hubero_dsl.errors import InputError
from hubero_dsl.model.program import ParamValue
from hubero_dsl.validation.compare import Comparison, compare
from hubero_dsl.validation.experiments import (
    Experiment,
    experiment_for,
    load_trajectory,
    shipped,
    shipped_path,
)
from hubero_dsl.validation.fundamental import Diagram, fundamental_diagram, pooled
from hubero_dsl.validation.rebuild import desired_speeds, simulate_experiment

EVERY_FRAME = (0, 2**62)


@dataclass(frozen=True)
class Measured:
    """A recording, loaded and analysed once, ready to be compared with any number of runs."""

    experiment: Experiment
    trajectory: Any            # pedpy.TrajectoryData
    diagram: Diagram
    speeds: npt.NDArray[Any]   # desired speeds of the series


@dataclass(frozen=True)
class Validation:
    measured: Measured
    simulated: Diagram
    comparison: Comparison


def experiments_of(paths: Sequence[Path]) -> list[Experiment]:
    """The experiments of the given files, or the shipped ones when none is given."""
    return [experiment_for(Path(p)) for p in paths] if paths else shipped()


def measure(experiments: Sequence[Experiment]) -> list[Measured]:
    """Load and analyse each recording (errors for unreadable files come first, before any
    simulation)."""
    free: dict[str, npt.NDArray[Any]] = {}
    measured = []
    for experiment in experiments:
        trajectory = load_trajectory(experiment)
        if experiment.free_flow not in free:
            reference = experiment_for(shipped_path(experiment.free_flow))
            if reference.name == experiment.name:  # this file is itself the free flow
                reference = experiment
            source = trajectory if reference is experiment else load_trajectory(reference)
            free[experiment.free_flow] = desired_speeds(source, reference)
        measured.append(Measured(experiment, trajectory,
                                 fundamental_diagram(trajectory, experiment),
                                 free[experiment.free_flow]))
    return measured


def simulate_and_compare(measured: Measured, *, seed: int,
                         params: Mapping[str, ParamValue] | None = None,
                         speed_scale: float = 1.0, seeds: int = 1) -> Validation:
    """Rebuild and run one recording (`params` over every person, desired speeds times
    `speed_scale`) with the seeds `seed` .. `seed + seeds - 1`, and compare their frames,
    pooled, with the measurement."""
    experiment = measured.experiment
    simulated = pooled([
        fundamental_diagram(simulate_experiment(experiment, measured.trajectory,
                                                measured.speeds * speed_scale, seed=s,
                                                params=params),
                            experiment, steady=EVERY_FRAME)
        for s in range(seed, seed + seeds)])
    return Validation(measured, simulated, compare(experiment.name, measured.diagram, simulated))


def validate(paths: Sequence[Path], *, seed: int = 1,
             params: Mapping[str, ParamValue] | None = None,
             seeds: int = 1) -> list[Validation]:
    return [simulate_and_compare(m, seed=seed, params=params, seeds=seeds)
            for m in measure(experiments_of(paths))]


MAX_DEFAULTS_BYTES = 2**20


def load_defaults(path: Path) -> dict[str, ParamValue]:
    """The parameters of a file holding a `defaults { }` block (as `hubero calibrate -o`
    writes), checked by the language: the block is compiled under a scenario header of its
    own line, and messages are moved up that line, to the file's own lines and columns.
    CompileError for errors in it."""
    import tempfile

    import numpy as np

    from hubero_dsl.errors import CompileError
    from hubero_dsl.files import read_bounded
    from hubero_dsl.pipeline import compile_source, first_other_than_defaults
    from hubero_dsl.world.grid import OccupancyGrid
    from hubero_dsl.world.mapfile import save_map

    try:
        text = read_bounded(path, MAX_DEFAULTS_BYTES, "defaults file").decode("utf-8")
    except UnicodeDecodeError:
        raise InputError(f"defaults file {path} is not UTF-8 text") from None
    with tempfile.TemporaryDirectory(prefix="hubero-defaults-") as folder:
        map_yaml = Path(folder) / "room.yaml"
        save_map(OccupancyGrid(np.zeros((20, 20), dtype=bool), 0.1, (0.0, 0.0)), map_yaml)
        header = f'scenario "defaults"; map "{map_yaml}"\n'
        try:
            other = first_other_than_defaults(header + text, str(path), after=2)
            if other is not None:  # a place, a human, a second scenario line
                raise InputError(f"{path}:{other.line - 1}:{other.column}: a defaults file "
                                 "holds a `defaults { }` block only")
            program = compile_source(header + text, str(path))
        except CompileError as exc:
            raise CompileError([_line_up(d) for d in exc.diagnostics]) from None
    return dict(program.defaults.values)


def _line_up(diagnostic: Diagnostic) -> Diagnostic:
    """A diagnostic of a defaults file compiled under a one-line header, at the file's own
    lines (one up); notes pointing into the header ("first given here") are dropped, as the
    file has no such line."""
    related = tuple(replace(r, span=_span_up(r.span)) for r in diagnostic.related
                    if r.span.line > 1)
    span = None if diagnostic.span is None else _span_up(diagnostic.span)
    return replace(diagnostic, span=span, related=related)


def _span_up(span: Span) -> Span:
    return replace(span, line=max(1, span.line - 1), end_line=max(1, span.end_line - 1))
