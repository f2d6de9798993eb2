"""People who come and go: a scenario's flows, brought into the scene and taken out of it.

A flow's members are rows of the engine's arrays from the start, so that the state stays in
fixed numpy arrays. Until a member arrives, and after they leave, they are absent
(`HumanArrays.present` is False): they wait far outside the map, where no neighbour search,
sensor or condition meets them, they are unknown as targets (`Engine.removed`), and the log
leaves them out.

Arrivals are a Poisson process per flow (or, for a flow built in code with `arrivals`, the
given times): the gaps between arrivals are drawn once per run from
the flow's own seeded generator (`stable_seed(seed, "flow", NAME)`), so a run is deterministic
and adding a flow does not change the others. At their arrival tick a member appears at a
random place of the flow's area where their body fits clear of every body present (a few
places are tried each tick; when none fits, the area is full and the arrival waits, and the
flow's later arrivals wait behind it). A member who appears is given `move_to TARGET`; when
that task ends (arrived, or given up as stuck or unreachable) they leave the scene, and where
they left is kept: `all FLOW reach T` and `any FLOW reaches T` count the people who came where
they are, or where they left (`whereabouts`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from hubero_dsl.model.tasks import Task

if TYPE_CHECKING:
    from hubero_dsl.model.conditions import Condition
    from hubero_dsl.model.program import FlowSpec
    from hubero_dsl.sim.engine import Engine
    from hubero_dsl.sim.status import TaskHandle

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]

OFF_MAP = 1e6         # m: where absent people wait, far beyond any map's 1e5 m coordinates
OFF_MAP_SPACING = 10  # m between them, more than any two bodies or ranges reach
ENTRY_TRIES = 16      # random places of the area tried per tick for the next arrival

Give = Callable[[str, Task], "TaskHandle"]
Holds = Callable[["Condition"], bool]


@dataclass
class FlowState:
    """One flow during a run: who has come, who is here, and whether more will come."""

    spec: FlowSpec
    rows: IntArray            # the members' engine rows, in order of appearance
    arrival_ticks: IntArray   # when each member may appear (fewer than rows: the rest never)
    entries: FloatArray       # (K, 2) places of the area where a member may appear
    radius: FloatArray        # each member's body radius
    rng: np.random.Generator
    end_tick: int             # the duration's end, or the time limit's
    arrived: int = 0          # members brought in so far
    stopped: bool = False     # no more arrivals: the duration passed or `until` held
    walking: dict[int, TaskHandle] = field(default_factory=dict)  # row -> its walk
    ended: list[int] = field(default_factory=list)  # rows whose walk ended since the last tick

    @property
    def spawning(self) -> bool:
        return not self.stopped and self.arrived < len(self.arrival_ticks)

    def may_bring_more(self, tick: int) -> bool:
        """Whether someone may still come: an arrival is waiting, or the flow's time is not
        over (judged by what a watcher knows, not by the arrivals drawn for later)."""
        return self.spawning or (not self.stopped and tick < self.end_tick)


class Flows:
    """The flows of a run. `update()` once per tick, before the engine steps."""

    def __init__(self, flows: tuple[FlowSpec, ...], engine: Engine, seed_for: Callable[
            [str], np.random.Generator], give: Give, holds: Holds, time_limit: float) -> None:
        self.engine = engine
        self._give = give
        self._holds = holds
        humans = engine.humans
        humans.present = np.ones(humans.count, dtype=bool)
        self.left_at = np.full((humans.count, 2), np.nan)  # where each one left the scene
        self.states = [self._state(spec, seed_for(spec.name), time_limit) for spec in flows]
        self._by_name = {state.spec.name: state for state in self.states}
        for state in self.states:
            self._leave(state.rows)

    def _state(self, spec: FlowSpec, rng: np.random.Generator, time_limit: float) -> FlowState:
        engine = self.engine
        rows = np.array([engine.index_of(m) for m in spec.members], dtype=np.intp)
        if spec.arrivals is not None:
            times = np.asarray(spec.arrivals[:len(rows)], dtype=np.float64)
        else:
            times = np.cumsum(rng.exponential(1.0 / spec.rate, size=len(rows)))
        end = min(spec.duration, time_limit) if spec.duration is not None else time_limit
        ticks = np.ceil(times[times < end] / engine.dt - 1e-9).astype(np.intp)
        radius = engine.humans.radius[rows]
        entries = engine.grid.entry_places(spec.area, spec.target, float(radius.max()))
        return FlowState(spec, rows, ticks, entries, radius, rng, engine.ticks(end))

    # ---- each tick ---------------------------------------------------------------------------

    def update(self) -> None:
        tick = self.engine.tick
        for state in self.states:
            self._see_off(state)
            if state.spec.until is not None and not state.stopped \
                    and self._holds(state.spec.until):
                state.stopped = True
            while state.spawning and state.arrival_ticks[state.arrived] <= tick:
                if not self._bring_in(state):
                    break  # the area is full: this arrival, and those after it, wait

    def whereabouts(self, flow: str) -> tuple[IntArray, FloatArray, bool]:
        """The rows of the people `flow` has brought so far, where each is now (or where they
        left the scene), and whether it may bring more."""
        state = self._by_name[flow]
        humans = self.engine.humans
        assert humans.present is not None
        rows = state.rows[:state.arrived]
        where = np.where(humans.present[rows, None], humans.position[rows], self.left_at[rows])
        return rows, where, state.may_bring_more(self.engine.tick)

    def keeps_alive(self) -> bool:
        """Whether a flow with a duration or `until` has not stopped (its time is not over,
        its `until` has not held, or an arrival is waiting) or has people here. Its time is
        over at its duration's end, whenever the last arrival drawn for the run came."""
        tick = self.engine.tick
        return any(s.spec.keeps_alive and (s.may_bring_more(tick) or s.walking)
                   for s in self.states)

    def _see_off(self, state: FlowState) -> None:
        if not state.ended:
            return
        ended, state.ended = state.ended, []
        for row in ended:
            del state.walking[row]
        rows = np.array(ended, dtype=np.intp)
        self.left_at[rows] = self.engine.humans.position[rows]
        self._leave(rows)

    def _bring_in(self, state: FlowState) -> bool:
        row = int(state.rows[state.arrived])
        place = self._free_place(state, float(state.radius[state.arrived]))
        if place is None:
            return False
        engine, humans = self.engine, self.engine.humans
        assert humans.present is not None
        name = humans.names[row]
        target = state.spec.target
        humans.position[row] = place
        humans.velocity[row] = 0.0
        humans.heading[row] = math.atan2(target[1] - place[1], target[0] - place[0])
        humans.present[row] = True
        engine.anchor[row] = place
        engine.anchor_tick[row] = engine.tick
        engine.removed.discard(name)
        state.arrived += 1
        walk = self._give(name, Task("move_to", target, {}, state.spec.span))
        state.walking[row] = walk
        # told when the walk ends rather than asking every walk every tick
        walk.on_change(lambda handle: _note_end(state, row, handle))
        _note_end(state, row, walk)  # a walk may end as it starts (no way to the target)
        return True

    def _free_place(self, state: FlowState, radius: float) -> FloatArray | None:
        """A random place of the flow's area where this body overlaps nobody present."""
        if not len(state.entries):
            return None
        tries = state.entries[state.rng.integers(len(state.entries), size=ENTRY_TRIES)]
        humans, robots = self.engine.humans, self.engine.robots
        assert humans.present is not None
        here = humans.present.nonzero()[0]
        centres = np.concatenate([humans.position[here], robots.position])
        reach = np.concatenate([humans.radius[here], robots.radius]) + radius
        if not len(centres):
            return tries[0].copy()
        gaps = np.hypot(tries[:, None, 0] - centres[None, :, 0],
                        tries[:, None, 1] - centres[None, :, 1])
        clear = (gaps >= reach[None, :]).all(axis=1)
        first = int(np.argmax(clear))
        return tries[first].copy() if clear[first] else None

    def _leave(self, rows: IntArray) -> None:
        """Take these people out of the scene: off the map, still, absent, unknown as targets."""
        humans = self.engine.humans
        assert humans.present is not None
        humans.position[rows, 0] = OFF_MAP
        humans.position[rows, 1] = OFF_MAP + OFF_MAP_SPACING * rows
        humans.velocity[rows] = 0.0
        humans.present[rows] = False
        self.engine.removed.update(humans.names[i] for i in rows.tolist())


def _note_end(state: FlowState, row: int, walk: TaskHandle) -> None:
    if walk.done and row not in state.ended:
        state.ended.append(row)
