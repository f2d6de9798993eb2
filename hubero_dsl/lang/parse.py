"""Text -> AST. The only module that imports lark.

The grammar (`grammar/hubero.lark`, shipped inside the wheel as `hubero_dsl/grammar/`) is built
once per process as an LALR(1) parser in strict mode. A post-lexer drops statement separators
inside parentheses and brackets, so points, polygons and conditions may wrap lines. The
Transformer only reshapes the tree into `hubero_dsl.lang.ast` nodes; every check happens later,
in passes over the AST. Syntax errors become `Diagnostic`s with the span of the offending token.
"""

from __future__ import annotations

import re
import stat
from collections.abc import Iterator
from dataclasses import dataclass, replace
from functools import cache
from importlib import resources
from pathlib import Path
from typing import Any

from lark import Lark, Token, Transformer, Tree, v_args
from lark.exceptions import UnexpectedCharacters, UnexpectedEOF, UnexpectedInput, UnexpectedToken
from lark.lexer import PatternStr

from hubero_dsl.diagnostics import Diagnostic, Related, Span, error
from hubero_dsl.errors import CompileError, InputError
from hubero_dsl.lang import ast
from hubero_dsl.model.tasks import TASKS
from hubero_dsl.model.units import Dimension, units_of

MAX_SOURCE_BYTES = 2_000_000
MAX_NESTING = 64
# The passes after the parser recurse over the tree; `not not ... C` nests without brackets.
MAX_TREE_DEPTH = 256

_GRAMMAR_NAME = "hubero.lark"


def grammar_text() -> str:
    """The grammar, from the installed package or, in a source checkout, from `grammar/`."""
    packaged = resources.files("hubero_dsl") / "grammar" / _GRAMMAR_NAME
    if packaged.is_file():
        return packaged.read_text(encoding="utf-8")
    source_tree = Path(__file__).resolve().parents[2] / "grammar" / _GRAMMAR_NAME
    return source_tree.read_text(encoding="utf-8")


class _DropSeparatorsInBrackets:
    """Post-lexer: newlines and ';' inside ( ) or [ ] do not end a statement."""

    always_accept = ("_SEP",)

    def process(self, stream: Iterator[Token]) -> Iterator[Token]:
        depth = 0
        for token in stream:
            if token.type in ("LPAR", "LSQB"):
                depth += 1
            elif token.type in ("RPAR", "RSQB"):
                depth = max(0, depth - 1)
            elif token.type == "_SEP" and depth > 0:
                continue
            yield token


# every control character but the white space ones (tab, line feed, vertical tab, form feed,
# carriage return): C0, DEL and C1
_CONTROL = re.compile("[\x00-\x08\x0e-\x1f\x7f-\x9f]")


@cache
def _parser() -> Lark:
    # `cache=True` keeps the analysed grammar in the temp directory, keyed by a hash of the
    # grammar and options, so a cold `hubero check` skips the LALR and collision analysis.
    return Lark(grammar_text(), parser="lalr", lexer="contextual", strict=True,
                propagate_positions=True, maybe_placeholders=False,
                postlex=_DropSeparatorsInBrackets(), cache=True)


def parse_source(text: str, path: str = "<string>") -> ast.Module:
    """Parse scenario text. Raises CompileError with a diagnostic on a syntax error."""
    source = ast.SourceFile(path, text)
    control = _CONTROL.search(text)
    if control is not None:  # a string that reaches a terminal could clear it or retitle it
        line = text.count("\n", 0, control.start()) + 1
        column = control.start() - (text.rfind("\n", 0, control.start()) + 1) + 1
        raise CompileError([error(
            "E002", f"control character U+{ord(control.group()):04X} in the file",
            Span(path, line, column, line, column + 1),
            "a scenario file is text: write names and strings without control characters")])
    depth_problem = _nesting_problem(text, path)
    if depth_problem is not None:
        raise CompileError([depth_problem])
    try:
        tree = _parser().parse(text)
    except UnexpectedInput as exc:
        raise CompileError([_syntax_diagnostic(exc, source)]) from None
    too_deep = _tree_depth_problem(tree, path)
    if too_deep is not None:
        raise CompileError([too_deep])
    statements = _ToAst(path).transform(tree)
    return ast.Module(source, tuple(statements))


def read_source(path: str | Path) -> str:
    """Read a scenario file as UTF-8 text, turning every way that can fail into an InputError."""
    file = Path(path)
    try:
        mode = file.stat().st_mode
    except FileNotFoundError:
        raise InputError(f"{file}: no such file") from None
    except OSError as exc:  # a name too long, a loop of links, no permission
        raise InputError(f"{file}: cannot be read ({exc.strerror or exc})") from None
    if stat.S_ISDIR(mode):
        raise InputError(f"{file}: is a directory, not a scenario file")
    if not stat.S_ISREG(mode):  # a device reads for ever, a FIFO blocks
        raise InputError(f"{file}: is not a regular file (a device, a FIFO or a socket)")
    try:
        with file.open("rb") as stream:
            data = stream.read(MAX_SOURCE_BYTES + 1)
    except FileNotFoundError:
        raise InputError(f"{file}: no such file") from None
    except OSError as exc:
        raise InputError(f"{file}: cannot be read ({exc.strerror or exc})") from None
    if len(data) > MAX_SOURCE_BYTES:
        raise InputError(f"{file}: is larger than {MAX_SOURCE_BYTES / 1e6:.0f} MB, the limit "
                         "of scenario files")
    if b"\x00" in data:
        raise InputError(f"{file}: is a binary file, not a scenario")
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = data[: exc.start].count(b"\n") + 1
        column = exc.start - (data.rfind(b"\n", 0, exc.start) + 1) + 1
        raise InputError(f"{file}:{line}:{column}: invalid UTF-8 byte 0x{data[exc.start]:02x}; "
                         "scenario files must be UTF-8 text") from None
    # classic Mac line endings (a lone CR) end lines too; CRLF is left as it is
    return re.sub(r"\r(?!\n)", "\n", text)


def parse_file(path: str | Path) -> ast.Module:
    return parse_source(read_source(path), str(path))


# ---- syntax errors -----------------------------------------------------------------------

_TOKEN_NAMES = {
    "NAME": "a name", "NUMBER": "a number", "QUANTITY": "a quantity (number and unit)",
    "STRING": "a string", "_SEP": "end of statement", "$END": "end of file",
    "LPAR": "'('", "RPAR": "')'", "LBRACE": "'{'", "RBRACE": "'}'", "LSQB": "'['", "RSQB": "']'",
    "COMMA": "','", "COLON": "':'", "DOT": "'.'", "COMPARE": "a comparison (< <= > >=)",
    "TASK_KIND": f"a task ({', '.join(TASKS)})",
    "SHAPE_KIND": "a shape (circle, ellipse, rectangle, square)",
    "EXPECT_MODE": "how it must hold (always, eventually, within)",
    "LABEL_EVENT": "a label event (done, started, failed)",
    "DISTRIBUTION": "a distribution (normal, uniform)",
    "SPEED_KW": "'speed'", "LOOP": "'loop'",
}

# Keyword terminals that a hint names as one group when the parser would take any of them.
_TERMINAL_GROUPS: tuple[tuple[frozenset[str], str], ...] = (
    # after a step's first name, a name is its task (or the name was a label, and ':' follows)
    (frozenset({"NAME", "COLON"}), "TASK_KIND"),
    (frozenset({"CIRCLE", "ELLIPSE", "RECTANGLE", "SQUARE"}), "SHAPE_KIND"),
    (frozenset({"ALWAYS", "EVENTUALLY", "WITHIN"}), "EXPECT_MODE"),
    (frozenset({"DONE", "STARTED", "FAILED"}), "LABEL_EVENT"),
    (frozenset({"NORMAL", "UNIFORM"}), "DISTRIBUTION"),
)


def _describe_terminal(name: str) -> str:
    if name in _TOKEN_NAMES:
        return _TOKEN_NAMES[name]
    for terminal in _parser().terminals:
        if terminal.name == name and isinstance(terminal.pattern, PatternStr):
            return f"'{terminal.pattern.value}'"
    return name.lower()


def _describe_found(token: Token) -> str:
    if token.type == "$END":
        return "end of file"
    if token.type == "_SEP":
        return "end of line" if "\n" in token.value else "';'"
    return f"'{token.value}'"


def _syntax_diagnostic(exc: UnexpectedInput, source: ast.SourceFile) -> Diagnostic:
    line = getattr(exc, "line", None) or 1
    column = getattr(exc, "column", None) or 1
    if isinstance(exc, UnexpectedToken):
        token = exc.token
        expected = sorted({_describe_terminal(t) for t in _expected_terminals(exc)})
        found = _describe_found(token)
        if token.type in ("$END",) or token.line is None:
            line, column = _end_position(source.text)
        width = max(1, len(token.value.rstrip("\n")) if token.type != "$END" else 1)
        span = Span(source.path, line, column, line, column + width)
        message = f"unexpected {found}"
        hint = _expected_hint(expected)
        if token.type == "NAME" and _follows_number(exc):
            hint = f"'{token.value}' is not a unit; units are {_UNITS_BY_DIMENSION}"
        elif token.type in ("ALWAYS", "EVENTUALLY", "WITHIN") and _expects_a_metric(
                source.line(line)):
            hint = ("a metric's expectation is judged once, when the run ends: it takes no "
                    "`always`, `eventually` or `within`")
        related = _unclosed_note(source) if token.type == "$END" else ()
        return error("E001", message, span, hint, related)
    if isinstance(exc, UnexpectedCharacters):
        char = source.line(line)[column - 1: column] or "?"
        span = Span(source.path, line, column, line, column + 1)
        escape = _unknown_escape(source.line(line), column) if char == '"' else None
        if escape is not None:
            return error("E002", f"unknown escape '{escape[1]}' in a string",
                         Span(source.path, line, escape[0], line, escape[0] + 2),
                         'a string knows only \\" (a quote) and \\\\ (a backslash); write '
                         "a backslash as \\\\, or a path with /")
        hint = {"'": "strings use double quotes",
                '"': 'a string ends with a " on the line it starts on',
                "=": "a comparison is <, <=, > or >= (`count(c in hall) >= 3`); a value "
                     "follows its keyword with no `=`",
                "!": "a comparison is <, <=, > or >=; `not` negates a condition",
                "/": "a rate is written per second, minute or hour: /s, /min, /h"}.get(char)
        return error("E002", f"unexpected character {char!r}", span, hint)
    if isinstance(exc, UnexpectedEOF):
        line, column = _end_position(source.text)
        return error("E001", "unexpected end of file", Span(source.path, line, column, line,
                                                             column + 1), "a block is not closed",
                     _unclosed_note(source))
    return error("E001", str(exc), Span(source.path, line, column, line, column + 1))


# every unit, those of one dimension together: "m cm mm, s ms min h, ..."
_UNITS_BY_DIMENSION = ", ".join(" ".join(units_of(d)) for d in Dimension if units_of(d))


# a string's text up to its first escape other than \" and \\, and that escape
_UNKNOWN_ESCAPE = re.compile(r'(?:[^"\\]|\\["\\])*(\\[^"\\])')


def _unknown_escape(text: str, quote: int) -> tuple[int, str] | None:
    """The column and text of the first backslash escape other than \\" and \\\\ in the
    string that opens at column `quote` (the reason it did not lex), if any."""
    escape = _UNKNOWN_ESCAPE.match(text, quote)
    if escape is None:
        return None
    return escape.start(1) + 1, escape.group(1)


_CLOSING = {"(": ")", "[": "]", "{": "}"}


def _unclosed_note(source: ast.SourceFile) -> tuple[Related, ...]:
    """Point at the innermost bracket left open at the end of the file, if any."""
    open_brackets: list[tuple[str, int, int]] = []
    for number, text in enumerate(source.text.split("\n"), start=1):
        code = re.sub(r'"(?:[^"\\\n]|\\.)*"', lambda m: " " * len(m.group()), text)
        code = code.split("#", 1)[0]
        for column, char in enumerate(code, start=1):
            if char in _CLOSING:
                open_brackets.append((char, number, column))
            elif char in _CLOSING.values() and open_brackets \
                    and _CLOSING[open_brackets[-1][0]] == char:
                open_brackets.pop()
    if not open_brackets:
        return ()
    char, number, column = open_brackets[-1]
    return (Related(f"this '{char}' is never closed",
                    Span(source.path, number, column, number, column + 1)),)


def _expected_terminals(exc: UnexpectedToken) -> set[str]:
    """What the parser would take here. `accepts` tries each terminal, so it leaves out the
    look-aheads that LALR state merging adds to `expected` (a `)` after a complete statement)."""
    accepted = exc.accepts or exc.expected
    names = {t for t in accepted if not t.startswith("__IGNORE")}
    for group, name in _TERMINAL_GROUPS:
        if group <= names:
            names = (names - group) | {name} | ({"COLON"} if name == "TASK_KIND" else set())
    return names


def _expected_hint(expected: list[str]) -> str | None:
    if not expected:
        return None
    if len(expected) > 8:
        return "expected one of: " + ", ".join(expected[:8]) + ", ..."
    if len(expected) == 1:
        return f"expected {expected[0]}"
    return "expected one of: " + ", ".join(expected)


def _expects_a_metric(line: str) -> bool:
    """Whether a source line is `expect METRIC(...) ...` (of the social-navigation metrics)."""
    from hubero_dsl.socialnav import METRICS

    called = re.match(r"\s*expect\s+(\w+)\s*\(", line)
    return called is not None and called.group(1) in METRICS


def _follows_number(exc: UnexpectedToken) -> bool:
    """The token before the unexpected one is a bare number (`5 kg`), not a name like `actor1`."""
    previous = exc.token_history[-1] if exc.token_history else None
    return previous is not None and previous.type == "NUMBER"


def _end_position(text: str) -> tuple[int, int]:
    lines = text.split("\n")
    return len(lines), len(lines[-1]) + 1


def _nesting_problem(text: str, path: str) -> Diagnostic | None:
    """Refuse absurd nesting before the parser recurses into it."""
    depth = 0
    line, column = 1, 0
    for char in text:
        column += 1
        if char == "\n":
            line, column = line + 1, 0
        elif char in "({[":
            depth += 1
            if depth > MAX_NESTING:
                return error("E003", f"nesting deeper than {MAX_NESTING} levels",
                             Span(path, line, column, line, column + 1),
                             "split the scenario into flatter steps")
        elif char in ")}]":
            depth = max(0, depth - 1)
    return None


def _tree_depth_problem(tree: Tree[Token], path: str) -> Diagnostic | None:
    """Refuse a parse tree deeper than the recursive passes after the parser can walk."""
    stack: list[tuple[Tree[Token], int]] = [(tree, 1)]
    while stack:
        node, depth = stack.pop()
        if depth > MAX_TREE_DEPTH:
            meta = node.meta
            line, column = (1, 1) if meta.empty else (meta.line, meta.column)
            return error("E003", f"nesting deeper than {MAX_TREE_DEPTH} levels of steps, "
                         "brackets and `not`", Span(path, line, column, line, column + 1),
                         "write `C` for `not not C`, or split the scenario into flatter steps")
        stack.extend((child, depth + 1) for child in node.children if isinstance(child, Tree))
    return None


# ---- tree -> AST -------------------------------------------------------------------------


def _unquote(token: str) -> str:
    return re.sub(r"\\(.)", r"\1", token[1:-1])


@dataclass(frozen=True, slots=True)
class _Heading:
    """`heading A` after a place, human or robot, told apart from the blocks that may follow."""

    value: Any


def _heading_in(rest: list[Any]) -> Any:
    return next((r.value for r in rest if isinstance(r, _Heading)), None)


_QUANTITY = re.compile(r"(-?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][-+]?[0-9]+)?)[ \t]*(.+)")


@v_args(meta=True)
class _ToAst(Transformer[Token, Any]):
    """Reshapes lark's tree into AST nodes. No checks here (see the module docstring)."""

    def __init__(self, path: str) -> None:
        super().__init__()
        self._path = path

    def _span(self, meta: Any) -> Span:
        if getattr(meta, "empty", True):
            return Span(self._path, 1, 1, 1, 1)
        return Span(self._path, meta.line, meta.column, meta.end_line, meta.end_column)

    def _token_span(self, token: Token) -> Span:
        return Span(self._path, token.line or 1, token.column or 1,
                    token.end_line or token.line or 1, token.end_column or (token.column or 1) + 1)

    def _name(self, token: Token) -> ast.NameRef:
        return ast.NameRef(str(token), self._token_span(token))

    # keywords kept as tokens by `!` rules
    def shape_kind(self, meta: Any, children: list[Token]) -> Token:
        return children[0]

    distribution_kind = event_kind = expect_mode = shape_kind

    # values
    def quantity(self, meta: Any, children: list[Token]) -> ast.Quantity:
        match = _QUANTITY.fullmatch(str(children[0]))
        assert match is not None
        return ast.Quantity(float(match.group(1)), match.group(2), self._token_span(children[0]))

    def number(self, meta: Any, children: list[Token]) -> ast.Number:
        token = children[0]
        return ast.Number(float(token), str(token), self._token_span(token))

    def string(self, meta: Any, children: list[Token]) -> ast.String:
        return ast.String(_unquote(str(children[0])), self._token_span(children[0]))

    def name_ref(self, meta: Any, children: list[Token]) -> ast.NameRef:
        return self._name(children[0])

    def point(self, meta: Any, children: list[Any]) -> ast.Point:
        return ast.Point(children[0], children[1], self._span(meta))

    def named_arg(self, meta: Any, children: list[Any]) -> ast.NamedArg:
        name, value = children
        return ast.NamedArg(str(name), value, self._span(meta), self._token_span(name))

    def shape(self, meta: Any, children: list[Any]) -> ast.ShapeLit:
        return ast.ShapeLit(str(children[0]), tuple(children[1:]), self._span(meta))

    def distribution(self, meta: Any, children: list[Any]) -> ast.Distribution:
        return ast.Distribution(str(children[0]), children[1], children[2], self._span(meta))

    def heading(self, meta: Any, children: list[Any]) -> _Heading:
        return _Heading(children[0])

    def rect(self, meta: Any, children: list[Any]) -> ast.RectArea:
        return ast.RectArea(children[0], children[1], self._span(meta))

    def polygon(self, meta: Any, children: list[Any]) -> ast.PolygonArea:
        return ast.PolygonArea(tuple(children), self._span(meta))

    # parameters
    def param_name(self, meta: Any, children: list[Token]) -> tuple[tuple[str, ...], Span]:
        return tuple(str(c) for c in children), self._span(meta)

    def param(self, meta: Any, children: list[Any]) -> ast.Param:
        (path, name_span), value = children
        return ast.Param(path, value, self._span(meta), name_span)

    def param_block(self, meta: Any, children: list[ast.Param]) -> tuple[ast.Param, ...]:
        return tuple(children)

    def robot_path(self, meta: Any, children: list[Any]) -> ast.RobotPath:
        loop = bool(children) and isinstance(children[-1], Token) and children[-1].type == "LOOP"
        points = children[:-1] if loop else children
        return ast.RobotPath(tuple(points), loop, self._span(meta))

    def robot_controller(self, meta: Any, children: list[Any]) -> ast.RobotController:
        written = children[0]
        if isinstance(written, ast.String):
            return ast.RobotController(written, self._span(meta))
        if isinstance(written, Token) and written.type == "STRING":
            target: ast.NameRef | ast.String = ast.String(_unquote(str(written)),
                                                          self._token_span(written))
        else:
            target = self._name(written)
        return ast.RobotController(target, self._span(meta))

    def robot_block(self, meta: Any, children: list[Any]) -> list[Any]:
        return children

    # conditions
    def label_event(self, meta: Any, children: list[Token]) -> ast.LabelCondition:
        return ast.LabelCondition(self._name(children[0]), ast.LabelEvent(str(children[1])),
                                  self._span(meta))

    def reaches(self, meta: Any, children: list[Any]) -> ast.ReachesCondition:
        return ast.ReachesCondition(self._name(children[0]), children[1], self._span(meta))

    def all_reach(self, meta: Any, children: list[Any]) -> ast.AllReach:
        return ast.AllReach(self._name(children[0]), children[1], self._span(meta))

    def any_reach(self, meta: Any, children: list[Any]) -> ast.AnyReaches:
        return ast.AnyReaches(self._name(children[0]), children[1], self._span(meta))

    def count_in(self, meta: Any, children: list[Any]) -> ast.CountIn:
        group, area, operator, threshold = children
        return ast.CountIn(self._name(group), area, str(operator), threshold, self._span(meta))

    def distance(self, meta: Any, children: list[Any]) -> ast.DistanceCondition:
        subject, target, operator, threshold = children
        return ast.DistanceCondition(self._name(subject), target, str(operator), threshold,
                                     self._span(meta))

    def inside(self, meta: Any, children: list[Any]) -> ast.InsideCondition:
        return ast.InsideCondition(self._name(children[0]), children[1], self._span(meta))

    def time_compare(self, meta: Any, children: list[Any]) -> ast.TimeCondition:
        return ast.TimeCondition(str(children[0]), children[1], self._span(meta))

    def negation(self, meta: Any, children: list[Any]) -> ast.NotCondition:
        return ast.NotCondition(children[0], self._span(meta))

    def all_of(self, meta: Any, children: list[Any]) -> ast.Condition:
        return children[0] if len(children) == 1 else ast.AllOf(tuple(children), self._span(meta))

    def any_of(self, meta: Any, children: list[Any]) -> ast.Condition:
        return children[0] if len(children) == 1 else ast.AnyOf(tuple(children), self._span(meta))

    # tasks and steps
    def _option(self, keyword: str, meta: Any, children: list[Any]) -> ast.TaskOption:
        return ast.TaskOption(keyword, children[-1], self._span(meta))

    def option_heading(self, meta: Any, children: list[Any]) -> ast.TaskOption:
        return self._option("heading", meta, children)

    def option_speed(self, meta: Any, children: list[Any]) -> ast.TaskOption:
        return self._option("speed", meta, children)

    def option_for(self, meta: Any, children: list[Any]) -> ast.TaskOption:
        return self._option("for", meta, children)

    def option_times(self, meta: Any, children: list[Any]) -> ast.TaskOption:
        return self._option("times", meta, children)

    def option_at(self, meta: Any, children: list[Any]) -> ast.TaskOption:
        return self._option("at", meta, children)

    def option_to(self, meta: Any, children: list[Any]) -> ast.TaskOption:
        return self._option("to", meta, children)

    def option_facing(self, meta: Any, children: list[Any]) -> ast.TaskOption:
        return self._option("facing", meta, children)

    def option_in(self, meta: Any, children: list[Any]) -> ast.TaskOption:
        return self._option("in", meta, children)

    def task(self, meta: Any, children: list[Any]) -> ast.Task:
        kind_token, rest = children[0], children[1:]
        target = None
        if rest and not isinstance(rest[0], ast.TaskOption):
            target, rest = rest[0], rest[1:]
        return ast.Task(str(kind_token), target, tuple(rest), self._span(meta),
                        self._token_span(kind_token))

    def until(self, meta: Any, children: list[Any]) -> tuple[str, Any, Span]:
        return ("until", children[0], self._span(meta))

    def within(self, meta: Any, children: list[Any]) -> tuple[str, Any, Span]:
        return ("within", children[0], self._span(meta))

    def forever(self, meta: Any, children: list[Any]) -> tuple[str, Any, Span]:
        return ("forever", True, self._span(meta))

    def task_step(self, meta: Any, children: list[Any]) -> ast.TaskStep:
        human, task, *modifiers = children
        found: dict[str, Any] = {}
        repeated = []
        for kind, value, span in modifiers:
            if kind in found:
                repeated.append((kind, span))
            else:
                found[kind] = value
        return ast.TaskStep(self._name(human), task, found.get("until"), found.get("within"),
                            bool(found.get("forever")), self._span(meta),
                            repeated=tuple(repeated))

    def wait(self, meta: Any, children: list[Any]) -> ast.WaitStep:
        return ast.WaitStep(children[0], self._span(meta))

    def wait_until(self, meta: Any, children: list[Any]) -> ast.WaitUntilStep:
        return ast.WaitUntilStep(children[0], self._span(meta))

    def parallel(self, meta: Any, children: list[Any]) -> ast.ParallelStep:
        return ast.ParallelStep(tuple(children), self._span(meta))

    def race(self, meta: Any, children: list[Any]) -> ast.RaceStep:
        return ast.RaceStep(tuple(children), self._span(meta))

    def sequence(self, meta: Any, children: list[Any]) -> ast.SequenceStep:
        return ast.SequenceStep(tuple(children), self._span(meta))

    def repeat(self, meta: Any, children: list[Any]) -> ast.RepeatStep:
        count = children[0]
        number = ast.Number(float(count), str(count), self._token_span(count))
        return ast.RepeatStep(number, children[1], self._span(meta))

    def labelled(self, meta: Any, children: list[Any]) -> Any:
        label, step = children
        return replace(step, label=self._name(label), span=self._span(meta))

    # statements
    def start(self, meta: Any, children: list[Any]) -> list[Any]:
        return children

    def scenario(self, meta: Any, children: list[Any]) -> ast.ScenarioDecl:
        return ast.ScenarioDecl(self.string(meta, children), self._span(meta))

    def map(self, meta: Any, children: list[Any]) -> ast.MapDecl:
        return ast.MapDecl(self.string(meta, children), self._span(meta))

    def _setting(self, keyword: str, meta: Any, value: Any) -> ast.SettingDecl:
        return ast.SettingDecl(keyword, value, self._span(meta))

    def seed(self, meta: Any, children: list[Any]) -> ast.SettingDecl:
        return self._setting("seed", meta, self.number(meta, children))

    def step(self, meta: Any, children: list[Any]) -> ast.SettingDecl:
        return self._setting("step", meta, children[0])

    def time_limit(self, meta: Any, children: list[Any]) -> ast.SettingDecl:
        return self._setting("time_limit", meta, children[0])

    def bounds(self, meta: Any, children: list[Any]) -> ast.SettingDecl:
        return self._setting("bounds", meta, children[0])

    def on_failure(self, meta: Any, children: list[Any]) -> ast.SettingDecl:
        return self._setting("on_failure", meta, self._name(children[0]))

    def place(self, meta: Any, children: list[Any]) -> ast.PlaceDecl:
        name, point, *rest = children
        return ast.PlaceDecl(self._name(name), point, _heading_in(rest), self._span(meta))

    def area(self, meta: Any, children: list[Any]) -> ast.AreaDecl:
        return ast.AreaDecl(self._name(children[0]), children[1], self._span(meta))

    def defaults(self, meta: Any, children: list[Any]) -> ast.DefaultsDecl:
        return ast.DefaultsDecl(children[0], self._span(meta))

    def human(self, meta: Any, children: list[Any]) -> ast.HumanDecl:
        name, start, *rest = children
        params = next((r for r in rest if isinstance(r, tuple)), ())  # the param block
        return ast.HumanDecl(self._name(name), start, _heading_in(rest), params,
                             self._span(meta))

    def crowd(self, meta: Any, children: list[Any]) -> ast.CrowdDecl:
        name, count, area, *rest = children
        params = next((r for r in rest if isinstance(r, tuple)), ())
        number = ast.Number(float(count), str(count), self._token_span(count))
        return ast.CrowdDecl(self._name(name), number, area, _heading_in(rest), params,
                             self._span(meta))

    def flow(self, meta: Any, children: list[Any]) -> ast.FlowDecl:
        name, area, target, rate, *rest = children
        end = next((r for r in rest if isinstance(r, tuple) and len(r) == 2
                    and r[0] in ("for", "until")), None)
        params = next((r for r in rest if isinstance(r, tuple) and r is not end), ())
        return ast.FlowDecl(self._name(name), area, target, rate,
                            end[1] if end is not None and end[0] == "for" else None,
                            end[1] if end is not None and end[0] == "until" else None,
                            params, self._span(meta))

    def flow_for(self, meta: Any, children: list[Any]) -> tuple[str, Any]:
        return ("for", children[0])

    def flow_until(self, meta: Any, children: list[Any]) -> tuple[str, Any]:
        return ("until", children[0])

    def group(self, meta: Any, children: list[Any]) -> ast.GroupDecl:
        name, *members = children
        return ast.GroupDecl(self._name(name), tuple(self._name(m) for m in members),
                             self._span(meta))

    def robot(self, meta: Any, children: list[Any]) -> ast.RobotDecl:
        name, start, *rest = children
        heading = _heading_in(rest)
        items = next((r for r in rest if isinstance(r, list)), [])
        params = tuple(i for i in items if isinstance(i, ast.Param))
        paths = [i for i in items if isinstance(i, ast.RobotPath)]
        controllers = [i for i in items if isinstance(i, ast.RobotController)]
        extra = tuple(paths[1:]) + tuple(controllers[1:])
        return ast.RobotDecl(self._name(name), start, heading, params,
                             paths[0] if paths else None,
                             controllers[0] if controllers else None, self._span(meta), extra)

    def variant(self, meta: Any, children: list[Any]) -> ast.VariantDecl:
        return ast.VariantDecl(self._name(children[0]), children[1], self._span(meta))

    def sweep(self, meta: Any, children: list[Any]) -> ast.SweepDecl:
        (path, name_span), *values = children
        param = ast.Param(path, values[0], name_span, name_span)
        return ast.SweepDecl(param, tuple(values), self._span(meta))

    def activity(self, meta: Any, children: list[Any]) -> ast.ActivityDecl:
        name = None
        if children and isinstance(children[0], Token):
            name, children = self._name(children[0]), children[1:]
        return ast.ActivityDecl(name, tuple(children), self._span(meta))

    def expect(self, meta: Any, children: list[Any]) -> ast.ExpectDecl:
        return ast.ExpectDecl(children[0], ast.ExpectMode(str(children[1])), None,
                              self._span(meta))

    def expect_metric(self, meta: Any, children: list[Any]) -> ast.ExpectDecl:
        return ast.ExpectDecl(children[0], ast.ExpectMode.AT_END, None, self._span(meta))

    def metric_compare(self, meta: Any, children: list[Any]) -> ast.MetricCompare:
        metric, subject, *rest = children
        other = self._name(rest[0]) if len(rest) == 3 else None
        operator, threshold = rest[-2], rest[-1]
        return ast.MetricCompare(self._name(metric), self._name(subject), other,
                                 str(operator), threshold, self._span(meta))

    def expect_within(self, meta: Any, children: list[Any]) -> ast.ExpectDecl:
        return ast.ExpectDecl(children[0], ast.ExpectMode.WITHIN, children[1], self._span(meta))
