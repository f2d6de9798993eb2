"""Properties of the graph over random step trees: what the scheduler relies on always holds."""

from __future__ import annotations

import itertools
from dataclasses import replace

import networkx as nx
from hypothesis import given, settings
from hypothesis import strategies as st

from hubero_dsl.diagnostics import SourceFile, Span
from hubero_dsl.graph.build import (
    FORK_KINDS,
    NodeKind,
    activity_nodes,
    branches_of,
    build_activity_graph,
    final_node,
    forward_graph,
    initial_nodes,
    label_scopes,
)
from hubero_dsl.graph.render import to_dot, to_mermaid
from hubero_dsl.graph.verify import verify_activities
from hubero_dsl.lang import ast
from hubero_dsl.lang.lower import Lowering
from hubero_dsl.model.activities import Activity

SPAN = Span("p.hub", 1, 1, 1, 2)


def _name(text: str) -> ast.NameRef:
    return ast.NameRef(text, SPAN)


def _task(human: str, kind: str, forever: bool) -> ast.TaskStep:
    return ast.TaskStep(_name(human), ast.Task(kind, None, (), SPAN, SPAN), None, None, forever,
                        SPAN)


def _wait_until(label: int, event: ast.LabelEvent) -> ast.WaitUntilStep:
    return ast.WaitUntilStep(ast.LabelCondition(_name(f"l{label}"), event, SPAN), SPAN)


def _repeat(count: int, body: list[ast.Step]) -> ast.RepeatStep:
    return ast.RepeatStep(ast.Number(count, str(count), SPAN), ast.SequenceStep(tuple(body), SPAN),
                          SPAN)


_leaves = st.one_of(
    st.builds(_task, st.sampled_from(["h0", "h1", "h2"]),
              st.sampled_from(["stand", "move_to", "move_around"]), st.booleans()),
    st.just(ast.WaitStep(ast.Quantity(1.0, "s", SPAN), SPAN)),
    st.builds(_wait_until, st.integers(0, 8), st.sampled_from(list(ast.LabelEvent))),
)
_steps = st.recursive(_leaves, lambda children: st.one_of(
    st.lists(children, max_size=3).map(lambda b: ast.ParallelStep(tuple(b), SPAN)),
    st.lists(children, max_size=3).map(lambda b: ast.RaceStep(tuple(b), SPAN)),
    st.builds(_repeat, st.integers(-1, 3), st.lists(children, max_size=3)),
    st.lists(children, max_size=3).map(lambda b: ast.SequenceStep(tuple(b), SPAN)),
), max_leaves=14)


def _relabel(step: ast.Step, counter: itertools.count[int]) -> ast.Step:
    """Every other step gets a label l0, l1, ... (so waits find some and miss some)."""
    match step:
        case ast.ParallelStep() | ast.RaceStep():
            step = replace(step, branches=tuple(_relabel(b, counter) for b in step.branches))
        case ast.SequenceStep():
            step = replace(step, steps=tuple(_relabel(s, counter) for s in step.steps))
        case ast.RepeatStep():
            body = replace(step.body, steps=tuple(_relabel(s, counter) for s in step.body.steps))
            step = replace(step, body=body)
    number = next(counter)
    return replace(step, label=_name(f"l{number // 2}")) if number % 2 == 0 else step


@st.composite
def _activities(draw: st.DrawFn) -> list[ast.ActivityDecl]:
    counter = itertools.count()
    bodies = draw(st.lists(st.lists(_steps, max_size=4), min_size=1, max_size=3))
    named = draw(st.lists(st.booleans(), min_size=len(bodies), max_size=len(bodies)))
    return [ast.ActivityDecl(_name(f"act{i}") if named[i] else None,
                             tuple(_relabel(s, counter) for s in body), SPAN)
            for i, body in enumerate(bodies)]


def _lowered(activities: list[ast.ActivityDecl]) -> tuple[Activity, ...]:
    source = SourceFile("t.hub", "")
    return Lowering(source, {}, {}, None).activities(activities)


def _count_steps(activities: list[ast.ActivityDecl], kind: type) -> int:
    return sum(isinstance(s, kind) for a in activities for s in ast.walk_steps(a.steps))


@settings(max_examples=50, deadline=None)
@given(_activities())
def test_every_activity_flows_from_its_initial_to_its_final(
        activities: list[ast.ActivityDecl]) -> None:
    graph = build_activity_graph(_lowered(activities))
    forward = forward_graph(graph)
    assert nx.is_directed_acyclic_graph(forward)
    assert len(initial_nodes(graph)) == len(activities)
    for initial in initial_nodes(graph):
        activity = graph.nodes[initial]["activity"]
        nodes = set(activity_nodes(graph, activity))
        final = final_node(graph, activity)
        assert nx.descendants(forward, initial) | {initial} == nodes
        assert nx.ancestors(forward, final) | {final} == nodes
        assert [n for n in nodes if forward.in_degree(n) == 0] == [initial]
        assert [n for n in nodes if forward.out_degree(n) == 0] == [final]


@settings(max_examples=50, deadline=None)
@given(_activities())
def test_nodes_mirror_the_steps(activities: list[ast.ActivityDecl]) -> None:
    graph = build_activity_graph(_lowered(activities))
    kinds = [kind for _, kind in graph.nodes(data="kind")]
    assert kinds.count(NodeKind.ACTION) == _count_steps(activities, ast.TaskStep)
    assert kinds.count(NodeKind.ACCEPT) == _count_steps(activities, ast.WaitUntilStep)
    assert kinds.count(NodeKind.RACE_FORK) == kinds.count(NodeKind.RACE_JOIN) == \
        _count_steps(activities, ast.RaceStep)
    assert kinds.count(NodeKind.REPEAT_START) == kinds.count(NodeKind.REPEAT_END) == \
        _count_steps(activities, ast.RepeatStep)
    assert kinds.count(NodeKind.LABEL_BEGIN) == kinds.count(NodeKind.LABEL_END)
    loops = [(u, v) for u, v, loop in graph.edges(data="loop") if loop]
    assert len(loops) == kinds.count(NodeKind.REPEAT_END)
    assert all(graph.nodes[u]["start"] == v for u, v in loops)
    assert all(isinstance(span, Span) for _, span in graph.nodes(data="span"))


@settings(max_examples=50, deadline=None)
@given(_activities())
def test_branches_partition_what_lies_between_fork_and_join(
        activities: list[ast.ActivityDecl]) -> None:
    graph = build_activity_graph(_lowered(activities))
    forward = forward_graph(graph)
    for fork in (n for n, kind in graph.nodes(data="kind") if kind in FORK_KINDS):
        join = graph.nodes[fork]["join"]
        between = nx.descendants(forward, fork) & nx.ancestors(forward, join)
        members = [m for branch in branches_of(graph, fork) for m in branch.members]
        assert sorted(members) == sorted(between)
        for branch in branches_of(graph, fork):
            if branch.entry is None:
                assert graph.edges[fork, join]["branch"] is not None
                continue
            assert graph.edges[fork, branch.entry]["branch"] == branch.index
            assert graph.edges[branch.exit, join]["branch"] == branch.index
    for scope in label_scopes(graph).values():
        assert scope.members[0] == scope.begin and scope.members[-1] == scope.end


@settings(max_examples=40, deadline=None)
@given(_activities())
def test_builds_renderings_and_analyses_repeat_exactly(activities: list[ast.ActivityDecl]) -> None:
    lowered = _lowered(activities)
    first, second = build_activity_graph(lowered), build_activity_graph(lowered)
    assert list(first.nodes(data=True)) == list(second.nodes(data=True))
    assert list(first.edges(data=True)) == list(second.edges(data=True))
    assert to_mermaid(first) == to_mermaid(second)
    assert to_dot(first) == to_dot(second)
    findings = verify_activities(lowered, first)
    assert findings == verify_activities(lowered, second)
    assert all(f.code.startswith("E3") and f.span is not None and f.hint for f in findings)
