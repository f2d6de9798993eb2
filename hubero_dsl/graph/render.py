"""Renderings of the activity graph: Mermaid and DOT text, and a PNG drawn with matplotlib.

The texts are deterministic (nodes and edges in source order), so they serve as golden files.
Shapes follow SysML activity diagrams: a filled circle starts an activity and a bull's eye ends
it, bars fork and join, rhombi decide and merge (repeat), rounded boxes are actions, a notched
box is an accept event (`wait until`) and a trapezium a time event (`wait Q`); a dotted arrow
runs from a label's event to each `wait until` or `until` waiting for it. The PNG needs no
graphviz: nodes are laid out in layers (longest path from the start) and columns (one per
branch), then drawn as matplotlib patches.

`describe_node` turns nodes back into the scenario's own words (the texts the lowering stored
on each step); the verification uses it in messages too.

`drawn_graph` is the graph the drawings show: a task given to a crowd or group runs as one
branch per member, but is drawn as the one step the scenario wrote (`visitors move_around in
lounge for 30 s, each of 8`), so a crowd of 1000 is one box, not a fork of 1000.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import networkx as nx

from hubero_dsl.graph.build import (
    NodeKind,
    activity_nodes,
    build_activity_graph,
    signals,
    successors_in_order,
)
from hubero_dsl.model import activities as m

# ---- the graph drawn ---------------------------------------------------------------------


def drawn_graph(activities: Sequence[m.Activity]) -> nx.DiGraph:
    """The activity graph with each task given to a crowd or group folded into one step."""
    return build_activity_graph([replace(a, steps=tuple(_fold(s) for s in a.steps))
                                 for a in activities])


def _fold(step: m.Step) -> m.Step:
    if isinstance(step, m.ParallelStep) and (folded := _crowd_task(step)) is not None:
        return folded
    match step:
        case m.ParallelStep() | m.RaceStep():
            return replace(step, branches=tuple(_fold(b) for b in step.branches))
        case m.RepeatStep():
            return replace(step, body=tuple(_fold(s) for s in step.body))
        case m.SequenceStep():
            return replace(step, steps=tuple(_fold(s) for s in step.steps))
    return step


def _crowd_task(step: m.ParallelStep) -> m.TaskStep | None:
    """The members' one task as the crowd's, or None when they are not one task said alike
    (then the fork of members is drawn as it runs)."""
    words = crowd_words(step)
    if words is None:
        return None
    first = step.branches[0]
    assert isinstance(first, m.TaskStep) and step.crowd is not None  # as crowd_words found
    return replace(first, actor=step.crowd, span=step.span, label=step.label,
                   text=f"{words}, each of {len(step.branches)}")


def crowd_words(step: m.ParallelStep) -> str | None:
    """A task given to a crowd or group as the scenario wrote it (`visitors stand for 2 s`),
    or None when the step is no such task or its members' steps are not one task said alike."""
    tasks = [b for b in step.branches if isinstance(b, m.TaskStep)]
    if step.crowd is None or not tasks or len(tasks) != len(step.branches) or \
            not all(t.text.startswith(f"{t.actor} ") for t in tasks):
        return None
    said = {t.text.removeprefix(f"{t.actor} ") for t in tasks}
    return f"{step.crowd} {said.pop()}" if len(said) == 1 else None


# ---- the scenario's words ----------------------------------------------------------------


def describe_node(graph: nx.DiGraph, node: str) -> str:
    """A node in the scenario's words (an action reads `invite: actor2 move_to sofa`)."""
    data = graph.nodes[node]
    prefix = f"{data['label']}: " if data["label"] and data["kind"] in _SIMPLE_KINDS else ""
    match data["kind"]:
        case NodeKind.ACTION:
            return prefix + data["step"].text
        case NodeKind.WAIT:
            return f"{prefix}wait {data['step'].duration_text}"
        case NodeKind.ACCEPT:
            return f"{prefix}wait until {data['condition'].text}"
        case NodeKind.FORK if (words := crowd_words(data["step"])) is not None:
            return words
        case NodeKind.REPEAT_START:
            return f"repeat {data['step'].count_text}"
        case NodeKind.REPEAT_END:
            return f"{data['step'].count_text} rounds done?"
        case NodeKind.LABEL_BEGIN:
            return f"begin {data['label']}"
        case NodeKind.LABEL_END:
            return f"end {data['label']}"
    return _KIND_WORDS[data["kind"]]


_SIMPLE_KINDS = frozenset({NodeKind.ACTION, NodeKind.WAIT, NodeKind.ACCEPT})
_KIND_WORDS = {NodeKind.INITIAL: "start", NodeKind.FINAL: "end", NodeKind.FORK: "parallel",
               NodeKind.JOIN: "all branches done", NodeKind.RACE_FORK: "race",
               NodeKind.RACE_JOIN: "first branch done"}


def _ordered_edges(graph: nx.DiGraph, nodes: list[str]) -> list[tuple[str, str]]:
    return [(u, v) for u in nodes for v in successors_in_order(graph, u)]


def _edge_caption(graph: nx.DiGraph, source: str, target: str) -> str | None:
    """Words on the edges out of a repeat's decision; other edges need none."""
    if graph.nodes[source]["kind"] is not NodeKind.REPEAT_END:
        return None
    return "next round" if graph.edges[source, target].get("loop", False) else "done"


# ---- Mermaid -----------------------------------------------------------------------------

_MERMAID_SHAPES = {
    NodeKind.INITIAL: ("((", "))"), NodeKind.FINAL: ("(((", ")))"),
    NodeKind.ACTION: ("(", ")"), NodeKind.WAIT: ("[/", "\\]"), NodeKind.ACCEPT: (">", "]"),
    NodeKind.FORK: ("[", "]"), NodeKind.JOIN: ("[", "]"), NodeKind.RACE_FORK: ("[", "]"),
    NodeKind.RACE_JOIN: ("[", "]"), NodeKind.REPEAT_START: ("{", "}"),
    NodeKind.REPEAT_END: ("{", "}"), NodeKind.LABEL_BEGIN: ("([", "])"),
    NodeKind.LABEL_END: ("([", "])"),
}
_MERMAID_CLASSES = {
    NodeKind.INITIAL: "terminal", NodeKind.FINAL: "terminal", NodeKind.FORK: "bar",
    NodeKind.JOIN: "bar", NodeKind.RACE_FORK: "bar", NodeKind.RACE_JOIN: "bar",
    NodeKind.LABEL_BEGIN: "label", NodeKind.LABEL_END: "label",
}
_MERMAID_CLASS_STYLES = {
    "terminal": "fill:#000,stroke:#000,color:#fff",
    "bar": "fill:#000,stroke:#000,color:#fff,font-size:10px",
    "label": "fill:#fff,stroke:#777,stroke-dasharray:3 3,color:#444",
}


def _mermaid_text(text: str) -> str:
    """Quoted Mermaid text; characters Mermaid would read as markup become entity codes."""
    for char in "#\"<>":
        text = text.replace(char, f"#{ord(char)};")
    return f'"{text}"'


def _short_caption(graph: nx.DiGraph, node: str) -> str:
    """The words inside a Mermaid node (and beside a DOT race bar): few on the symbols."""
    kind = graph.nodes[node]["kind"]
    return _SYMBOL_WORDS[kind] if kind in _SYMBOL_WORDS else describe_node(graph, node)


_SYMBOL_WORDS = {NodeKind.INITIAL: "●", NodeKind.FINAL: "●", NodeKind.FORK: " ",
                 NodeKind.JOIN: " ", NodeKind.RACE_FORK: "race", NodeKind.RACE_JOIN: "first done"}


def to_mermaid(graph: nx.DiGraph) -> str:
    """A Mermaid `flowchart TD`, one subgraph per activity."""
    lines = ["flowchart TD"]
    ids: dict[str, str] = {}
    by_class: dict[str, list[str]] = {}
    for number, activity in enumerate(graph.graph["activities"], start=1):
        nodes = activity_nodes(graph, activity)
        ids.update({n: f"a{number}_{graph.nodes[n]['order']}" for n in nodes})
        lines.append(f"    subgraph act{number} [{_mermaid_text(activity)}]")
        for node in nodes:
            kind = graph.nodes[node]["kind"]
            opening, closing = _MERMAID_SHAPES[kind]
            text = _short_caption(graph, node)
            lines.append(f"        {ids[node]}{opening}{_mermaid_text(text)}{closing}")
            if kind in _MERMAID_CLASSES:
                by_class.setdefault(_MERMAID_CLASSES[kind], []).append(ids[node])
        for source, target in _ordered_edges(graph, nodes):
            caption = _edge_caption(graph, source, target)
            arrow = "-.->" if graph.edges[source, target].get("loop", False) else "-->"
            words = f"|{_mermaid_text(caption)}|" if caption else ""
            lines.append(f"        {ids[source]} {arrow}{words} {ids[target]}")
        lines.append("    end")
    for signal in signals(graph):  # a wait's dotted arrow from the event it waits for
        lines.append(f"    {ids[signal.source]} -.->|{_mermaid_text(signal.event.value)}| "
                     f"{ids[signal.target]}")
    for name in sorted(by_class):
        lines.append(f"    classDef {name} {_MERMAID_CLASS_STYLES[name]}")
        lines.append(f"    class {','.join(by_class[name])} {name}")
    return "\n".join(lines) + "\n"


# ---- DOT ---------------------------------------------------------------------------------

_BAR = 'shape=box, style=filled, fillcolor=black, height=0.05, width=1.6, fixedsize=true'
_DOT_STYLES = {
    NodeKind.INITIAL: 'shape=circle, style=filled, fillcolor=black, width=0.25, fixedsize=true',
    NodeKind.FINAL: 'shape=doublecircle, style=filled, fillcolor=black, width=0.2, '
                    'fixedsize=true',
    NodeKind.ACTION: 'shape=box, style=rounded',
    NodeKind.WAIT: 'shape=trapezium',
    NodeKind.ACCEPT: 'shape=cds',
    NodeKind.FORK: _BAR, NodeKind.JOIN: _BAR,
    NodeKind.RACE_FORK: _BAR, NodeKind.RACE_JOIN: _BAR,
    NodeKind.REPEAT_START: 'shape=diamond', NodeKind.REPEAT_END: 'shape=diamond',
    NodeKind.LABEL_BEGIN: 'shape=box, style="rounded,dashed", fontcolor=gray30',
    NodeKind.LABEL_END: 'shape=box, style="rounded,dashed", fontcolor=gray30',
}
_DOT_NO_TEXT = frozenset({NodeKind.INITIAL, NodeKind.FINAL, NodeKind.FORK, NodeKind.JOIN})


def _dot_quote(text: str) -> str:
    escaped = text.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n")
    return f'"{escaped}"'


def _dot_node(graph: nx.DiGraph, node: str) -> str:
    kind = graph.nodes[node]["kind"]
    style = _DOT_STYLES[kind]
    if kind in (NodeKind.RACE_FORK, NodeKind.RACE_JOIN):  # a bar, with its words beside it
        caption = _dot_quote(_short_caption(graph, node))
        return f'{_dot_quote(node)} [{style}, label="", xlabel={caption}];'
    text = "" if kind in _DOT_NO_TEXT else describe_node(graph, node)
    return f"{_dot_quote(node)} [{style}, label={_dot_quote(text)}];"


def to_dot(graph: nx.DiGraph) -> str:
    """A graphviz digraph, one cluster per activity."""
    lines = ["digraph activities {",
             "    graph [rankdir=TB, fontname=Helvetica, nodesep=0.4];",
             "    node [fontname=Helvetica, fontsize=11];",
             "    edge [arrowsize=0.7, fontname=Helvetica, fontsize=10];"]
    for number, activity in enumerate(graph.graph["activities"], start=1):
        nodes = activity_nodes(graph, activity)
        lines.append(f"    subgraph cluster_{number} {{")
        lines.append(f"        label={_dot_quote(activity)};")
        lines += [f"        {_dot_node(graph, node)}" for node in nodes]
        for source, target in _ordered_edges(graph, nodes):
            attrs = []
            if graph.edges[source, target].get("loop", False):
                attrs += ["style=dashed", "constraint=false"]
            if (caption := _edge_caption(graph, source, target)) is not None:
                attrs.append(f"label={_dot_quote(caption)}")
            suffix = f" [{', '.join(attrs)}]" if attrs else ""
            lines.append(f"        {_dot_quote(source)} -> {_dot_quote(target)}{suffix};")
        lines.append("    }")
    for signal in signals(graph):  # dotted, and not ranked: the flow alone lays out the graph
        lines.append(f"    {_dot_quote(signal.source)} -> {_dot_quote(signal.target)} "
                     f"[style=dotted, color=steelblue, fontcolor=steelblue, constraint=false, "
                     f"label={_dot_quote(signal.event.value)}];")
    lines.append("}")
    return "\n".join(lines) + "\n"
