"""A scenario's own words back from its syntax: values, conditions and task steps as text.

The lowering stores these texts on the model (a condition's `text`, a task step's `text`), so
that messages and diagrams quote the scenario as it was written, in one canonical spelling.
"""

from __future__ import annotations

from hubero_dsl.lang import ast


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
        case ast.AllReach():
            return f"all {condition.group.name} reach {format_value(condition.target)}"
        case ast.AnyReaches():
            return f"any {condition.group.name} reaches {format_value(condition.target)}"
        case ast.CountIn():
            return (f"count({condition.group.name} in {format_value(condition.area)}) "
                    f"{condition.operator} {format_value(condition.threshold)}")
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
