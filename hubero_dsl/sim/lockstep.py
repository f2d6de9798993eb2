"""A tick's array work, for one engine or for many at once (a vector environment's copies).

At its beginning the robots move (all engines' robots in one set of rows, `move_fleets`) and
each engine gathers what its local planners are to be asked (`Engine.steering`). Once the
planners have answered (`Engine.steer`, or `JointSteering` for many engines), everyone moves,
is kept apart and out of walls and turns, and the tick's events (arrived, aligned, timer,
stuck) are found. All of that is array work over the bodies of every engine stacked into one
set of rows (each engine's rows one after another), so numpy's fixed cost per call is paid
once per tick however many engines there are; only the humans with an event wake their
behaviour, in their own engine.

An engine's tick is the same, bit for bit, alone or with others: every step is element by
element, and bodies are kept apart engine by engine (only the test whether anyone overlaps is
made for all engines at once, by one neighbour search in which engines are worlds apart).
"""

from __future__ import annotations

import bisect
import itertools
import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from hubero_dsl.planners.neighbours import PairFinder
from hubero_dsl.sim import physics
from hubero_dsl.sim.arrays import BoolArray, FloatArray, HumanArrays, IntArray
from hubero_dsl.sim.robots import move_fleets, stop_at_people
from hubero_dsl.sim.status import Posture

if TYPE_CHECKING:
    from hubero_dsl.sim.engine import Engine, Steering

ALIGNED = math.radians(3.0)   # rad: a heading this close to its goal counts as reached
PROGRESS = 0.5              # m a walking human must make within `stuck_time`
_STANDING = int(Posture.STANDING)  # an int compares with the posture array faster than an enum

_Array = npt.NDArray[Any]


class Lockstep:
    """Begins and ends the tick of a list of engines that share a map and a step."""

    def __init__(self) -> None:
        self._overlaps = PairFinder(skin=0.6)
        self._worlds: IntArray | None = None  # the engine of each row the finder was built on

    def begin_step(self, engines: Sequence[Engine]) -> list[Steering | None]:
        """A tick's first part for each engine: the robots of all of them move together
        (`move_fleets`), then each engine gathers what its local planners are to be asked
        (None: nobody walks; of several engines, without their crowds, which `JointSteering`
        stacks at once)."""
        driving = [e for e in engines if e.robots.count]
        if driving:
            _check_shared(driving)
            move_fleets([e.robots for e in driving],
                        [e.robots.wanted(e.dt, e.tick, e.humans, e.position_of)
                         for e in driving], driving[0].dt)
        alone = len(engines) == 1
        return [engine.steering(crowd=alone) for engine in engines]

    def end_step(self, engines: Sequence[Engine], steerings: Sequence[Steering | None],
                 steered: Sequence[list[FloatArray]]) -> None:
        """A tick's last part for each engine, given its steering (`begin_step`) and the
        planners' answers: everyone moves, then the tick's events are dispatched."""
        if not engines:
            return
        _check_shared(engines)
        rows = _Rows(engines)
        # who walks (`begin_step` gave a steering) or is teleoperated; the others are at rest
        active = [s is not None or bool(e.humans.teleop.any())
                  for e, s in zip(engines, steerings, strict=True)]
        velocity = (None if not any(active) else rows.join([
            e.velocities(s, v) if on else np.zeros(e.humans.velocity.shape)
            for e, s, v, on in zip(engines, steerings, steered, active, strict=True)]))
        self._move(rows, velocity)
        driving = [e for e in engines if e.robots.count]
        if driving:  # robots still inside someone who could not yield are taken back
            stop_at_people([e.robots for e in driving], [e.humans for e in driving],
                           driving[0].dt)
        heading_goals = ~np.isnan(rows.humans.heading_goal)
        if any(active) or heading_goals.any():
            _turn(rows, heading_goals)
        for engine in engines:
            engine.tick += 1
        _dispatch_events(rows, [s is not None for s in steerings], heading_goals)
        for engine, steering in zip(engines, steerings, strict=True):
            if steering is not None:  # somebody walked: who is held short of a taken goal
                engine.ways_round.hold_at_goals()
            if engine.robots.count:
                engine.robots.settle(engine.tick, engine.dt, engine.ticks(engine.stuck_time),
                                     engine.position_of, engine.finish_robot,
                                     engine.standing_at)

    def _move(self, rows: _Rows, velocity: FloatArray | None) -> None:
        """Everyone moves at `velocity` (None at rest: zero), kept apart and out of walls."""
        h = rows.humans
        dt = rows.engines[0].dt
        old = h.position
        moved = old + (0.0 if velocity is None else velocity * dt)
        movable = h.posture == _STANDING
        if not movable.all():
            moved[~movable] = old[~movable]
        separated = self._separate(rows, moved, movable)
        if not np.isfinite(separated).all():  # before the walls, which would hide it as a stop
            bad = int(np.flatnonzero(~np.isfinite(separated).all(axis=1))[0])
            engine, part = rows.engine_of(bad)
            engine.diverged(rows.part(separated, part))
        if velocity is None and separated is moved:
            # at rest and nobody overlaps: nobody moved, so the walls stop no one and no one
            # walked any length (the values the arithmetic below would give)
            h.velocity = np.zeros(old.shape)
            h.position = moved
        else:
            moved = _keep_out_of_walls(rows, old, separated)
            step = moved - old
            h.velocity = step / dt
            h.path_length = h.path_length + physics.lengths(step)
            h.position = moved
        rows.scatter(h, "velocity", "position", "path_length")

    def _separate(self, rows: _Rows, moved: FloatArray, movable: BoolArray) -> FloatArray:
        """Bodies pushed apart, engine by engine (each with its robots); `moved` itself when
        nobody overlaps."""
        engines = rows.engines
        if len(engines) == 1:
            return engines[0].separated(moved, movable)
        overlapping = self._overlapping(rows, moved)
        if not overlapping:
            return moved
        separated = moved.copy()
        for part in overlapping:
            start, end = rows.starts[part], rows.starts[part + 1]
            separated[start:end] = engines[part].separated(moved[start:end],
                                                           movable[start:end])
        return separated

    def _overlapping(self, rows: _Rows, moved: FloatArray) -> list[int]:
        """The engines in which two bodies (humans or robots) overlap after `moved`."""
        engines = rows.engines
        robots = [e.robots for e in engines]
        position = np.concatenate([moved, *(r.position for r in robots)])
        radius = np.concatenate([rows.humans.radius, *(r.radius for r in robots)])
        world = np.concatenate([np.repeat(np.arange(len(engines)), rows.counts),
                                np.repeat(np.arange(len(engines)), [r.count for r in robots])])
        if not np.isfinite(position).all() or not len(radius):
            return list(range(len(engines)))  # each engine's own separation reports it
        if self._worlds is None or not np.array_equal(self._worlds, world):
            # rows changed engines (another set of copies ticks): the finder's pairs are void
            self._overlaps, self._worlds = PairFinder(skin=0.6), world
        pairs = self._overlaps.find(position, np.full(len(radius), 2.0 * float(radius.max())),
                                    world)
        hit = radius[pairs.first] + radius[pairs.second] > pairs.distance
        return sorted(set(world[pairs.first[hit]].tolist()))


def joined(arrays: list[_Array]) -> _Array:
    """Arrays one after another; one array itself (numpy's concatenate copies)."""
    return arrays[0] if len(arrays) == 1 else np.concatenate(arrays)


def _check_shared(engines: Sequence[Engine]) -> None:
    first = engines[0]
    if len(engines) > 1 and any(e.grid is not first.grid or e.dt != first.dt for e in engines):
        raise ValueError("engines ticking together share one map and one step")


class _Joined:
    """An attribute's arrays of several objects (engines, or their humans), one after
    another: read on first use, and written back, each object's rows a view, by `scatter`."""

    def __init__(self, parts: list[Any], starts: list[int]) -> None:
        self._parts = parts
        self._starts = starts

    def __getattr__(self, name: str) -> Any:
        joined = np.concatenate([getattr(part, name) for part in self._parts])
        setattr(self, name, joined)
        return joined

    def __setattr__(self, name: str, value: Any) -> None:
        object.__setattr__(self, name, value)  # a joined array, written back by `scatter`

    def scatter(self, *names: str) -> None:
        for name in names:
            joined = getattr(self, name)
            for part, (start, end) in zip(self._parts, itertools.pairwise(self._starts),
                                          strict=True):
                setattr(part, name, joined[start:end])


class _Rows:
    """Where each engine's humans are in the stack of all of them, and the stack's arrays:
    `humans` (the humans' arrays) and `state` (the engines' per-human arrays), joined for
    several engines; for one, the engine's own objects, which `scatter` leaves as they are."""

    def __init__(self, engines: Sequence[Engine]) -> None:
        self.engines = engines
        self.humans: HumanArrays | _Joined
        self.state: Engine | _Joined
        if len(engines) == 1:
            self.counts = [engines[0].humans.count]
            self.starts = [0, self.counts[0]]
            self.humans, self.state = engines[0].humans, engines[0]
        else:
            self.counts = [e.humans.count for e in engines]
            self.starts = list(itertools.accumulate(self.counts, initial=0))
            self.humans = _Joined([e.humans for e in engines], self.starts)
            self.state = _Joined(list(engines), self.starts)

    @staticmethod
    def scatter(joined: HumanArrays | Engine | _Joined, *names: str) -> None:
        """Write joined arrays back to each engine (one engine's were written in place)."""
        if isinstance(joined, _Joined):
            joined.scatter(*names)

    def join(self, arrays: list[_Array]) -> _Array:
        """The engines' arrays, one after another (one engine's array itself)."""
        return joined(arrays)

    def part(self, array: _Array, index: int) -> _Array:
        return array[self.starts[index]:self.starts[index + 1]]

    def engine_of(self, row: int) -> tuple[Engine, int]:
        """The engine of a joined row, and that engine's index in the list."""
        index = bisect.bisect_right(self.starts, row) - 1
        return self.engines[index], index

    def per_row(self, values: list[int]) -> IntArray | int:
        """One value per engine, repeated for each of its rows (one engine's value itself,
        which numpy broadcasts)."""
        return values[0] if len(values) == 1 else np.repeat(values, self.counts)


def _keep_out_of_walls(rows: _Rows, old: FloatArray, moved: FloatArray) -> FloatArray:
    """`physics.keep_out_of_walls` for the bodies present (the absent wait off the map, where
    there are no walls)."""
    engines = rows.engines
    grid = engines[0].grid
    radius = rows.humans.radius
    if all(e.humans.present is None for e in engines):
        return physics.keep_out_of_walls(grid, old, moved, radius)
    present = rows.join([e.humans.present if e.humans.present is not None
                         else np.ones(e.humans.count, dtype=bool) for e in engines])
    here = present.nonzero()[0]
    moved[here] = physics.keep_out_of_walls(grid, old[here], moved[here], radius[here])
    return moved


def _turn(rows: _Rows, heading_goals: BoolArray) -> None:
    """Walkers turn to where they go, the others to their heading goals (the rows of
    `heading_goals`)."""
    h = rows.humans
    speed = physics.lengths(h.velocity)
    walking = (speed > 0.1) & (h.moving | h.teleop)
    turning = walking | heading_goals
    if not turning.any():
        return
    # rows that do not turn keep their heading whatever `wanted` holds for them
    wanted = np.where(walking, np.arctan2(h.velocity[:, 1], h.velocity[:, 0]), h.heading_goal)
    h.heading = physics.turn_towards(h.heading, wanted, turning, rows.engines[0].dt)
    rows.scatter(h, "heading")


def _dispatch_events(rows: _Rows, walkers: list[bool], heading_goals: BoolArray) -> None:
    """Wake the humans whose behaviour has something to react to: an arrival, no progress,
    a heading reached, a timer. `walkers` is whether someone walks this tick in each engine,
    `heading_goals` which rows have a heading to turn to."""
    h, state = rows.humans, rows.state
    tick = rows.per_row([e.tick for e in rows.engines])
    wake = timer = state.wake_tick <= tick
    arrived = stuck = aligned = None
    moving = h.moving
    if any(walkers):  # arrivals and progress concern walkers only
        # a walking human always has a goal
        arrived = moving & (physics.lengths(h.position - h.goal) <= h.stop_distance)
        _note_progress(rows, walkers, tick)
        stuck_ticks = rows.per_row([e.ticks(e.stuck_time) for e in rows.engines])
        stuck = moving & (tick - state.anchor_tick > stuck_ticks)
        wake = wake | arrived | stuck
    turning = heading_goals & ~moving
    if turning.any():
        aligned = turning & (np.abs(physics.wrap_angle(h.heading - h.heading_goal)) < ALIGNED)
        wake = wake | aligned
    if not wake.any():
        return
    for row in wake.nonzero()[0].tolist():
        engine, part = rows.engine_of(row)
        engine.wake(row - rows.starts[part], arrived is not None and bool(arrived[row]),
                     aligned is not None and bool(aligned[row]),
                     stuck is not None and bool(stuck[row]), bool(timer[row]))


def _note_progress(rows: _Rows, walkers: list[bool], tick: IntArray | int) -> None:
    """Anchor each walker where it last made PROGRESS, and when; a standing human's anchor is
    set afresh when it starts walking (`Engine.walk_to`). Engines where nobody walks
    (`walkers`) are left as they are."""
    h, state = rows.humans, rows.state
    progressed = physics.lengths(h.position - state.anchor) > PROGRESS
    renewed = progressed | ~h.moving
    if not all(walkers):
        walking = np.repeat(walkers, rows.counts)
        progressed &= walking
        renewed &= walking
    if progressed.any():
        state.anchor[progressed] = h.position[progressed]
    state.anchor_tick[renewed] = tick[renewed] if isinstance(tick, np.ndarray) else tick
    rows.scatter(state, "anchor", "anchor_tick")
