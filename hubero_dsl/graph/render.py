"""Renderings of the activity graph: Mermaid and DOT text, and a PNG drawn with matplotlib.

The texts are deterministic (nodes and edges in source order), so they serve as golden files.
Shapes follow SysML activity diagrams: a filled circle starts an activity and a bull's eye ends
it, bars fork and join, rhombi decide and merge (repeat), rounded boxes are actions, a notched
box is an accept event (`wait until`) and a trapezium a time event (`wait Q`). The PNG needs no
graphviz: nodes are laid out in layers (longest path from the start) and columns (one per
branch), then drawn as matplotlib patches.

`describe_node` (and the `format_*` helpers) turn nodes back into the scenario's own words;
the analyses use them in messages too.
"""

from __future__ import annotations

import networkx as nx

from hubero_dsl.graph.build import (
    NodeKind,
    activity_nodes,
    successors_in_order,
)
from hubero_dsl.lang import ast

# ---- the scenario's words ----------------------------------------------------------------


def format_number(value: float) -> str:
    return str(int(value)) if float(value).is_integer() else repr(float(value))


def format_value(value: ast.Value | ast.RectArea | ast.PolygonArea) -> str:
    match value:
        case ast.Number():
            return value.text
        case ast.Quantity():
            return f"{format_number(value.magnitude)} {value.unit}"
        case ast.String():
            return '"' + value.value.replace("\\", "\\\\").replace('"', '\\"') + '"'
        case ast.NameRef():
            return value.name
        case ast.Point():
            return f"({format_value(value.x)}, {format_value(value.y)})"
        case ast.ShapeLit():
            args = ", ".join(f"{a.name}: {format_value(a.value)}" for a in value.args)
            return f"{value.kind}({args})"
        case ast.Distribution():
            return f"{value.kind}({format_value(value.first)}, {format_value(value.second)})"
        case ast.RectArea():
            return f"rect({format_value(value.corner_a)}, {format_value(value.corner_b)})"
        case ast.PolygonArea():
            return f"polygon({', '.join(format_value(v) for v in value.vertices)})"
    raise TypeError(f"not a value: {value!r}")


def format_condition(condition: ast.Condition) -> str:
    match condition:
        case ast.LabelCondition():
            return f"{condition.label.name} {condition.event.value}"
        case ast.ReachesCondition():
            return f"{condition.subject.name} reaches {format_value(condition.target)}"
        case ast.DistanceCondition():
            return (f"distance({condition.subject.name}, {format_value(condition.target)}) "
                    f"{condition.operator} {format_value(condition.threshold)}")
        case ast.InsideCondition():
            return f"{condition.subject.name} in {format_value(condition.area)}"
        case ast.TimeCondition():
            return f"time {condition.operator} {format_value(condition.threshold)}"
        case ast.NotCondition():
            return f"not {_operand(condition.operand, (ast.AllOf, ast.AnyOf))}"
        case ast.AllOf():
            return " and ".join(_operand(c, (ast.AnyOf,)) for c in condition.operands)
        case ast.AnyOf():
            return " or ".join(_operand(c, (ast.AllOf,)) for c in condition.operands)
    raise TypeError(f"not a condition: {condition!r}")


def _operand(condition: ast.Condition, needs_parentheses: tuple[type, ...]) -> str:
    text = format_condition(condition)
    return f"({text})" if isinstance(condition, needs_parentheses) else text


def format_task_step(step: ast.TaskStep) -> str:
    """`actor2 move_to sofa heading 75 deg until invite done`: the step without its label."""
    words = [step.human.name, step.task.kind]
    if step.task.target is not None:
        words.append(format_value(step.task.target))
    words += [f"{o.keyword} {format_value(o.value)}" for o in step.task.options]
    if step.until is not None:
        words.append(f"until {format_condition(step.until)}")
    if step.within is not None:
        words.append(f"within {format_value(step.within)}")
    if step.forever:
        words.append("forever")
    return " ".join(words)


def describe_node(graph: nx.DiGraph, node: str) -> str:
    """A node in the scenario's words (an action reads `invite: actor2 move_to sofa`)."""
    data = graph.nodes[node]
    prefix = f"{data['label']}: " if data["label"] and data["kind"] in _SIMPLE_KINDS else ""
    match data["kind"]:
        case NodeKind.ACTION:
            return prefix + format_task_step(data["step"])
        case NodeKind.WAIT:
            return f"{prefix}wait {format_value(data['duration'])}"
        case NodeKind.ACCEPT:
            return f"{prefix}wait until {format_condition(data['condition'])}"
        case NodeKind.REPEAT_START:
            return f"repeat {data['step'].count.text}"
        case NodeKind.REPEAT_END:
            return f"{data['step'].count.text} rounds done?"
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
    lines.append("}")
    return "\n".join(lines) + "\n"
