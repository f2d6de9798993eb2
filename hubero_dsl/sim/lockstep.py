"""The end of a tick, for one engine or for many at once (a vector environment's copies).

Once the local planners have answered (`Engine.steer`, or `JointSteering` for many engines),
everyone moves, is kept apart and out of walls and turns, and the tick's events (arrived,
aligned, timer, stuck) are found. All of that is array work over the humans of every engine
stacked into one set of rows (each engine's rows one after another), so numpy's fixed cost per
call is paid once per tick however many engines there are; only the humans with an event wake
their behaviour, in their own engine.

An engine ends its tick the same, bit for bit, alone or with others: every step is element by
element, and bodies are kept apart engine by engine (only the test whether anyone overlaps is
made for all engines at once, by one neighbour search in which engines are worlds apart).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from hubero_dsl.planners.neighbours import PairFinder
from hubero_dsl.sim import physics
from hubero_dsl.sim.arrays import BoolArray, FloatArray, IntArray
from hubero_dsl.sim.robots import move_fleets
from hubero_dsl.sim.status import Posture

if TYPE_CHECKING:
    from hubero_dsl.sim.engine import Engine, Steering

ALIGNED = math.radians(3.0)   # rad: a heading this close to its goal counts as reached
PROGRESS = 0.5              # m a walking human must make within `stuck_time`
_STANDING = int(Posture.STANDING)  # an int compares with the posture array faster than an enum

_Array = npt.NDArray[Any]


class Lockstep:
    """Ends the tick of a list of engines that share a map and a step."""

    def __init__(self) -> None:
        self._overlaps = PairFinder(skin=0.6)

    def begin_step(self, engines: Sequence[Engine]) -> list[Steering | None]:
        """`Engine.begin_step` of each engine: the robots of all of them move together
        (`move_fleets`), then each engine gathers what its local planners are to be asked."""
        driving = [e for e in engines if e.robots.count]
        if driving:
            _check_shared(driving)
            move_fleets([e.robots for e in driving],
                        [e.robots.wanted(e.dt, e.tick, e.humans, e.position_of)
                         for e in driving], driving[0].dt)
        return [engine.steering() for engine in engines]

    def end_step(self, engines: Sequence[Engine], steerings: Sequence[Steering | None],
                 steered: Sequence[list[FloatArray]]) -> None:
        """`Engine.end_step` of each engine, with its steering and the planners' answers."""
        if not engines:
            return
        _check_shared(engines)
        rows = _Rows(engines)
        # who walks (`begin_step` gave a steering) or is teleoperated; the others are at rest
        active = [s is not None or bool(e.humans.teleop.any())
                  for e, s in zip(engines, steerings, strict=True)]
        velocity = (None if not any(active) else rows.join([
            e._velocities(s, v) if on else np.zeros(e.humans.velocity.shape)
            for e, s, v, on in zip(engines, steerings, steered, active, strict=True)]))
        self._move(rows, velocity)
        heading_goals = ~np.isnan(rows.join([e.humans.heading_goal for e in engines]))
        if any(active) or heading_goals.any():
            _turn(rows, heading_goals)
        for engine in engines:
            engine.tick += 1
        _dispatch_events(rows, [s is not None for s in steerings], heading_goals)
        for engine in engines:
            if engine.robots.count:
                engine.robots.settle(engine.tick, engine.dt, engine.ticks(engine.stuck_time),
                                     engine.position_of, engine.finish_robot,
                                     engine.standing_at)

    def _move(self, rows: _Rows, velocity: FloatArray | None) -> None:
        """Everyone moves at `velocity` (None at rest: zero), kept apart and out of walls."""
        engines = rows.engines
        dt = engines[0].dt
        old = rows.join([e.humans.position for e in engines])
        moved = old + (0.0 if velocity is None else velocity * dt)
        movable = rows.join([e.humans.posture for e in engines]) == _STANDING
        if not movable.all():
            moved[~movable] = old[~movable]
        separated = self._separate(rows, moved, movable)
        if not np.isfinite(separated).all():  # before the walls, which would hide it as a stop
            bad = int(np.flatnonzero(~np.isfinite(separated).all(axis=1))[0])
            engine, part = rows.engine_of(bad)
            engine._diverged(rows.part(separated, part))
        if velocity is None and separated is moved:
            # at rest and nobody overlaps: nobody moved, so the walls stop no one and no one
            # walked any length (the values the arithmetic below would give)
            for engine, position in zip(engines, rows.split(moved), strict=True):
                engine.humans.velocity = np.zeros(position.shape)
                engine.humans.position = position
            return
        moved = _keep_out_of_walls(rows, old, separated)
        step = moved - old
        walked = rows.join([e.humans.path_length for e in engines]) + physics.lengths(step)
        for engine, v, p, w in zip(engines, rows.split(step / dt), rows.split(moved),
                                   rows.split(walked), strict=True):
            engine.humans.velocity, engine.humans.position, engine.humans.path_length = v, p, w

    def _separate(self, rows: _Rows, moved: FloatArray, movable: BoolArray) -> FloatArray:
        """Bodies pushed apart, engine by engine (each with its robots); `moved` itself when
        nobody overlaps."""
        engines = rows.engines
        if len(engines) == 1:
            return engines[0]._separate(moved, movable)
        overlapping = self._overlapping(rows, moved)
        if not overlapping:
            return moved
        separated = moved.copy()
        for part in overlapping:
            start, end = rows.starts[part], rows.starts[part + 1]
            separated[start:end] = engines[part]._separate(moved[start:end],
                                                           movable[start:end])
        return separated

    def _overlapping(self, rows: _Rows, moved: FloatArray) -> list[int]:
        """The engines in which two bodies (humans or robots) overlap after `moved`."""
        engines = rows.engines
        robots = [e.robots for e in engines]
        position = np.concatenate([moved, *(r.position for r in robots)])
        radius = np.concatenate([*(e.humans.radius for e in engines), *(r.radius for r in robots)])
        world = np.concatenate([np.repeat(np.arange(len(engines)), rows.counts),
                                np.repeat(np.arange(len(engines)), [r.count for r in robots])])
        if not np.isfinite(position).all() or not len(radius):
            return list(range(len(engines)))  # each engine's own separation reports it
        pairs = self._overlaps.find(position, np.full(len(radius), 2.0 * float(radius.max())),
                                    world)
        hit = radius[pairs.first] + radius[pairs.second] > pairs.distance
        return sorted(set(world[pairs.first[hit]].tolist()))


def _check_shared(engines: Sequence[Engine]) -> None:
    first = engines[0]
    if any(e.grid is not first.grid or e.dt != first.dt for e in engines):
        raise ValueError("engines ticking together share one map and one step")


class _Rows:
    """Where each engine's humans are in the stack of all of them."""

    def __init__(self, engines: Sequence[Engine]) -> None:
        self.engines = engines
        self.counts = [e.humans.count for e in engines]
        self.starts = np.cumsum([0, *self.counts]).tolist()

    def join(self, arrays: list[_Array]) -> _Array:
        """The engines' arrays, one after another (one engine's array itself)."""
        return arrays[0] if len(arrays) == 1 else np.concatenate(arrays)

    def split(self, array: _Array) -> list[_Array]:
        """Each engine's rows of a joined array (views into it)."""
        if len(self.engines) == 1:
            return [array]
        return [array[a:b] for a, b in itertools.pairwise(self.starts)]

    def part(self, array: _Array, index: int) -> _Array:
        return array[self.starts[index]:self.starts[index + 1]]

    def engine_of(self, row: int) -> tuple[Engine, int]:
        """The engine of a joined row, and that engine's index in the list."""
        index = int(np.searchsorted(self.starts, row, side="right")) - 1
        return self.engines[index], index

    def per_row(self, values: list[int] | list[bool]) -> IntArray:
        """One value per engine, repeated for each of its rows."""
        return np.repeat(values, self.counts)


def _keep_out_of_walls(rows: _Rows, old: FloatArray, moved: FloatArray) -> FloatArray:
    """`physics.keep_out_of_walls` for the bodies present (the absent wait off the map, where
    there are no walls)."""
    engines = rows.engines
    grid = engines[0].grid
    radius = rows.join([e.humans.radius for e in engines])
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
    engines = rows.engines
    velocity = rows.join([e.humans.velocity for e in engines])
    speed = physics.lengths(velocity)
    steered = rows.join([e.humans.moving | e.humans.teleop for e in engines])
    walking = (speed > 0.1) & steered
    turning = walking | heading_goals
    if not turning.any():
        return
    # rows that do not turn keep their heading whatever `wanted` holds for them
    heading_goal = rows.join([e.humans.heading_goal for e in engines])
    wanted = np.where(walking, np.arctan2(velocity[:, 1], velocity[:, 0]), heading_goal)
    heading = physics.turn_towards(rows.join([e.humans.heading for e in engines]), wanted,
                                   turning, engines[0].dt)
    for engine, part in zip(engines, rows.split(heading), strict=True):
        engine.humans.heading = part


def _dispatch_events(rows: _Rows, walkers: list[bool], heading_goals: BoolArray) -> None:
    """Wake the humans whose behaviour has something to react to: an arrival, no progress,
    a heading reached, a timer. `walkers` is whether someone walks this tick in each engine,
    `heading_goals` which rows have a heading to turn to."""
    engines = rows.engines
    tick = rows.per_row([e.tick for e in engines])
    wake = timer = rows.join([e.wake_tick for e in engines]) <= tick
    arrived = stuck = aligned = None
    moving = rows.join([e.humans.moving for e in engines])
    if any(walkers):  # arrivals and progress concern walkers only
        position = rows.join([e.humans.position for e in engines])
        # a walking human always has a goal
        goal = rows.join([e.humans.goal for e in engines])
        stop = rows.join([e.humans.stop_distance for e in engines])
        arrived = moving & (physics.lengths(position - goal) <= stop)
        _note_progress(rows, position, moving, rows.per_row(walkers).astype(bool), tick)
        anchor_tick = rows.join([e.anchor_tick for e in engines])
        stuck_ticks = rows.per_row([e.ticks(e.stuck_time) for e in engines])
        stuck = moving & (tick - anchor_tick > stuck_ticks)
        wake = wake | arrived | stuck
    turning = heading_goals & ~moving
    if turning.any():
        heading = rows.join([e.humans.heading for e in engines])
        heading_goal = rows.join([e.humans.heading_goal for e in engines])
        aligned = turning & (np.abs(physics.wrap_angle(heading - heading_goal)) < ALIGNED)
        wake = wake | aligned
    if not wake.any():
        return
    for row in wake.nonzero()[0].tolist():
        engine, part = rows.engine_of(row)
        engine._wake(row - rows.starts[part], arrived is not None and bool(arrived[row]),
                     aligned is not None and bool(aligned[row]),
                     stuck is not None and bool(stuck[row]), bool(timer[row]))


def _note_progress(rows: _Rows, position: FloatArray, moving: BoolArray, walking_engine: BoolArray,
                   tick: IntArray) -> None:
    """Anchor each walker where it last made PROGRESS, and when; a standing human's anchor is
    set afresh when it starts walking (`Engine.walk_to`). Engines where nobody walks are left
    as they are."""
    engines = rows.engines
    anchor = rows.join([e.anchor for e in engines])
    progressed = (physics.lengths(position - anchor) > PROGRESS) & walking_engine
    if progressed.any():
        anchor[progressed] = position[progressed]
    anchor_tick = rows.join([e.anchor_tick for e in engines])
    renewed = (progressed | ~moving) & walking_engine
    anchor_tick[renewed] = tick[renewed]
    for engine, a, t in zip(engines, rows.split(anchor), rows.split(anchor_tick), strict=True):
        engine.anchor, engine.anchor_tick = a, t
