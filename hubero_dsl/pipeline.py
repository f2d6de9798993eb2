"""The compiler pipeline: text -> syntax tree -> checks -> map -> lowered model -> activity
graph -> verification -> `Program`.

It sits above the language (`hubero_dsl.lang`) and the graph (`hubero_dsl.graph`), which know
nothing of each other: the language lowers a module to the model, the graph is built from the
model. `check_file` / `check_source` collect every diagnostic of a file and return them with the
program (None when there are errors). `compile_file` / `compile_source` return the program or
raise `CompileError` with all diagnostics.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Literal, cast

from hubero_dsl.diagnostics import Diagnostic, SourceFile, Span, error
from hubero_dsl.errors import CompileError
from hubero_dsl.graph.build import build_activity_graph
from hubero_dsl.graph.verify import verify_activities
from hubero_dsl.lang import ast
from hubero_dsl.lang.checks import Checker, Facts, no_activity
from hubero_dsl.lang.lower import Lowering, named_areas
from hubero_dsl.lang.parse import parse_source, read_source
from hubero_dsl.lang.placement import (
    check_bodies,
    check_overlapping_starts,
    check_positions,
    check_robot_paths,
    load_scenario_map,
    map_path,
    place_crowd,
)
from hubero_dsl.model.activities import Activity
from hubero_dsl.model.program import (
    CrowdSpec,
    FlowSpec,
    HumanSpec,
    ParamLayer,
    Pose,
    Program,
    Variant,
    sweep_products,
)

if TYPE_CHECKING:
    from shapely.geometry import Polygon

    from hubero_dsl.world.grid import OccupancyGrid


@dataclass(frozen=True)
class CheckResult:
    source: SourceFile | None
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
    source = SourceFile(path, text)
    try:
        module = parse_source(text, path)
    except CompileError as exc:
        return CheckResult(source, tuple(sorted(exc.diagnostics, key=Diagnostic.sort_key)), None)
    diagnostics: list[Diagnostic] = []
    program = _check_module(module, diagnostics)
    # a step given to a crowd or group is checked once per member: said once
    ordered = tuple(sorted(dict.fromkeys(diagnostics), key=Diagnostic.sort_key))
    has_errors = any(d.is_error for d in ordered)
    return CheckResult(source, ordered, None if has_errors else program)


def first_other_than_defaults(text: str, path: str, *, after: int = 0) -> Span | None:
    """Where the first statement past the first `after` is that is not a `defaults { }`
    block (a file of fitted defaults holds nothing else), or None. CompileError for a syntax
    error."""
    statements = parse_source(text, path).statements[after:]
    return next((s.span for s in statements if not isinstance(s, ast.DefaultsDecl)), None)


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


DEFAULT_ROBOT_RADIUS = 0.3  # m, as the robot parameters declare it


@dataclass(frozen=True)
class Outline:
    """What a scenario's text says without its map: its activities and its robots' sizes. For
    tools that read a log's copy of the scenario, whose map may be gone."""

    activities: tuple[Activity, ...]
    radii: dict[str, float]                        # robot -> radius, as declared
    variant_radii: dict[str, dict[str, float]]     # variant -> robot -> radius it sets

    def robot_radii(self, variant: str | None) -> dict[str, float]:
        """Robots' radii as the scenario and the variant set them (declared ones only)."""
        return {**self.radii, **self.variant_radii.get(variant or "", {})}


def outline_source(text: str, path: str = "<string>") -> Outline:
    """Parse `text` (CompileError for a syntax error) and read its outline; no checks."""
    module = parse_source(text, path)
    radii = {}
    for robot in module.of_type(ast.RobotDecl):
        for param in robot.params:
            if param.path == ("radius",) and (metres := _metres(param.value)) is not None:
                radii[robot.name.name] = metres
    variant_radii: dict[str, dict[str, float]] = {}
    for declared in module.of_type(ast.VariantDecl):
        for param in declared.params:
            if len(param.path) == 2 and param.path[1] == "radius" and param.path[0] in radii \
                    and (metres := _metres(param.value)) is not None:
                variant_radii.setdefault(declared.name.name, {})[param.path[0]] = metres
    return Outline(lower_activities(module), radii, variant_radii)


def _metres(value: ast.Value) -> float | None:
    if isinstance(value, ast.Quantity):
        return value.si if value.known_unit else DEFAULT_ROBOT_RADIUS
    if isinstance(value, ast.Number):
        return float(value.value)
    return None


def lower_activities(module: ast.Module) -> tuple[Activity, ...]:
    """A module's activities lowered on their own, without its map or places (named targets stay
    names): what the graph's renderings and verification need, for tools and tests."""
    return Lowering(module.source, {}, {}, None).activities(module.of_type(ast.ActivityDecl))


def _check_module(module: ast.Module, diagnostics: list[Diagnostic]) -> Program | None:
    checker = Checker(module)
    facts = checker.run()
    diagnostics.extend(checker.diagnostics)
    # the file's names and values hold together: every check on the map can run, and one
    # place that does not fit hides no other (a person's start no crowd's area)
    coherent = not any(d.is_error for d in checker.diagnostics)
    grid = None
    if facts.map is not None:
        grid = load_scenario_map(module.source, facts.map, diagnostics)
        if grid is not None:
            check_positions(grid, facts.positions, diagnostics, facts.bodies)
            check_bodies(grid, facts.bodies, diagnostics, facts.radius_origins)
            check_overlapping_starts(list(facts.starts.values()), diagnostics)
            check_robot_paths(grid, facts.robots, diagnostics)
    areas = named_areas(module, facts.places)
    lowering = Lowering(module.source, facts.places, areas,
                        cast("Polygon | None", facts.settings.get("bounds")),
                        {**{crowd.name: crowd.members for crowd in facts.crowds},
                         **{flow.name: flow.members for flow in facts.flows},
                         **facts.groups}, frozenset(facts.groups),
                        frozenset(flow.name for flow in facts.flows))
    activities = lowering.activities(module.of_type(ast.ActivityDecl))
    graph = build_activity_graph(activities)
    diagnostics.extend(verify_activities(activities, graph, label_names=False))
    if grid is None or facts.map is None or not coherent:
        return None
    crowds = _crowd_members(facts, grid, lowering, diagnostics)
    flows, arrivals = _flows(facts, grid, lowering, diagnostics)
    if any(d.is_error for d in diagnostics):
        return None
    if (idle := no_activity(module)) is not None:
        diagnostics.append(idle)
    return Program(
        source=module.source, title=facts.title, map_path=map_path(module.source, facts.map),
        map_written=facts.map.value,
        grid=grid, seed=cast(int, facts.settings.get("seed") or 0),
        step=cast(float, facts.settings.get("step") or 0.05),
        time_limit=cast(float, facts.settings.get("time_limit") or 600.0),
        on_failure=cast(Literal["stop", "continue"],
                        facts.settings.get("on_failure") or "stop"),
        bounds=lowering.bounds, places=dict(facts.places), areas=areas,
        defaults=facts.defaults, humans=_humans(module, facts) + crowds.members + arrivals,
        robots=tuple(facts.robots), groups=dict(facts.groups), flows=flows,
        crowds=crowds.specs, fixed_bodies=crowds.fixed_bodies,
        variants=_variants(facts), activities=activities,
        expectations=lowering.expectations(module.of_type(ast.ExpectDecl)), graph=graph)


def _humans(module: ast.Module, facts: Facts) -> tuple[HumanSpec, ...]:
    return tuple(
        HumanSpec(decl.name.name, facts.human_starts[decl.name.name],
                  facts.human_layers.get(decl.name.name, ParamLayer()), decl.span)
        for decl in module.of_type(ast.HumanDecl))


@dataclass(frozen=True)
class _Crowds:
    """Every crowd as placed with the scenario's seed, and what placing them again needs."""

    members: tuple[HumanSpec, ...]
    specs: tuple[CrowdSpec, ...]
    fixed_bodies: tuple[tuple[float, float, float], ...]


def _crowd_members(facts: Facts, grid: OccupancyGrid, lowering: Lowering,
                   diagnostics: list[Diagnostic]) -> _Crowds:
    """Every crowd's members, placed at seeded random places of its area where they fit."""
    taken = [(*start.xy, facts.largest_radius(name)[0])
             for name, start in facts.human_starts.items()]
    taken += [(*robot.start.xy, robot.radius) for robot in facts.robots]
    fixed = tuple(taken)
    seed = cast(int, facts.settings.get("seed") or 0)
    members: list[HumanSpec] = []
    specs: list[CrowdSpec] = []
    for crowd in facts.crowds:
        spec = CrowdSpec(crowd.name, lowering.area(crowd.area),
                         facts.largest_radius(crowd.name, crowd.layer)[0],
                         crowd.heading, crowd.members, crowd.span)
        places = place_crowd(grid, crowd.name, len(crowd.members), spec.area, spec.radius,
                             taken, seed, crowd.span, diagnostics)
        members += [HumanSpec(member, Pose(x, y, crowd.heading), crowd.layer, crowd.span,
                              crowd.name)
                    for member, (x, y) in zip(crowd.members, places, strict=False)]
        specs.append(spec)
    return _Crowds(tuple(members), tuple(specs), fixed)


def _flows(facts: Facts, grid: OccupancyGrid, lowering: Lowering,
           diagnostics: list[Diagnostic]) -> tuple[tuple[FlowSpec, ...], tuple[HumanSpec, ...]]:
    """Every flow, with its members (who start nowhere: a run brings them in), after checking
    that its people fit in its area with a way to its target, and fit at the target."""
    flows: list[FlowSpec] = []
    members: list[HumanSpec] = []
    for flow in facts.flows:
        if flow.target is None or flow.rate is None:
            continue
        area, radius = lowering.area(flow.area), facts.largest_radius(flow.name, flow.layer)[0]
        if not check_bodies(grid, [(f"the target of flow '{flow.name}'", flow.target, radius,
                                    flow.target_span)], diagnostics):
            continue  # no way leads to a target where nobody fits: that is the error
        if not len(grid.entry_places(area, flow.target, radius)):
            diagnostics.append(error(
                "E407", f"nowhere in the area of flow '{flow.name}' can a body of radius "
                f"{radius:g} m stand with a way to the flow's target", flow.span,
                "make the area larger or move it off the obstacles, or check that a way "
                "leads from it to the target"))
            continue
        until = lowering.condition(flow.until) if flow.until is not None else None
        flows.append(FlowSpec(flow.name, area, flow.target, flow.rate, flow.members, flow.span,
                              flow.duration, until))
        members += [HumanSpec(member, Pose(*flow.target), flow.layer, flow.span, flow.name)
                    for member in flow.members]
    return tuple(flows), tuple(members)


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
