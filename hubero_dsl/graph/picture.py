"""The activity graph as a PNG, drawn with matplotlib: no graphviz needed.

Nodes are laid out in layers (longest path from the start) and columns (one per branch), then
drawn as SysML-looking patches. Kept apart from `render.py` so that checking a scenario never
imports matplotlib.
"""

from __future__ import annotations

import textwrap
from functools import cache
from pathlib import Path

import networkx as nx
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.patches import Ellipse, FancyArrowPatch, FancyBboxPatch, Patch, Polygon, Rectangle
from matplotlib.path import Path as MplPath
from matplotlib.transforms import Bbox

from hubero_dsl.graph.build import (
    FORK_KINDS,
    JOIN_KINDS,
    NodeKind,
    Signal,
    branches_of,
    exit_successor,
    forward_graph,
    signals,
)
from hubero_dsl.graph.render import _ordered_edges, _short_caption, describe_node

COLUMN_INCHES = 2.8
ROW_INCHES = 0.8
FONT_SIZE = 8
_CHAR_INCHES = 0.6 * FONT_SIZE / 72  # DejaVu Sans Mono advances 0.6 em per character
_LINE_INCHES = 1.25 * FONT_SIZE / 72
_WRAP = 34
_MAX_PIXELS = 30_000
_LEAST_DPI = 40  # below it, a drawing squeezed into _MAX_PIXELS cannot be read
_DIAMOND_INCHES = 0.12  # half the diagonal of a decision/merge rhombus
_NOTCH_INCHES = 0.1     # how deep a wait's (accept event's) box is notched on its left
_BAR_HEIGHT = 0.07 / ROW_INCHES  # a fork or join bar, in rows
SIGNAL_COLOUR = "steelblue"  # the arrows from a label's event to who waits for it
_SIGNAL_BEND = -0.25  # matplotlib's arc3 `rad`: to the left of the way the arrow goes


def to_png(graph: nx.DiGraph, path: str | Path, *, dpi: int = 110) -> Path:
    """Draw the graph into a PNG file (no graphviz needed); returns the path written."""
    positions, (x0, x1, y0, y1) = layout(graph)
    edges = _ordered_edges(graph, list(positions))
    loops = {edge: _loop_left(graph, edge, positions) for edge in edges
             if graph.edges[edge].get("loop", False)}
    x0 = min([x0, *(left - 0.05 for left in loops.values())])
    width_in, height_in = max(1.0, x1 - x0) * COLUMN_INCHES, max(1.0, y1 - y0) * ROW_INCHES
    if _MAX_PIXELS / max(width_in, height_in) < _LEAST_DPI:  # its words would be specks
        from hubero_dsl.errors import InputError

        raise InputError(f"the graph is too large to draw as a picture ({width_in:.0f} x "
                         f"{height_in:.0f} inches at {FONT_SIZE} pt): give `--format mermaid` "
                         "or `--format dot` (graphviz draws large graphs)")
    figure = Figure(figsize=(width_in, height_in))
    axes = figure.add_axes((0.0, 0.0, 1.0, 1.0))
    axes.set_xlim(x0, x1)
    axes.set_ylim(y0, y1)
    axes.set_axis_off()
    patches = {node: _draw_node(axes, graph, node, positions) for node in positions}
    for edge in edges:
        if edge in loops:
            _draw_loop(axes, edge, positions, loops[edge])
        else:
            _draw_edge(axes, graph, edge, positions, patches)
    for signal in signals(graph):
        _draw_signal(axes, signal, positions, patches)
    for activity in graph.graph["activities"]:
        x, y = positions[f"{activity}/0"]
        axes.text(x, y + 0.35, activity, ha="center", va="bottom", fontsize=FONT_SIZE + 2,
                  fontweight="bold")
    out = Path(path)
    safe_dpi = min(dpi, int(_MAX_PIXELS / max(width_in, height_in)))
    figure.savefig(out, dpi=safe_dpi, facecolor="white", metadata={"Software": None})
    return out


def layout(graph: nx.DiGraph) -> tuple[dict[str, tuple[float, float]],
                                       tuple[float, float, float, float]]:
    """Node centres (x in columns, y in layers going down) and the (x0, x1, y0, y1) extent."""
    depth: dict[str, int] = {}
    forward = forward_graph(graph)
    for node in nx.topological_sort(forward):
        depth[node] = max((depth[p] + 1 for p in forward.predecessors(node)), default=0)
    columns = _Columns(graph)
    left = 0.0
    for activity in graph.graph["activities"]:
        initial = f"{activity}/0"
        width = columns.width(columns.chain(initial, None))
        columns.place(initial, None, left + width / 2)
        left += width
    positions = {n: (columns.x[n], -float(depth[n])) for n in sorted(columns.x, key=_id_key)}
    lowest = min((y for _, y in positions.values()), default=0.0)
    return positions, (-0.1, max(left, 1.0) + 0.1, lowest - 0.6, 0.8)


def _id_key(node: str) -> tuple[str, int]:
    activity, _, order = node.rpartition("/")
    return (activity, int(order))


class _Columns:
    """Horizontal placement: a sequence shares one column; a fork's branches sit side by side."""

    def __init__(self, graph: nx.DiGraph) -> None:
        self.graph = graph
        self.x: dict[str, float] = {}

    def chain(self, start: str, stop: str | None) -> list[str]:
        """The nodes from `start` up to `stop`, a fork's branches folded into the fork."""
        nodes: list[str] = []
        node: str | None = start
        while node is not None and node != stop:
            nodes.append(node)
            data = self.graph.nodes[node]
            node = data["join"] if data["kind"] in FORK_KINDS else exit_successor(self.graph,
                                                                                    node)
        return nodes

    def width(self, nodes: list[str]) -> float:
        return max((self._node_width(n) for n in nodes), default=1.0)

    def _node_width(self, node: str) -> float:
        if self.graph.nodes[node]["kind"] not in FORK_KINDS:
            return 1.0
        return max(1.0, sum(self._branch_widths(node)))

    def _branch_widths(self, fork: str) -> list[float]:
        join = self.graph.nodes[fork]["join"]
        return [self.width(self.chain(b.entry, join)) if b.entry else 0.0
                for b in branches_of(self.graph, fork)]

    def place(self, start: str, stop: str | None, centre: float) -> None:
        for node in self.chain(start, stop):
            self.x[node] = centre
            if self.graph.nodes[node]["kind"] not in FORK_KINDS:
                continue
            join = self.graph.nodes[node]["join"]
            widths = self._branch_widths(node)
            left = centre - sum(widths) / 2
            for branch, width in zip(branches_of(self.graph, node), widths, strict=True):
                if branch.entry is not None:
                    self.place(branch.entry, join, left + width / 2)
                left += width


@cache
def _wrapped(text: str) -> str:
    return "\n".join(textwrap.wrap(text, _WRAP, break_long_words=True)) or " "


def _box_size(text: str, kind: NodeKind | None = None) -> tuple[float, float]:
    """Width in columns and height in rows of a box around the wrapped text (a wait's box
    wider by its notch, which the text keeps clear of)."""
    lines = text.split("\n")
    notch = _NOTCH_INCHES if kind is NodeKind.ACCEPT else 0.0
    width = (max(len(line) for line in lines) * _CHAR_INCHES + 0.16 + notch) / COLUMN_INCHES
    height = (len(lines) * _LINE_INCHES + 0.12) / ROW_INCHES
    return width, height


def _draw_node(axes: Axes, graph: nx.DiGraph, node: str,
               positions: dict[str, tuple[float, float]]) -> Patch:
    kind = graph.nodes[node]["kind"]
    x, y = positions[node]
    if kind in (NodeKind.INITIAL, NodeKind.FINAL):
        return _draw_terminal(axes, kind, x, y)
    if kind in FORK_KINDS | JOIN_KINDS:
        return _draw_bar(axes, graph, node, positions)
    if kind in (NodeKind.REPEAT_START, NodeKind.REPEAT_END):
        return _draw_diamond(axes, describe_node(graph, node), x, y)
    text = _wrapped(describe_node(graph, node))
    width, height = _box_size(text, kind)
    patch: Patch
    text_x = x
    if kind is NodeKind.ACCEPT:
        notch = _NOTCH_INCHES / COLUMN_INCHES
        text_x = x + notch / 2
        patch = Polygon([(x - width / 2, y + height / 2), (x + width / 2, y + height / 2),
                         (x + width / 2, y - height / 2), (x - width / 2, y - height / 2),
                         (x - width / 2 + notch, y)], closed=True)
    elif kind is NodeKind.WAIT:
        slant = 0.08 / COLUMN_INCHES
        patch = Polygon([(x - width / 2 + slant, y + height / 2),
                         (x + width / 2 - slant, y + height / 2),
                         (x + width / 2 + slant, y - height / 2),
                         (x - width / 2 - slant, y - height / 2)], closed=True)
    else:
        patch = FancyBboxPatch((x - width / 2, y - height / 2), width, height,
                               boxstyle="round,pad=0,rounding_size=0.04",
                               mutation_aspect=COLUMN_INCHES / ROW_INCHES)
    dashed = kind in (NodeKind.LABEL_BEGIN, NodeKind.LABEL_END)
    patch.set(facecolor="#f4f7ff" if kind is NodeKind.ACTION else "white", edgecolor="#333",
              linewidth=0.8, linestyle="--" if dashed else "-", zorder=2)
    axes.add_patch(patch)
    axes.text(text_x, y, text, ha="center", va="center", fontsize=FONT_SIZE,
              family="DejaVu Sans Mono", color="#555" if dashed else "black", zorder=3)
    return patch


def _draw_terminal(axes: Axes, kind: NodeKind, x: float, y: float) -> Patch:
    size = 0.2
    outer = Ellipse((x, y), size / COLUMN_INCHES, size / ROW_INCHES, facecolor="black",
                    edgecolor="black", zorder=2)
    axes.add_patch(outer)
    if kind is NodeKind.FINAL:
        outer.set_facecolor("white")
        inner = Ellipse((x, y), 0.6 * size / COLUMN_INCHES, 0.6 * size / ROW_INCHES,
                        facecolor="black", zorder=3)
        axes.add_patch(inner)
    return outer


def _draw_bar(axes: Axes, graph: nx.DiGraph, node: str,
              positions: dict[str, tuple[float, float]]) -> Patch:
    """A fork or join bar, reaching over every branch's column."""
    x, y = positions[node]
    fork = node if graph.nodes[node]["kind"] in FORK_KINDS else graph.nodes[node]["fork"]
    columns = [positions[b.entry][0] for b in branches_of(graph, fork) if b.entry] + [x]
    left, right = min(columns) - 0.2, max(columns) + 0.2
    bar = Rectangle((left, y - _BAR_HEIGHT / 2), right - left, _BAR_HEIGHT, facecolor="black",
                    zorder=2)
    axes.add_patch(bar)
    if graph.nodes[node]["kind"] in (NodeKind.RACE_FORK, NodeKind.RACE_JOIN):
        axes.text(right + 0.03, y, _short_caption(graph, node), ha="left", va="center",
                  fontsize=FONT_SIZE - 1, style="italic")
    return bar


def _draw_diamond(axes: Axes, text: str, x: float, y: float) -> Patch:
    half_w, half_h = _DIAMOND_INCHES / COLUMN_INCHES, _DIAMOND_INCHES / ROW_INCHES
    diamond = Polygon([(x, y + half_h), (x + half_w, y), (x, y - half_h), (x - half_w, y)],
                      closed=True, facecolor="white", edgecolor="#333", zorder=2)
    axes.add_patch(diamond)
    axes.text(x + half_w + 0.02, y, text, ha="left", va="center",
              fontsize=FONT_SIZE - 1, style="italic")
    return diamond


def _draw_edge(axes: Axes, graph: nx.DiGraph, edge: tuple[str, str],
               positions: dict[str, tuple[float, float]], patches: dict[str, Patch]) -> None:
    source, target = edge
    (x0, y0), (x1, y1) = positions[source], positions[target]
    patch_a: Patch | None = patches[source]
    patch_b: Patch | None = patches[target]
    # Arrows leave a fork bar and enter a join bar straight down, under their own branch,
    # from and to the bar's edge: clipping a thousand arrows to a bar as wide as a thousand
    # branches is most of the drawing's time
    if graph.nodes[source]["kind"] in FORK_KINDS:
        x0, y0, patch_a = x1, y0 - _BAR_HEIGHT / 2, None
    if graph.nodes[target]["kind"] in JOIN_KINDS:
        x1, y1, patch_b = x0, y1 + _BAR_HEIGHT / 2, None
    if x0 == x1 and y0 > y1:  # straight down: from the bottom of one shape to the next's top
        if patch_a is not None:
            y0, patch_a = _extent(patch_a).y0, None
        if patch_b is not None:
            y1, patch_b = _extent(patch_b).y1, None
    axes.add_patch(FancyArrowPatch((x0, y0), (x1, y1), patchA=patch_a, patchB=patch_b,
                                   arrowstyle="-|>", mutation_scale=9, shrinkA=0, shrinkB=0,
                                   linewidth=0.8, color="#222", zorder=1))


def _draw_signal(axes: Axes, signal: Signal, positions: dict[str, tuple[float, float]],
                 patches: dict[str, Patch]) -> None:
    """A dotted arc from where a label's event happens to the node waiting for it, its event
    written at the middle; bent, so that it does not hide the flow between the two."""
    (x0, y0), (x1, y1) = positions[signal.source], positions[signal.target]
    axes.add_patch(FancyArrowPatch((x0, y0), (x1, y1), patchA=patches[signal.source],
                                   patchB=patches[signal.target], arrowstyle="-|>",
                                   connectionstyle=f"arc3,rad={_SIGNAL_BEND}", mutation_scale=9,
                                   linewidth=0.8, linestyle=":", color=SIGNAL_COLOUR, zorder=2))
    # the arc's middle: half its bend off the chord's middle, square to the chord in inches
    # (matplotlib bends it on the page, where a column and a row differ in size)
    across, down = (x1 - x0) * COLUMN_INCHES, (y1 - y0) * ROW_INCHES
    middle = ((x0 + x1) / 2 + _SIGNAL_BEND / 2 * down / COLUMN_INCHES,
              (y0 + y1) / 2 - _SIGNAL_BEND / 2 * across / ROW_INCHES)
    axes.text(*middle, signal.event.value, ha="center", va="center",
              fontsize=FONT_SIZE - 1, color=SIGNAL_COLOUR,
              bbox={"boxstyle": "round,pad=0.15", "facecolor": "white", "edgecolor": "none"})


def _extent(patch: Patch) -> Bbox:
    """A shape's extent in the drawing's units."""
    return patch.get_path().get_extents(patch.get_patch_transform())


def _loop_left(graph: nx.DiGraph, loop: tuple[str, str],
               positions: dict[str, tuple[float, float]]) -> float:
    """Where a repeat's loop-back runs up: left of every box of its body and of inner loops."""
    end, start = loop
    activity, first, last = (graph.nodes[start]["activity"], graph.nodes[start]["order"],
                             graph.nodes[end]["order"])
    centre = positions[start][0]
    reach, inner_loops = _DIAMOND_INCHES, 0
    for order in range(first + 1, last):
        node = f"{activity}/{order}"
        half = _box_size(_wrapped(describe_node(graph, node)), graph.nodes[node]["kind"])[0] / 2
        reach = max(reach, (centre - positions[node][0] + half) * COLUMN_INCHES)
        inner_loops += graph.nodes[node]["kind"] is NodeKind.REPEAT_END
    return centre - (reach + 0.15 + 0.12 * inner_loops) / COLUMN_INCHES


def _draw_loop(axes: Axes, loop: tuple[str, str], positions: dict[str, tuple[float, float]],
               left: float) -> None:
    """Out of the repeat's decision to the left, up past the body, into its merge."""
    end, start = loop
    (centre, top), bottom = positions[start], positions[end][1]
    tip = centre - _DIAMOND_INCHES / COLUMN_INCHES
    route = MplPath([(tip, bottom), (left, bottom), (left, top), (tip, top)])
    axes.add_patch(FancyArrowPatch(path=route, arrowstyle="-|>", mutation_scale=9,
                                   linewidth=0.8, color="#666", linestyle="--", zorder=1))
