"""Walkers held up near walls, and the ways round that the social force alone does not find.

The engine asks `WaysRound.look` every tick; every LOOK_AGAIN s it looks at the walkers who
have made no progress for STALLED s near a wall and are not in a crowd (at most CROWDED others
within ALONE m: in a crowd, the crowd carries people through an opening), and gives each one
way round at most every STALLED s:

* pushed back round a wall's end after passing its corner, so that the target is hidden, a
  walker goes back to the corner when it sees it within REACH m (`PathPool.retreat`), and
  passes it only once it sees past it;
* with no such corner (pushed off its path by others as they set out, round a corridor's
  mouth, its target now behind the wall), it plans anew from where it stands;
* of two such walkers within MAKE_WAY m of each other (side by side at a door or a corridor's
  mouth, each pushing the other off the way in, and nothing in the model telling them apart
  when they stand as each other's mirror image), the one with further to go steps aside,
  towards a point STEP_ASIDE m away from the other (passed, like any waypoint, the look-ahead
  before it: about 0.6 m aside), then goes on to its goal. A group member leaves its group's
  formation until it has stepped aside: the group's pull would hold it where it was.

A walker of any surroundings stalled for STALLED s within HEMMED m of someone standing still
(a group that stopped round it to talk) squeezes past: it plans round the bodies standing
within STANDING_REACH m, as round walls, and for STALLED s keeps `engine.SQUEEZE` of its social
push, which otherwise holds it between their personal spaces (all of it near a robot:
`Engine._squeezing`).

At the end of every tick that begins a look, a walker of any surroundings stalled for STALLED
s within CROWDED_GOAL of its goal while someone stands on it (or another stalled walker sent
to the same point stands nearer it) is told so (`Engine.hold_short`): a `move_to` queued there
stops short, rather than wait out the stuck time that the jostling of a queue keeps resetting.

Progress is still measured from where each walker was (`Engine.anchor`): one who cannot get on
is given up as stuck all the same.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Protocol

import numpy as np
from scipy.spatial import cKDTree

from hubero_dsl.sim import physics

if TYPE_CHECKING:
    from hubero_dsl.sim.arrays import BoolArray, FloatArray, HumanArrays, IntArray, PathPool
    from hubero_dsl.world.grid import OccupancyGrid

STALLED = 3.0       # s without progress
CROWDED = 2         # others within ALONE m: more is a crowd
ALONE = 1.0         # m
LOOK_AGAIN = 0.25   # s between looks
REACH = 1.5         # m to the corner gone back to
MAKE_WAY = 1.2      # m between two who hold each other up
STEP_ASIDE = 1.2    # m to the point aside
HEMMED = 0.5        # m (surface gap) to someone standing still, of a walker hemmed in by them
STANDING_REACH = 3.0  # m (surface gap): the people standing still that a way round goes round


class Walkers(Protocol):
    """What a way round needs of the engine (`Engine` is one)."""

    humans: HumanArrays
    paths: PathPool
    grid: OccupancyGrid
    tick: int
    anchor_tick: IntArray

    def ticks(self, seconds: float) -> int: ...

    def plan_path(self, index: int, goal: tuple[float, float],
                  via: tuple[float, float] | None = None) -> str | None: ...

    def plan_to_goal(self, index: int) -> str | None: ...

    def fits(self, index: int, point: tuple[float, float]) -> bool: ...

    def in_sight(self, a: tuple[float, float], b: tuple[float, float]) -> bool: ...

    def hold_short(self, index: int, stalled: BoolArray | None = None) -> None: ...

    def at_rest_beside(self, rows: IntArray, gap: float) -> BoolArray: ...

    def squeeze_round_standing(self, index: int, reach: float, seconds: float) -> bool: ...


class WaysRound:
    """The ways round given to one engine's walkers."""

    def __init__(self, engine: Walkers, lookahead: float) -> None:
        self.engine = engine
        self.lookahead = lookahead  # m: how near a waypoint counts as passed
        # when each was last given a way round: it has STALLED s to get on before the next
        self.rerouted_tick = np.full(engine.humans.count, -engine.ticks(STALLED),
                                     dtype=np.int64)
        # group members stepping aside: row -> the version of that path in `paths`
        self._stepping_aside: dict[int, int] = {}

    def look(self, rows: IntArray) -> None:
        """Every LOOK_AGAIN s: the walkers among `rows` held up near walls get a way round,
        and those hemmed in by people standing squeeze past them."""
        engine = self.engine
        if engine.tick % max(1, engine.ticks(LOOK_AGAIN)):
            return
        self._rejoin_groups()
        stalled = rows[engine.tick - engine.anchor_tick[rows] >= engine.ticks(STALLED)]
        if not stalled.size:
            return
        by_walls = self._alone_by_walls(stalled)
        by_walls = by_walls[engine.tick - self.rerouted_tick[by_walls] >= engine.ticks(STALLED)]
        self._plan_again(engine.paths.retreat(by_walls, engine.humans.position,
                                              engine.grid.crosses_obstacle, REACH))
        self._make_way(by_walls)
        self._squeeze_past_standing(stalled)

    def _squeeze_past_standing(self, stalled: IntArray) -> None:
        """Stalled walkers (`stalled`) within HEMMED m of people standing still (a group that
        stopped round them to talk) squeeze past them, at most every STALLED s: a way round
        them, and less of the social push for STALLED s (`Engine.squeeze_round_standing`)."""
        engine = self.engine
        stalled = stalled[engine.tick - self.rerouted_tick[stalled] >= engine.ticks(STALLED)]
        if not stalled.size:
            return
        for index in stalled[engine.at_rest_beside(stalled, HEMMED)].tolist():
            # tried, with a way or not, not again for STALLED s: a way is planned afresh
            engine.squeeze_round_standing(index, STANDING_REACH, STALLED)
            self.rerouted_tick[index] = engine.tick

    def hold_at_goals(self) -> None:
        """At a tick's end, every LOOK_AGAIN s: walkers stalled for STALLED s near their goal
        with someone standing on it, or queued behind those, are told so (a move_to stops
        short there). Told at the end of the tick they stalled in, as arrivals are, the step
        after theirs starts at the next tick's beginning, with the event's time."""
        engine, humans = self.engine, self.engine.humans
        moved = engine.tick - 1   # the tick whose move has just been made
        if moved % max(1, engine.ticks(LOOK_AGAIN)):
            return
        rows = humans.moving.nonzero()[0]
        stalled = rows[moved - engine.anchor_tick[rows] >= engine.ticks(STALLED)]
        stalled = stalled[np.isfinite(humans.goal[stalled]).all(axis=1)]
        halted = np.zeros(humans.count, dtype=bool)   # who count as standing (`standing_at`)
        halted[stalled] = True
        # beyond the goal's ring only one with someone at rest beside it can be queued (in a
        # jam far from every goal, that leaves nobody to look at one by one)
        far = physics.lengths(humans.goal[stalled] - humans.position[stalled]) \
            > physics.CROWDED_GOAL + humans.stop_distance[stalled]
        if far.any():
            far[far] = ~engine.at_rest_beside(stalled[far], physics.QUEUE_GAP)
            stalled = stalled[~far]
        for index in stalled.tolist():
            engine.hold_short(index, halted)

    def _alone_by_walls(self, stalled: IntArray) -> IntArray:
        """The stalled walkers (`stalled`) within the look-ahead of a wall (more, to within a
        cell), not in a crowd."""
        engine, humans = self.engine, self.engine.humans
        stalled = stalled[~engine.grid.surely_clear(humans.position[stalled],
                                                    humans.radius[stalled] + self.lookahead)]
        if not stalled.size:
            return stalled
        near = cKDTree(humans.position).query_ball_point(humans.position[stalled], ALONE,
                                                          return_length=True)
        return stalled[near - 1 <= CROWDED]  # less themselves

    def _plan_again(self, rows: IntArray) -> None:
        """New paths from where they stand for walkers whose target lies behind a wall, with
        no corner of their path near to go back to."""
        engine, goals = self.engine, self.engine.humans.goal
        for index in rows.tolist():
            if np.isfinite(goals[index]).all():
                engine.plan_to_goal(index)
                self.rerouted_tick[index] = engine.tick

    def _make_way(self, stalled: IntArray) -> None:
        """Of two stalled walkers near each other, the one further from its goal steps
        aside."""
        if len(stalled) < 2:
            return
        position = self.engine.humans.position
        for a, b in sorted(cKDTree(position[stalled]).query_pairs(MAKE_WAY)):
            first, second = int(stalled[a]), int(stalled[b])
            if self._further(first, second):
                first, second = second, first
            self._step_aside(second, position[first])

    def _further(self, index: int, other: int) -> bool:
        """Whether walker `index` has further to go than `other` (the lower row on a tie)."""
        paths, position = self.engine.paths, self.engine.humans.position
        mine = paths.remaining_length(index, position[index])
        theirs = paths.remaining_length(other, position[other])
        return mine > theirs or (mine == theirs and index > other)

    def _step_aside(self, index: int, other: FloatArray) -> None:
        """Walker `index` walks STEP_ASIDE m away from `other` (half as far where a wall is in
        the way), then on to its goal; where neither fits, it stays."""
        engine, humans = self.engine, self.engine.humans
        here, goal = humans.position[index], humans.goal[index]
        away = here - other
        span = math.hypot(away[0], away[1])
        if span == 0.0 or not np.isfinite(goal).all():
            return
        for distance in (STEP_ASIDE, STEP_ASIDE / 2):
            point = here + away * (distance / span)
            if reachable(engine, index, point) and engine.plan_path(
                    index, (float(goal[0]), float(goal[1])),
                    (float(point[0]), float(point[1]))) is None:
                self.rerouted_tick[index] = engine.tick
                if humans.with_group[index]:  # the group's pull would hold it where it was
                    humans.with_group[index] = False
                    self._stepping_aside[index] = int(engine.paths.version[index])
                return

    def _rejoin_groups(self) -> None:
        """Group members who have stepped aside walk with their group again (those whose
        path has changed since are on another walk, which says whether they do)."""
        paths = self.engine.paths
        for index, version in list(self._stepping_aside.items()):
            if paths.version[index] != version:
                del self._stepping_aside[index]
            elif paths.passed(index) > 1:  # past the point aside
                self.engine.humans.with_group[index] = True
                del self._stepping_aside[index]


def reachable(engine: Walkers, index: int, point: FloatArray) -> bool:
    """Whether walker `index`'s body fits at `point`, in sight from where it stands."""
    here, there = engine.humans.position[index], (float(point[0]), float(point[1]))
    return engine.fits(index, there) and engine.in_sight((float(here[0]), float(here[1])),
                                                         there)
