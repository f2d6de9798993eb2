"""Mermaid, DOT and PNG renderings of the activity graph, and the words nodes are shown with."""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import networkx as nx
import numpy as np
import pytest
from PIL import Image

from hubero_dsl.graph.build import build_activity_graph, signals
from hubero_dsl.graph.picture import layout, to_png
from hubero_dsl.graph.render import describe_node, to_dot, to_mermaid
from hubero_dsl.lang import ast
from hubero_dsl.lang.parse import parse_source
from hubero_dsl.lang.text import format_condition
from hubero_dsl.pipeline import lower_activities

SCENARIO = """\
activity dinner {
    invite: actor2 move_to sofa
    wait until invite done and distance(actor1, actor2) < 2 m
    both: parallel {
        actor2 talk to actor1 for 5 s
        { wait 500ms; actor1 move_to (0.6, -2.0) heading -135 deg }
    }
    race { actor1 stand forever; wait 10 s }
    repeat 2 { actor1 move_around in rect((0, 0), (4, 4)) times 3 }
}
activity { actor3 talk to "say \\"hi\\" #1" for 2 s }
"""


def graph_of(text: str) -> nx.DiGraph:
    module = parse_source(text, "t.hub")
    return build_activity_graph(lower_activities(module))


@pytest.fixture(scope="module")
def graph() -> nx.DiGraph:
    return graph_of(SCENARIO)


def test_nodes_are_described_in_the_scenarios_words(graph: nx.DiGraph) -> None:
    words = [describe_node(graph, n) for n in graph.nodes]
    assert words[:6] == ["start", "invite: actor2 move_to sofa",
                         "wait until invite done and distance(actor1, actor2) < 2 m",
                         "begin both", "parallel", "actor2 talk to actor1 for 5 s"]
    assert "wait 500 ms" in words
    assert "actor1 move_to (0.6, -2.0) heading -135 deg" in words
    assert "actor1 move_around in rect((0, 0), (4, 4)) times 3" in words
    assert [w for w in words if "repeat" in w or "rounds" in w] == ["repeat 2", "2 rounds done?"]
    assert 'actor3 talk to "say \\"hi\\" #1" for 2 s' in words


@pytest.mark.parametrize("text", [
    "a done", "not a done", "a done and (b started or c failed)",
    "not (a done and b done) or time >= 5 s", "h in rect((0, 0), (1, 1))",
    "h reaches sofa and distance(h, (1, 2)) <= 0.5 m",
])
def test_conditions_read_back_as_written(text: str) -> None:
    module = parse_source(f"activity a {{ wait until {text} }}", "t.hub")
    step = module.of_type(ast.ActivityDecl)[0].steps[0]
    assert isinstance(step, ast.WaitUntilStep)
    assert format_condition(step.condition) == text


def test_mermaid_shapes(graph: nx.DiGraph) -> None:
    text = to_mermaid(graph)
    assert text.startswith("flowchart TD\n")
    assert text.count("subgraph ") == 2 and text.count("\n    end\n") == 2
    assert '    a1_0(("●"))' in text                              # initial
    assert '    a1_17((("●")))' in text                            # final
    assert '    a1_1("invite: actor2 move_to sofa")' in text       # action
    assert ('    a1_2>"wait until invite done and distance(actor1, actor2) #60; 2 m"]'
            in text)                                                # accept event
    assert '    a1_6[/"wait 500 ms"\\]' in text                    # time event
    assert '    a1_14{"repeat 2"}' in text                          # merge
    assert '    a1_16 -.->|"next round"| a1_14' in text            # loop back
    assert 'a2_1("actor3 talk to #34;say \\#34;hi\\#34; #35;1#34; for 2 s")' in text
    assert re.search(r"class [a-z0-9_,]*a1_4[a-z0-9_,]* bar", text)


def test_mermaid_has_one_edge_line_per_edge_and_per_signal(graph: nx.DiGraph) -> None:
    assert len(signals(graph)) == 1              # `wait until invite done and ...`
    assert len(re.findall(r" -(?:->|\.->)", to_mermaid(graph))) == \
        graph.number_of_edges() + 1


def test_dot_quotes_ids_and_escapes_labels(graph: nx.DiGraph) -> None:
    text = to_dot(graph)
    assert text.startswith("digraph activities {\n") and text.endswith("}\n")
    assert '"activity#2/1" [shape=box, style=rounded, ' \
           'label="actor3 talk to \\"say \\\\\\"hi\\\\\\" #1\\" for 2 s"];' in text
    assert '"dinner/16" -> "dinner/14" [style=dashed, constraint=false, label="next round"];' \
        in text
    assert text.count(" -> ") == graph.number_of_edges() + len(signals(graph))


@pytest.mark.skipif(shutil.which("dot") is None, reason="graphviz is not installed")
def test_dot_is_accepted_by_graphviz(graph: nx.DiGraph, tmp_path: Path) -> None:
    result = subprocess.run(["dot", "-Tsvg"], input=to_dot(graph), capture_output=True,
                            text=True, check=False, timeout=30)
    assert result.returncode == 0, result.stderr
    assert result.stderr == ""
    assert "actor3 talk to &quot;say \\&quot;hi\\&quot; #1&quot; for 2 s" in result.stdout


WAITS_ACROSS = """\
activity one {
    arrive: a move_to (2.0, -2.8)
    wait until back started
}
activity two {
    wait until arrive done
    back: { b move_to (0.6, -2.0); b stand for 1 s }
    b move_around for 9 s until arrive done or back failed
}
"""


def test_waits_are_drawn_from_the_event_they_wait_for() -> None:
    graph = graph_of(WAITS_ACROSS)
    found = {(s.source, s.target, s.event.value) for s in signals(graph)}
    # move_to ends `arrive`; `back` starts at its begin node, and can fail from there on
    assert found == {("one/1", "two/1", "done"), ("two/2", "one/2", "started"),
                     ("one/1", "two/6", "done"), ("two/2", "two/6", "failed")}
    mermaid = to_mermaid(graph)
    assert '    a1_1 -.->|"done"| a2_1\n' in mermaid
    assert '    a2_2 -.->|"started"| a1_2\n' in mermaid
    assert '"one/1" -> "two/1" [style=dotted, color=steelblue, fontcolor=steelblue, ' \
           'constraint=false, label="done"];' in to_dot(graph)


def test_png_draws_the_waits(tmp_path: Path) -> None:
    with Image.open(to_png(graph_of(WAITS_ACROSS), tmp_path / "g.png")) as image:
        pixels = np.asarray(image.convert("RGB")).astype(int)
    red, green, blue = pixels[..., 0], pixels[..., 1], pixels[..., 2]
    assert ((blue - red > 60) & (blue > green)).sum() > 100   # steelblue arcs and words


def test_renderings_are_deterministic() -> None:
    first, second = graph_of(SCENARIO), graph_of(SCENARIO)
    assert to_mermaid(first) == to_mermaid(second)
    assert to_dot(first) == to_dot(second)


def test_layout_puts_branches_side_by_side_and_steps_below(graph: nx.DiGraph) -> None:
    positions, (x0, x1, y0, y1) = layout(graph)
    assert set(positions) == set(graph.nodes)
    fork_x, fork_y = positions["dinner/4"]
    talk, wait = positions["dinner/5"], positions["dinner/6"]
    assert talk[0] < fork_x < wait[0]
    assert talk[1] == wait[1] == fork_y - 1
    assert positions["dinner/7"][0] == wait[0]          # the branch's second step, same column
    for u, v in nx.subgraph_view(graph, filter_edge=lambda u, v: not graph.edges[u, v].get(
            "loop", False)).edges:
        assert positions[v][1] < positions[u][1]
    assert all(x0 < x < x1 and y0 < y < y1 for x, y in positions.values())
    assert positions["activity#2/0"][0] > max(x for n, (x, _) in positions.items()
                                              if n.startswith("dinner/"))


def test_png_is_a_real_drawing(graph: nx.DiGraph, tmp_path: Path) -> None:
    written = to_png(graph, tmp_path / "graph.png")
    assert written == tmp_path / "graph.png"
    with Image.open(written) as image:
        assert image.format == "PNG"
        pixels = np.asarray(image.convert("L"))
    height, width = pixels.shape
    assert width > 400 and height > 800          # two columns of branches, 17 layers
    dark = pixels < 100
    assert 0.005 < dark.mean() < 0.2             # lines and text, not blank, not a blot
    assert dark[:, : width // 2].any() and dark[:, width // 2:].any()


def test_png_of_no_activities(tmp_path: Path) -> None:
    written = to_png(graph_of(""), tmp_path / "empty.png")
    with Image.open(written) as image:
        assert image.size[0] > 0


def test_a_graph_too_wide_to_read_as_a_picture_is_refused(tmp_path: Path) -> None:
    from hubero_dsl.errors import InputError

    branches = "; ".join(f"wait {i + 1} s" for i in range(1000))
    with pytest.raises(InputError, match=r"too large to draw as a picture.*--format dot"):
        to_png(graph_of(f"activity {{ parallel {{ {branches} }} }}"), tmp_path / "wide.png")
    assert not (tmp_path / "wide.png").exists()


def test_a_task_given_to_a_crowd_is_drawn_as_the_one_step_written() -> None:
    from hubero_dsl.graph.render import drawn_graph
    from hubero_dsl.pipeline import check_source
    from tests.lang.conftest import CASE_PATH, ROOM

    result = check_source(ROOM + "crowd c 100 in rect((-4.5, 0.5), (3.0, 5.0))\n"
                          "activity {\n"
                          "    browse: c move_around in rect((-4, 1), (2, 4)) for 30 s\n"
                          "    c_3 stand for 1 s\n"
                          "}\n"
                          "activity { actor1 stand for 1 s until browse done }\n", CASE_PATH)
    assert result.program is not None, result.diagnostics
    graph = drawn_graph(result.program.activities)
    assert len(result.program.graph) > 100 > len(graph)  # runs as 100 branches, drawn as one
    words = [describe_node(graph, n) for n in graph]
    assert "browse: c move_around in rect((-4, 1), (2, 4)) for 30 s, each of 100" in words
    assert "c_3 stand for 1 s" in words  # a member's own step stays its own
    (waits,) = signals(graph)
    assert describe_node(graph, waits.target) == "actor1 stand for 1 s until browse done"
    text = to_mermaid(graph)
    assert text.count("move_around") == 1 and "c_1" not in text
