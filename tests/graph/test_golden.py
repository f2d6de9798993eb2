"""Golden files: every `tests/cases/graph/NAME.hub` against its Mermaid, DOT and diagnostics.

Regenerate after an intended change with `HUBERO_UPDATE_GOLDEN=1 pytest tests/graph`, then
read the diff before committing it.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path

import networkx as nx
import pytest

from hubero_dsl.diagnostics import Diagnostic
from hubero_dsl.graph.build import build_activity_graph
from hubero_dsl.graph.render import to_dot, to_mermaid
from hubero_dsl.graph.verify import verify_activities
from hubero_dsl.lang.parse import parse_source
from hubero_dsl.pipeline import lower_activities

CASES = Path(__file__).resolve().parents[1] / "cases" / "graph"
UPDATE = os.environ.get("HUBERO_UPDATE_GOLDEN") == "1"


def format_diagnostics(diagnostics: list[Diagnostic]) -> str:
    """One block per diagnostic, positions as line:col so the files do not depend on paths."""
    lines = []
    for d in diagnostics:
        where = f"{d.span.line}:{d.span.column}" if d.span else "-"
        lines.append(f"{where}: {d.severity} {d.code}: {d.message}")
        if d.hint:
            lines.append(f"    hint: {d.hint}")
        lines += [f"    note {r.span.line}:{r.span.column}: {r.message}" for r in d.related]
    return "\n".join(lines) + "\n" if lines else ""


def _render(source: Path, suffix: str) -> str:
    module = parse_source(source.read_text(encoding="utf-8"), source.name)
    activities = lower_activities(module)
    graph = build_activity_graph(activities)
    renderers: dict[str, Callable[[nx.DiGraph], str]] = {
        ".mermaid": to_mermaid, ".dot": to_dot,
        ".diagnostics": lambda g: format_diagnostics(verify_activities(activities, g)),
    }
    return renderers[suffix](graph)


@pytest.mark.parametrize("suffix", [".mermaid", ".dot", ".diagnostics"])
@pytest.mark.parametrize("source", sorted(CASES.glob("*.hub")), ids=lambda p: p.stem)
def test_golden(source: Path, suffix: str) -> None:
    actual = _render(source, suffix)
    golden = source.with_suffix(suffix)
    if UPDATE:
        golden.write_text(actual, encoding="utf-8")
    assert golden.exists(), f"{golden.name} is missing: run with HUBERO_UPDATE_GOLDEN=1"
    assert actual == golden.read_text(encoding="utf-8")


def test_every_golden_file_has_a_source() -> None:
    sources = {p.stem for p in CASES.glob("*.hub")}
    orphans = [p.name for p in CASES.iterdir() if p.suffix != ".hub" and p.stem not in sources]
    assert orphans == []
