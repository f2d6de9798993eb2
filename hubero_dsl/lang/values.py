"""Checking and converting values: units and dimensions, ranges, shapes and distributions.

`ValueReader` turns AST values into SI floats, shapes and distributions, appending a diagnostic
for each problem and returning None for a value it cannot use, so the caller goes on and every
problem of a file is reported in one pass.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable

from hubero_dsl.diagnostics import Diagnostic, Span, closest, error
from hubero_dsl.errors import InputError
from hubero_dsl.lang import ast
from hubero_dsl.model.params import ParamKind, ParamSpec
from hubero_dsl.model.program import Distribution, ParamValue
from hubero_dsl.model.units import (
    BARE_IS_SI,
    EXAMPLE_UNIT,
    LARGEST,
    UNITS,
    Dimension,
    describe,
    dimension_named,
)
from hubero_dsl.world.shapes import Circle, Ellipse, Rectangle, Shape

SHAPE_ARGS: dict[str, tuple[tuple[str, ...], tuple[str, ...]]] = {
    # kind: (required, optional)
    "circle": (("radius",), ()),
    "ellipse": (("semi_major", "semi_minor"), ("offset",)),
    "rectangle": (("length", "width"), ()),
    "square": (("side",), ()),
}


def did_you_mean(word: str, candidates: Iterable[str]) -> str | None:
    """'did you mean X?' for the closest candidate, or None when nothing is close."""
    meant = closest(word, candidates)
    return f"did you mean '{meant}'?" if meant is not None else None


def field_dimension(model: type, field: str) -> Dimension:
    """The dimension a planner declares for a parameter (`json_schema_extra={"dimension": ...}`
    on its pydantic field); a parameter that declares none is a plain number."""
    extra = model.model_fields[field].json_schema_extra  # type: ignore[attr-defined]
    return dimension_named(extra.get("dimension") if isinstance(extra, dict) else None)


def _range_problem(spec: ParamSpec, number: float) -> str | None:
    """What is wrong with a value of a quantity parameter, or None when it is fine."""
    if spec.positive and number <= 0:
        return "must be greater than zero"
    if not spec.positive and number < 0:
        return "must not be negative"
    if number > spec.maximum:
        return f"may be at most {format_si(spec.maximum, spec.dimension)}"
    return None


def _shown_as_written(value: object, dimension: Dimension) -> Callable[[float], str]:
    """SI values shown in the unit `value` was written in (`1001 /s` stays per second), else
    in the examples' unit."""
    if isinstance(value, ast.Quantity) and value.known_unit:
        unit, factor = value.unit, UNITS[value.unit][1]
        return lambda number: f"{number / factor:g} {unit}"
    return lambda number: format_si(number, dimension)


def format_si(value: float, dimension: Dimension) -> str:
    """An SI value in the unit the language's examples use (a rate per minute, an angle in
    degrees)."""
    unit = EXAMPLE_UNIT[dimension]
    if dimension is Dimension.ANGLE:
        return f"{math.degrees(value):g} deg"
    factor = UNITS[unit][1] if unit in UNITS else 1.0
    return f"{value / factor:g} {unit}".strip()


class ValueReader:
    """Converts values to SI while collecting diagnostics."""

    def __init__(self, diagnostics: list[Diagnostic]) -> None:
        self.diagnostics = diagnostics

    def report(self, code: str, message: str, span: Span, hint: str | None = None) -> None:
        self.diagnostics.append(error(code, message, span, hint))

    # ---- quantities ----------------------------------------------------------------------

    def quantity(self, value: ast.Value | ast.RectArea | ast.PolygonArea, dimension: Dimension,
                 what: str, *, positive: bool = False, non_negative: bool = False,
                 maximum: float = math.inf) -> float | None:
        """The SI value of a quantity of `dimension`, or None after reporting why not."""
        number = self._magnitude(value, dimension, what)
        if number is None:
            return None
        if not math.isfinite(number):
            self.report("E203", f"{what} must be a finite number", value.span)
            return None
        maximum = min(maximum, LARGEST.get(dimension, math.inf))
        shown = _shown_as_written(value, dimension)
        if number < -LARGEST.get(dimension, math.inf):
            self.report("E203", f"{what} is {shown(number)}; the least it may be "
                        f"is {shown(-LARGEST[dimension])}", value.span)
            return None
        if positive and number <= 0:
            self.report("E203", f"{what} must be greater than zero, not {shown(number)}",
                        value.span)
            return None
        if non_negative and number < 0:
            self.report("E203", f"{what} must not be negative", value.span)
            return None
        if number > maximum:
            self.report("E203", f"{what} is {shown(number)}; the most it may be is "
                        f"{shown(maximum)}", value.span)
            return None
        return number

    def _magnitude(self, value: ast.Value | ast.RectArea | ast.PolygonArea,
                   dimension: Dimension, what: str) -> float | None:
        if isinstance(value, ast.Quantity):
            if not value.known_unit:
                hint = did_you_mean(value.unit, UNITS) or "units are " + ", ".join(UNITS)
                self.report("E202", f"unknown unit '{value.unit}'", value.span, hint)
                return None
            if value.dimension is not dimension:
                got = value.dimension.value if value.dimension else "?"
                hint = (f"write a value like `1 {EXAMPLE_UNIT[dimension]}`"
                        if dimension is not Dimension.NUMBER else "write a plain number")
                self.report("E201", f"{what} takes {describe(dimension)}, but '{value.unit}' is "
                            f"a unit of {got}", value.span, hint)
                return None
            return value.si
        if isinstance(value, ast.Number):
            if dimension is Dimension.NUMBER or dimension in BARE_IS_SI:
                return value.value
            self.report("E204", f"{what} needs a unit: {describe(dimension)}", value.span,
                        _unit_hint(value, dimension))
            return None
        if isinstance(value, ast.Distribution):  # its values may be of the dimension: not it
            self.report("E201", f"{what} takes one {dimension.value}, not a distribution",
                        value.span, _one_value_hint(value))
            return None
        self.report("E201", f"{what} takes {describe(dimension)}", value.span)
        return None

    def integer(self, value: ast.Value, what: str, *, minimum: int = 0) -> int | None:
        if isinstance(value, ast.Number) and value.text.isdigit() \
                and not math.isfinite(value.value):  # hundreds of digits: whole, but no float
            self.report("E203", f"{what} has {len(value.text)} digits: too large",
                        value.span, "write a number of a few digits")
            return None
        if not isinstance(value, ast.Number) or not value.is_integer:
            self.report("E207", f"{what} must be a whole number", value.span)
            return None
        if value.value < minimum:
            self.report("E203", f"{what} must be at least {minimum}", value.span)
            return None
        # the literal itself: a seed above 2**53 would round through a float
        return int(value.text) if value.text.isdigit() else int(value.value)

    # ---- parameters ------------------------------------------------------------------------

    def param(self, spec: ParamSpec, value: ast.Value,
              planners: Iterable[str]) -> ParamValue | None:
        """A human parameter's value, checked against its spec."""
        what = f"'{spec.name}'"
        if spec.kind is ParamKind.SHAPE:
            return self.shape(value)
        if spec.kind is ParamKind.PLANNER:
            names = sorted(planners)
            if not isinstance(value, ast.NameRef):
                self.report("E201", f"{what} takes a planner name", value.span,
                            "one of: " + ", ".join(names))
                return None
            return self._planner(spec.name, value, names)
        if spec.kind is ParamKind.CHOICE:
            if isinstance(value, ast.NameRef) and value.name in spec.choices:
                return value.name
            written = value.name if isinstance(value, ast.NameRef) else ""
            self.report("E201", f"{what} is one of {', '.join(spec.choices)}", value.span,
                        did_you_mean(written, spec.choices) if written else None)
            return None
        if isinstance(value, ast.Distribution):
            return self.distribution(value, spec)
        return self.quantity(value, spec.dimension, what, positive=spec.positive,
                             non_negative=not spec.positive, maximum=spec.maximum)

    def _planner(self, param: str, value: ast.NameRef, names: list[str]) -> str | None:
        """A planner's name given to `param` (`global_planner`, `local_planner`): installed,
        of that kind, and, for a plugin, loadable as a planner."""
        from hubero_dsl.planners.registry import (
            check_plugin,
            global_planner_names,
            local_planner_names,
        )

        kind, other = ("global", "local") if param == "global_planner" else ("local", "global")
        if value.name not in names:
            others = global_planner_names() if other == "global" else local_planner_names()
            if value.name in others:
                self.report("E101", f"'{value.name}' is a {other} planner, not a {kind} one",
                            value.span, f"give it as `{other}_planner {value.name}`; {kind} "
                            "planners: " + ", ".join(names))
                return None
            hint = did_you_mean(value.name, names) or "installed: " + ", ".join(names)
            self.report("E101", f"unknown {kind} planner '{value.name}'", value.span, hint)
            return None
        try:
            check_plugin(kind, value.name)
        except InputError as exc:
            self.report("E110", exc.message, value.span)
            return None
        return value.name

    def distribution(self, value: ast.Distribution, spec: ParamSpec) -> Distribution | None:
        what = f"'{spec.name}'"
        first = self.quantity(value.first, spec.dimension, f"{value.kind} of {what}")
        second = self.quantity(value.second, spec.dimension, f"{value.kind} of {what}")
        if first is None or second is None:
            return None
        if value.kind == "normal" and second <= 0:
            self.report("E206", "the standard deviation of normal(...) must be greater than "
                        "zero", value.second.span)
            return None
        if value.kind == "uniform" and second <= first:
            self.report("E206", "uniform(low, high) needs low < high", value.span)
            return None
        if not self._distribution_in_range(value, spec, first, second):
            return None
        return Distribution("normal" if value.kind == "normal" else "uniform", first, second)

    def _distribution_in_range(self, value: ast.Distribution, spec: ParamSpec, first: float,
                               second: float) -> bool:
        """A normal's mean, or both ends of a uniform, must be values the parameter may take."""
        what = f"'{spec.name}'"
        if value.kind == "normal":
            ends = [(first, value.first.span, f"the mean of {what} {{}}")]
        else:
            ends = [(first, value.first.span, f"{what} {{}}; uniform(...) starts at {{}}"),
                    (second, value.second.span, f"{what} {{}}; uniform(...) ends at {{}}")]
        for number, span, message in ends:
            problem = _range_problem(spec, number)
            if problem is not None:
                self.report("E203", message.format(problem, format_si(number, spec.dimension)),
                            span)
                return False
        return True

    def shape(self, value: ast.Value) -> Shape | None:
        if not isinstance(value, ast.ShapeLit):
            self.report("E201", "a personal space is a shape", value.span,
                        "write circle(radius: 0.5 m), ellipse(semi_major: 1.1 m, semi_minor: "
                        "0.8 m), rectangle(length: 1 m, width: 0.6 m) or square(side: 0.5 m)")
            return None
        args = self._shape_args(value)
        if args is None:
            return None
        if value.kind == "circle":
            return Circle(args["radius"])
        if value.kind == "square":
            return Rectangle(args["side"], args["side"])
        if value.kind == "rectangle":
            return Rectangle(args["length"], args["width"])
        return self._ellipse(value, args)

    def _ellipse(self, value: ast.ShapeLit, args: dict[str, float]) -> Shape | None:
        major, minor, offset = args["semi_major"], args["semi_minor"], args.get("offset", 0.0)
        if minor > major:
            arg = value.arg("semi_minor")
            self.report("E203", f"semi_minor ({minor:g} m) is larger than semi_major "
                        f"({major:g} m)", arg.span if arg else value.span,
                        "semi_major runs along the heading and is the longer axis; swap them")
            return None
        if abs(offset) >= major:
            arg = value.arg("offset")
            self.report("E203", f"offset {offset:g} m puts the human outside its own personal "
                        f"space (semi_major is {major:g} m)", arg.span if arg else value.span)
            return None
        return Ellipse(major, minor, offset)

    def _shape_args(self, value: ast.ShapeLit) -> dict[str, float] | None:
        required, optional = SHAPE_ARGS[value.kind]
        allowed = required + optional
        found: dict[str, float] = {}
        ok = True
        for arg in value.args:
            if arg.name not in allowed:
                takes = f"{value.kind} takes " + ", ".join(allowed)
                hint = did_you_mean(arg.name, allowed) or takes
                self.report("E105", f"{value.kind} has no argument '{arg.name}'", arg.name_span,
                            hint)
                ok = False
            elif arg.name in found:
                self.report("E106", f"'{arg.name}' is given twice", arg.name_span)
                ok = False
            else:
                number = self.quantity(arg.value, Dimension.LENGTH, arg.name,
                                       positive=arg.name != "offset")
                ok = ok and number is not None
                found[arg.name] = number if number is not None else 0.0
        missing = [name for name in required if name not in found]
        if missing:
            example = ", ".join(f"{name}: 0.5 m" for name in required)
            self.report("E205", f"{value.kind} needs {' and '.join(missing)}", value.span,
                        f"write {value.kind}({example})")
            ok = False
        return found if ok else None


def _one_value_hint(value: ast.Distribution) -> str:
    """What to write instead of a distribution where one value goes: its first value."""
    first = value.first
    written = (first.text if isinstance(first, ast.Number) else
               f"{first.magnitude:g} {first.unit}" if isinstance(first, ast.Quantity) else "")
    drawn = "only people's parameters are drawn from normal(...) or uniform(...)"
    return f"{drawn}; write one value, like `{written}`" if written else drawn


def _unit_hint(value: ast.Number, dimension: Dimension) -> str:
    """How to write `value` with a unit; a share written as a fraction (0.9) is shown in
    percent (90 %), not as 0.9 %."""
    if dimension is Dimension.RATIO and 0.0 < value.value <= 1.0:
        return (f"write `{value.value * 100:g} %` (a share is written in percent; "
                f"`{value.text} %` would be {value.text} in a hundred)")
    return f"write `{value.text} {EXAMPLE_UNIT[dimension]}`"
