"""The time gap's lane at a narrow door: people who keep their headway only to whoever is in
their own lane pass a 0.7 m door in staggered lanes, as people do (the zipper effect), where
a lane of two radii makes each wait for the person beside the one in front."""

from __future__ import annotations

from pathlib import Path

import pytest
from shapely.geometry import box
from shapely.ops import unary_union

from hubero_dsl.pipeline import compile_source
from hubero_dsl.sim.simulation import Simulation
from hubero_dsl.world.drawing import grid_from_walkable
from hubero_dsl.world.mapfile import save_map

# the values fitted to the Juelich corridors with the lane (docs/fitted_juelich_lanes.hub)
FITTED = ("relaxation_time 0.2014 s; social_force.A 2.5855; social_force.B 0.1185 m; "
          "personal_space circle(radius: 0.3149 m); social_force.B_wall 0.2061 m; "
          "social_force.space_at_rest 0.7192; social_force.time_gap 0.1665 s")


def through_the_door(folder: Path, lane: float, seed: int) -> int:
    """How many of 40 people waiting in a 4 m room are through its 0.7 m door after 20 s."""
    walkable = unary_union([box(0, 0, 4, 4), box(3.9, 1.65, 4.5, 2.35), box(4.4, 0, 8.4, 4)])
    save_map(grid_from_walkable(walkable), folder / "door.yaml")
    text = (f'scenario "door"\nmap "{folder / "door.yaml"}"\nseed {seed}\ntime_limit 60 s\n'
            f"defaults {{ {FITTED}; social_force.time_gap_lane {lane} }}\n"
            "crowd queue 40 in rect((0.4, 0.4), (3.4, 3.6))\n"
            "activity go { queue move_around in rect((5.0, 0.5), (8.0, 3.5)) for 60 s }\n")
    sim = Simulation(compile_source(text, "door.hub"))
    for _ in range(400):
        sim.step()
    return int((sim.engine.humans.position[:, 0] > 4.5).sum())


@pytest.mark.parametrize("seed", [1, 2])
def test_a_lane_of_ones_own_lets_more_through_a_narrow_door(tmp_path: Path, seed: int) -> None:
    own_lane = through_the_door(tmp_path, 0.5, seed)
    two_radii = through_the_door(tmp_path, 1.0, seed)
    assert own_lane >= two_radii + 3   # 19-20 against 15-18 over seeds 1-4
