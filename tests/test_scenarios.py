"""Every scenario in scenarios/ is a test: it parses, checks clean under --strict, compiles to a
graph, and every variant runs to the end with every task SUCCEEDED and sane physics."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.distance import pdist

from hubero_dsl.graph.render import to_mermaid
from hubero_dsl.pipeline import check_file, compile_file, compile_source
from hubero_dsl.sim.loop import RunResult, run_program
from hubero_dsl.sim.scheduler import RunState
from hubero_dsl.sim.simulation import Simulation
from hubero_dsl.sim.status import TaskStatus

ROOT = Path(__file__).resolve().parents[1]
# the shipped scenarios and the social-navigation benchmark suite (docs/benchmark.md)
SCENARIOS = sorted([*(ROOT / "scenarios").glob("*.hub"),
                    *(ROOT / "scenarios" / "benchmark").glob("*.hub")])
ORIGINAL_MAPS = ROOT.parent / "shared" / "maps" / "hubero-original"
RUNS = [(path, variant) for path in SCENARIOS
        for variant in (list(compile_file(path).variants)[:4] or [None])]


def test_there_are_scenarios() -> None:
    assert {"living_room.hub", "parking.hub"} <= {p.name for p in SCENARIOS}


def test_the_benchmark_suite_is_collected() -> None:
    assert {"frontal_approach.hub", "overtaking.hub", "being_overtaken.hub", "crossing.hub",
            "doorway.hub", "narrow_corridor.hub", "crowd.hub",
            "joining_group.hub"} <= {p.name for p in SCENARIOS if p.parent.name == "benchmark"}


@pytest.mark.parametrize("path", SCENARIOS, ids=lambda p: p.name)
def test_scenario_checks_clean_and_compiles_to_a_graph(path: Path) -> None:
    result = check_file(path)
    assert result.diagnostics == ()
    assert result.program is not None
    graph = result.program.graph
    assert graph.number_of_nodes() > 0
    assert all("span" in data for _, data in graph.nodes(data=True))
    assert to_mermaid(graph).startswith("flowchart")


class Recorder:
    """Collects every tick's positions for the physics checks (NaN for the absent: the
    members of a flow who have not come or have left)."""

    def __init__(self) -> None:
        self.positions: list[np.ndarray] = []

    def __call__(self, sim: Simulation) -> None:
        humans = sim.engine.humans
        position = humans.position.copy()
        if humans.present is not None:
            position[~humans.present] = np.nan
        self.positions.append(position)


def run_with_record(path: Path, variant: str | None) -> tuple[Simulation, RunResult, Recorder]:
    sim = Simulation(compile_file(path), variant=variant)
    recorder = Recorder()
    return sim, run_program(sim, [recorder]), recorder


@pytest.mark.parametrize(("path", "variant"), RUNS, ids=lambda v: getattr(v, "name", str(v)))
def test_scenario_runs_to_the_end_with_sane_physics(path: Path, variant: str | None) -> None:
    sim, result, recorder = run_with_record(path, variant)
    assert result.state is RunState.COMPLETED, result.reason
    aborted = [e for e in result.events if e.status is TaskStatus.ABORTED]
    assert aborted == []
    assert all(e.held for e in result.expectations), [e.text for e in result.expectations
                                                      if not e.held]
    trajectory = np.stack(recorder.positions)             # (ticks, humans, 2)
    points = trajectory.reshape(-1, 2)
    assert sim.engine.grid.is_free(points[np.isfinite(points).all(axis=1)]).all()
    radius = sim.engine.humans.radius
    if len(radius) > 1:
        allowed = pdist(radius[:, None], lambda a, b: a[0] + b[0])
        closest = np.nanmin([pdist(frame) - allowed for frame in trajectory])
        assert closest > -0.05  # bodies never overlap by more than a few centimetres


def _aisle_visits(variant: str) -> int:
    sim, result, recorder = run_with_record(ROOT / "scenarios" / "parking.hub", variant)
    assert result.state is RunState.COMPLETED
    actor1 = np.stack(recorder.positions)[:, sim.engine.index_of("actor1")]
    in_aisle = (actor1[:, 0] > -3.6) & (actor1[:, 0] < -0.1) & (actor1[:, 1] < -6.9)
    return int(in_aisle.sum())


def test_parking_the_big_circle_keeps_actor1_out_of_the_narrow_aisle() -> None:
    assert _aisle_visits("square") > 20   # the 0.25 m square squeezes through
    assert _aisle_visits("circle") == 0   # the 0.70 m circle walks round through the gate


@pytest.mark.skipif(not ORIGINAL_MAPS.is_dir(), reason="shared/ maps are not beside the checkout")
@pytest.mark.parametrize("name", ["living_room", "parking"])
def test_paper_scenarios_also_run_on_the_original_maps(name: str) -> None:
    path = ROOT / "scenarios" / f"{name}.hub"
    original = (ORIGINAL_MAPS / f"{name}.yaml").resolve()
    text = path.read_text().replace(f'map "../maps/{name}.yaml"', f'map "{original}"')
    program = compile_source(text, str(path))
    for variant in program.variants:
        result = run_program(Simulation(program, variant=variant))
        assert result.state is RunState.COMPLETED, (variant, result.reason)
        assert not [e for e in result.events if e.status is TaskStatus.ABORTED]
