"""The compiler driver: text -> AST -> checks -> map -> activity graph -> `Program`.

`check_file` / `check_source` collect every diagnostic of a file and return them with the program
(None when there are errors). `compile_file` / `compile_source` return the program or raise
`CompileError` with all diagnostics.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Literal, cast

from hubero_dsl.diagnostics import Diagnostic
from hubero_dsl.errors import CompileError
from hubero_dsl.lang import ast
from hubero_dsl.lang.checks import Checker, Facts
from hubero_dsl.lang.parse import parse_source, read_source
from hubero_dsl.lang.placement import check_positions, load_scenario_map, map_path
from hubero_dsl.lang.program import HumanSpec, ParamLayer, Program, Variant, sweep_products

if TYPE_CHECKING:
    import networkx as nx
    from shapely.geometry import Polygon


@dataclass(frozen=True)
class CheckResult:
    source: ast.SourceFile | None
    diagnostics: tuple[Diagnostic, ...]
    program: Program | None

    @property
    def errors(self) -> list[Diagnostic]:
        return [d for d in self.diagnostics if d.is_error]

    @property
    def warnings(self) -> list[Diagnostic]:
        return [d for d in self.diagnostics if not d.is_error]


def check_source(text: str, path: str = "<string>") -> CheckResult:
    """Parse and check scenario text; never raises for a bad scenario."""
    source = ast.SourceFile(path, text)
    try:
        module = parse_source(text, path)
    except CompileError as exc:
        return CheckResult(source, tuple(sorted(exc.diagnostics, key=Diagnostic.sort_key)), None)
    diagnostics: list[Diagnostic] = []
    program = _check_module(module, diagnostics)
    ordered = tuple(sorted(diagnostics, key=Diagnostic.sort_key))
    has_errors = any(d.is_error for d in ordered)
    return CheckResult(source, ordered, None if has_errors else program)


def check_file(path: str | Path) -> CheckResult:
    """Read (InputError if it cannot be read), parse and check a scenario file."""
    return check_source(read_source(path), str(path))


def compile_source(text: str, path: str = "<string>") -> Program:
    result = check_source(text, path)
    if result.program is None:
        raise CompileError(result.diagnostics)
    return result.program


def compile_file(path: str | Path) -> Program:
    return compile_source(read_source(path), str(path))


def _check_module(module: ast.Module, diagnostics: list[Diagnostic]) -> Program | None:
    from hubero_dsl.graph.analysis import analyse_activities
    from hubero_dsl.graph.build import build_activity_graph

    checker = Checker(module)
    facts = checker.run()
    diagnostics.extend(checker.diagnostics)
    grid = None
    if facts.map is not None:
        grid = load_scenario_map(module.source, facts.map, diagnostics)
        if grid is not None:
            check_positions(grid, facts.positions, diagnostics)
    activities = tuple(module.of_type(ast.ActivityDecl))
    graph = build_activity_graph(activities)
    diagnostics.extend(analyse_activities(activities, graph, label_names=False))
    if grid is None or facts.map is None or any(d.is_error for d in diagnostics):
        return None
    return _program(module, facts, grid, graph)


def _program(module: ast.Module, facts: Facts, grid: object, graph: object) -> Program:
    settings = facts.settings
    humans = tuple(
        HumanSpec(decl.name.name, facts.human_starts[decl.name.name],
                  facts.human_layers.get(decl.name.name, ParamLayer()), decl.span)
        for decl in module.of_type(ast.HumanDecl))
    assert facts.map is not None
    return Program(
        source=module.source, module=module, title=facts.title,
        map_path=map_path(module.source, facts.map), grid=grid,  # type: ignore[arg-type]
        seed=cast(int, settings.get("seed") or 0),
        step=cast(float, settings.get("step") or 0.05),
        time_limit=cast(float, settings.get("time_limit") or 600.0),
        on_failure=cast(Literal["stop", "continue"], settings.get("on_failure") or "stop"),
        bounds=cast("Polygon | None", settings.get("bounds")),
        places=dict(facts.places), areas=_areas(module, facts),
        defaults=facts.defaults, humans=humans, robots=tuple(facts.robots),
        variants=_variants(facts),
        activities=tuple(module.of_type(ast.ActivityDecl)),
        expectations=tuple(module.of_type(ast.ExpectDecl)),
        graph=cast("nx.DiGraph", graph),
    )


def _areas(module: ast.Module, facts: Facts) -> dict[str, object]:
    from hubero_dsl.lang.program import area_polygon

    areas: dict[str, object] = {}
    aliases: dict[str, str] = {}
    for decl in module.of_type(ast.AreaDecl):
        if isinstance(decl.area, ast.NameRef):  # an area may be another area's name
            aliases[decl.name.name] = decl.area.name
        else:
            areas[decl.name.name] = area_polygon(decl.area, facts.places)
    for name in aliases:  # follow chains of names (the checker rejected cycles)
        target, hops = aliases[name], 0
        while target in aliases and hops < len(aliases):
            target, hops = aliases[target], hops + 1
        if target in areas:
            areas[name] = areas[target]
    return areas


def _variants(facts: Facts) -> dict[str, Variant]:
    """Named variants, then sweeps multiplied (with every named variant, if there are any)."""
    named = [Variant(name, (layer,)) for name, layer in facts.variants]
    swept = sweep_products(facts.sweeps)
    if not swept:
        return {v.name: v for v in named}
    if not named:
        return {name: Variant(name, layers) for name, layers in swept}
    return {f"{v.name},{name}": Variant(f"{v.name},{name}", v.layers + layers)
            for v in named for name, layers in swept}
