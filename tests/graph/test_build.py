"""The activity graph's structure: node kinds, edges of parallel/race/repeat, labels, spans, ids."""

from __future__ import annotations

import networkx as nx
import pytest

from hubero_dsl.diagnostics import Span
from hubero_dsl.graph.build import (
    Branch,
    NodeKind,
    activity_nodes,
    branches_of,
    build_activity_graph,
    exit_successor,
    final_node,
    forward_graph,
    initial_nodes,
    label_scopes,
    nodes_of_kind,
    successors_in_order,
)
from hubero_dsl.lang.parse import parse_source
from hubero_dsl.model.activities import TaskStep
from hubero_dsl.pipeline import lower_activities

DINNER = """\
activity dinner {
    invite: actor2 move_to sofa
    actor2 talk to actor1 for 5 s
    parallel {
        actor2 move_to (2.0, -2.8) heading -160 deg
        actor1 move_to (0.6, -2.0) heading -135 deg
    }
}
"""


def graph_of(text: str) -> nx.DiGraph:
    module = parse_source(text, "t.hub")
    return build_activity_graph(lower_activities(module))


def kinds(graph: nx.DiGraph) -> list[NodeKind]:
    return [graph.nodes[n]["kind"] for n in activity_nodes(graph, graph.graph["activities"][0])]


def test_dinner_nodes_in_source_order() -> None:
    graph = graph_of(DINNER)
    assert kinds(graph) == [NodeKind.INITIAL, NodeKind.ACTION, NodeKind.ACTION, NodeKind.FORK,
                            NodeKind.ACTION, NodeKind.ACTION, NodeKind.JOIN, NodeKind.FINAL]
    assert list(graph.nodes) == [f"dinner/{n}" for n in range(8)]
    assert graph.number_of_edges() == 8


def test_action_attributes() -> None:
    graph = graph_of(DINNER)
    invite = graph.nodes["dinner/1"]
    assert invite["human"] == "actor2"
    assert invite["task"].kind == "move_to"
    assert invite["label"] == "invite"
    assert (invite["until"], invite["within"], invite["forever"]) == (None, None, False)
    assert isinstance(invite["step"], TaskStep)
    assert invite["span"] == Span("t.hub", 2, 5, 2, 32)
    assert graph.nodes["dinner/2"]["label"] is None


def test_parallel_edges_carry_branch_indices() -> None:
    graph = graph_of(DINNER)
    fork, join = "dinner/3", "dinner/6"
    assert [(v, graph.edges[fork, v]["branch"]) for v in successors_in_order(graph, fork)] == \
        [("dinner/4", 0), ("dinner/5", 1)]
    assert sorted((u, graph.edges[u, join]["branch"]) for u in graph.predecessors(join)) == \
        [("dinner/4", 0), ("dinner/5", 1)]
    assert graph.nodes[fork]["join"] == join and graph.nodes[join]["fork"] == fork
    assert branches_of(graph, fork) == (Branch(0, "dinner/4", "dinner/4", ("dinner/4",)),
                                        Branch(1, "dinner/5", "dinner/5", ("dinner/5",)))


def test_race_records_branch_members_for_preemption() -> None:
    graph = graph_of("""\
activity a {
    race {
        { actor1 move_to (1, 1); actor1 stand for 2 s }
        wait 10 s
    }
    actor1 stand for 1 s
}
""")
    assert kinds(graph)[1:7] == [NodeKind.RACE_FORK, NodeKind.ACTION, NodeKind.ACTION,
                                 NodeKind.WAIT, NodeKind.RACE_JOIN, NodeKind.ACTION]
    fork, join = "a/1", "a/5"
    assert graph.nodes[fork]["join"] == join
    assert branches_of(graph, fork) == (Branch(0, "a/2", "a/3", ("a/2", "a/3")),
                                        Branch(1, "a/4", "a/4", ("a/4",)))
    assert graph.edges["a/3", join]["branch"] == 0 and graph.edges["a/4", join]["branch"] == 1
    assert graph.nodes[join]["span"].line == 5  # the closing brace


def test_repeat_is_a_merge_and_a_decision_with_one_loop_edge() -> None:
    graph = graph_of("activity a {\n    repeat 3 { actor1 stand for 1 s; wait 1 s }\n}\n")
    start, end = "a/1", "a/4"
    assert (graph.nodes[start]["kind"], graph.nodes[end]["kind"]) == (NodeKind.REPEAT_START,
                                                                      NodeKind.REPEAT_END)
    assert graph.nodes[start]["count"] == graph.nodes[end]["count"] == 3
    assert graph.nodes[start]["end"] == end and graph.nodes[end]["start"] == start
    loops = [(u, v) for u, v, loop in graph.edges(data="loop") if loop]
    assert loops == [(end, start)]
    assert successors_in_order(graph, end) == ["a/5", start]  # the way out first
    assert exit_successor(graph, end) == "a/5"
    assert list(graph.successors(start)) == ["a/2"]


def test_labels_on_composite_steps_get_begin_and_end_nodes() -> None:
    graph = graph_of("""\
activity a {
    both: parallel { actor1 stand for 1 s; actor2 stand for 1 s }
    go: { actor1 move_to (1, 1); actor1 move_to (2, 2) }
    w: wait 2 s
    twice: repeat 2 { wait 1 s }
}
""")
    scopes = label_scopes(graph)
    assert list(scopes) == ["both", "go", "w", "twice"]
    both = scopes["both"]
    assert (graph.nodes[both.begin]["kind"], graph.nodes[both.end]["kind"]) == \
        (NodeKind.LABEL_BEGIN, NodeKind.LABEL_END)
    assert graph.nodes[both.begin]["end"] == both.end
    assert graph.nodes[both.end]["begin"] == both.begin
    assert both.members == tuple(f"a/{n}" for n in range(1, 7))
    assert both.ref.span == Span("t.hub", 2, 5, 2, 9)
    assert scopes["go"].members == ("a/7", "a/8", "a/9", "a/10")
    assert scopes["w"].begin == scopes["w"].end == "a/11"
    assert scopes["w"].members == ("a/11",)
    assert graph.nodes["a/11"]["label"] == "w"
    assert [graph.nodes[n]["kind"] for n in scopes["twice"].members] == [
        NodeKind.LABEL_BEGIN, NodeKind.REPEAT_START, NodeKind.WAIT, NodeKind.REPEAT_END,
        NodeKind.LABEL_END]


def test_sequences_are_inlined_and_empty_blocks_still_link() -> None:
    graph = graph_of("activity a {\n    { { wait 1 s } }\n    parallel { }\n    {}\n}\n")
    assert kinds(graph) == [NodeKind.INITIAL, NodeKind.WAIT, NodeKind.FORK, NodeKind.JOIN,
                            NodeKind.FINAL]
    assert list(graph.edges) == [("a/0", "a/1"), ("a/1", "a/2"), ("a/2", "a/3"), ("a/3", "a/4")]


def test_empty_branch_links_fork_to_join() -> None:
    graph = graph_of("activity a {\n    race { wait 1 s; { } }\n}\n")
    fork, join = "a/1", "a/3"
    assert graph.edges[fork, join]["branch"] == 1
    assert branches_of(graph, fork)[1] == Branch(1, None, None, ())


def test_activity_keys_and_initial_nodes() -> None:
    graph = graph_of("activity { wait 1 s }\nactivity b { }\nactivity b { }\nactivity { }\n")
    assert graph.graph["activities"] == ("activity#1", "b", "b#3", "activity#4")
    assert initial_nodes(graph) == ["activity#1/0", "b/0", "b#3/0", "activity#4/0"]
    assert final_node(graph, "activity#1") == "activity#1/2"
    assert {graph.nodes[n]["activity"] for n in activity_nodes(graph, "b#3")} == {"b#3"}
    assert nx.number_weakly_connected_components(graph) == 4


def test_every_node_has_a_span_and_the_common_attributes() -> None:
    graph = graph_of(DINNER + "activity other {\n    l: repeat 2 { race { wait 1 s } }\n}\n")
    for node, data in graph.nodes(data=True):
        assert isinstance(data["kind"], NodeKind)
        assert isinstance(data["span"], Span) and data["span"].file == "t.hub"
        assert node == f"{data['activity']}/{data['order']}"
        assert "label" in data
    assert graph.nodes["dinner/0"]["span"] == Span("t.hub", 1, 1, 1, 16)  # `activity dinner`
    assert graph.nodes["dinner/7"]["span"] == Span("t.hub", 8, 1, 8, 2)   # the closing brace
    assert graph.nodes["dinner/6"]["span"] == Span("t.hub", 7, 5, 7, 6)   # the parallel's


def test_forward_graph_is_a_dag_from_initial_to_final() -> None:
    graph = graph_of(DINNER + "activity o {\n    repeat 2 { repeat 3 { wait 1 s } }\n}\n")
    forward = forward_graph(graph)
    assert nx.is_directed_acyclic_graph(forward)
    assert not nx.is_directed_acyclic_graph(graph)
    for initial in initial_nodes(graph):
        activity = graph.nodes[initial]["activity"]
        reached = nx.descendants(forward, initial) | {initial}
        assert reached == set(activity_nodes(graph, activity))
        assert final_node(graph, activity) in reached


def test_ids_and_attributes_are_the_same_across_builds() -> None:
    text = DINNER + "activity { race { wait 1 s; a: wait until invite done } }\n"
    first, second = graph_of(text), graph_of(text)
    assert list(first.nodes(data=True)) == list(second.nodes(data=True))
    assert list(first.edges(data=True)) == list(second.edges(data=True))


@pytest.mark.parametrize(("count", "rounds"), [("2", 2), ("0", 0), ("-1", 0), ("2.5", 0)])
def test_repeat_count_attribute(count: str, rounds: int) -> None:
    graph = graph_of(f"activity a {{ repeat {count} {{ wait 1 s }} }}")
    assert [graph.nodes[n]["count"] for n in nodes_of_kind(graph, NodeKind.REPEAT_START)] == \
        [rounds]
