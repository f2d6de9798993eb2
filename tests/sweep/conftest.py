"""Tiny scenarios for the sweep tests: one or two humans in the living room, runs of a second."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pytest

REPO_ROOT = Path(__file__).resolve().parents[2]
MAP = REPO_ROOT / "maps" / "living_room.yaml"

# Two sweep values x one named variant, and a drawn speed so that the seed matters.
SWEPT = """\
scenario "sweep test"
map "{map}"
seed 4
time_limit 20 s
human a at (1, 1) {{ speed normal(1.2 m/s, 0.2 m/s) }}
human b at (1, 2)
variant slow {{ speed 0.6 m/s
    b.personal_space ellipse(semi_major: 0.6 m, semi_minor: 0.4 m) }}
sweep avoidance_strength in [0.5, 1.5]
activity {{ a move_to (2, 1) }}
activity {{ b move_to (2, 2) }}
"""

# quick completes; late completes but misses its expectation; slow runs out of time.
OUTCOMES = """\
scenario "outcomes"
map "{map}"
time_limit 3 s
human a at (1, 1)
variant quick {{ speed 1.3 m/s }}
variant late {{ speed 0.7 m/s }}
variant slow {{ speed 0.1 m/s }}
activity {{ a move_to (2, 1) }}
expect a reaches (2, 1) within 1.5 s
"""

# The task is aborted (too slow for its `within`): the run fails under `on_failure stop`.
ABORTED = """\
scenario "aborted"
map "{map}"
human a at (1, 1)
activity {{ a move_to (3, 1) within 0.5 s }}
"""

# No variants: the sweep runs the scenario as written.
PLAIN = """\
scenario "plain"
map "{map}"
seed 9
human a at (1, 1)
activity {{ a move_to (1.5, 1) }}
"""

def wandering(map_path: Path | str, seconds: float) -> str:
    """Two people wandering for `seconds`: a run that lasts long enough to be stopped in."""
    return (f'scenario "wandering"\nmap "{map_path}"\ntime_limit 2 min\n'
            "human a at (1, 1)\nhuman b at (3, 1)\n"
            + "".join(f"activity {{ {who} move_around in rect((0, 0), (4, 3)) for {seconds} s }}\n"
                      for who in "ab"))


Write = Callable[[str], Path]


@pytest.fixture
def write_scenario(tmp_path: Path) -> Write:
    """`write_scenario(TEMPLATE)` puts a scenario using the living-room map in tmp_path."""

    def write(template: str, name: str = "s.hub") -> Path:
        path = tmp_path / name
        path.write_text(template.format(map=MAP), encoding="utf-8")
        return path

    return write
