"""`hubero graph`: formats, output files and errors, in-process with a stand-in program."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import networkx as nx
import pytest

from hubero_dsl import pipeline as compile_module
from hubero_dsl.diagnostics import Span, warning
from hubero_dsl.graph import picture as graph_picture
from hubero_dsl.graph import render as graph_render
from hubero_dsl.lang import ast

Cli = Callable[..., Any]
Write = Callable[[str, "str | bytes"], Path]


class FakeProgram:
    def __init__(self) -> None:
        self.graph = nx.DiGraph()
        self.graph.add_edge("start", "end")
        self.map_path = Path("nowhere.yaml")  # no map: nothing beside it to keep
        self.activities = ()


@pytest.fixture
def stand_in(monkeypatch: pytest.MonkeyPatch) -> list[tuple[str, object]]:
    """A checker that finds nothing wrong (one warning for `warned.hub`), and renderers that
    record what they were asked for."""
    calls: list[tuple[str, object]] = []

    def check_file(path: str) -> compile_module.CheckResult:
        found = (warning("W9", "odd", Span(path, 1, 1, 1, 9)),) if "warned" in path else ()
        source = ast.SourceFile(path, 'scenario "x"\n')
        return compile_module.CheckResult(source, found, FakeProgram())  # type: ignore[arg-type]

    def to_png(graph: nx.DiGraph, path: Path) -> Path:
        calls.append(("png", path))
        if not path.parent.is_dir():
            raise FileNotFoundError(2, "No such file or directory")
        path.write_bytes(b"\x89PNG")
        return path

    monkeypatch.setattr(compile_module, "check_file", check_file)
    monkeypatch.setattr(graph_render, "to_mermaid", lambda g: "flowchart TD\n  start --> end")
    monkeypatch.setattr(graph_render, "to_dot", lambda g: "digraph {\n  start -> end\n}\n")
    monkeypatch.setattr(graph_picture, "to_png", to_png)
    return calls


def test_mermaid_by_default(cli: Cli, stand_in: list[Any]) -> None:
    outcome = cli("graph", "x.hub")
    assert (outcome.status, outcome.out, outcome.err) == (0, "flowchart TD\n  start --> end\n",
                                                          "")


def test_dot(cli: Cli, stand_in: list[Any]) -> None:
    assert cli("graph", "x.hub", "--format", "dot").out.startswith("digraph {")


def test_output_file_and_format_from_its_suffix(cli: Cli, stand_in: list[Any],
                                                tmp_path: Path) -> None:
    target = tmp_path / "g.dot"
    outcome = cli("graph", "x.hub", "-o", str(target))
    assert (outcome.status, outcome.out) == (0, "")
    assert target.read_text(encoding="utf-8").startswith("digraph {")


@pytest.mark.parametrize("name", ["g.svg", "g.PDF", "g.jpg"])
def test_a_picture_hubero_does_not_draw_is_refused_with_the_command_that_does(
        cli: Cli, stand_in: list[Any], tmp_path: Path, name: str) -> None:
    # Mermaid text under an image's name was a file no viewer opens
    outcome = cli("graph", "s.hub", "-o", str(tmp_path / name))
    assert outcome.status == 2 and "--format dot | dot -T" in outcome.err
    assert not (tmp_path / name).exists()


@pytest.mark.parametrize("text_format", ["dot", "mermaid"])
def test_text_is_not_written_under_a_pictures_name(cli: Cli, stand_in: list[Any],
                                                   tmp_path: Path, text_format: str) -> None:
    # DOT text in g.png, exit 0: a file no viewer opened, and later refused as no PNG
    outcome = cli("graph", "x.hub", "--format", text_format, "-o", str(tmp_path / "g.png"))
    assert outcome.status == 2 and "writes text, not a picture" in outcome.err
    assert not (tmp_path / "g.png").exists()


def test_png_goes_to_the_output_file(cli: Cli, stand_in: list[Any], tmp_path: Path) -> None:
    target = tmp_path / "g.png"
    assert cli("graph", "x.hub", "-o", str(target)).status == 0
    # drawn beside it, then renamed into place: a failed drawing leaves nothing
    assert [kind for kind, _ in stand_in] == ["png"]
    assert target.read_bytes() == b"\x89PNG" and sorted(tmp_path.iterdir()) == [target]


@pytest.mark.parametrize("name", ["m", "g.txt", "g.svg", "g.jpg", "s2.hub", ".png"])
def test_a_png_is_written_to_a_name_ending_in_png_only(cli: Cli, stand_in: list[Any],
                                                       tmp_path: Path, name: str) -> None:
    # `-o m` wrote m.png: over a map's image named so
    outcome = cli("graph", "x.hub", "--format", "png", "-o", str(tmp_path / name))
    assert outcome.status == 2 and "give -o a name ending in .png" in outcome.err
    assert stand_in == [] and list(tmp_path.iterdir()) == []


def test_a_file_that_is_no_graph_is_not_written_over(cli: Cli, stand_in: list[Any],
                                                     tmp_path: Path) -> None:
    notes, picture = tmp_path / "notes.txt", tmp_path / "photo.png"
    notes.write_text("mine\n", encoding="utf-8")
    picture.write_bytes(b"GIF89a")
    for target, message in ((notes, "is not a graph"), (picture, "is not a PNG")):
        outcome = cli("graph", "x.hub", "-o", str(target))
        assert outcome.status == 2 and message in outcome.err
    assert notes.read_text(encoding="utf-8") == "mine\n"
    assert picture.read_bytes() == b"GIF89a"
    fresh = tmp_path / "graph.txt"       # a new file may have any name
    assert cli("graph", "x.hub", "-o", str(fresh)).status == 0
    assert cli("graph", "x.hub", "-o", str(tmp_path / "g.mmd")).status == 0
    assert cli("graph", "x.hub", "-o", str(tmp_path / "g.mmd")).status == 0  # a graph again


def test_png_needs_an_output_file(cli: Cli, stand_in: list[Any]) -> None:
    outcome = cli("graph", "x.hub", "--format", "png")
    assert outcome.status == 2
    assert "-o" in outcome.err
    assert stand_in == []


@pytest.mark.parametrize("name", ["g.mmd", "g.png"])
def test_unwritable_output_exits_2(cli: Cli, stand_in: list[Any], tmp_path: Path,
                                   name: str) -> None:
    outcome = cli("graph", "x.hub", "-o", str(tmp_path / "no" / "such" / name))
    assert outcome.status == 2
    assert "cannot be written" in outcome.err


def test_warnings_go_to_stderr_and_the_graph_is_still_printed(cli: Cli,
                                                              stand_in: list[Any]) -> None:
    outcome = cli("graph", "warned.hub")
    assert outcome.status == 0
    assert outcome.out.startswith("flowchart TD")
    assert outcome.err.startswith("warning[W9]: odd")


def test_errors_go_to_stderr_and_exit_1(cli: Cli, write: Write) -> None:
    outcome = cli("graph", str(write("a.hub", "scenario 'x'\n")))
    assert (outcome.status, outcome.out) == (1, "")
    assert outcome.err.startswith("error[E002]")


def test_unreadable_input_exits_2(cli: Cli, tmp_path: Path) -> None:
    outcome = cli("graph", str(tmp_path / "missing.hub"))
    assert outcome.status == 2
    assert outcome.err == f"error: {tmp_path / 'missing.hub'}: no such file\n"
