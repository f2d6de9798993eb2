"""docs/robots.md's Python examples of the Gymnasium environment run as written, on the page's
own delivery scenario with its robot handed to the environment (fewer steps and copies)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

pytest.importorskip("gymnasium")

REPO_ROOT = Path(__file__).resolve().parents[1]
ROBOTS = REPO_ROOT / "docs" / "robots.md"
SHORTER = ((r"num_envs=64", "num_envs=3"), (r"range\(1000\)", "range(30)"),
           (r"range\(20\)", "range(2)"))


def _page() -> str:
    return ROBOTS.read_text(encoding="utf-8")


def _gym_examples() -> list[str]:
    """The Python blocks that make the environment, dedented (some sit in list items);
    RecordVideo's needs moviepy, which hubero does not install."""
    blocks = re.findall(r"^( *)```python\n(.*?)^\1```", _page(), flags=re.M | re.S)
    examples = []
    for indent, block in blocks:
        code = "\n".join(line[len(indent):] for line in block.splitlines())
        if "hubero/Scenario-v0" in code and "RecordVideo" not in code:
            examples.append(code)
    return examples


def _scenario(folder: Path) -> Path:
    """The page's delivery among guests, its cart driven from outside towards its goal."""
    text = re.search(r"```hub\n(scenario \"A delivery among guests\".*?)```", _page(),
                     flags=re.S).group(1)
    text = text.replace('map "../maps/', f'map "{REPO_ROOT / "maps"}/')
    text = text.replace("controller navigator", "controller external\n    goal (3.5, 0.5)")
    text = text.replace("    navigator.safety_margin 0.25 m\n", "")
    text = text.replace("activity { deliver: cart move_to (3.5, 0.5) within 60 s }\n", "")
    text = text.replace("expect deliver done within 60 s\n", "")
    file = folder / "my_scenario.hub"
    file.write_text(text, encoding="utf-8")
    return file


def test_the_page_shows_the_environment() -> None:
    assert len(_gym_examples()) == 3  # training, the vector env, evaluating a policy


def test_the_gym_examples_of_the_page_run_in_turn(tmp_path: Path,
                                                 monkeypatch: pytest.MonkeyPatch) -> None:
    """In the page's order and one namespace, as a reader pastes them (the vector env's
    example goes on from the first one's imports)."""
    _scenario(tmp_path)
    monkeypatch.chdir(tmp_path)           # the examples name my_scenario.hub and write logs
    namespace: dict[str, object] = {}
    for index, code in enumerate(_gym_examples()):
        for pattern, shorter in SHORTER:
            code = re.sub(pattern, shorter, code)
        exec(compile(code, f"{ROBOTS}:example {index}", "exec"), namespace)  # our own docs
    assert (tmp_path / "episode.mcap").is_file()      # the first example's log
    assert len(namespace["finished"]) == 2             # the evaluation's episodes


def test_the_pages_controller_drives_its_unicycle_towards_the_goal() -> None:
    # it answered (vx, vy) whatever the kinematics: the page's unicycle turned in circles
    from hubero_dsl.pipeline import compile_source
    from hubero_dsl.sim.simulation import Simulation

    code = re.search(r"## Writing a controller.*?```python\n(.*?)```", _page(), flags=re.S)
    namespace: dict[str, object] = {}
    exec(compile(code.group(1), f"{ROBOTS}:GoStraight", "exec"), namespace)  # our own docs
    text = (f'scenario "s"\nmap "{REPO_ROOT / "maps" / "living_room.yaml"}"\n'
            "robot cart at (6.3, 2.5) heading 180 deg { kinematics unicycle; goal (4.8, 1.0) }\n"
            "activity { cart move_to (4.8, 1.0) }\n")
    sim = Simulation(compile_source(text, "s.hub"), controllers={"cart": namespace["GoStraight"]})
    for _ in range(200):
        sim.step()
    assert sim.engine.robots.specs[0].kinematics == "unicycle"
    x, y = sim.robot("cart").position
    assert (x - 4.8) ** 2 + (y - 1.0) ** 2 < 0.3 ** 2
