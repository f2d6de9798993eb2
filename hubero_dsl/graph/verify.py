"""Verification of the activity graph: the E3xx diagnostics.

The checks run on the graph of `hubero_dsl.graph.build`, built from the lowered activities, and
find what would make a scenario hang or fight over a human at run time:

- E301 a human commanded by two activities (activities run concurrently; one controller each).
- E302 a human commanded by two steps of one activity that can run at the same time.
- E303 `wait until L ...` where no step is labelled L.
- E304 a wait that can never be satisfied: L can only start/finish after the wait has ended.
- E305 a deadlock: waits across branches or activities that wait for each other (a cycle);
  a task that ends only by its `until` waits as a `wait until` does.
- E306 a task with no natural end and no `for`, `times`, `until` or `forever`.
- E307 (warning) `forever` on a task that ends by itself.
- E308 a `forever` task that blocks what follows: later steps, a `parallel`'s join, a repeat.
- E309 a `repeat` count that is not a whole number of at least 1.
- E310 a label defined twice (clashes with other kinds of names are the name checker's).
- E311 an empty `parallel`/`race` or branch (an error for a race branch: it ends the race).
- E312 `wait until L done` (or a task that ends only `until L done`) where L never finishes
  because a `forever` task holds it.
- E313 an `until` that can never hold while its task runs.
- E314 (a warning) a wait outside a race's branch that needs a label inside it.

Ordering is a happens-before relation on events: every node `n` has a start event `(n, "s")`
and an end event `(n, "e")`; a flow edge u -> v orders `(u, "e")` before `(v, "s")` (repeat
loop-back edges excluded, so each activity is a DAG), and each `wait until` orders the label
events its condition needs (a `LABEL ...` condition, or one of an `and`) before the wait's end.
Two steps can overlap unless one's end happens before the other's start; a wait whose end must
happen before the label event it waits for can never be satisfied.
"""

from __future__ import annotations

import re
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, replace
from functools import cache
from itertools import pairwise

import networkx as nx

from hubero_dsl.diagnostics import Diagnostic, Related, Span, error, warning
from hubero_dsl.graph.build import (
    LabelScope,
    NodeKind,
    activity_keys,
    branches_of,
    exit_successor,
    forward_graph,
    label_definitions,
    label_event,
    label_scopes,
    node_sort_key,
    nodes_of_kind,
)
from hubero_dsl.graph.render import crowd_words, describe_node
from hubero_dsl.model import activities as m
from hubero_dsl.model.conditions import (
    Condition,
    Label,
    LabelCondition,
    LabelEvent,
    required_labels,
    walk_conditions,
)
from hubero_dsl.model.tasks import TASKS, Task

Event = tuple[str, str]  # (node, "s" | "e")


def ends_by_itself(task: Task) -> bool:
    """Whether a task ends without `until`: it reaches its goal, or its `for`/`times` run out.
    (An unknown task kind is the checker's error; it is not reported again here.)"""
    kind = TASKS.get(task.kind)
    return kind is None or kind.ends(task.arguments)


def needs_forever(step: m.TaskStep) -> bool:
    """A task with no natural end, no `for`/`times` and no `until`: it must say `forever`."""
    return step.until is None and not ends_by_itself(step.task)


def never_ends(step: m.TaskStep) -> bool:
    """A task that nothing ends: not even `within` (which ends it by aborting it)."""
    return needs_forever(step) and step.within is None


def verify_activities(activities: Sequence[m.Activity], graph: nx.DiGraph, *,
                       label_names: bool = True) -> list[Diagnostic]:
    """Every E3xx diagnostic of the scenario's activities, in source order.

    `label_names=False` leaves duplicate (E310) and unknown (E303) labels to the name checker.
    """
    context = _Context(graph, activities)
    found = [*_repeat_counts(context), *_empty_blocks(context), *_task_ends(context),
             *_controllers(context)]
    if label_names:
        found += _duplicate_labels(context)
    blocked, never_done = _forever_flow(context)
    found += blocked
    found += _waits(context, never_done, label_names)
    found += _untils(context)
    found += _waits_on_race_branches(context)
    return sorted(_in_crowds_words(found, activities), key=Diagnostic.sort_key)


# ---- a task given to a crowd or group, told once -----------------------------------------

_NAME_AFTER_BACKTICK = re.compile(r"`([A-Za-z_][A-Za-z0-9_]*)")


def _in_crowds_words(found: list[Diagnostic], activities: Sequence[m.Activity]
                     ) -> list[Diagnostic]:
    """A finding made alike of several members of a crowd or group (or of its only one) is
    told once, of the crowd: a crowd of 1000 given two clashing steps had 1000 errors naming
    `NAME_1` to `NAME_1000`. A finding of one member alone (given a step of its own) keeps
    its name.
    Names are replaced where the words quote them (after a backtick), never in the prose
    around them."""
    told = list(found)
    crowds = _crowds(activities)
    # the smallest set first: a group of some of a crowd's members is named by the group
    for crowd, (members, spans) in sorted(crowds.items(), key=lambda c: len(c[1][0])):
        told = _folded(told, crowd, members, spans, crowds)
    return told


def _crowds(activities: Sequence[m.Activity]
            ) -> dict[str, tuple[frozenset[str], frozenset[Span]]]:
    """Each crowd or group given a task: its members, and where its tasks are written."""
    found: dict[str, tuple[frozenset[str], frozenset[Span]]] = {}
    for activity in activities:
        for step in m.walk_steps(activity.steps):
            if isinstance(step, m.ParallelStep) and step.crowd is not None:
                members = frozenset(s.actor for s in m.walk_steps(step.branches)
                                    if isinstance(s, m.TaskStep))
                known, spans = found.get(step.crowd, (frozenset(), frozenset()))
                found[step.crowd] = (known | members, spans | {step.span})
    return found


def _folded(found: list[Diagnostic], crowd: str, members: frozenset[str],
            spans: frozenset[Span], crowds: dict[str, tuple[frozenset[str], frozenset[Span]]]
            ) -> list[Diagnostic]:
    """`found` with each finding at one of the crowd's tasks (`spans`) that is the same of
    every member, or of its only one, but for their names, told once, of the crowd, where the
    first of them was. The same finding of some members only is told of the crowd or group
    given a task that has just these members (a group of the crowd's members commanded by
    another activity), else of each member. A finding at a member's own step is never
    folded."""
    alike: dict[Diagnostic, list[tuple[int, Diagnostic, set[str]]]] = {}
    for index, diagnostic in enumerate(found):
        named = _quoted_names(diagnostic) & members
        if named and diagnostic.span in spans:
            alike.setdefault(_speaking_of(diagnostic, crowd, members), []).append(
                (index, diagnostic, named))
    once: dict[int, Diagnostic] = {}
    dropped: set[int] = set()
    for told, where in alike.items():
        named = set().union(*(named for _, _, named in where))
        if named != members:  # some members only: told of the set of just them, if any
            some = next((name for name, (others, _) in crowds.items() if others == named),
                        None)
            if some is None or len(named) == 1:
                continue  # each member told by its name
            told = _speaking_of(where[0][1], some, frozenset(named))
        once[where[0][0]] = told
        dropped.update(index for index, _, _ in where[1:])
    return [once.get(i, d) for i, d in enumerate(found) if i not in dropped]


def _quoted_names(diagnostic: Diagnostic) -> set[str]:
    texts = [diagnostic.message, diagnostic.hint or "", *(r.message for r in diagnostic.related)]
    return {name for text in texts for name in _NAME_AFTER_BACKTICK.findall(text)}


def _speaking_of(diagnostic: Diagnostic, crowd: str, members: frozenset[str]) -> Diagnostic:
    def words(text: str) -> str:
        return _NAME_AFTER_BACKTICK.sub(
            lambda name: f"`{crowd}" if name.group(1) in members else name.group(0), text)

    return replace(diagnostic, message=words(diagnostic.message),
                   hint=words(diagnostic.hint) if diagnostic.hint else diagnostic.hint,
                   related=tuple(replace(r, message=words(r.message))
                                 for r in diagnostic.related))


@dataclass(frozen=True, slots=True)
class _Wait:
    """One ordering a `wait until` imposes: `source` happens before the wait ends."""

    accept: str
    condition: LabelCondition
    scope: LabelScope
    source: Event


class _Context:
    """The graph, its label scopes, and the happens-before relation, built once."""

    def __init__(self, graph: nx.DiGraph, activities: Sequence[m.Activity]) -> None:
        self.graph = graph
        self.activities = dict(zip(activity_keys(activities), activities, strict=True))
        self.scopes = label_scopes(graph)
        self.structure = _structural_order(graph)
        self.waits = list(self._wait_orders())
        self.crowd_joins: set[str] = set()  # crowds' joins already walked past
        self.order = self.structure.copy()
        self.order.add_edges_from((w.source, (w.accept, "e")) for w in self.waits)
        self.after_in_structure = cache(lambda event: nx.descendants(self.structure, event))
        self.after_in_order = cache(lambda event: nx.descendants(self.order, event))

    def _wait_orders(self) -> Iterator[_Wait]:
        for accept in nodes_of_kind(self.graph, NodeKind.ACCEPT):
            yield from self._orders(accept, self.graph.nodes[accept]["condition"])

    def until_orders(self) -> Iterator[_Wait]:
        """What a task with no end but its `until` waits for, as a `wait until` does."""
        for action in self.actions():
            step: m.TaskStep = self.graph.nodes[action]["step"]
            if step.until is not None and not ends_by_itself(step.task):
                yield from self._orders(action, step.until)

    def _orders(self, node: str, condition: Condition) -> Iterator[_Wait]:
        for needed in required_labels(condition):
            scope = self.scopes.get(needed.label.name)
            if scope is not None:
                yield _Wait(node, needed, scope, label_event(scope, needed.event))

    def structurally_after(self, first: Event, then: Event) -> bool:
        """`then` can only happen after `first`, by the flow of the activities alone."""
        return first == then or then in self.after_in_structure(first)

    def after(self, first: Event, then: Event) -> bool:
        """`then` can only happen after `first`, waits included."""
        return first == then or then in self.after_in_order(first)

    def activity_name(self, key: str) -> str:
        decl = self.activities.get(key)
        if decl is None or decl.name is not None:
            return f"activity `{key}`"
        return f"the activity at line {decl.span.line}"

    def actions(self) -> list[str]:
        return nodes_of_kind(self.graph, NodeKind.ACTION)


def _structural_order(graph: nx.DiGraph) -> nx.DiGraph:
    order = nx.DiGraph()
    order.add_edges_from(((n, "s"), (n, "e")) for n in graph.nodes)
    order.add_edges_from(((u, "e"), (v, "s")) for u, v in forward_graph(graph).edges)
    return order


def _quoted(graph: nx.DiGraph, node: str) -> str:
    """A step in the scenario's words; a crowd member's, as the crowd's step was written."""
    fork = graph.nodes[node].get("crowd_fork")
    if fork is not None:
        step: m.ParallelStep = graph.nodes[fork]["step"]
        words = crowd_words(step)
        if words is not None:
            return f"`{step.label.name}: {words}`" if step.label is not None else f"`{words}`"
    return f"`{describe_node(graph, node)}`"


# ---- counts, empty blocks, labels ---------------------------------------------------------


def _repeat_counts(context: _Context) -> Iterator[Diagnostic]:
    for start in nodes_of_kind(context.graph, NodeKind.REPEAT_START):
        step: m.RepeatStep = context.graph.nodes[start]["step"]
        if not step.count_is_whole:
            problem = f"`repeat` needs a whole number of rounds, not {step.count_text}"
        elif step.count < 1:
            problem = f"`repeat {step.count_text}` never runs its body"
        else:
            continue
        yield error("E309", problem, step.count_span, "write `repeat N` with N = 1, 2, 3, ...")


def _empty_blocks(context: _Context) -> Iterator[Diagnostic]:
    for fork in nodes_of_kind(context.graph, NodeKind.FORK, NodeKind.RACE_FORK):
        step: m.ParallelStep | m.RaceStep = context.graph.nodes[fork]["step"]
        word = "race" if isinstance(step, m.RaceStep) else "parallel"
        if isinstance(step, m.ParallelStep) and step.crowd is not None:
            continue  # a task given to a crowd: it has members unless its statement is wrong
        if not step.branches:
            yield warning("E311", f"this `{word}` has no branches and does nothing", step.span,
                          "remove it, or add branches")
            continue
        for branch in branches_of(context.graph, fork):
            if branch.entry is not None:
                continue
            span = step.branches[branch.index].span
            related = (Related(f"the `{word}` is here", step.span),)
            if word == "race" and len(step.branches) > 1:
                yield error("E311", "an empty branch ends this `race` at once, so the other "
                            "branches are preempted as soon as they start", span,
                            "remove the empty branch", related)
            else:
                yield warning("E311", f"an empty branch of a `{word}` does nothing", span,
                              "remove the empty branch", related)


def _duplicate_labels(context: _Context) -> Iterator[Diagnostic]:
    first_seen: dict[str, Label] = {}
    for ref, _ in label_definitions(context.graph):
        first = first_seen.setdefault(ref.name, ref)
        if first is not ref:
            yield error("E310", f"the label `{ref.name}` is defined twice", ref.span,
                        "a label names one step; rename one of them",
                        (Related("first defined here", first.span),))


# ---- how tasks end ------------------------------------------------------------------------


def _task_ends(context: _Context) -> Iterator[Diagnostic]:
    for action in context.actions():
        step: m.TaskStep = context.graph.nodes[action]["step"]
        kind = step.task.kind
        if not step.forever and needs_forever(step):
            yield error("E306", f"`{kind}` has no natural end, so this step would never end",
                        step.span, "add `for 10 s`, `until ...`, or `forever`")
        elif step.forever and ends_by_itself(step.task):
            spec = TASKS.get(kind)
            why = ("it ends when the human gets there" if spec is not None
                   and spec.ends_by_itself else "its `for`/`times` ends it")
            yield warning("E307", f"`forever` has no effect on this `{kind}`: {why}",
                          step.span, "remove `forever`")


def _forever_flow(context: _Context) -> tuple[list[Diagnostic], dict[str, str]]:
    """E308 for every `forever` task that blocks the flow after it; and the labels it keeps
    from ever being done (label -> the forever task)."""
    found: list[Diagnostic] = []
    never_done: dict[str, str] = {}
    for action in context.actions():
        step: m.TaskStep = context.graph.nodes[action]["step"]
        if step.forever and never_ends(step):
            diagnostic, held = _follow_forever(context, action)
            found += [diagnostic] if diagnostic is not None else []
            for label in held:
                never_done.setdefault(label, action)
    return found, never_done


def _follow_forever(context: _Context, action: str) -> tuple[Diagnostic | None, list[str]]:
    """Walk on from a task that never ends: what after it waits in vain for its token?"""
    graph = context.graph
    held = [graph.nodes[action]["label"]] if graph.nodes[action]["label"] else []
    stuck: list[str] = []  # joins, repeat ends and race joins that never let the token on
    node = action
    while (following := exit_successor(graph, node)) is not None:
        node = following
        kind = graph.nodes[node]["kind"]
        if kind is NodeKind.LABEL_END:
            held.append(graph.nodes[node]["label"])
        elif kind is NodeKind.RACE_JOIN and _race_can_end(context, graph.nodes[node]["fork"],
                                                          action):
            return None, []  # another branch ends the race; preempted counts as done
        elif kind is NodeKind.JOIN and _crowd_step(graph, node) is not None:
            # a crowd's task runs forever as one task: what follows it is what it blocks
            if node in context.crowd_joins:
                return None, held  # said once for the crowd, not once per member
            context.crowd_joins.add(node)
        elif kind in _BLOCKS or (kind is NodeKind.REPEAT_END and graph.nodes[node]["count"] != 1):
            stuck.append(node)
        elif kind not in (NodeKind.REPEAT_END, NodeKind.FINAL):
            return _blocks_step(context, action, node, stuck), held
    # At the end of the activity only a parallel or a repeat that never ends is a problem: a
    # task (or a race of tasks) that runs forever there does not keep the run alive.
    waiting = [n for n in stuck if graph.nodes[n]["kind"] is not NodeKind.RACE_JOIN]
    return (_blocks_join(context, action, waiting[0]) if waiting else None), held


_BLOCKS = frozenset({NodeKind.JOIN, NodeKind.RACE_JOIN})


def _crowd_step(graph: nx.DiGraph, join: str) -> str | None:
    """The crowd whose task a join ends (a task given to a crowd is a parallel), if any."""
    step = graph.nodes[graph.nodes[join]["fork"]]["step"]
    return step.crowd if isinstance(step, m.ParallelStep) else None
_BLOCK_WORDS = {NodeKind.JOIN: "parallel", NodeKind.RACE_JOIN: "race",
                NodeKind.REPEAT_END: "repeat"}


def _race_can_end(context: _Context, fork: str, action: str) -> bool:
    """Some other branch of the race holds no task that never ends."""
    graph = context.graph
    for branch in branches_of(graph, fork):
        if action in branch.members:
            continue
        if not any(graph.nodes[n]["kind"] is NodeKind.ACTION and never_ends(graph.nodes[n]["step"])
                   for n in branch.members):
            return True
    return False


_FOREVER_HINT = ("bound it with `for 10 s` or `until ...`, make it the activity's last step, or "
                 "run it in a `race` beside the steps that should end it")


def _blocks_step(context: _Context, action: str, dead: str, stuck: list[str]) -> Diagnostic:
    graph = context.graph
    around = ""
    if stuck:
        around = f" the `{_BLOCK_WORDS[graph.nodes[stuck[0]]['kind']]}` around it never ends and"
    return error("E308", f"{_quoted(graph, action)} runs forever, so{around} the steps after it "
                 "never run", graph.nodes[action]["span"], _FOREVER_HINT,
                 (Related(f"{_quoted(graph, dead)} never runs", graph.nodes[dead]["span"]),))


def _blocks_join(context: _Context, action: str, blocked: str) -> Diagnostic:
    graph = context.graph
    if graph.nodes[blocked]["kind"] is NodeKind.JOIN:
        fork = graph.nodes[blocked]["fork"]
        what = "the `parallel` around it never ends: it waits for every branch to end"
        related = Related("the `parallel` is here", graph.nodes[fork]["span"])
        hint = "use `race` instead of `parallel` if the other branches should end it, or " + \
               "bound the task with `for 10 s` or `until ...`"
    else:
        start = graph.nodes[blocked]["start"]
        what = "the `repeat` around it never starts its next round"
        related = Related("the `repeat` is here", graph.nodes[start]["span"])
        hint = _FOREVER_HINT
    return error("E308", f"{_quoted(graph, action)} runs forever, so {what}",
                 graph.nodes[action]["span"], hint, (related,))


def _untils(context: _Context) -> Iterator[Diagnostic]:
    """E313: `until` conditions that need a label event only possible after the task."""
    for action in context.actions():
        step: m.TaskStep = context.graph.nodes[action]["step"]
        if step.until is None:
            continue
        for condition in required_labels(step.until):
            scope = context.scopes.get(condition.label.name)
            if scope is None or not context.structurally_after(
                    (action, "e"), label_event(scope, condition.event)):
                continue
            message = (f"`until {step.until.text}` can never hold while this task "
                       f"runs: `{scope.label}` can only {_verb(condition.event)} after it")
            related = (Related(f"`{scope.label}` is here", scope.ref.span),)
            if ends_by_itself(step.task):
                yield warning("E313", message, step.span, "remove `until`, or wait for a label "
                              "that can happen while the task runs", related)
            else:
                yield error("E313", message + ", so the task never ends", step.span,
                            "add `for 10 s`, or wait for a label that can happen while the task "
                            "runs", related)
            break


def _verb(event: LabelEvent) -> str:
    return {LabelEvent.DONE: "finish", LabelEvent.STARTED: "start",
            LabelEvent.FAILED: "fail"}[event]


# ---- who commands whom --------------------------------------------------------------------


def _controllers(context: _Context) -> Iterator[Diagnostic]:
    by_human: dict[str, list[str]] = {}
    for action in context.actions():
        by_human.setdefault(context.graph.nodes[action]["human"], []).append(action)
    for human in sorted(by_human):
        yield from _two_activities(context, human, by_human[human])
        yield from _overlapping_steps(context, human, by_human[human])


def _two_activities(context: _Context, human: str, actions: list[str]) -> Iterator[Diagnostic]:
    """E301: the first step of each further activity that commands the human."""
    firsts: dict[str, str] = {}
    for action in actions:
        firsts.setdefault(context.graph.nodes[action]["activity"], action)
    owner, *others = sorted(firsts.values(), key=lambda n: node_sort_key(context.graph, n))
    owner_name = context.activity_name(context.graph.nodes[owner]["activity"])
    for other in others:
        other_name = context.activity_name(context.graph.nodes[other]["activity"])
        yield error("E301", f"`{human}` is commanded by two activities, {owner_name} and "
                    f"{other_name}, which run at the same time", context.graph.nodes[other]["span"],
                    "a human takes commands from one activity only: move these steps into one "
                    "activity and order them there (in sequence, or with `wait until`)",
                    (Related(f"{owner_name} commands `{human}` here",
                             context.graph.nodes[owner]["span"]),))


def _overlapping_steps(context: _Context, human: str, actions: list[str]) -> Iterator[Diagnostic]:
    """E302: a step that can run while an earlier step of the same activity and human runs."""
    for index, action in enumerate(actions):
        activity = context.graph.nodes[action]["activity"]
        other = next((earlier for earlier in actions[:index]
                      if context.graph.nodes[earlier]["activity"] == activity
                      and _can_overlap(context, earlier, action)), None)
        if other is None:
            continue
        yield error("E302", f"`{human}` is commanded by two steps that can run at the same "
                    "time", context.graph.nodes[action]["span"],
                    "a human follows one step at a time: run these steps one after the other, or "
                    "make one branch `wait until` the other's label is done",
                    (Related(f"this step also commands `{human}`",
                             context.graph.nodes[other]["span"]),))


def _can_overlap(context: _Context, first: str, second: str) -> bool:
    return not (context.after((first, "e"), (second, "s"))
                or context.after((second, "e"), (first, "s")))


# ---- waits --------------------------------------------------------------------------------


def _waits(context: _Context, never_done: dict[str, str],
           label_names: bool) -> list[Diagnostic]:
    found: list[Diagnostic] = list(_unknown_labels(context)) if label_names else []
    possible: list[_Wait] = []
    for wait in context.waits:
        if wait.condition.event is LabelEvent.DONE and wait.scope.label in never_done:
            found.append(_never_done(context, wait, never_done[wait.scope.label]))
        elif context.structurally_after((wait.accept, "e"), wait.source):
            found.append(_waits_for_later(context, wait))
        else:
            possible.append(wait)
    # a task that ends only by its `until` waits as a `wait until` does (E313 says when its
    # label can only come after it)
    for wait in context.until_orders():
        if wait.condition.event is LabelEvent.DONE and wait.scope.label in never_done:
            found.append(_never_done(context, wait, never_done[wait.scope.label]))
        elif not context.structurally_after((wait.accept, "e"), wait.source):
            possible.append(wait)
    return found + _deadlocks(context, possible)


def _waits_on_race_branches(context: _Context) -> Iterator[Diagnostic]:
    """E314 (a warning): a wait outside a race's branch that needs a label inside it: when
    another branch ends the race first, the label's step is preempted (or never starts) and
    the wait waits until the time limit. Once per wait."""
    races = [(fork, branches_of(context.graph, fork))
             for fork in nodes_of_kind(context.graph, NodeKind.RACE_FORK)]
    branches = [(fork, branch) for fork, each in races if len(each) > 1 for branch in each]
    warned: set[str] = set()
    for wait in [*context.waits, *context.until_orders()]:
        for fork, branch in branches:
            if wait.accept in warned or wait.scope.begin not in branch.members \
                    or wait.accept in branch.members:
                continue
            warned.add(wait.accept)
            line = context.graph.nodes[fork]["span"].line
            yield warning("E314", f"{_quoted(context.graph, wait.accept)} needs "
                          f"`{wait.scope.label}`, in a branch of the `race` at line {line}: "
                          f"when another branch ends the race first, `{wait.scope.label}` "
                          f"may never {_verb(wait.condition.event)}, and the wait then lasts "
                          "until the time limit", context.graph.nodes[wait.accept]["span"],
                          "wait for the race itself (label it), or give the wait a way out with "
                          "`or`",
                          (Related(f"`{wait.scope.label}` is here", wait.scope.ref.span),))


def _unknown_labels(context: _Context) -> Iterator[Diagnostic]:
    for accept in nodes_of_kind(context.graph, NodeKind.ACCEPT):
        condition: Condition = context.graph.nodes[accept]["condition"]
        for part in walk_conditions(condition):
            if isinstance(part, LabelCondition) and part.label.name not in context.scopes:
                yield error("E303", f"no step is labelled `{part.label.name}`, so this wait "
                            "would never end", part.label.span,
                            f"label the step to wait for: `{part.label.name}: HUMAN TASK ...`")


def _never_done(context: _Context, wait: _Wait, forever: str) -> Diagnostic:
    graph = context.graph
    label = wait.scope.label
    return error("E312", f"{_quoted(graph, wait.accept)} never ends: {_quoted(graph, forever)} "
                 f"runs forever, so `{label}` is never done", graph.nodes[wait.accept]["span"],
                 f"bound the task with `for 10 s` or `until ...`, or wait for `{label} started`",
                 (Related("this task runs forever", graph.nodes[forever]["span"]),))


def _waits_for_later(context: _Context, wait: _Wait) -> Diagnostic:
    graph = context.graph
    label = wait.scope.label
    if wait.accept in wait.scope.members:
        why = f"this wait is part of `{label}`, which cannot {_verb(wait.condition.event)} " \
              "before the wait ends"
    else:
        why = f"`{label}` can only {_verb(wait.condition.event)} after this wait has ended"
    return error("E304", f"`wait until {wait.condition.text}` can never be "
                 f"satisfied: {why}", graph.nodes[wait.accept]["span"],
                 f"move the step labelled `{label}` before this wait, or into a branch of a "
                 "`parallel` that runs beside it",
                 (Related(f"`{label}` is here", wait.scope.ref.span),))


def _deadlocks(context: _Context, waits: list[_Wait]) -> list[Diagnostic]:
    """E305: waits on a cycle of the happens-before relation, one diagnostic per cycle."""
    order = context.structure.copy()
    by_edge = {(w.source, (w.accept, "e")): w for w in waits}
    order.add_edges_from(by_edge)
    found: list[Diagnostic] = []
    reported: set[str] = set()
    siblings: dict[str, list[str]] = {}  # a crowd's task: its members' steps, one cycle for all
    for action in context.actions():
        fork = context.graph.nodes[action].get("crowd_fork")
        if fork is not None:
            siblings.setdefault(fork, []).append(action)
    for wait in waits:
        if wait.accept in reported or not nx.has_path(order, (wait.accept, "e"), wait.source):
            continue
        path = nx.shortest_path(order, (wait.accept, "e"), wait.source)
        later = [by_edge[edge] for edge in pairwise(path) if edge in by_edge]
        cycle = [wait, *reversed(later)]
        for waiting in cycle:
            fork = context.graph.nodes[waiting.accept].get("crowd_fork")
            reported.update(siblings.get(fork, [waiting.accept]))
        found.append(_deadlock(context, cycle))
    return found


def _where(context: _Context, node: str, reference: str) -> str:
    """`line 8`, with the activity when it is not the reference node's."""
    data = context.graph.nodes[node]
    line = f"line {data['span'].line}"
    if data["activity"] == context.graph.nodes[reference]["activity"]:
        return line
    return f"{line}, in {context.activity_name(data['activity'])}"


def _waiter(graph: nx.DiGraph, node: str) -> str:
    """What waits at `node`: a `wait until`, or a task that ends by its `until`."""
    return "wait" if graph.nodes[node]["kind"] is NodeKind.ACCEPT else "step"


def _deadlock(context: _Context, cycle: list[_Wait]) -> Diagnostic:
    """`cycle[0]` waits for a label that comes after `cycle[1]`, which waits for ... cycle[0]."""
    graph = context.graph
    steps = []
    for index, wait in enumerate(cycle):
        following = cycle[(index + 1) % len(cycle)]
        where = f"this {_waiter(graph, cycle[0].accept)}"
        if following is not cycle[0]:
            place = _where(context, following.accept, cycle[0].accept)
            where = f"{_quoted(graph, following.accept)} ({place})"
        steps.append(f"needs `{wait.condition.text}`, which can only happen after "
                     f"{where}")
    message = (f"deadlock: {_quoted(graph, cycle[0].accept)} " + ", which ".join(steps))
    related = tuple(Related(f"this {_waiter(graph, w.accept)} is part of the cycle: it needs "
                            f"`{w.condition.text}`", graph.nodes[w.accept]["span"])
                    for w in cycle[1:])
    related += tuple(Related(f"`{w.scope.label}` is here", w.scope.ref.span) for w in cycle)
    return error("E305", message, graph.nodes[cycle[0].accept]["span"],
                 "break the cycle: let one of these steps go ahead without waiting for the other",
                 related)
