"""`hubero check` and `hubero graph` through the real parser, checker, map and graph renderers."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

REPO_ROOT = Path(__file__).resolve().parents[2]
LIVING_ROOM_MAP = REPO_ROOT / "maps" / "living_room.yaml"

Cli = Callable[..., Any]
Write = Callable[[str, "str | bytes"], Path]

pytestmark = pytest.mark.skipif(not LIVING_ROOM_MAP.exists(), reason="maps/ is not built")

SCENARIO = """\
scenario "Living room: dinner invitation"
map "{map}"
seed 7

place sofa  (5.5, 1.0) heading 75 deg
place table (1.0, -2.5)

human actor1 at (6.30, 2.50) heading 180 deg
human actor2 at (3.80, -5.30) heading 90 deg

activity dinner {{
    invite: actor2 move_to sofa
    actor2 talk to actor1 for 5 s
    parallel {{
        actor2 move_to table heading -160 deg
        actor1 move_to (0.6, -2.0) heading -135 deg
    }}
}}
"""


def scenario(write: Write, name: str, extra: str = "") -> Path:
    return write(name, SCENARIO.format(map=LIVING_ROOM_MAP.as_posix()) + extra)


def test_a_clean_scenario_passes_even_strictly(cli: Cli, write: Write) -> None:
    path = scenario(write, "clean.hub")
    for options in ((), ("--strict",)):
        outcome = cli("check", *options, str(path))
        assert (outcome.status, outcome.out) == (0, "0 errors, 0 warnings in 1 file\n")


def test_warnings_pass_unless_strict(cli: Cli, write: Write) -> None:
    path = scenario(write, "warned.hub", "place unused (1.0, -2.0)\n")
    relaxed, strict = cli("check", str(path)), cli("check", "--strict", str(path))
    assert relaxed.status == 0 and strict.status == 1
    assert relaxed.out.startswith("warning[")
    assert relaxed.out.splitlines()[-1] == "0 errors, 1 warning in 1 file"
    assert strict.out.splitlines()[-1].endswith("(--strict: warnings fail the check)")


def test_errors_in_one_file_of_several(cli: Cli, write: Write) -> None:
    clean = scenario(write, "clean.hub")
    broken = scenario(write, "broken.hub", "human actor3 at (6.30, 2.50) { sped 1 m/s }\n")
    outcome = cli("check", "--format", "json", str(clean), str(broken))
    document = json.loads(outcome.out)
    assert outcome.status == 1
    assert [f["status"] for f in document["files"]] == ["clean", "errors"]
    assert document["summary"]["exit_status"] == 1
    for diagnostic in document["files"][1]["diagnostics"]:
        assert diagnostic["file"] == str(broken)
        assert diagnostic["line"] >= 1 and diagnostic["code"]


def test_an_empty_file_is_an_error_not_a_crash(cli: Cli, write: Write) -> None:
    outcome = cli("check", str(write("empty.hub", "")))
    assert outcome.status == 1
    assert outcome.out.startswith("error[")


def test_graph_as_mermaid_and_dot(cli: Cli, write: Write) -> None:
    path = scenario(write, "clean.hub")
    mermaid = cli("graph", str(path))
    assert mermaid.status == 0 and mermaid.err == ""
    assert mermaid.out.startswith("flowchart")
    assert "invite: actor2 move_to sofa" in mermaid.out
    dot = cli("graph", "--format", "dot", str(path))
    assert dot.status == 0
    assert dot.out.lstrip().startswith(("digraph", "strict digraph"))
