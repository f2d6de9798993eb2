"""The checked program: what a scenario means, resolved to SI values, ready to simulate.

`Program` is what the compiler hands downstream (the engine, the scheduler, the log, the
analyses); nothing downstream reads the syntax tree. Names are resolved (places to poses, areas
to shapely polygons), quantities are SI floats, parameters are layered (built-in defaults <
`defaults` < human block < variant), activities and expectations are lowered
(`hubero_dsl.model.activities`) and the activity graph is built. Distributions stay unresolved
(`Distribution`) until a run draws them from its seed.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Literal

from hubero_dsl.diagnostics import SourceFile, Span
from hubero_dsl.model.activities import Activity, Expectation
from hubero_dsl.model.conditions import Condition
from hubero_dsl.model.params import HUMAN_PARAMS
from hubero_dsl.world.shapes import Shape

if TYPE_CHECKING:
    import networkx as nx
    from shapely.geometry import Polygon

    from hubero_dsl.world.grid import OccupancyGrid


@dataclass(frozen=True, slots=True)
class Distribution:
    """A parameter each human draws once per run: normal(mean, sd) or uniform(low, high)."""

    kind: Literal["normal", "uniform"]
    first: float
    second: float

    def describe(self) -> str:
        return f"{self.kind}({self.first:g}, {self.second:g})"

    @property
    def upper(self) -> float:
        """The most a draw may be, as far as checks go: the high end, or two deviations up."""
        return self.second if self.kind == "uniform" else self.first + 2 * self.second


ParamValue = float | str | Shape | Distribution


@dataclass(frozen=True, slots=True)
class Pose:
    x: float
    y: float
    heading: float | None = None

    @property
    def xy(self) -> tuple[float, float]:
        return (self.x, self.y)


@dataclass(frozen=True, slots=True)
class ParamLayer:
    """One layer of the parameter precedence.

    `values` maps a parameter (`speed`, or a planner's `social_force.A`) to its value for every
    human the layer applies to; `per_human` holds a variant's `actor1.speed`-style settings.
    """

    values: Mapping[str, ParamValue] = field(default_factory=dict)
    per_human: Mapping[str, Mapping[str, ParamValue]] = field(default_factory=dict)


@dataclass(frozen=True, slots=True)
class HumanSpec:
    name: str
    start: Pose
    params: ParamLayer
    span: Span
    group: str | None = None  # the crowd or flow the human belongs to


@dataclass(frozen=True, slots=True)
class CrowdSpec:
    """A crowd as placed: its members start at places of `area` drawn from the run's seed, clear
    of `radius` around the obstacles and of the bodies placed before them."""

    name: str
    area: Polygon
    radius: float
    heading: float
    members: tuple[str, ...]
    span: Span | None = None  # the `crowd` statement, for errors of a run with another seed


@dataclass(frozen=True, slots=True)
class FlowSpec:
    """People who keep arriving: they appear in `area` at seeded Poisson times, `rate` per
    second on average, walk to `target` and leave the scene there.

    `members` are their names in order of appearance, as many as the flow may bring (its
    bound, `flow_bound`); a run draws the arrival times and uses the first ones. Spawning
    stops after `duration` seconds, or once `until` holds; a flow with either keeps the run
    alive until it has stopped and its people have left (`keeps_alive`)."""

    name: str
    area: Polygon
    target: tuple[float, float]
    rate: float
    members: tuple[str, ...]
    span: Span
    duration: float | None = None
    until: Condition | None = None
    # Explicit arrival times (s, one per member, in order) instead of Poisson ones: people who
    # enter at a given time, as a rebuild of a recording brings them in.
    arrivals: tuple[float, ...] | None = None

    @property
    def keeps_alive(self) -> bool:
        return self.duration is not None or self.until is not None


def flow_bound(rate: float, seconds: float) -> int:
    """How many people a flow may bring in `seconds`: the Poisson mean plus six standard
    deviations (a run that draws more, about once in a billion, stops spawning there)."""
    mean = rate * seconds
    return math.ceil(mean + 6.0 * math.sqrt(mean) + 6.0)


@dataclass(frozen=True, slots=True)
class RobotSpec:
    """A robot as declared: its body, kinematics and limits, and who drives it.

    `controller` is a registered controller's name (`path`, `navigator`, `external`, or a
    plugin's); `controller_params` its own parameters (`navigator.safety_margin 0.3`).
    Limits that were not set are infinite."""

    name: str
    start: Pose
    radius: float
    speed: float
    path: tuple[tuple[float, float], ...]
    loop: bool
    controller: str
    span: Span
    controller_params: Mapping[str, float] = field(default_factory=dict)
    kinematics: Literal["holonomic", "unicycle"] = "holonomic"
    goal: tuple[float, float] | None = None
    max_speed: float = math.inf
    max_acceleration: float = math.inf
    max_angular_speed: float = math.inf
    goal_tolerance: float = 0.2
    sensor_range: float = 5.0
    field_of_view: float = 2 * math.pi


@dataclass(frozen=True, slots=True)
class Variant:
    name: str
    layers: tuple[ParamLayer, ...]  # applied in order, later wins


@dataclass(frozen=True, eq=False)
class Program:
    """A checked scenario. Read-only; a run never changes it."""

    source: SourceFile
    title: str
    map_path: Path
    grid: OccupancyGrid
    seed: int
    step: float
    time_limit: float
    on_failure: Literal["stop", "continue"]
    bounds: Polygon | None
    places: Mapping[str, Pose]
    areas: Mapping[str, Polygon]
    defaults: ParamLayer
    humans: tuple[HumanSpec, ...]
    robots: tuple[RobotSpec, ...]
    variants: Mapping[str, Variant]
    activities: tuple[Activity, ...]
    expectations: tuple[Expectation, ...]
    graph: nx.DiGraph
    groups: Mapping[str, tuple[str, ...]] = field(default_factory=dict)  # walk together
    flows: tuple[FlowSpec, ...] = ()
    # The crowds in the order they are placed, and the bodies placed before any of them (named
    # humans and robots: x, y, radius): what a run with another seed places the crowds anew by.
    crowds: tuple[CrowdSpec, ...] = ()
    fixed_bodies: tuple[tuple[float, float, float], ...] = ()
    # the map as the file wrote it (relative to the file): what a log records, so that the
    # same file logs the same bytes wherever it lies; `map_path` when empty
    map_written: str = ""

    def people_sets(self) -> dict[str, tuple[str, tuple[str, ...]]]:
        """The crowds, flows and groups: name -> (kind, members), crowds and flows in the order
        of their first member, then groups."""
        flows = {flow.name for flow in self.flows}
        members: dict[str, list[str]] = {}
        for human in self.humans:
            if human.group is not None:
                members.setdefault(human.group, []).append(human.name)
        sets = {name: ("flow" if name in flows else "crowd", tuple(names))
                for name, names in members.items()}
        sets.update((name, ("group", tuple(names))) for name, names in self.groups.items())
        return sets

    @property
    def human_names(self) -> list[str]:
        return [h.name for h in self.humans]

    def human(self, name: str) -> HumanSpec:
        return next(h for h in self.humans if h.name == name)

    def resolved_params(self, variant: str | None = None) -> dict[str, dict[str, ParamValue]]:
        """Every human's parameters, by name, with the precedence of the language applied."""
        layers = list(self.variants[variant].layers) if variant else []
        resolved: dict[str, dict[str, ParamValue]] = {}
        for human in self.humans:
            values: dict[str, ParamValue] = {n: s.default for n, s in HUMAN_PARAMS.items()}
            for layer in (self.defaults, human.params, *layers):
                values.update(layer.values)
                if human.group is not None:  # `shoppers.speed 1 m/s` in a variant
                    values.update(layer.per_human.get(human.group, {}))
                values.update(layer.per_human.get(human.name, {}))
            resolved[human.name] = values
        return resolved


def unknown_variants(names: Sequence[object], variants: Iterable[str]) -> str:
    """The words for variants a scenario does not have, listing those it has: `; ` between
    them, since a swept variant's name holds commas (`x=1,y=2`)."""
    known = "; ".join(variants) or "none (this scenario has no variants)"
    quoted = ", ".join(f"'{name}'" for name in names)
    return f"unknown variant {quoted} (variants: {known})"


def sweep_products(sweeps: list[tuple[str, list[tuple[str, ParamLayer]]]]
                   ) -> list[tuple[str, tuple[ParamLayer, ...]]]:
    """Variants of several sweeps multiplied: names `a=1 m/s,b=2` with one layer per sweep."""
    if not sweeps:
        return []
    combos = itertools.product(*(options for _, options in sweeps))
    return [(",".join(name for name, _ in combo), tuple(layer for _, layer in combo))
            for combo in combos]
