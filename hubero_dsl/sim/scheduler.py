"""The scheduler: executes the activity graph with token semantics, tick by tick.

A token sits on one node. Instant nodes (initial, fork, join, repeat, label markers) pass it on
at once; an action gives its actor the node's task through `command` (the simulation passes the
human API's) and holds the token until the task ends; `wait` holds it for a time and `wait
until` until its condition holds. A `race` join takes the first token and preempts every other
token of its branches. Tokens are processed in source order, so the same program and seed always
give the same run.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from enum import StrEnum
from typing import TYPE_CHECKING, Any, Literal

import networkx as nx

from hubero_dsl.graph.build import (
    NodeKind,
    branches_of,
    exit_successor,
    initial_nodes,
    label_scopes,
    node_sort_key,
    successors_in_order,
)
from hubero_dsl.sim.conditions import Conditions, LabelBook
from hubero_dsl.sim.status import TaskHandle, TaskStatus

if TYPE_CHECKING:
    from hubero_dsl.diagnostics import Span
    from hubero_dsl.model.tasks import Task
    from hubero_dsl.sim.engine import Engine

# gives an actor (by name) a task, written at a span; returns the task's handle
Command = Callable[[str, "Task", "Span | None"], TaskHandle]


class RunState(StrEnum):
    RUNNING = "running"
    COMPLETED = "completed"   # every activity ended
    FAILED = "failed"         # a task was aborted under `on_failure stop`
    TIMED_OUT = "timed_out"   # time_limit reached first


@dataclass(eq=False)
class Token:
    node: str
    activity: str
    order: tuple[int, int] = (0, 0)      # the node's place in the source, for processing order
    handle: TaskHandle | None = None     # the task an action node is waiting for
    until_tick: int | None = None        # `wait Q` and `within Q` deadlines
    entered: bool = False                # the node's entry work is done
    done: bool = False                   # the node finished; move on next pass
    dormant: bool = False                # waits for its task's end only: nothing to poll


@dataclass
class Scheduler:
    graph: nx.DiGraph
    engine: Engine
    command: Command
    time_limit: float
    on_failure: Literal["stop", "continue"]
    tokens: list[Token] = field(default_factory=list)
    labels: LabelBook = field(default_factory=LabelBook)
    state: RunState = RunState.RUNNING
    reason: str = ""
    rounds: dict[str, int] = field(default_factory=dict)       # repeat start -> round
    arrivals: dict[str, int] = field(default_factory=dict)     # join -> tokens arrived
    ended: set[str] = field(default_factory=set)               # activities at their final node
    # what else keeps the run going when every activity is done (flows still bringing people)
    keep_alive: Callable[[], bool] | None = None

    def __post_init__(self) -> None:
        self.conditions = Conditions(self.engine, self.labels)
        self._last_tick = self.engine.ticks(self.time_limit)
        self._scopes = label_scopes(self.graph)
        self._label_of_member = {m: s.label for s in self._scopes.values() for m in s.members}
        self.tokens = []
        for node in initial_nodes(self.graph):
            self._enter(Token(node, self.graph.nodes[node]["activity"]))

    # ---- the loop ------------------------------------------------------------------------

    def update(self) -> None:
        """Move every token as far as it can go at the current time."""
        for _ in range(10_000):  # instant nodes chain; a bound guards against a logic error
            if self.state is not RunState.RUNNING or not self._pass():
                break
        self._check_end()

    def after_step(self) -> None:
        self._check_end()

    def _pass(self) -> bool:
        """One sweep over the tokens that may move. A token waiting only for its task to end
        is dormant until the task's handle wakes it, so a thousand walking humans cost nothing
        here while they walk."""
        moved = False
        awake = sorted((t for t in self.tokens if not t.dormant), key=lambda t: t.order)
        for token in awake:
            if not token.dormant and token in self.tokens and self._advance(token):
                moved = True
        return moved

    def _check_end(self) -> None:
        if self.state is not RunState.RUNNING:
            return
        if all(self._idle_forever(t) for t in self.tokens) and not (
                self.keep_alive is not None and self.keep_alive()):
            self.state = RunState.COMPLETED
        elif self.engine.tick >= self._last_tick:
            self.state = RunState.TIMED_OUT
            self.reason = f"time limit of {self.time_limit:g} s reached"

    def _idle_forever(self, token: Token) -> bool:
        """A `forever` task with no `until` does not keep the run alive."""
        data = self.graph.nodes[token.node]
        return data["kind"] is NodeKind.ACTION and data["forever"] and data["until"] is None \
            and token.entered and not token.done

    def reached(self) -> list[str]:
        """The actors (by name) of the tasks the activities had reached and not started, one
        name per task. A run stopped by a failure stops in the middle of a moment: tokens are
        left short of the actions they reach at that moment (at the start of an activity, at a
        fork, past a task that ended then), whose tasks never start."""
        actors: list[str] = []
        arrivals, rounds = dict(self.arrivals), dict(self.rounds)
        once: set[str] = set()  # race joins passed, repeats looped (a loop reaching no task)
        walk = [(t.node, t.done) for t in self.tokens if t.done or not t.entered]
        while walk:
            node, passed = walk.pop()
            data = self.graph.nodes[node]
            kind: NodeKind = data["kind"]
            if not passed:
                if kind is NodeKind.ACTION:
                    actors.append(data["human"])
                    continue
                if kind in (NodeKind.WAIT, NodeKind.ACCEPT, NodeKind.FINAL):
                    continue
                if kind is NodeKind.JOIN:
                    arrivals[node] = arrivals.get(node, 0) + 1
                    if arrivals[node] < self.graph.in_degree(node):
                        continue
                if kind is NodeKind.RACE_JOIN:
                    if node in once:
                        continue
                    once.add(node)
            walk.extend((n, False) for n in reversed(self._passed_on(node, kind, rounds, once)))
        return actors

    def _passed_on(self, node: str, kind: NodeKind, rounds: dict[str, int],
                   once: set[str]) -> list[str]:
        """Where a token leaving `node` goes next, the repeats' rounds counted in `rounds`."""
        if kind in (NodeKind.FORK, NodeKind.RACE_FORK):
            return successors_in_order(self.graph, node)
        if kind is NodeKind.REPEAT_START:
            rounds[node] = rounds.get(node, 0) + 1
        if kind is NodeKind.REPEAT_END:
            start = self.graph.nodes[node]["start"]
            if rounds.get(start, 0) < self.graph.nodes[node]["count"]:
                if start in once:
                    return []
                once.add(start)
                return [start]
        following = exit_successor(self.graph, node)
        return [] if following is None else [following]

    # ---- one token -----------------------------------------------------------------------

    def _advance(self, token: Token) -> bool:
        """Do the token's node work; True when something changed."""
        data = self.graph.nodes[token.node]
        kind: NodeKind = data["kind"]
        if token.done:
            return self._leave(token, kind)
        if kind is NodeKind.ACTION:
            return self._action(token, data)
        if kind is NodeKind.WAIT:
            return self._wait(token, data)
        if kind is NodeKind.ACCEPT:
            token.entered = True
            if self.conditions.holds(data["condition"]):
                token.done = True
                return True
            return False
        return self._instant(token, kind, data)

    def _instant(self, token: Token, kind: NodeKind, data: dict[str, Any]) -> bool:
        if kind is NodeKind.FINAL:
            self.tokens.remove(token)
            self.ended.add(token.activity)
            return True
        if kind is NodeKind.LABEL_BEGIN:
            self.labels.started.add(data["label"])
        elif kind is NodeKind.LABEL_END:
            self.labels.done.add(data["label"])
        elif kind is NodeKind.JOIN:
            return self._join(token, data)
        elif kind is NodeKind.RACE_JOIN:
            self._preempt_losers(token, data)
        token.done = True
        return True

    def _leave(self, token: Token, kind: NodeKind) -> bool:
        node = token.node
        if kind in (NodeKind.FORK, NodeKind.RACE_FORK):
            self.tokens.remove(token)
            for successor in successors_in_order(self.graph, node):
                self._enter(Token(successor, token.activity))
            return True
        if kind is NodeKind.REPEAT_START:
            self.rounds[node] = self.rounds.get(node, 0) + 1
        if kind is NodeKind.REPEAT_END:
            start = self.graph.nodes[node]["start"]
            if self.rounds.get(start, 0) < self.graph.nodes[node]["count"]:
                self._move(token, start)
                return True
            self.rounds.pop(start, None)
        following = exit_successor(self.graph, node)
        if following is None:
            self.tokens.remove(token)
            return True
        self._move(token, following)
        return True

    def _move(self, token: Token, node: str) -> None:
        self.tokens.remove(token)
        self._enter(Token(node, token.activity))

    def _enter(self, token: Token) -> None:
        token.order = node_sort_key(self.graph, token.node)
        self.tokens.append(token)

    def _join(self, token: Token, data: dict[str, Any]) -> bool:
        node = token.node
        self.arrivals[node] = self.arrivals.get(node, 0) + 1
        needed = self.graph.in_degree(node)
        self.tokens.remove(token)
        if self.arrivals[node] >= needed:
            del self.arrivals[node]
            self._enter(Token(node, token.activity, entered=True, done=True))
        return True

    def _preempt_losers(self, winner: Token, data: dict[str, Any]) -> None:
        fork = data["fork"]
        members = {m for branch in branches_of(self.graph, fork) for m in branch.members}
        for token in list(self.tokens):
            if token is not winner and token.node in members:
                if token.handle is not None:  # not done: its label is not done either
                    token.handle.cancel("another branch of its race ended first")
                self.tokens.remove(token)
        for member in members:   # joins inside the losing branches forget partial arrivals
            self.arrivals.pop(member, None)
            self.rounds.pop(member, None)

    # ---- actions and waits -----------------------------------------------------------------

    def _action(self, token: Token, data: dict[str, Any]) -> bool:
        if not token.entered:
            token.entered = True
            self._start_action(token, data)
            return True
        handle = token.handle
        assert handle is not None
        if not handle.done:
            if data["until"] is not None and self.conditions.holds(data["until"]):
                handle.cancel(f"until {data['until'].text} held")   # counts as done
            elif token.until_tick is not None and self.engine.tick >= token.until_tick:
                self.engine.abort(handle, f"did not finish within {data['within']:g} s")
            if not handle.done:
                return False
        return self._action_ended(token, data, handle)

    def _start_action(self, token: Token, data: dict[str, Any]) -> None:
        if data["label"] is not None:
            self.labels.started.add(data["label"])
        if data["within"] is not None:
            token.until_tick = self.engine.tick + max(1, self.engine.ticks(data["within"]))
        handle = self.command(data["human"], data["task"], data["step"].span)
        token.handle = handle
        if not handle.done and data["until"] is None and data["within"] is None:
            token.dormant = True
            handle.on_change(lambda changed: self._wake(token, changed))

    @staticmethod
    def _wake(token: Token, handle: TaskHandle) -> None:
        if handle.done:
            token.dormant = False

    def _action_ended(self, token: Token, data: dict[str, Any], handle: TaskHandle) -> bool:
        if handle.status is TaskStatus.ABORTED:
            self._mark_failed(token.node)
            if self.on_failure == "stop":
                self.state = RunState.FAILED
                self.reason = f"{handle.human} {handle.description}: {handle.reason}"
                return True
        elif data["label"] is not None:
            self.labels.done.add(data["label"])
        token.done = True
        return True

    def _mark_failed(self, node: str) -> None:
        for scope in self._scopes.values():
            if node in scope.members:
                self.labels.failed.add(scope.label)

    def _wait(self, token: Token, data: dict[str, Any]) -> bool:
        if not token.entered:
            token.entered = True
            token.until_tick = self.engine.tick + max(1, self.engine.ticks(data["duration"]))
            if data["label"] is not None:
                self.labels.started.add(data["label"])
            return True
        if token.until_tick is not None and self.engine.tick >= token.until_tick:
            if data["label"] is not None:
                self.labels.done.add(data["label"])
            token.done = True
            return True
        return False

