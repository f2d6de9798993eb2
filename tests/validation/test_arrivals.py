"""People who enter at given times: a flow built in code with explicit arrival times."""

from __future__ import annotations

import dataclasses
from pathlib import Path

from hubero_dsl.pipeline import compile_source
from hubero_dsl.sim.simulation import Simulation

CORRIDOR = Path(__file__).resolve().parents[2] / "maps" / "rimea_corridor.yaml"
SOURCE = f'''scenario "arrivals"
map "{CORRIDOR}"
area door rect((1.0, 0.5), (2.0, 1.5))
flow walkers from door to (40.0, 1.0) rate 1 /s for 10 s
'''


def test_members_enter_at_their_times_and_not_before() -> None:
    program = compile_source(SOURCE, str(CORRIDOR.parent / "x.hub"))
    (flow,) = program.flows
    arrivals = (0.0, 2.0, 2.0, 5.5) + (1e9,) * (len(flow.members) - 4)
    program = dataclasses.replace(program, flows=(dataclasses.replace(flow,
                                                                      arrivals=arrivals),))
    sim = Simulation(program)
    present = sim.engine.humans.present
    seen: dict[str, float] = {}
    while sim.time < 8.0:
        sim.step()
        assert present is not None
        for row in present.nonzero()[0]:
            seen.setdefault(sim.engine.humans.names[row], sim.time)
    entered = sorted(seen.values())
    assert len(entered) == 4  # the later times lie beyond the flow's 10 s: nobody else came
    step = sim.dt
    for expected, got in zip((0.0, 2.0, 2.0, 5.5), entered, strict=True):
        assert expected <= got <= expected + 2 * step + 0.5  # the second at 2 s may wait a tick
