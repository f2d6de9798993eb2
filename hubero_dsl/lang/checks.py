"""Semantic checks over the AST: structure, names, parameters, tasks and conditions.

`Checker.run()` walks a parsed module once, collecting every diagnostic (never stopping at the
first) and the resolved facts the program is built from. Checks that need the map live in
`placement.py`; checks that need the activity graph live in `hubero_dsl.graph.verify`.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field, replace
from typing import Literal

from hubero_dsl.controllers.registry import controller_class, controller_names
from hubero_dsl.diagnostics import Diagnostic, Related, Span, error, warning
from hubero_dsl.errors import InputError
from hubero_dsl.lang import ast
from hubero_dsl.lang.lower import area_polygon, coordinate
from hubero_dsl.lang.symbols import MANY, MEMBER_NAME, NameKind, SymbolTable, alias_depths
from hubero_dsl.lang.values import ValueReader, did_you_mean, field_dimension
from hubero_dsl.model.params import HUMAN_PARAMS, KINEMATICS, ROBOT_PARAMS, SEED_DIGITS
from hubero_dsl.model.program import (
    Distribution,
    ParamLayer,
    ParamValue,
    Pose,
    RobotSpec,
    flow_bound,
)
from hubero_dsl.model.tasks import TASKS, OptionSpec, TargetRule, TaskKind, ValueKind
from hubero_dsl.model.units import LARGEST, Dimension, dimension_named
from hubero_dsl.planners.registry import global_planner_names, local_planner_names

MAX_CONDITION_PARTS = 1000  # conditions, `and`s, `or`s and `not`s in one condition
BODIES = (NameKind.HUMAN, NameKind.ROBOT)
DEFAULT_STEP = 0.05  # s, the language's default `step`
DEFAULT_TIME_LIMIT = 600.0  # s, the language's default `time_limit`
MIN_STEP, MAX_STEP = 1e-3, 1.0  # s: the range of `step`
MAX_TICKS = 1e8  # ticks in a run (time_limit / step): about 14 h of computing at 2000 ticks/s
MAX_VARIANTS = 10_000  # variants of a scenario (named variants times sweep values)
MAX_HUMANS = 20_000    # humans of a scenario, crowds included (a log has 65,535 channels)
# People and robots times ticks: what a run computes and logs grows with both, and the other
# bounds alone let their product reach 2e12 (20,000 humans for 1e8 ticks; 10,000 people for
# 1e6 s at a 1 s step are already 1e10 and a log of more than a terabyte). 5e8 is 10,000
# people for 42 min at the default step, or 1,000 for 7 h.
MAX_BODY_TICKS = 5e8
TARGETS = (NameKind.PLACE, NameKind.HUMAN, NameKind.ROBOT, NameKind.GROUP)

@dataclass(frozen=True)
class CrowdFacts:
    """A crowd as checked: its members are placed on the map by the pipeline."""

    name: str
    members: tuple[str, ...]
    area: ast.AreaValue
    heading: float
    layer: ParamLayer
    span: Span


@dataclass(frozen=True)
class FlowFacts:
    """A flow as checked: the pipeline checks its area and target on the map."""

    name: str
    area: ast.AreaValue
    target: tuple[float, float] | None
    rate: float | None
    duration: float | None
    until: ast.Condition | None
    layer: ParamLayer
    span: Span
    target_span: Span
    members: tuple[str, ...] = ()


@dataclass
class Facts:
    """What the checker resolved, for building the program."""

    title: str = ""
    map: ast.String | None = None
    settings: dict[str, object] = field(default_factory=dict)
    places: dict[str, Pose] = field(default_factory=dict)
    defaults: ParamLayer = field(default_factory=ParamLayer)
    human_layers: dict[str, ParamLayer] = field(default_factory=dict)
    human_starts: dict[str, Pose] = field(default_factory=dict)
    robots: list[RobotSpec] = field(default_factory=list)
    crowds: list[CrowdFacts] = field(default_factory=list)
    flows: list[FlowFacts] = field(default_factory=list)
    groups: dict[str, tuple[str, ...]] = field(default_factory=dict)
    variants: list[tuple[str, ParamLayer]] = field(default_factory=list)
    sweeps: list[tuple[str, list[tuple[str, ParamLayer]]]] = field(default_factory=list)
    # every fixed point written in the file, with what it is, for the map checks
    positions: list[tuple[str, tuple[float, float], Span]] = field(default_factory=list)
    # where bodies start or are sent, with the largest radius they may have there
    bodies: list[tuple[str, tuple[float, float], float, Span]] = field(default_factory=list)
    # a body's words -> " (variant 'V')" where a variant gives it the radius it is checked with
    radius_origins: dict[str, str] = field(default_factory=dict)
    # the humans' and robots' starts among `bodies`, by what they are (a name defined twice
    # keeps its first; that is an error of its own)
    starts: dict[str, tuple[str, tuple[float, float], float, Span]] = field(
        default_factory=dict)

    def largest_radius(self, name: str, own: ParamLayer | None = None) -> tuple[float, str]:
        """The largest body radius human `name` (or the crowd or flow of that name, whose
        block is `own`) may have, at the upper end of a distribution: as the file gives it
        (its own block's, else the defaults', else the built-in one) or as a variant or a
        swept value sets it; and " (variant 'V')" when a variant makes it larger than the
        file's ("" otherwise). People are placed once, for every variant, where the largest
        of them fits."""
        own = own if own is not None else self.human_layers.get(name, ParamLayer())
        written = next((value for layer in (own, self.defaults)
                        if (value := layer.values.get("radius")) is not None),
                       HUMAN_PARAMS["radius"].default)
        largest = (_upper(written), "")
        for variant, layer in [*self.variants,
                               *(option for _, options in self.sweeps for option in options)]:
            for value in (layer.values.get("radius"),
                          layer.per_human.get(name, {}).get("radius")):
                if value is not None and _upper(value) > largest[0]:
                    largest = (_upper(value), f" (variant '{variant}')")
        return largest


def _upper(value: ParamValue) -> float:
    """A radius, or the upper end of a distribution of radii."""
    return value.upper if isinstance(value, Distribution) else float(value)  # type: ignore[arg-type]


class Checker:
    def __init__(self, module: ast.Module) -> None:
        self.module = module
        self.diagnostics: list[Diagnostic] = []
        self._reported: set[tuple[str, str, Span | None]] = set()
        self.values = ValueReader(self.diagnostics)
        self.symbols = SymbolTable(self.diagnostics)
        self.facts = Facts()
        self.planners = sorted(set(global_planner_names()) | set(local_planner_names()))
        self.planner_values: list[tuple[type, str, str, float, Span]] = []
        self.controllers = controller_names()
        self.robot_steps: list[tuple[ast.NameRef, ast.TaskStep]] = []
        self.goals: list[tuple[str, str, ast.PointValue]] = []  # actor, task, fixed target
        self.planners_by_param = {"global_planner": global_planner_names(),
                                  "local_planner": local_planner_names()}

    def report(self, code: str, message: str, span: Span | None, hint: str | None = None,
               related: tuple[Related, ...] = ()) -> None:
        """Add an error, once: a value checked again (each value of a sweep checks its
        parameter's name) repeats the same error at the same place."""
        if (code, message, span) in self._reported:
            return
        self._reported.add((code, message, span))
        self.diagnostics.append(error(code, message, span, hint, related))

    def warn(self, code: str, message: str, span: Span | None, hint: str | None = None) -> None:
        """Add a warning, once, as `report` adds an error."""
        if (code, message, span) in self._reported:
            return
        self._reported.add((code, message, span))
        self.diagnostics.append(warning(code, message, span, hint))

    def run(self) -> Facts:
        self._structure()
        self._define_names()
        for statement in self._in_definition_order():
            self._statement(statement)
        self._unused()
        self._inert_planner_values()
        self._robot_tasks()
        self._arrivals_measured()
        self._body_places()
        self._tick_count()
        self._flow_members()
        self._sizes()
        return self.facts

    def _sizes(self) -> None:
        """A scenario has at most MAX_VARIANTS variants (counted before any is built) and
        MAX_HUMANS humans, crowds' members included."""
        sweeps = self.module.of_type(ast.SweepDecl)
        count = max(1, len(self.facts.variants))
        for _, options in self.facts.sweeps:
            count *= max(1, len(options))
        if sweeps and count > MAX_VARIANTS:
            self.report("E203", f"the sweeps make {count:,} variants; a scenario has at most "
                        f"{MAX_VARIANTS:,}", sweeps[0].span,
                        "sweep fewer parameters or fewer values, or run a sweep's parts in "
                        "files of their own")
        people = 0
        flows = {flow.name: len(flow.members) for flow in self.facts.flows}
        for statement in self.module.statements:
            if isinstance(statement, ast.HumanDecl | ast.CrowdDecl | ast.FlowDecl):
                match statement:
                    case ast.CrowdDecl():
                        people += len(statement.members)
                    case ast.FlowDecl():  # as many as it may bring (1 when its rate is wrong)
                        people += flows.get(statement.name.name, 1)
                    case _:
                        people += 1
                if people > MAX_HUMANS:
                    self.report("E203", f"more than {MAX_HUMANS:,} humans; a scenario has at "
                                "most that many (logs and planning are sized for it)",
                                statement.span, "a flow counts as many people as it may "
                                "bring: its rate times its duration (or the time limit), "
                                "and a margin" if isinstance(statement, ast.FlowDecl) else None)
                    return
        self._body_ticks(people + len(self.module.of_type(ast.RobotDecl)))

    def _step_and_limit(self) -> tuple[float, float]:
        """The run's step and time limit (s), the language's defaults where not set."""
        settings = self.facts.settings
        step, limit = settings.get("step"), settings.get("time_limit")
        return (step if isinstance(step, float) else DEFAULT_STEP,
                limit if isinstance(limit, float) else DEFAULT_TIME_LIMIT)

    def _timing_span(self) -> Span | None:
        return next((s.value.span for s in self.module.of_type(ast.SettingDecl)
                     if s.keyword in ("time_limit", "step")), None)

    def _body_ticks(self, bodies: int) -> None:
        """A run's people and robots times its ticks are bounded by MAX_BODY_TICKS (the
        defaults' 12,000 ticks never exceed it, so a time limit or a step is written)."""
        step, limit = self._step_and_limit()
        ticks = limit / step
        if bodies * ticks > MAX_BODY_TICKS and ticks <= MAX_TICKS:  # else E203 says so
            self.report("E203", f"{bodies:,} people and robots for {ticks:,.0f} ticks (a time "
                        f"limit of {limit:g} s at a step of {step:g} s) is "
                        f"{bodies * ticks:.3g} body-ticks; a run has at most "
                        f"{MAX_BODY_TICKS:.0e}", self._timing_span(),
                        "shorten the time limit, lengthen the step or simulate fewer people "
                        "(a flow counts as many as it may bring)")

    def _tick_count(self) -> None:
        """A run's ticks are bounded: time_limit / step at most MAX_TICKS."""
        step, limit = self._step_and_limit()
        if limit / step > MAX_TICKS:
            self.report("E203", f"a time limit of {limit:g} s at a step of {step:g} s is "
                        f"{limit / step:.3g} ticks; a run has at most {MAX_TICKS:.0e}",
                        self._timing_span(), "shorten the time limit or lengthen the step")

    def _in_definition_order(self) -> list[ast.Statement]:
        """Places first, each after the place it is defined by, so that a place may be used
        before its own statement; then the rest in source order."""
        places = self.module.of_type(ast.PlaceDecl)
        depths = alias_depths([(p.name, p.point) for p in places], "place", self.diagnostics)
        alias_depths([(a.name, a.area) for a in self.module.of_type(ast.AreaDecl)], "area",
                     self.diagnostics)
        # places on a cycle come last: they resolve to nothing, but their names count as used
        ordered = sorted(places, key=lambda p: depths.get(p.name.name, len(places)))
        return [*ordered, *(s for s in self.module.statements if not isinstance(s, ast.PlaceDecl))]

    # ---- structure and names ---------------------------------------------------------------

    def _structure(self) -> None:
        statements = self.module.statements
        path = self.module.source.path
        if not statements:
            self.report("E404", "the file is empty", Span.whole_file(path),
                        'a scenario starts with `scenario "TITLE"` and names a `map "FILE.yaml"`')
            return
        if not isinstance(statements[0], ast.ScenarioDecl):
            self.report("E404", 'a scenario file must start with `scenario "TITLE"`',
                        statements[0].span)
        seen: dict[str, Span] = {}
        for statement in statements:
            keyword = _singleton_keyword(statement)
            if keyword is None:
                continue
            if keyword in seen:
                self.report("E102", f"'{keyword}' is given twice", statement.span, None,
                            (Related("first given here", seen[keyword]),))
            seen.setdefault(keyword, statement.span)
        if "map" not in seen:
            self.report("E404", "the scenario names no map", statements[0].span,
                        'add `map "maps/NAME.yaml"` (a ROS map_server YAML file)')

    def _define_names(self) -> None:
        kinds = {ast.PlaceDecl: NameKind.PLACE, ast.AreaDecl: NameKind.AREA,
                 ast.HumanDecl: NameKind.HUMAN, ast.RobotDecl: NameKind.ROBOT,
                 ast.VariantDecl: NameKind.VARIANT}
        for statement in self.module.statements:
            kind = kinds.get(type(statement))
            if kind is not None and isinstance(statement, ast.PlaceDecl | ast.AreaDecl
                                               | ast.HumanDecl | ast.RobotDecl | ast.VariantDecl):
                self.symbols.define(statement.name, kind)
            elif isinstance(statement, ast.GroupDecl):
                self.symbols.define(statement.name, NameKind.GROUP)
            elif isinstance(statement, ast.FlowDecl):
                self.symbols.define(statement.name, NameKind.FLOW)
            elif isinstance(statement, ast.CrowdDecl):
                self.symbols.define(statement.name, NameKind.CROWD)
                for member in statement.members:  # NAME_1 ... NAME_N, at the crowd's name
                    self.symbols.define(ast.NameRef(member, statement.name.span),
                                        NameKind.HUMAN, crowd=statement.name.name)
            elif isinstance(statement, ast.ActivityDecl):
                if statement.name is not None:
                    self.symbols.define(statement.name, NameKind.ACTIVITY)
                for step in ast.walk_steps(statement.steps):
                    if step.label is not None:
                        self.symbols.define(step.label, NameKind.LABEL)

    def _unused(self) -> None:
        for symbol in self.symbols.symbols.values():
            unused = symbol.name not in self.symbols.used
            if symbol.kind in (NameKind.PLACE, NameKind.AREA) and unused:
                self.diagnostics.append(warning(
                    "W501", f"{symbol.kind.value} '{symbol.name}' is never used", symbol.span,
                    "remove it, or use it in a task or condition"))

    # ---- statements ------------------------------------------------------------------------

    def _statement(self, statement: ast.Statement) -> None:
        match statement:
            case ast.ScenarioDecl(title=title):
                self.facts.title = title.value
            case ast.MapDecl(path=path):
                self.facts.map = path
            case ast.SettingDecl():
                self._setting(statement)
            case ast.PlaceDecl():
                self._place(statement)
            case ast.AreaDecl(area=area):
                self._area(area, f"area '{statement.name.name}'")
            case ast.DefaultsDecl(params=params):
                self.facts.defaults = self._layer(params, per_human_allowed=False)
            case ast.HumanDecl():
                self._human(statement)
            case ast.CrowdDecl():
                self._crowd(statement)
            case ast.FlowDecl():
                self._flow(statement)
            case ast.GroupDecl():
                self._group(statement)
            case ast.RobotDecl():
                self._robot(statement)
            case ast.VariantDecl(name=name, params=params):
                self.facts.variants.append((name.name, self._layer(params,
                                                                   per_human_allowed=True)))
            case ast.SweepDecl():
                self._sweep(statement)
            case ast.ActivityDecl(steps=steps):
                for step in ast.walk_steps(steps):
                    self._step(step)
            case ast.ExpectDecl(condition=ast.MetricCompare() as metric):
                self._metric(metric)
            case ast.ExpectDecl():
                self._condition(statement.condition)  # type: ignore[arg-type]
                if statement.deadline is not None:
                    self.values.quantity(statement.deadline, Dimension.TIME, "'within'",
                                         positive=True)

    def _metric(self, compare: ast.MetricCompare) -> None:
        """`METRIC(NAME [, OTHER]) OP Q`: a known metric, bodies, a value of its dimension."""
        from hubero_dsl.socialnav import METRICS

        spec = METRICS.get(compare.metric.name)
        if spec is None:
            self.report("E111", f"unknown metric '{compare.metric.name}'", compare.metric.span,
                        did_you_mean(compare.metric.name, METRICS)
                        or "metrics: " + ", ".join(METRICS))
        for ref in (compare.subject, compare.other):
            if ref is not None:
                self.symbols.resolve(ref, *BODIES, role=f"{compare.metric.name}(...)")
        if compare.other is not None and compare.other.name == compare.subject.name:
            self.report("E203", f"{compare.metric.name} measures {compare.subject.name} "
                        "against someone else, not itself", compare.other.span,
                        f"write `{compare.metric.name}({compare.subject.name})` to measure it "
                        "against everyone")
        if spec is None:
            return
        self.values.quantity(compare.threshold, dimension_named(spec.dimension), f"{spec.name}",
                             non_negative=True)

    def _setting(self, setting: ast.SettingDecl) -> None:
        keyword, value = setting.keyword, setting.value
        settings = self.facts.settings
        if keyword == "seed":
            assert isinstance(value, ast.Number)
            if value.text.isdigit() and len(value.text) > SEED_DIGITS:
                self.report("E203", f"the seed has {len(value.text)} digits: at most "
                            f"{SEED_DIGITS}", value.span)
            else:
                settings["seed"] = self.values.integer(value, "the seed")
        elif keyword in ("step", "time_limit"):
            what = "the time step" if keyword == "step" else "the time limit"
            number = self.values.quantity(value, Dimension.TIME, what, positive=True,
                                          maximum=MAX_STEP if keyword == "step" else math.inf)
            if keyword == "step" and number is not None and number < MIN_STEP:
                self.report("E203", f"the time step is {number:g} s; the least it may be is "
                            f"{MIN_STEP * 1e3:g} ms", value.span)
                number = None
            settings[keyword] = number
        elif keyword == "on_failure":
            assert isinstance(value, ast.NameRef)
            if value.name not in ("stop", "continue"):
                self.report("E201", f"on_failure is `stop` or `continue`, not '{value.name}'",
                            value.span, did_you_mean(value.name, ("stop", "continue")))
            settings["on_failure"] = value.name
        elif keyword == "bounds":
            assert not isinstance(value, ast.Number | ast.Quantity | ast.String)
            settings["bounds"] = self._area(value, "the bounds")  # type: ignore[arg-type]

    def _place(self, place: ast.PlaceDecl) -> None:
        xy = self._fixed_point(place.point, f"place '{place.name.name}'")
        heading = self._heading(place.heading)
        if xy is not None:
            self.facts.places[place.name.name] = Pose(xy[0], xy[1], heading)

    def _human(self, human: ast.HumanDecl) -> None:
        xy = self._fixed_point(human.start, f"the start of '{human.name.name}'")
        heading = self._heading(human.heading)
        self.facts.human_starts[human.name.name] = Pose(*(xy or (0.0, 0.0)), heading or 0.0)
        self.facts.human_layers[human.name.name] = self._layer(human.params,
                                                               per_human_allowed=False)

    def _group(self, group: ast.GroupDecl) -> None:
        members: list[str] = []
        for ref in group.members:
            flow = self.symbols.flow_of_member(ref.name)
            if flow is not None and self.symbols.kind_of(ref.name) is None:
                self.report("E103", f"'{ref.name}' is one of the people flow '{flow}' brings, "
                            "who come and go: a group is of humans and crowd members", ref.span,
                            "a flow's people walk alone")
                continue
            if self.symbols.resolve(ref, NameKind.HUMAN, role=f"a member of group "
                                    f"'{group.name.name}'") is None:
                continue
            other = next((g for g, held in self.facts.groups.items() if ref.name in held), None)
            if ref.name in members:
                self.report("E113", f"'{ref.name}' is named twice in group "
                            f"'{group.name.name}'", ref.span)
                continue
            if other is not None:
                self.report("E113", f"'{ref.name}' is in group '{other}' already; a human "
                            "belongs to one group", ref.span)
                continue
            members.append(ref.name)
        if len(group.members) < 2:
            self.report("E203", "a group has at least two members", group.span)
        self.facts.groups[group.name.name] = tuple(members)

    def _crowd(self, crowd: ast.CrowdDecl) -> None:
        count = crowd.count
        if not count.is_integer or not 1 <= count.value <= ast.MAX_CROWD:
            self.report("E203", f"a crowd has a whole number of people from 1 to "
                        f"{ast.MAX_CROWD:,}, not {count.text}", count.span)
        self._area(crowd.area, f"the area of crowd '{crowd.name.name}'")
        heading = self._heading(crowd.heading) or 0.0
        layer = self._layer(crowd.params, per_human_allowed=False)
        self.facts.crowds.append(CrowdFacts(crowd.name.name, crowd.members, crowd.area, heading,
                                            layer, crowd.span))

    def _flow(self, flow: ast.FlowDecl) -> None:
        what = f"flow '{flow.name.name}'"
        self._area(flow.area, f"the area of {what}")
        target = self._fixed_point(flow.target, f"the target of {what}")
        rate = self.values.quantity(flow.rate, Dimension.RATE, "a flow's rate", positive=True)
        duration = None
        if flow.duration is not None:
            duration = self.values.quantity(flow.duration, Dimension.TIME, "a flow's duration",
                                            positive=True)
        if flow.until is not None:
            self._condition(flow.until)
            if (own := _requires_all_of(flow.until, flow.name.name)) is not None:
                self.diagnostics.append(error(
                    "E313", f"the `until` of {what} waits for `all {flow.name.name} reach "
                    "...`, which can only hold once the flow has stopped bringing people: it "
                    "would never stop", own.span,
                    f"stop it with `any {flow.name.name} reaches ...`, "
                    f"`count({flow.name.name} in AREA) >= N`, a time, or `for Q`"))
        layer = self._layer(flow.params, per_human_allowed=False)
        self.facts.flows.append(FlowFacts(flow.name.name, flow.area, target, rate, duration,
                                          flow.until, layer, flow.span, flow.target.span))

    def _flow_members(self) -> None:
        """Each flow's members, as many as it may bring before it stops spawning (its
        duration, or the time limit)."""
        limit = self.facts.settings.get("time_limit")
        limit = limit if isinstance(limit, float) else DEFAULT_TIME_LIMIT
        for index, flow in enumerate(self.facts.flows):
            if flow.rate is None:
                continue
            seconds = min(flow.duration, limit) if flow.duration is not None else limit
            count = flow_bound(flow.rate, seconds)
            if count > MAX_HUMANS:  # named no further: E203 follows in _sizes
                count = MAX_HUMANS + 1
            self.facts.flows[index] = replace(
                flow, members=tuple(f"{flow.name}_{i}" for i in range(1, count + 1)))
            self._flow_member_clashes(flow, count)

    def _flow_member_clashes(self, flow: FlowFacts, count: int) -> None:
        """Names that a flow's members (NAME_1 ... NAME_count) would take too: an error at the
        later of the two definitions."""
        members = f"{flow.name}_1 ... {flow.name}_{count}"
        for symbol in list(self.symbols.symbols.values()):
            found = MEMBER_NAME.fullmatch(symbol.name)
            if found is None or found.group(1) != flow.name or int(found.group(2)) > count:
                continue
            if (symbol.span.line, symbol.span.column) > (flow.span.line, flow.span.column):
                self.report("E102", f"'{symbol.name}' is defined twice: it names a member of "
                            f"flow '{flow.name}' ({members})", symbol.span,
                            "every name is defined once; rename it",
                            (Related(f"flow '{flow.name}' is defined here", flow.span),))
            else:
                self.report("E102", f"flow '{flow.name}' names its members {members}, but "
                            f"'{symbol.name}' is defined already ({symbol.kind.value})", flow.span,
                            "every name is defined once; rename the flow or the other",
                            (Related(f"'{symbol.name}' is defined here", symbol.span),))

    def _robot(self, robot: ast.RobotDecl) -> None:
        name = robot.name.name
        start = self._fixed_point(robot.start, f"the start of robot '{name}'") or (0.0, 0.0)
        heading = self._heading(robot.heading) or 0.0
        controller = self._controller(robot)
        values: dict[str, float] = {n: float(s.default) for n, s in ROBOT_PARAMS.items()
                                    if isinstance(s.default, float)}
        kinematics: Literal["holonomic", "unicycle"] = "holonomic"
        goal: tuple[float, float] | None = None
        controller_params: dict[str, float] = {}
        for param in self._unique_params(robot.params):
            if param.dotted == "kinematics":
                kinematics = self._kinematics(param)
            elif param.dotted == "goal":
                goal = self._robot_goal(param, name)
            elif len(param.path) == 2 and param.path[0] == controller:
                number = self._controller_param(param, controller, param.path[1])
                if number is not None:
                    controller_params[param.path[1]] = number
            elif (spec := ROBOT_PARAMS.get(param.dotted)) is not None:
                number = self.values.quantity(param.value, spec.dimension, f"'{spec.name}'",
                                              positive=True, maximum=spec.maximum)
                if number is not None:
                    values[spec.name] = number
            elif controller and len(param.path) == 2 and param.path[0] in self.controllers:
                self.report("E105", f"robot '{name}' has controller {controller}, not "
                            f"{param.path[0]}: '{param.dotted}' is not its parameter",
                            param.name_span, f"write `controller {param.path[0]}` in its block "
                            "to use that controller")
            else:
                self.report("E105", f"robots have no parameter '{param.dotted}'",
                            param.name_span, did_you_mean(param.dotted, [
                                *ROBOT_PARAMS, "kinematics", "goal", "path", "controller"]))
        for extra in robot.extra_items:
            self.report("E106", "a robot has one path and one controller", extra.span)
        path = tuple(self._fixed_point(p, f"the path of robot '{name}'") or start
                     for p in (robot.path.waypoints if robot.path else ()))
        if robot.path is not None and controller not in ("path", ""):
            self.report("E106", f"a robot with a `path` drives it (controller path), not "
                        f"controller {controller}", robot.path.span,
                        "remove the path, or the controller")
        self.facts.robots.append(RobotSpec(
            name, Pose(start[0], start[1], heading), values["radius"], values["speed"], path,
            bool(robot.path and robot.path.loop), controller or "external", robot.span,
            controller_params, kinematics, goal, values["max_speed"],
            values["max_acceleration"], values["max_angular_speed"], values["goal_tolerance"],
            values["sensor_range"], values["field_of_view"]))

    def _controller(self, robot: ast.RobotDecl) -> str:
        """The controller's name: the one written (checked), `path` for a robot with a path,
        else `external` (it stays put unless driven from outside). "" when it is wrong."""
        written = robot.controller
        if written is None:
            return "path" if robot.path is not None else "external"
        if isinstance(written.target, ast.String):
            self.report("E110", "a scenario file names no Python code", written.target.span,
                        "name a registered controller (`controller navigator`), or hand the "
                        "robot to your class with `hubero run FILE --controller "
                        f"{robot.name.name}=MODULE:CLASS`")
            return ""
        name = written.target.name
        if name not in self.controllers:
            self.report("E110", f"no robot controller named '{name}'", written.target.span,
                        did_you_mean(name, self.controllers)
                        or "controllers: " + ", ".join(self.controllers))
            return ""
        try:  # an installed plugin that cannot be loaded fails here, not only in a run
            controller_class(name)
        except InputError as exc:
            self.report("E110", exc.message, written.target.span)
            return ""
        return name

    def _kinematics(self, param: ast.Param) -> Literal["holonomic", "unicycle"]:
        value = param.value
        if isinstance(value, ast.NameRef) and value.name in KINEMATICS:
            return "unicycle" if value.name == "unicycle" else "holonomic"
        self.report("E201", "kinematics is `holonomic` or `unicycle`", value.span,
                    did_you_mean(value.name, KINEMATICS)
                    if isinstance(value, ast.NameRef) else None)
        return "holonomic"

    def _robot_goal(self, param: ast.Param, robot: str) -> tuple[float, float] | None:
        if isinstance(param.value, ast.Point | ast.NameRef):
            return self._fixed_point(param.value, f"the goal of robot '{robot}'")
        self.report("E201", "a robot's goal is a point or a place", param.value.span)
        return None

    def _controller_param(self, param: ast.Param, controller: str, name: str) -> float | None:
        from hubero_dsl.controllers.registry import controller_params

        model = controller_params(controller)
        if model is None:
            return None
        return self._model_param(param, model, controller, name)

    def _sweep(self, sweep: ast.SweepDecl) -> None:
        if sweep.param.path == ("seed",):  # the scenario's `seed`, not a human's parameter
            self.report("E105", "a sweep varies humans' parameters, not the seed",
                        sweep.param.name_span, "run each seed with `hubero run --seed N`, or "
                        "every variant with several seeds with `hubero bench --seeds 1..3`")
            return
        options: list[tuple[str, ParamLayer]] = []
        for value in sweep.values:
            param = ast.Param(sweep.param.path, value, value.span, sweep.param.name_span)
            layer = self._layer((param,), per_human_allowed=True)
            text = self.module.source.text
            options.append((f"{param.dotted}={_source_text(text, value.span)}", layer))
        for index, (name, layer) in enumerate(options):
            # the same value however written (`1.0 m/s` and `1 m/s`) would run twice
            said = bool(layer.values or layer.per_human)  # (a value in error says nothing)
            same = next((earlier for earlier, other in options[:index]
                         if earlier == name or (said and other == layer)), None)
            if same is not None:
                written = "" if same == name else f" (as '{same}')"
                self.report("E102", f"the sweep lists '{name}' twice{written}",
                            sweep.values[index].span)
        self.facts.sweeps.append((sweep.param.dotted, options))

    # ---- parameters ------------------------------------------------------------------------

    def _unique_params(self, params: tuple[ast.Param, ...]) -> list[ast.Param]:
        seen: dict[str, ast.Param] = {}
        for param in params:
            if param.dotted in seen:
                self.report("E106", f"'{param.dotted}' is set twice in one block", param.name_span,
                            None, (Related("first set here", seen[param.dotted].name_span),))
            else:
                seen[param.dotted] = param
        return list(seen.values())

    def _layer(self, params: tuple[ast.Param, ...], *, per_human_allowed: bool) -> ParamLayer:
        values: dict[str, ParamValue] = {}
        per_human: dict[str, dict[str, ParamValue]] = {}
        for param in self._unique_params(params):
            path = param.path
            target = values
            if len(path) > 1 and self.symbols.kind_of(path[0]) in (NameKind.HUMAN,
                                                                     NameKind.CROWD,
                                                                     NameKind.FLOW):
                if not per_human_allowed:
                    self.report("E105", f"'{param.dotted}': per-human settings belong in a "
                                "variant", param.name_span,
                                self._where_to_set(path[0], ".".join(path[1:])))
                    continue
                self.symbols.used.add(path[0])
                target = per_human.setdefault(path[0], {})
                path = path[1:]
            result = self._param(param, path)
            if result is not None:
                target[".".join(path)] = result
        return ParamLayer(values, per_human)

    def _param(self, param: ast.Param, path: tuple[str, ...]) -> ParamValue | None:
        if len(path) == 1:
            spec = HUMAN_PARAMS.get(path[0])
            if spec is None:
                hint = did_you_mean(path[0], HUMAN_PARAMS) or did_you_mean(
                    path[0], self.symbols.names_of(NameKind.HUMAN))
                self.report("E105", f"unknown parameter '{path[0]}'", param.name_span,
                            hint or "parameters: " + ", ".join(sorted(HUMAN_PARAMS)))
                return None
            planners = self.planners_by_param.get(spec.name, self.planners)
            return self.values.param(spec, param.value, planners)
        if len(path) == 2:
            return self._planner_param(param, path[0], path[1])
        self.report("E105", f"unknown parameter '{'.'.join(path)}'", param.name_span,
                    "write PARAM, PLANNER.PARAM, or (in a variant) HUMAN.PARAM")
        return None

    def _planner_param(self, param: ast.Param, planner: str, name: str) -> ParamValue | None:
        from hubero_dsl.planners.registry import planner_params

        try:
            model = planner_params(planner)
        except InputError as exc:  # a plugin that cannot be loaded, or is no planner
            self.report("E110", exc.message, param.name_span)
            return None
        if model is None:
            flow = self.symbols.flow_of_member(planner)
            if flow is not None:
                self.report("E105", f"'{planner}' is a member of flow '{flow}': a flow's "
                            "members take their parameters from the flow", param.name_span,
                            f"give it in the flow's block: `flow {flow} ... {{ {name} ... }}`")
                return None
            if self.symbols.kind_of(planner) is NameKind.ROBOT:
                self.report("E105", f"'{planner}' is a robot: parameters here are humans' and "
                            "planners'", param.name_span,
                            f"give a robot's in its block: `robot {planner} ... {{ {name} ... }}`"
                            " (a variant cannot change it)")
                return None
            if self.symbols.kind_of(planner) is NameKind.GROUP:
                members = ", ".join(f"{member}.{name}" for member in
                                    self.facts.groups.get(planner, ())[:3])
                self.report("E105", f"'{planner}' is a group: parameters are set for humans, "
                            "crowds and flows", param.name_span,
                            f"set it for each member: {members}" if members else None)
                return None
            hint = did_you_mean(planner, [*self.planners, *self.symbols.names_of(NameKind.HUMAN)])
            self.report("E105", f"'{planner}' is neither a planner nor a human", param.name_span,
                        hint or "planners: " + ", ".join(self.planners))
            return None
        return self._model_param(param, model, planner, name)

    def _model_param(self, param: ast.Param, model: type, owner: str,
                     name: str) -> float | None:
        """A parameter of a planner or controller, checked against its pydantic model."""
        kind = "planner" if owner in self.planners else "controller"
        fields = {f.alias or n: n for n, f in model.model_fields.items()}  # type: ignore[attr-defined]
        if name not in fields:
            hint = did_you_mean(name, fields) or f"{owner} takes " + ", ".join(sorted(fields))
            self.report("E105", f"{kind} '{owner}' has no parameter '{name}'",
                        param.name_span, hint)
            return None
        value, what = param.value, f"'{owner}.{name}'"
        number: float | None
        if isinstance(value, ast.Quantity):  # its unit must fit the dimension the planner declares
            number = self.values.quantity(value, field_dimension(model, fields[name]), what)
        elif isinstance(value, ast.Number):  # a bare number is in SI units
            number = value.value
        else:
            self.report("E201", f"{what} takes a number", value.span)
            return None
        if number is None:
            return None
        return self._validate_planner_value(model, name, what, number, value.span)

    def _validate_planner_value(self, model: type, name: str, what: str, number: float,
                                span: Span) -> float | None:
        from pydantic import ValidationError

        try:
            model.model_validate({name: number})  # type: ignore[attr-defined]
        except ValidationError as exc:
            problem = exc.errors()[0]
            self.report("E203", f"{what}: {problem['msg'].lower()}", span)
            return None
        self.planner_values.append((model, name, what, number, span))
        return number

    def _inert_planner_values(self) -> None:
        """W106: a planner parameter set above what the time step lets act (known only once
        every statement, `step` among them, has been read)."""
        step = self.facts.settings.get("step")
        step = step if isinstance(step, float) and step > 0 else DEFAULT_STEP
        for model, name, what, number, span in self.planner_values:
            inert_above = getattr(model, "inert_above", None)  # planners declare it
            bound = inert_above(step).get(name) if inert_above is not None else None
            if bound is not None and number > bound:
                self.diagnostics.append(warning(
                    "W106", f"{what} {number:g} acts as {bound:g}: the step of {step * 1e3:g} ms "
                    "caps it", span, f"a value above {bound:g} changes nothing at this step; "
                    "a smaller `step` lets a larger value act"))

    # ---- places, points, areas -------------------------------------------------------------

    def _heading(self, value: ast.Value | None) -> float | None:
        if value is None:
            return None
        return self.values.quantity(value, Dimension.ANGLE, "a heading")

    def _fixed_point(self, value: ast.PointValue, what: str) -> tuple[float, float] | None:
        """A literal point or a place: checked, converted and remembered for the map checks."""
        if isinstance(value, ast.NameRef):
            symbol = self.symbols.resolve(value, NameKind.PLACE, role=what)
            pose = self.facts.places.get(value.name) if symbol else None
            return pose.xy if pose else None
        x = self._coordinate(value.x)
        y = self._coordinate(value.y)
        if x is None or y is None:
            return None
        self.facts.positions.append((what, (x, y), value.span))
        return (x, y)

    def _coordinate(self, value: ast.Coordinate) -> float | None:
        """A coordinate in metres, a bare number or a length: finite and within LARGEST."""
        if not isinstance(value, ast.Number):
            return self.values.quantity(value, Dimension.LENGTH, "a coordinate")
        number = coordinate(value)
        farthest = LARGEST[Dimension.LENGTH]
        if not math.isfinite(number):
            self.report("E203", "a coordinate must be a finite number", value.span)
        elif abs(number) > farthest:
            self.report("E203", f"a coordinate is {number:g} m; the farthest it may be is "
                        f"{farthest:g} m", value.span)
        else:
            return number
        return None

    def _target(self, value: ast.Value, role: str) -> None:
        """A task target: a point, a place, or a human/robot (its position at the time)."""
        if isinstance(value, ast.NameRef):
            self.symbols.resolve(value, *TARGETS, role=role)
        elif isinstance(value, ast.Point):
            self._fixed_point(value, role)
        else:
            self.report("E201", f"{role} is a point, a place, a human or a robot", value.span)

    def _area(self, value: ast.AreaValue, what: str) -> object:
        if isinstance(value, ast.NameRef):
            self.symbols.resolve(value, NameKind.AREA, role=what)
            return None
        corners = (value.corner_a, value.corner_b) if isinstance(value, ast.RectArea) \
            else value.vertices
        if isinstance(value, ast.PolygonArea) and len(value.vertices) < 3:
            self.report("E203", f"{what}: a polygon needs at least three corners, not "
                        f"{len(value.vertices)}", value.span,
                        "write polygon(P, P, P, ...) or rect(P, P)")
            return None
        points = [self._fixed_point(c, what) for c in corners]
        if any(p is None for p in points):
            return None
        polygon = area_polygon(value, self.facts.places)
        if polygon.area <= 0 or not polygon.is_valid:
            self.report("E203", f"{what} has no area (its corners coincide, lie on a line, or "
                        "its edges cross)", value.span)
            return None
        return polygon

    # ---- activities ------------------------------------------------------------------------

    def _step(self, step: ast.Step) -> None:
        if isinstance(step, ast.TaskStep):
            self._task_step(step)
        elif isinstance(step, ast.WaitStep):
            self.values.quantity(step.duration, Dimension.TIME, "a wait", positive=True)
        elif isinstance(step, ast.WaitUntilStep):
            self._condition(step.condition)

    def _task_step(self, step: ast.TaskStep) -> None:
        task = step.task
        kind = TASKS.get(task.kind)
        if kind is None:
            self._unknown_task(task)
            return
        if self.symbols.kind_of(step.human.name) is NameKind.ROBOT:
            if kind.robot_options is None:
                robot_kinds = ", ".join(k.name for k in TASKS.values() if k.robots)
                self.report("E109", f"robots take {robot_kinds}, not {task.kind}",
                            task.kind_span)
                return
            kind = kind.for_robots()
            self.robot_steps.append((step.human, step))
        human = self.symbols.resolve(step.human, *BODIES, role=f"the subject of {task.kind}") \
            if self.symbols.kind_of(step.human.name) is NameKind.ROBOT else \
            self.symbols.resolve(step.human, NameKind.HUMAN, NameKind.CROWD, NameKind.GROUP,
                                 role=f"the subject of {task.kind}") \
            if self.symbols.kind_of(step.human.name) in (NameKind.CROWD, NameKind.GROUP) else \
            self.symbols.resolve(step.human, NameKind.HUMAN, role=f"the subject of {task.kind}")
        self._bare_target(step, kind)
        lasts = self._task_options(step, kind)
        for modifier, span in step.repeated:
            self.report("E106", f"`{modifier}` is given twice", span,
                        "keep one: a step has one `until`, one `within` and one `forever`")
        if step.until is not None:
            self._condition(step.until)
        if step.within is not None:
            deadline = self.values.quantity(step.within, Dimension.TIME, "'within'",
                                            positive=True)
            self._never_in_time(step, lasts, deadline)
        if human is not None and kind.target is TargetRule.BODY \
                and isinstance(task.target, ast.NameRef) \
                and self.symbols.kind_of(task.target.name) is NameKind.PLACE:
            self.report("E103", f"'{task.target.name}' is a place; {task.kind} needs a human or "
                        "robot", task.target.span)
        if kind.target is TargetRule.BODY and isinstance(task.target, ast.Point):
            self.report("E201", f"{task.kind} needs a human or robot, not a point",
                        task.target.span, "to walk to a point, use move_to")

    def _body_places(self) -> None:
        """Where bodies start and are sent, with the largest radius each may have (any variant,
        the upper end of a distribution), for the map check that they fit there."""
        largest = {name: self.facts.largest_radius(name)
                   for name in self.facts.human_starts}
        for crowd in self.facts.crowds:  # a crowd's or group's goal: where its largest fits
            largest[crowd.name] = self.facts.largest_radius(crowd.name, crowd.layer)
            largest |= dict.fromkeys(crowd.members, largest[crowd.name])
        radius = {name: value for name, (value, _) in largest.items()}
        for robot in self.facts.robots:
            radius[robot.name] = robot.radius
        for group, members in self.facts.groups.items():
            radius[group] = max((radius[m] for m in members if m in radius), default=0.0)
        for decl in self.module.of_type(ast.HumanDecl):
            name = decl.name.name
            start = self.facts.human_starts.get(name)
            if start is not None:
                self._start((f"the start of '{name}'", start.xy, radius[name],
                             decl.start.span), largest[name][1])
        for robot_decl, robot in zip(self.module.of_type(ast.RobotDecl), self.facts.robots,
                                     strict=False):
            self._start((f"the start of robot '{robot.name}'", robot.start.xy, robot.radius,
                         robot_decl.start.span), "")
            goal = next((p for p in robot_decl.params if p.dotted == "goal"), None)
            if robot.goal is not None and goal is not None:  # where it must arrive: it fits
                self.facts.bodies.append((f"the goal of robot '{robot.name}'", robot.goal,
                                          robot.radius, goal.value.span))
        # the first position written at each span (a scenario of thousands of goals looked
        # each one up in the whole list)
        points: dict[Span, tuple[float, float]] = {}
        for _, xy, span in self.facts.positions:
            points.setdefault(span, xy)
        for actor, kind, target in self.goals:
            where = self._point_of(target, points)
            if where is not None and actor in radius:
                what = f"the goal of {actor}'s {kind}"
                self.facts.bodies.append((what, where, radius[actor], target.span))
                if largest.get(actor, (0.0, ""))[1]:
                    self.facts.radius_origins[what] = largest[actor][1]

    def _start(self, body: tuple[str, tuple[float, float], float, Span], origin: str) -> None:
        self.facts.bodies.append(body)
        self.facts.starts.setdefault(body[0], body)
        if origin:
            self.facts.radius_origins[body[0]] = origin

    def _point_of(self, target: ast.PointValue, points: dict[Span, tuple[float, float]]
                  ) -> tuple[float, float] | None:
        if isinstance(target, ast.Point):
            return points.get(target.span)
        pose = self.facts.places.get(target.name)
        return pose.xy if pose is not None else None

    def _arrivals_measured(self) -> None:
        """E103: `time_to_goal` of a body without a `goal` (a human, a robot without one): it
        never arrives, so the expectation always fails (known once every robot is read)."""
        goals = {robot.name: robot.goal for robot in self.facts.robots}
        for expect in self.module.of_type(ast.ExpectDecl):
            compare = expect.condition
            if not isinstance(compare, ast.MetricCompare) \
                    or compare.metric.name != "time_to_goal":
                continue
            name = compare.subject.name
            kind = self.symbols.kind_of(name)
            if (kind is NameKind.ROBOT and goals.get(name) is not None) or kind not in (
                    NameKind.HUMAN, NameKind.ROBOT):
                continue  # a robot with a goal, or a name already reported
            what = f"robot '{name}' has no `goal`" if kind is NameKind.ROBOT else \
                f"'{name}' is a human, and humans have no goal it measures"
            self.report("E103", f"time_to_goal measures a robot's arrival at its `goal`: "
                        f"{what}, so the expectation always fails", compare.subject.span,
                        f"give the robot `goal P` in its block, or expect `{name} reaches P "
                        "within Q`" if kind is NameKind.ROBOT
                        else f"expect `{name} reaches P within Q` instead")

    def _robot_tasks(self) -> None:
        """E109: tasks given to a robot that drives a scripted path (known once every robot
        has been read, wherever it is declared)."""
        controllers = {robot.name: robot.controller for robot in self.facts.robots}
        unsaid = {decl.name.name for decl in self.module.of_type(ast.RobotDecl)
                  if decl.controller is None and decl.path is None}
        warned: set[str] = set()
        for ref, step in self.robot_steps:
            if controllers.get(ref.name) == "path":
                self.report("E109", f"robot '{ref.name}' drives its `path` and takes no tasks",
                            step.task.kind_span, "give it `controller navigator` (or "
                            "`external`) and a task, or drop the task")
            elif ref.name in unsaid and ref.name not in warned:
                warned.add(ref.name)  # once per robot: its first task
                self.diagnostics.append(warning(
                    "W505", f"robot '{ref.name}' names no controller, so nothing moves it but "
                    "a program driving it from Python (`controller external`): its tasks wait "
                    "for that", step.task.kind_span, "give it `controller navigator` to run it "
                    "from the command line, or write `controller external` when a program "
                    "drives it"))

    def _unknown_task(self, task: ast.Task) -> None:
        self.report("E108", f"unknown task '{task.kind}'", task.kind_span,
                    did_you_mean(task.kind, TASKS) or "the tasks are " + ", ".join(TASKS))

    def _bare_target(self, step: ast.TaskStep, kind: TaskKind) -> None:
        task = step.task
        if kind.target is not TargetRule.NONE and task.target is None:
            what = ("a human or robot: `{} {} NAME`" if kind.target is TargetRule.BODY
                    else "`{} {} PLACE` or a point `(x, y)`").format(step.human.name, task.kind)
            self.report("E205", f"{task.kind} needs a target", task.kind_span, f"write {what}")
        if task.target is None:
            return
        if kind.target is TargetRule.NONE:
            self.report("E205", f"{task.kind} takes no bare target", task.target.span,
                        f"write `{task.kind} {kind.hint_keyword} ...`")
        else:
            self._target(task.target, f"the target of {task.kind}")
            self._not_self(step, task.target)
            if kind.marks_goal:  # the actor's body must fit where it is sent
                self.goals.append((step.human.name, task.kind, task.target))

    def _not_self(self, step: ast.TaskStep, target: ast.Value, keyword: str = "") -> None:
        """A body is never its own target, nor is a member of the crowd or group told."""
        if not isinstance(target, ast.NameRef):
            return
        subject = step.human.name
        words = " ".join(w for w in (step.task.kind, keyword, "itself") if w)
        if target.name == subject:
            self.report("E203", f"{subject} cannot {words}", target.span)
        elif target.name in self._members_of(subject):
            self.report("E203", f"{target.name} is one of {subject}: it cannot {words}",
                        target.span, f"give the task to the others of {subject} one by one")

    def _where_to_set(self, name: str, param: str) -> str:
        """Where a parameter of one human (a crowd's member too), crowd or flow is given
        outside a variant."""
        symbol = self.symbols.symbols[name]
        if symbol.crowd is not None:
            return (f"set it for all of crowd '{symbol.crowd}' in its block as `{param}`, or "
                    f"for {name} alone in a variant")
        if symbol.kind is NameKind.HUMAN:
            return f"set it in human {name}'s own block as `{param}`"
        return f"set it for all of {symbol.kind.value} '{name}' in its block as `{param}`"

    def _members_of(self, name: str) -> tuple[str, ...]:
        """The members of crowd or group `name` (none for anyone else)."""
        if name in self.facts.groups:
            return self.facts.groups[name]
        return next((crowd.members for crowd in self.facts.crowds if crowd.name == name), ())

    def _never_in_time(self, step: ast.TaskStep, lasts: float | None,
                       deadline: float | None) -> None:
        """A task that lasts longer than its `within` (and has no `until` to end it sooner) is
        aborted on every run: say so."""
        if lasts is not None and deadline is not None and lasts > deadline \
                and step.until is None and step.within is not None:
            self.warn("W506", f"{step.task.kind} lasts at least {lasts:g} s (its `for`), so "
                      f"`within {deadline:g} s` aborts it on every run", step.within.span,
                      "give the task a shorter `for` or more time")

    def _task_options(self, step: ast.TaskStep, kind: TaskKind) -> float | None:
        """Check a task's options; the time its `for` gives it (None: no `for`)."""
        task = step.task
        lasts: float | None = None
        seen: dict[str, ast.TaskOption] = {}
        for option in task.options:
            spec = kind.option(option.keyword)
            if spec is None:
                takes = ", ".join(f"`{k}`" for k in kind.keywords) or "no options"
                self.report("E107", f"{task.kind} takes no `{option.keyword}`", option.span,
                            f"{task.kind} takes {takes}")
                continue
            if option.keyword in seen:
                self.report("E106", f"`{option.keyword}` is given twice", option.span, None,
                            (Related("first given here", seen[option.keyword].span),))
                continue
            seen[option.keyword] = option
            number = self._option_value(step, option, spec)
            if option.keyword == "for":
                lasts = number
        if "for" in seen and "times" in seen:
            self.report("E106", f"{task.kind} takes `for` or `times`, not both",
                        seen["times"].span)
        return lasts

    def _option_value(self, step: ast.TaskStep, option: ast.TaskOption,
                      spec: OptionSpec) -> float | None:
        """Check an option's value; its SI number where it is a quantity."""
        value = option.value
        role = f"`{option.keyword}` of {step.task.kind}"
        if spec.value is ValueKind.TARGET:
            self._target(value, role)  # type: ignore[arg-type]
            self._not_self(step, value, option.keyword)  # type: ignore[arg-type]
        elif spec.value is ValueKind.AREA:
            self._area(value, role)  # type: ignore[arg-type]
        elif spec.value is ValueKind.COUNT:
            self.values.integer(value, role, minimum=1)  # type: ignore[arg-type]
        elif spec.value.dimension is not None:
            return self.values.quantity(value, spec.value.dimension, role,
                                        positive=spec.value is not ValueKind.ANGLE)
        return None

    # ---- conditions ------------------------------------------------------------------------

    def _condition(self, condition: ast.Condition) -> None:
        parts = ast.walk_conditions(condition)
        if len(parts) > MAX_CONDITION_PARTS:  # each is judged every tick the condition waits
            self.report("E203", f"a condition of {len(parts):,} parts; the most one may have "
                        f"is {MAX_CONDITION_PARTS:,}", condition.span,
                        "name what it waits for with labels, areas or `count(...)`")
            return
        for part in parts:
            match part:
                case ast.LabelCondition(label=label):
                    self.symbols.resolve(label, NameKind.LABEL,
                                         role=f"`{label.name} {part.event.value}`")
                case ast.ReachesCondition(subject=subject, target=target):
                    self.symbols.resolve(subject, *BODIES, role="`reaches`",
                                         for_many="of many: `all NAME reach ...`, "
                                                  "`any NAME reaches ...`")
                    self._target(target, "the target of `reaches`")
                case ast.DistanceCondition(subject=subject, target=target):
                    self.symbols.resolve(subject, *BODIES, role="distance(...)")
                    self._target(target, "distance(...)")
                    self.values.quantity(part.threshold, Dimension.LENGTH, "a distance",
                                         non_negative=True)
                case ast.AllReach(group=group, target=target) | \
                        ast.AnyReaches(group=group, target=target):
                    self.symbols.resolve(group, *MANY, role="`all`/`any`")
                    self._target(target, "the target of `reach`")
                case ast.CountIn(group=group, area=area, threshold=threshold):
                    self.symbols.resolve(group, *MANY, role="count(...)")
                    self._area(area, "count(...)")
                    self.values.integer(threshold, "a count", minimum=0)
                case ast.InsideCondition(subject=subject, area=area):
                    self.symbols.resolve(subject, *BODIES, role="`in`",
                                         for_many="count them: `count(NAME in AREA) >= N`")
                    self._area(area, "`in`")
                case ast.TimeCondition(threshold=threshold):
                    self.values.quantity(threshold, Dimension.TIME, "a time", non_negative=True)


def no_activity(module: ast.Module) -> Diagnostic | None:
    """W502 for a scenario in which nobody does anything (a run would end at once). The
    pipeline asks only of a file with no errors, where it is not the least of its problems."""
    activities = module.of_type(ast.ActivityDecl)
    if not module.statements or any(a.steps for a in activities) or any(
            f.duration is not None or f.until is not None for f in module.of_type(ast.FlowDecl)):
        return None
    return warning("W502", "the scenario has no activity: nobody does anything and a run ends "
                   "at once", Span.whole_file(module.source.path),
                   "add `activity { HUMAN TASK ... }`")


def _singleton_keyword(statement: ast.Statement) -> str | None:
    if isinstance(statement, ast.ScenarioDecl):
        return "scenario"
    if isinstance(statement, ast.MapDecl):
        return "map"
    if isinstance(statement, ast.SettingDecl):
        return statement.keyword
    if isinstance(statement, ast.DefaultsDecl):
        return "defaults"
    return None


def _source_text(text: str, span: Span) -> str:
    """What a span covers, on one line: the name of a sweep's variant (`speed=1.2 m/s`)."""
    lines = text.split("\n")  # as the lexer counts lines (str.splitlines also splits at \f)
    if span.end_line > len(lines):
        return "?"
    if span.line == span.end_line:
        written = lines[span.line - 1][span.column - 1: span.end_column - 1]
    else:  # a value wrapped inside its parentheses
        written = "\n".join([lines[span.line - 1][span.column - 1:],
                             *lines[span.line: span.end_line - 1],
                             lines[span.end_line - 1][: span.end_column - 1]])
    return " ".join(re.sub(r"#[^\n]*", "", written).split())


__all__ = ["Checker", "Distribution", "Facts"]


def _requires_all_of(condition: ast.Condition, flow: str) -> ast.AllReach | None:
    """`all FLOW reach T` where `condition` cannot hold without it (itself, or a part of an
    `and`)."""
    if isinstance(condition, ast.AllReach):
        return condition if condition.group.name == flow else None
    if isinstance(condition, ast.AllOf):
        for operand in condition.operands:
            if (found := _requires_all_of(operand, flow)) is not None:
                return found
    return None
