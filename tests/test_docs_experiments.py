"""docs/experiments.md quotes runs of the shipped scenarios: it must be what
scripts/experiments.py writes now, so that a change to the simulator cannot leave the page's
numbers behind."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_the_experiments_page_is_what_its_script_writes(tmp_path: Path) -> None:
    spec = importlib.util.spec_from_file_location("experiments", ROOT / "scripts" /
                                                  "experiments.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules["experiments"] = module  # dataclasses look their module up while being built
    spec.loader.exec_module(module)
    assert module.main(["--out", str(tmp_path)]) == 0
    written = (tmp_path / "experiments.md").read_text(encoding="utf-8")
    committed = (ROOT / "docs" / "experiments.md").read_text(encoding="utf-8")
    assert written == committed, "regenerate it: .venv/bin/python scripts/experiments.py"
    pictures = sorted(path.name for path in (tmp_path / "images").glob("*.png"))
    assert pictures == sorted(f"{name}.png" for name in (
        "living_room_circle", "living_room_ellipse", "living_room_diff", "parking_square",
        "parking_circle", "parking_diff_actor1"))
    for name in pictures:
        assert (ROOT / "docs" / "images" / name).is_file()
