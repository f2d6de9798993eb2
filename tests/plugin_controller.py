"""A controller plugin package as `pip install` would leave it in site-packages: `straight_drive`
(drives straight at its goal, at its cruise speed scaled by `gain`, blind to people and walls),
with metadata that registers it under the entry-point group `hubero.controllers`.

Tests of plugins (tests/sim/test_robots_under_test.py) and of the benchmark with a controller
of the user's own (tests/sweep/test_bench.py) install it into a folder of their own and put that
folder on the path.
"""

from __future__ import annotations

from pathlib import Path

SOURCE = (
    "from pydantic import Field\n"
    "from hubero_dsl.controllers.base import ControllerParams\n"
    "class Params(ControllerParams):\n"
    "    gain: float = Field(default=1.0, gt=0)\n"
    "class StraightDrive:\n    Params = Params\n"
    "    def __init__(self, body, params):\n"
    "        self.body, self.gain = body, params.gain\n"
    "    def command(self, observation):\n"
    "        if observation.goal is None:\n            return (0.0, 0.0)\n"
    "        dx = observation.goal[0] - observation.position[0]\n"
    "        dy = observation.goal[1] - observation.position[1]\n"
    "        d = max((dx * dx + dy * dy) ** 0.5, 1e-9)\n"
    "        v = min(self.body.speed, self.gain * d)\n"
    "        return (v * dx / d, v * dy / d)\n")


def install_straight_drive(site: Path) -> Path:
    """Write the package and its dist-info into `site`; returns `site`."""
    (site / "straight_drive").mkdir(parents=True, exist_ok=True)
    (site / "straight_drive" / "__init__.py").write_text(SOURCE, encoding="utf-8")
    info = site / "straight_drive-0.1.dist-info"
    info.mkdir(exist_ok=True)
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: straight-drive\n"
                                   "Version: 0.1\n", encoding="utf-8")
    (info / "entry_points.txt").write_text(
        "[hubero.controllers]\nstraight_drive = straight_drive:StraightDrive\n",
        encoding="utf-8")
    return site
