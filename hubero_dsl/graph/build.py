"""The activity graph: every activity of a scenario as a SysML-like flow of nodes (networkx).

`build_activity_graph` compiles the activities' steps into one `nx.DiGraph` that the scheduler
executes with token semantics. Each activity is its own connected piece, from an `initial` node
to a `final` node. Node ids are `"ACTIVITY/N"`, N counting up in source order, so two builds of
the same file give the same graph.

Every node has the attributes `kind` (a `NodeKind`), `activity` (the activity's key: its name,
or `activity#N` for the N-th activity when it has none), `order` (N of the id), `span` and
`label` (the step's label, or None). Per kind:

- `initial`, `final`: where the activity's token starts and where it ends.
- `action` (a task step): `human` (the actor's name), `task` (`model.tasks.Task`), `until`
  (condition or None), `within` (seconds or None), `forever` (bool), `step`. Ends when the task
  ends.
- `wait` (`wait Q`): `duration` (seconds), `step`. `accept` (`wait until C`): `condition`,
  `step`.
- `fork` / `join` (`parallel`): the fork passes a token to every branch; the join fires when
  every branch has arrived. `race_fork` / `race_join` (`race`): the join fires when the FIRST
  branch arrives, and the nodes of the other branches are preempted. Forks carry `join` and
  `branches` (a tuple of `Branch`: entry, exit and every member node, to find what to preempt);
  joins carry `fork`. Edges out of a fork and into a join carry `branch` (the branch index).
- `repeat_start` (a merge) / `repeat_end` (a decision): `count` (rounds), `step`; the start
  carries `end`, the end carries `start`. The end's edge back to the start has `loop=True`;
  its other edge leaves the repeat. A token entering the start from outside begins round 1.
- `label_begin` / `label_end`: wrap a labelled composite step (parallel, race, repeat or
  `{ ... }`), carrying `label`, `step`, and `end` / `begin`. A labelled task, wait or accept is
  its own begin and end (its `label` attribute). `label_scopes` gives each label's begin, end
  and member nodes: `LABEL started` holds once a token enters the begin node, `LABEL done` once
  a token leaves the end node, `LABEL failed` once a member action is aborted.

`signals` lists what each `wait until` and task `until` waits for (which node's start or end),
for the renderings to draw; the executed graph has no edge for them.

Empty `parallel`/`race` blocks and empty branches are rejected by the analyses
(`hubero_dsl.graph.verify`); the graph still links them (fork straight to join).
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from enum import StrEnum
from itertools import pairwise
from typing import Any

import networkx as nx

from hubero_dsl.diagnostics import Span
from hubero_dsl.model import activities as m
from hubero_dsl.model.conditions import Label, LabelCondition, LabelEvent, walk_conditions


class NodeKind(StrEnum):
    INITIAL = "initial"
    FINAL = "final"
    ACTION = "action"
    WAIT = "wait"
    ACCEPT = "accept"
    FORK = "fork"
    JOIN = "join"
    RACE_FORK = "race_fork"
    RACE_JOIN = "race_join"
    REPEAT_START = "repeat_start"
    REPEAT_END = "repeat_end"
    LABEL_BEGIN = "label_begin"
    LABEL_END = "label_end"


FORK_KINDS = frozenset({NodeKind.FORK, NodeKind.RACE_FORK})
JOIN_KINDS = frozenset({NodeKind.JOIN, NodeKind.RACE_JOIN})


@dataclass(frozen=True, slots=True)
class Branch:
    """One branch of a fork: its first and last node (None when empty) and all its nodes."""

    index: int
    entry: str | None
    exit: str | None
    members: tuple[str, ...]


@dataclass(frozen=True, slots=True)
class LabelScope:
    """Where a label's step begins and ends, and every node inside it (begin and end included)."""

    label: str
    ref: Label
    begin: str
    end: str
    members: tuple[str, ...]


@dataclass(frozen=True, slots=True)
class Signal:
    """A label's event that a `wait until` or a task's `until` waits for: `source` is the node
    where the event happens (see `label_event`), `target` the node that waits."""

    source: str
    target: str
    event: LabelEvent


# A built piece of flow: (entry node, exit node), or None when it holds no node at all.
_Fragment = tuple[str, str] | None


def build_activity_graph(activities: Sequence[m.Activity]) -> nx.DiGraph:
    """One graph for the whole scenario; see the module docstring for nodes and edges."""
    graph = nx.DiGraph()
    keys = activity_keys(activities)
    graph.graph["activities"] = tuple(keys)
    for decl, key in zip(activities, keys, strict=True):
        _ActivityBuilder(graph, key).build(decl)
    return graph


def activity_keys(activities: Sequence[m.Activity]) -> list[str]:
    """Each activity's key: its name, `activity#N` when unnamed, `NAME#N` for a repeated name."""
    keys: list[str] = []
    for number, decl in enumerate(activities, start=1):
        key = decl.name if decl.name is not None else f"activity#{number}"
        keys.append(f"{key}#{number}" if key in keys else key)
    return keys


class _ActivityBuilder:
    """Adds one activity's nodes to the graph, numbering them in source order."""

    def __init__(self, graph: nx.DiGraph, key: str) -> None:
        self.graph = graph
        self.key = key
        self.count = 0

    def build(self, decl: m.Activity) -> None:
        initial = self._add(NodeKind.INITIAL, decl.head_span, decl=decl)
        body = self._sequence(decl.steps)
        final = self._add(NodeKind.FINAL, _closing_span(decl.span), decl=decl)
        self._chain([(initial, initial), body, (final, final)])

    def _add(self, kind: NodeKind, span: Span, label: str | None = None, **attrs: Any) -> str:
        node = f"{self.key}/{self.count}"
        self.graph.add_node(node, kind=kind, activity=self.key, order=self.count, span=span,
                            label=label, **attrs)
        self.count += 1
        return node

    def _members_since(self, first: int) -> tuple[str, ...]:
        return tuple(f"{self.key}/{n}" for n in range(first, self.count))

    def _chain(self, fragments: Sequence[_Fragment]) -> _Fragment:
        present = [f for f in fragments if f is not None]
        for (_, exit_node), (entry_node, _) in pairwise(present):
            self.graph.add_edge(exit_node, entry_node)
        return (present[0][0], present[-1][1]) if present else None

    def _sequence(self, steps: Sequence[m.Step]) -> _Fragment:
        return self._chain([self._step(step) for step in steps])

    def _step(self, step: m.Step) -> _Fragment:
        if step.label is None or isinstance(step, m.TaskStep | m.WaitStep | m.WaitUntilStep):
            return self._bare_step(step)
        name = step.label.name
        begin = self._add(NodeKind.LABEL_BEGIN, step.label.span, name, step=step)
        inner = self._bare_step(step)
        end = self._add(NodeKind.LABEL_END, _closing_span(step.span), name, step=step,
                        begin=begin)
        self.graph.nodes[begin]["end"] = end
        return self._chain([(begin, begin), inner, (end, end)])

    def _bare_step(self, step: m.Step) -> _Fragment:
        label = step.label.name if step.label is not None else None
        match step:
            case m.TaskStep():
                node = self._add(NodeKind.ACTION, step.span, label, human=step.actor,
                                 task=step.task, until=step.until, within=step.within,
                                 forever=step.forever, step=step)
            case m.WaitStep():
                node = self._add(NodeKind.WAIT, step.span, label, duration=step.duration,
                                 step=step)
            case m.WaitUntilStep():
                node = self._add(NodeKind.ACCEPT, step.span, label, condition=step.condition,
                                 step=step)
            case m.ParallelStep():
                return self._fork(step, NodeKind.FORK, NodeKind.JOIN)
            case m.RaceStep():
                return self._fork(step, NodeKind.RACE_FORK, NodeKind.RACE_JOIN)
            case m.RepeatStep():
                return self._repeat(step)
            case m.SequenceStep():
                return self._sequence(step.steps)
        return (node, node)

    def _fork(self, step: m.ParallelStep | m.RaceStep, fork_kind: NodeKind,
              join_kind: NodeKind) -> _Fragment:
        fork = self._add(fork_kind, step.span, step=step)
        built: list[tuple[_Fragment, tuple[str, ...]]] = []
        for branch in step.branches:
            first = self.count
            fragment = self._step(branch)
            built.append((fragment, self._members_since(first)))
        join = self._add(join_kind, _closing_span(step.span), step=step, fork=fork)
        branches = []
        for index, (fragment, members) in enumerate(built):
            entry, exit_node = fragment if fragment is not None else (join, fork)
            self.graph.add_edge(fork, entry, branch=index)
            self.graph.add_edge(exit_node, join, branch=index)
            branches.append(Branch(index, fragment[0] if fragment else None,
                                   fragment[1] if fragment else None, members))
        if not step.branches:
            self.graph.add_edge(fork, join)
        self.graph.nodes[fork].update(join=join, branches=tuple(branches))
        if isinstance(step, m.ParallelStep) and step.crowd is not None:
            for made in branches:  # a member's step: told as the crowd's where it is quoted
                if made.entry is not None and made.entry == made.exit:
                    self.graph.nodes[made.entry]["crowd_fork"] = fork
        return (fork, join)

    def _repeat(self, step: m.RepeatStep) -> _Fragment:
        count = step.rounds
        start = self._add(NodeKind.REPEAT_START, step.span, count=count, step=step)
        body = self._sequence(step.body)
        end = self._add(NodeKind.REPEAT_END, _closing_span(step.span), count=count, step=step,
                        start=start)
        self.graph.nodes[start]["end"] = end
        self._chain([(start, start), body, (end, end)])
        self.graph.add_edge(end, start, loop=True)
        return (start, end)


def _closing_span(span: Span) -> Span:
    """The last character of a step or block (its closing brace, for blocks)."""
    return Span(span.file, span.end_line, max(1, span.end_column - 1), span.end_line,
                max(2, span.end_column))


# ---- what the scheduler and the analyses ask of the graph ----------------------------------


def node_sort_key(graph: nx.DiGraph, node: str) -> tuple[int, int]:
    """Source order: activity by activity, then node by node."""
    activities: tuple[str, ...] = graph.graph["activities"]
    data = graph.nodes[node]
    return (activities.index(data["activity"]), data["order"])


def initial_nodes(graph: nx.DiGraph) -> list[str]:
    """Every activity's initial node, in the activities' source order."""
    return [f"{key}/0" for key in graph.graph["activities"]]


def final_node(graph: nx.DiGraph, activity: str) -> str:
    return next(n for n in activity_nodes(graph, activity)
                if graph.nodes[n]["kind"] is NodeKind.FINAL)


def activity_nodes(graph: nx.DiGraph, activity: str) -> list[str]:
    """The nodes of one activity, in order."""
    return sorted((n for n, a in graph.nodes(data="activity") if a == activity),
                  key=lambda n: graph.nodes[n]["order"])


def successors_in_order(graph: nx.DiGraph, node: str) -> list[str]:
    """Successors by branch index, then source order; a repeat's loop-back edge comes last."""
    def key(successor: str) -> tuple[int, int, int]:
        edge = graph.edges[node, successor]
        return (edge.get("branch", 0), int(edge.get("loop", False)),
                graph.nodes[successor]["order"])
    return sorted(graph.successors(node), key=key)


def exit_successor(graph: nx.DiGraph, node: str) -> str | None:
    """The successor reached by leaving `node` without looping back (None at a final node)."""
    forward = [s for s in successors_in_order(graph, node)
               if not graph.edges[node, s].get("loop", False)]
    return forward[0] if forward else None


def forward_graph(graph: nx.DiGraph) -> nx.DiGraph:
    """The graph without the repeat loop-back edges: a DAG per activity."""
    return nx.subgraph_view(graph, filter_edge=lambda u, v: not graph.edges[u, v].get("loop",
                                                                                          False))


def nodes_of_kind(graph: nx.DiGraph, *kinds: NodeKind) -> list[str]:
    """Nodes of the given kinds, in source order."""
    found = [n for n, kind in graph.nodes(data="kind") if kind in kinds]
    return sorted(found, key=lambda n: node_sort_key(graph, n))


def branches_of(graph: nx.DiGraph, fork: str) -> tuple[Branch, ...]:
    branches: tuple[Branch, ...] = graph.nodes[fork]["branches"]
    return branches


def label_scopes(graph: nx.DiGraph) -> dict[str, LabelScope]:
    """Every label's scope; when a label is defined twice (an error), the first one counts."""
    scopes: dict[str, LabelScope] = {}
    for begin, end, ref in _labelled_nodes(graph):
        if ref.name not in scopes:
            first, last = graph.nodes[begin]["order"], graph.nodes[end]["order"]
            activity = graph.nodes[begin]["activity"]
            members = tuple(f"{activity}/{n}" for n in range(first, last + 1))
            scopes[ref.name] = LabelScope(ref.name, ref, begin, end, members)
    return scopes


def label_event(scope: LabelScope, event: LabelEvent) -> tuple[str, str]:
    """The event, (node, "s" for its start | "e" for its end), after which `LABEL event`
    holds (a composite step can fail from its start on)."""
    if event is LabelEvent.STARTED:
        return (scope.begin, "s")
    if event is LabelEvent.FAILED and scope.begin != scope.end:
        return (scope.begin, "s")
    return (scope.end, "e")


def signals(graph: nx.DiGraph) -> list[Signal]:
    """Every label event a node waits for (`wait until`, a task's `until`), in source order of
    the waiting node, each once; labels that are not defined (an error) give none."""
    scopes = label_scopes(graph)
    found: list[Signal] = []
    for node in nodes_of_kind(graph, NodeKind.ACCEPT, NodeKind.ACTION):
        data = graph.nodes[node]
        condition = data["condition"] if data["kind"] is NodeKind.ACCEPT else data["until"]
        for part in walk_conditions(condition) if condition is not None else ():
            if not isinstance(part, LabelCondition) or part.label.name not in scopes:
                continue
            source, _ = label_event(scopes[part.label.name], part.event)
            if (signal := Signal(source, node, part.event)) not in found:
                found.append(signal)
    return found


def label_definitions(graph: nx.DiGraph) -> list[tuple[Label, str]]:
    """Every label as written (duplicates included), with the node that begins it."""
    return [(ref, begin) for begin, _, ref in _labelled_nodes(graph)]


def _labelled_nodes(graph: nx.DiGraph) -> Iterator[tuple[str, str, Label]]:
    """(begin node, end node, label) of every labelled step, in source order."""
    for node in nodes_of_kind(graph, NodeKind.ACTION, NodeKind.WAIT, NodeKind.ACCEPT,
                              NodeKind.LABEL_BEGIN):
        data = graph.nodes[node]
        step: m.Step = data["step"]
        if step.label is None:
            continue
        end = data.get("end", node) if data["kind"] is NodeKind.LABEL_BEGIN else node
        yield node, end, step.label
