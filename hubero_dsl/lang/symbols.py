"""The scenario's one namespace: every defined name, its kind and where it was defined.

Places, areas, humans, robots, variants, activities and step labels share one namespace
(LANGUAGE.md). Building the table reports duplicates and reserved words; lookups report unknown
names (with a "did you mean") and names of the wrong kind.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass
from enum import StrEnum
from functools import cache

from hubero_dsl.diagnostics import Diagnostic, Related, Span, error
from hubero_dsl.lang import ast
from hubero_dsl.lang.values import did_you_mean
from hubero_dsl.model.tasks import TASKS


class NameKind(StrEnum):
    PLACE = "place"
    AREA = "area"
    HUMAN = "human"
    CROWD = "crowd"
    FLOW = "flow"
    GROUP = "group"
    ROBOT = "robot"
    VARIANT = "variant"
    ACTIVITY = "activity"
    LABEL = "label"


MANY = (NameKind.CROWD, NameKind.GROUP, NameKind.FLOW)  # names of sets of humans
MEMBER_NAME = re.compile(r"(\w+)_([1-9][0-9]*)")  # a crowd's or flow's member: NAME_N


@dataclass(frozen=True, slots=True)
class Symbol:
    name: str
    kind: NameKind
    span: Span
    crowd: str | None = None  # the crowd a member is one of (defined at the crowd's name)


@cache
def reserved_words() -> frozenset[str]:
    """Every keyword of the grammar that looks like a name, and every task kind.

    Shape and distribution kinds (`circle`, `normal`, ...) are only keywords right before `(`,
    so they stay free for names: `variant circle { ... }` is fine. Task kinds are names to the
    grammar (the registry knows them), but a human called `talk` would read badly, so they are
    reserved like keywords.
    """
    from hubero_dsl.lang.parse import grammar_text

    words = set(re.findall(r'"([A-Za-z_][A-Za-z0-9_]*)"', grammar_text()))
    return frozenset((words - VALUE_KEYWORDS) | set(TASKS))


VALUE_KEYWORDS = frozenset({"circle", "ellipse", "rectangle", "square", "normal", "uniform"})


class SymbolTable:
    def __init__(self, diagnostics: list[Diagnostic]) -> None:
        self.diagnostics = diagnostics
        self.symbols: dict[str, Symbol] = {}
        self.used: set[str] = set()

    def define(self, ref: ast.NameRef, kind: NameKind, crowd: str | None = None) -> None:
        if ref.name in reserved_words():
            self.diagnostics.append(error(
                "E104", f"'{ref.name}' is a keyword and cannot name {_a(kind.value)}", ref.span,
                f"pick another name, e.g. '{ref.name}_1'"))
            return
        previous = self.symbols.get(ref.name)
        if previous is not None:
            self.diagnostics.append(error(
                "E102", f"'{ref.name}' is defined twice", ref.span,
                "every name (place, area, human, robot, variant, activity, label) is defined once",
                (Related(f"first defined here as {_a(previous.kind.value)}" if previous.crowd
                         is None else f"first defined here as a member of crowd "
                         f"'{previous.crowd}'", previous.span),)))
            return
        self.symbols[ref.name] = Symbol(ref.name, kind, ref.span, crowd)

    def names_of(self, *kinds: NameKind) -> list[str]:
        return sorted(s.name for s in self.symbols.values() if s.kind in kinds)

    def kind_of(self, name: str) -> NameKind | None:
        symbol = self.symbols.get(name)
        return symbol.kind if symbol else None

    def resolve(self, ref: ast.NameRef, *kinds: NameKind, role: str,
                for_many: str | None = None) -> Symbol | None:
        """The symbol `ref` names if it is one of `kinds`; otherwise report and return None.
        `for_many`: the hint when it names a crowd, flow or group (the form that takes many,
        with NAME for its name)."""
        symbol = self.symbols.get(ref.name)
        wanted = " or ".join(k.value for k in kinds)
        if symbol is None and (flow := self.flow_of_member(ref.name)) is not None:
            self.used.add(flow)
            self.diagnostics.append(error(
                "E103", f"'{ref.name}' is one of the people flow '{flow}' brings, who come and "
                f"go: they are not named one by one ({role})", ref.span,
                f"name the flow: `all {flow} reach P`, `any {flow} reaches P`, "
                f"`count({flow} in AREA)`"))
            return None
        if symbol is None:
            # a crowd's name is closer to a slip of it than any of its members' (`shopers`)
            sets = MANY if NameKind.HUMAN in kinds else ()
            hint = did_you_mean(ref.name, self.names_of(*kinds, *sets))
            if hint is None and (names := self.names_of(*kinds)):
                hint = "defined: " + ", ".join(names[:8]) + (", ..." if len(names) > 8 else "")
            self.diagnostics.append(error("E101", f"unknown {wanted} '{ref.name}' ({role})",
                                          ref.span, hint))
            return None
        self.used.add(ref.name)
        if symbol.kind not in kinds:
            hint = for_many.replace("NAME", ref.name) if for_many and symbol.kind in MANY \
                else None
            self.diagnostics.append(error(
                "E103", f"'{ref.name}' is {_a(symbol.kind.value)}, but {role} needs {_a(wanted)}",
                ref.span, hint, (Related(f"'{ref.name}' is defined here", symbol.span),)))
            return None
        return symbol


    def flow_of_member(self, name: str) -> str | None:
        """The flow whose member `name` would be (`NAME_N`), or None."""
        found = MEMBER_NAME.fullmatch(name)
        flow = found.group(1) if found is not None else None
        return flow if flow is not None and self.kind_of(flow) is NameKind.FLOW else None


def _a(noun: str) -> str:
    """The noun with its indefinite article: 'a place', 'an area'."""
    return f"{'an' if noun[:1] in 'aeiou' else 'a'} {noun}"


def alias_depths(definitions: Sequence[tuple[ast.NameRef, object]], kind: str,
                 diagnostics: list[Diagnostic]) -> dict[str, int]:
    """How far each place (area) is from one with a position (shape) of its own, through names
    defined as other names (`place a at b`, `area a b`); names defined through themselves are
    reported and left out."""
    names = {name.name for name, _ in definitions}
    aliases = {name.name: value.name for name, value in definitions
               if isinstance(value, ast.NameRef) and value.name in names}
    depths = {name: 0 for name in names - aliases.keys()}
    for name, value in definitions:
        chain = [name.name]
        while chain[-1] in aliases and aliases[chain[-1]] not in chain:
            chain.append(aliases[chain[-1]])
        if chain[-1] not in aliases:
            depths[name.name] = len(chain) - 1
        elif isinstance(value, ast.NameRef):  # its chain goes round a cycle
            diagnostics.append(error(
                "E103", f"{kind} '{name.name}' is defined through itself", value.span,
                f"give one {kind} of the cycle a definition of its own"))
    return depths
