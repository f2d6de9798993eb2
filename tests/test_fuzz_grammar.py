"""Grammar-aware fuzzing: scenarios built from the language's own statements, with random names,
values, units and extreme numbers, are checked and, when they check clean, run.

`check_source` must never raise, and a run of a clean scenario must end or raise one of
hubero's own errors (a SimulationError, a controller's error): never anything else. In CI the
search is derandomized and bounded (HUBERO_FUZZ_EXAMPLES, default 60 examples, a few seconds);
for a long local search give more and a fresh seed:

    HUBERO_FUZZ_EXAMPLES=100000 HUBERO_FUZZ_RANDOM=1 python -m pytest tests/test_fuzz_grammar.py
"""

from __future__ import annotations

import contextlib
import os
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from hubero_dsl.errors import HuberoError
from hubero_dsl.pipeline import check_source
from hubero_dsl.simulate import simulate
from hubero_dsl.world.grid import OccupancyGrid
from hubero_dsl.world.mapfile import save_map

EXAMPLES = int(os.environ.get("HUBERO_FUZZ_EXAMPLES", "60"))
FUZZ = settings(max_examples=EXAMPLES, deadline=None, database=None,
                derandomize=os.environ.get("HUBERO_FUZZ_RANDOM") != "1",
                suppress_health_check=list(HealthCheck))

NAMES = ["alice", "bob", "carol", "dave"]
# plain values most of the time, so that many scenarios check clean and run; extremes sometimes
NUMBERS = ["1", "2.5", "0.5", "3", "1", "2.5", "0.5", "3", "0", "-1", "1e308", "-1e308",
           "1e-300", "7.9"]
UNITS = {"length": ["m", "cm", "mm"], "time": ["s", "ms", "min"], "speed": ["m/s", "km/h"],
         "angle": ["deg", "rad"]}
TASKS = ["stand", "move_to", "run_to", "move_around", "follow", "talk", "sit_down", "lie_down",
         "teleop", "walk_to", "stands"]


@pytest.fixture(scope="module")
def room(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("fuzz")
    occupied = np.zeros((80, 100), dtype=bool)
    occupied[[0, -1], :] = occupied[:, [0, -1]] = True
    occupied[30:50, 48:52] = True
    save_map(OccupancyGrid(occupied, 0.1, (0.0, 0.0)), folder / "room.yaml")
    return folder


@st.composite
def quantity(draw: st.DrawFn, dimension: str) -> str:
    number = draw(st.sampled_from(NUMBERS))
    unit = draw(st.sampled_from([*UNITS[dimension] * 4, "", "kg"]))
    return f"{number} {unit}".strip()


@st.composite
def point(draw: st.DrawFn) -> str:
    if draw(st.booleans()):
        return draw(st.sampled_from(["home", "home", *NAMES, "cart", "nowhere"]))
    x = draw(st.sampled_from(["1", "2.5", "8", "3", "7", "-3", "1e308", "9.95", "5"]))
    y = draw(st.sampled_from(["1", "4", "7", "2", "6", "0", "-1e308", "7.95"]))
    return f"({x}, {y})"


@st.composite
def area(draw: st.DrawFn) -> str:
    return draw(st.sampled_from(["rect((1, 1), (4, 7))", "zone", "zone", "polygon((1, 1), "
                                 "(2, 2))", "polygon((1, 1), (3, 1), (3, 3))",
                                 "rect((0, 0), (0, 0))"]))


@st.composite
def task_step(draw: st.DrawFn) -> str:
    actor = draw(st.sampled_from([*NAMES, *NAMES, "cart", "crowd1", "ghost"]))
    kind = draw(st.sampled_from([*TASKS[:9], "stand", "move_to", "move_to", *TASKS]))
    words = [actor, kind]
    if kind in ("move_to", "run_to", "follow") or draw(st.integers(0, 5)) == 0:
        words.append(draw(point()))
    options = {"for": lambda: draw(quantity("time")), "heading": lambda: draw(quantity("angle")),
               "speed": lambda: draw(quantity("speed")), "at": lambda: draw(point()),
               "to": lambda: draw(point()), "facing": lambda: draw(point()),
               "in": lambda: draw(area()), "times": lambda: draw(st.sampled_from(["1", "0",
                                                                                  "2.5"]))}
    if draw(st.integers(0, 3)) > 0 and kind not in ("move_to", "run_to"):
        words += ["for", draw(st.sampled_from(["1 s", "0.5 s", "2 s"]))]  # a natural end
    elif draw(st.booleans()):
        for keyword in draw(st.lists(st.sampled_from(sorted(options)), max_size=2,
                                     unique=True)):
            words += [keyword, options[keyword]()]
    ending = draw(st.sampled_from(["", "", "", "forever", "within 5 s", "until time > 1 s"]))
    return " ".join(words + ([ending] if ending else []))


@st.composite
def step(draw: st.DrawFn, depth: int = 0) -> str:
    choices = ["task", "task", "task", "task", "wait", "wait_until"] + (["parallel", "race",
                                                                         "repeat"]
                                                       if depth < 2 else [])
    kind = draw(st.sampled_from(choices))
    if kind == "task":
        return draw(task_step())
    if kind == "wait":
        return f"wait {draw(quantity('time'))}"
    if kind == "wait_until":
        return "wait until " + draw(condition())
    inner = "; ".join(draw(st.lists(step(depth + 1), min_size=0, max_size=3)))
    if kind == "repeat":
        return f"repeat {draw(st.sampled_from(['1', '2', '0']))} {{ {inner} }}"
    return f"{kind} {{ {inner} }}"


@st.composite
def condition(draw: st.DrawFn) -> str:
    return draw(st.sampled_from([
        "l1 done", "l1 started", "alice reaches home", "distance(alice, bob) < 1 m",
        "alice in zone", "time >= 2 s", "all crowd1 reach home", "any crowd1 reaches (2, 2)",
        "count(crowd1 in zone) >= 1", "not l1 failed", "l1 done and time > 1 s",
        "cart reaches (8, 2)"]))


@st.composite
def scenario(draw: st.DrawFn) -> str:
    lines = ['scenario "fuzz"', 'map "room.yaml"', f"seed {draw(st.integers(0, 3))}",
             f"time_limit {draw(st.sampled_from(['2 s', '1 s', '3 s']))}",
             "place home (2, 2)", "area zone rect((1, 1), (4, 7))"]
    positions = ["(1, 1)", "(3, 6)", "(7, 2)", "(8, 6)"]
    for name, start in zip(NAMES, positions, strict=True):
        where = start if draw(st.integers(0, 5)) else draw(point())
        params = draw(st.lists(st.sampled_from([
            f"speed {draw(quantity('speed'))}", f"radius {draw(quantity('length'))}",
            "personal_space ellipse(semi_major: 1 m, semi_minor: 0.5 m)",
            f"social_force.A {draw(st.sampled_from(NUMBERS))}", "robot_reaction scared"]),
            max_size=1 if draw(st.integers(0, 3)) else 2))
        lines.append(f"human {name} at {where} {{ {'; '.join(params)} }}")
    crowd_area = "zone" if draw(st.integers(0, 4)) else draw(area())
    lines.append(f"crowd crowd1 {draw(st.sampled_from(['3', '3', '3', '0', '40000']))} in "
                 f"{crowd_area}")
    if draw(st.integers(0, 5)):
        controller = draw(st.sampled_from(["navigator", "navigator", "external", '"os:system"',
                                           "nav"]))
        lines.append(f"robot cart at (8, 2) {{ controller {controller}; kinematics "
                     f"{draw(st.sampled_from(['unicycle', 'holonomic', 'holonomic', 'tank']))} }}")
    if draw(st.booleans()):
        lines.append(f"sweep speed in [{draw(quantity('speed'))}, 1 m/s]")
    steps = draw(st.lists(step(), min_size=1, max_size=4))
    lines.append("activity { " + "; ".join(f"l1: {steps[0]}" if i == 0 else s
                                          for i, s in enumerate(steps)) + " }")
    lines.append(f"expect {draw(condition())} {draw(st.sampled_from(['always', 'eventually']))}")
    return "\n".join(lines) + "\n"


@FUZZ
@given(text=scenario())
def test_generated_scenarios_check_and_run_within_the_contract(room: Path, text: str) -> None:
    result = check_source(text, str(room / "fuzz.hub"))
    if result.program is None:
        assert result.errors, text
        return
    variant = next(iter(result.program.variants), None)
    # a run may fail with hubero's own error (a diverged force model, a controller)
    with contextlib.suppress(HuberoError):
        simulate(result.program, variant=variant)
