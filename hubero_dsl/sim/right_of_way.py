"""Two streams jammed head-on in a narrow place take turns, as people at a busy door do.

The social force alone holds two crowds pressed against each other in a door or a corridor
they try to pass at once, until everyone there is given up as stuck. Every LOOK_AGAIN s the
engine asks `RightOfWay.look`, which finds such jams and settles each with a turn:

* **A jam** is two walkers stalled for STALLED s within MEET m of each other, in sight of each
  other, each with the other ahead, going opposite ways (the cosine of their ways below
  HEAD_ON), away from any jam already being settled. A walker's way is the direction to the
  point AHEAD m on along its path. The jam's centre is the narrowest point of their ways
  ahead of both, where it is clearly narrower (under NARROWER of the clearance) than between
  them: a door a step ahead of a queue; else the midpoint between them (a corridor). Only
  where there is room to stand aside, ROOM m of clearance ROOM_AT m before the centre and
  past it, do they take turns: a door or a short passage between rooms, not the inside of a
  long corridor, where stepping back frees nothing.
* **The first turn** goes to the stream with more people heading through the centre within
  REACH m; on a tie, to the one whose front walker has less far to go.
* **Those who wait** are the others heading through the centre from within REACH m, short of
  it (the centre ahead, and their path passing within THROUGH m of it). Each walks ASIDE m
  (half as far where that does not fit) away from the centre and across to its right, 60,
  45 or 30 degrees off straight back, where its body fits in sight (else the same to its
  left, else straight back, else it stays): off the line the others come along. It stands
  there.
* **The turn passes** to the waiting stream when nobody of the going one still heads through
  the centre, or after TURN s when someone waits; those of the old stream still short of
  the centre wait in their turn. The new stream walks on once the old one's last walkers
  have come out (none within HANDOVER m past the centre), or after HANDOVER_AT_MOST s: each
  plans its way anew (straight at its goal where no plan is found).
* **The jam ends** when nobody waits and nobody goes.

Waiting is not being stuck: a waiting walker's stuck time starts anew at every look, for
WAIT_AT_MOST s at most, when it walks on and waits at that jam no more; and a walker queued
for a jam (heading through it within QUEUE m) makes progress whenever someone gets through
it. Someone the jam holds for the whole stuck time is still given up. Members of a group
and robots take no part (a group walks through as its members are steered).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Protocol

import numpy as np
from scipy.spatial import cKDTree

from hubero_dsl.sim import physics, ways_round

if TYPE_CHECKING:
    from hubero_dsl.sim.arrays import BoolArray, FloatArray, IntArray

MEET = 1.5          # m between the two stalled walkers of a jam
ONCOMING = -0.5     # cosine between two ways below which they come at each other
HEAD_ON = -0.8      # ... and between the ways of a jam's two stalled walkers
HEAD_ON_AHEAD = 0.7  # cosine between one's way and the other of a jam's two at least
AHEAD = 2.5         # m along one's path to the point that says which way one goes
SAMPLE = 0.25       # m between the points of a way where a jam's narrowest point is looked for
NARROWER = 0.8      # of the clearance between the two, at most: a point clearly narrower
REACH = 3.0         # m from a jam's centre within which walkers heading through it take turns
THROUGH = 2.5       # m from a jam's centre within which one's path passes: one heads through it
ROOM_AT = 2.5       # m before and past a jam's centre where there must be ...
ROOM = 1.2          # ... at least this clearance: room to stand aside
WAIT_AT_MOST = 30.0  # s one waits at a jam at most
QUEUE = 6.0         # m from a jam's centre within which walkers heading through it queue
HANDOVER = 1.0      # m past the centre within which one is still coming out of a narrow place
HANDOVER_AT_MOST = 5.0   # s a stream whose turn it is waits for the other to come out
TURN = 10.0         # s a turn lasts at most while the other stream waits
ASIDE = 1.2         # m to the point where one waits, or half as far where that does not fit
ASIDE_ANGLES = (math.radians(60.0), math.radians(45.0), math.radians(30.0))  # off straight back


class Walkers(ways_round.Walkers, Protocol):
    """What taking turns needs of the engine (`Engine` is one): what a way round needs,
    where each walker last made progress, and who belongs to a group."""

    anchor: FloatArray
    groups: dict[str, IntArray]


@dataclass(eq=False)
class _Jam:
    """A jam being settled: where the streams meet, the way of the one whose turn it is, and
    since when; who waits for their turn, and who has been given it but waits for the other
    stream to come out (row -> the version of their path aside in `PathPool`, and the tick
    they began to wait); who went
    through it at the last look, and when someone last got through."""

    centre: FloatArray
    way: FloatArray
    since: int
    waiting: dict[int, tuple[int, int]] = field(default_factory=dict)
    cleared: dict[int, tuple[int, int]] = field(default_factory=dict)
    going: set[int] = field(default_factory=set)
    moved: int = 0
    waited: set[int] = field(default_factory=set)   # who waited WAIT_AT_MOST s: no more


class RightOfWay:
    """The jams of one engine's walkers, and whose turn it is in each."""

    def __init__(self, engine: Walkers) -> None:
        self.engine = engine
        self._jams: list[_Jam] = []
        # group members walk through as their group is steered: they take no turns
        self._in_group = np.zeros(engine.humans.count, dtype=bool)
        for members in engine.groups.values():
            self._in_group[members] = True

    @property
    def waiting(self) -> set[int]:
        """The rows of everyone waiting for their turn, or for the other stream to come out."""
        return {row for jam in self._jams for row in (*jam.waiting, *jam.cleared)}

    def look(self, rows: IntArray) -> None:
        """Every LOOK_AGAIN s: new jams among the walkers `rows` are found and every jam's
        turns are kept (module docstring). Only the walkers stalled or near a jam are looked
        at closely."""
        engine = self.engine
        if engine.tick % max(1, engine.ticks(ways_round.LOOK_AGAIN)):
            return
        free = rows[~self._in_group[rows]]
        stalled = free[engine.tick - engine.anchor_tick[free] >= engine.ticks(ways_round.STALLED)]
        if stalled.size >= 2:
            self._find_jams(free, stalled)
        for jam in list(self._jams):
            near = self._near(free, jam.centre, QUEUE)
            self._keep_turns(jam, near, self._ways(near))

    def _near(self, rows: IntArray, centre: FloatArray, reach: float) -> IntArray:
        """The walkers of `rows` within `reach` m of `centre`."""
        return rows[physics.lengths(self.engine.humans.position[rows] - centre) < reach]

    def _ways(self, rows: IntArray) -> FloatArray:
        """The unit vector from each walker of `rows` to the point AHEAD m on along its path:
        the way it is going through a narrow place, where its next waypoint may lie aside
        (the corner of a door's jamb, walked round)."""
        humans = self.engine.humans
        towards = (self.engine.paths.points_ahead(rows, humans.position, AHEAD)
                   - humans.position[rows])
        span = np.maximum(physics.lengths(towards), 1e-9)
        return np.asarray(towards / span[:, None], dtype=np.float64)

    # ---- jams ----------------------------------------------------------------------------

    def _find_jams(self, free: IntArray, stalled: IntArray) -> None:
        """New jams: walkers of `stalled` face to face, away from the jams already settled
        (`free`: every walker who may take turns)."""
        engine = self.engine
        stalled = stalled[~np.isin(stalled, list(self.waiting))]
        if stalled.size < 2:
            return
        ways = self._ways(stalled)
        position = engine.humans.position[stalled]
        for a, b in _face_to_face(position, ways).tolist():
            if not engine.in_sight((float(position[a, 0]), float(position[a, 1])),
                                   (float(position[b, 0]), float(position[b, 1]))):
                continue   # a wall between them
            pair, pair_ways = stalled[[a, b]], ways[[a, b]]
            centre = self._narrowest(pair, pair_ways, (position[a] + position[b]) / 2.0)
            if any(math.dist(jam.centre, centre) < REACH for jam in self._jams) \
                    or not self._room_to_wait(centre, pair_ways[0]):
                continue
            way = self._first_turn(self._near(free, centre, REACH), centre, pair, pair_ways)
            self._jams.append(_Jam(centre, way, engine.tick, moved=engine.tick))

    def _narrowest(self, pair: IntArray, ways: FloatArray, midpoint: FloatArray
                   ) -> FloatArray:
        """Where two walkers jammed head-on (going `ways`) meet: the narrowest point of their
        ways ahead (within REACH m, every SAMPLE m) that lies ahead of both, where it is
        clearly narrower than between them (a door a step ahead of a queue); else the
        midpoint between them (a corridor)."""
        engine = self.engine
        grid, paths, position = engine.grid, engine.paths, engine.humans.position
        points = paths.points_along(pair, position, np.arange(0.0, REACH, SAMPLE)
                                    ).reshape(-1, 2)
        clearance = grid.clearance_at(points)
        ahead_of_both = np.all([(points - position[row]) @ way > 0.0
                                for row, way in zip(pair.tolist(), ways, strict=True)], axis=0)
        # nor where no body fits (a way cut round a corner): no place to meet
        clearance[~ahead_of_both
                  | (clearance <= float(engine.humans.radius[pair].max()))] = np.inf
        narrowest = int(np.argmin(clearance))
        if clearance[narrowest] < NARROWER * grid.clearance_at(midpoint[None, :])[0]:
            return np.asarray(points[narrowest], dtype=np.float64)
        return midpoint

    def _room_to_wait(self, centre: FloatArray, way: FloatArray) -> bool:
        """Whether there is room to stand aside ROOM_AT m before `centre` and past it along
        `way`: a door or a short passage between rooms, not the inside of a long corridor
        (where stepping back frees nothing and the other stream is met further on)."""
        ends = centre + np.outer([-ROOM_AT, ROOM_AT], way)
        return bool((self.engine.grid.clearance_at(ends) >= ROOM).all())

    def _first_turn(self, near: IntArray, centre: FloatArray, pair: IntArray,
                    pair_ways: FloatArray) -> FloatArray:
        """The way of the stream that goes first at a jam between the walkers `pair` (going
        `pair_ways`): the one of more walkers of `near` heading through `centre`."""
        axis = pair_ways[0] - pair_ways[1]
        axis /= math.hypot(axis[0], axis[1])   # the first's way, the two ways' mean direction
        ways = self._ways(near)
        distance, leads = self._leading(near, ways, centre)
        along = ways[leads & (distance < REACH)] @ axis
        mine, theirs = int((along > -ONCOMING).sum()), int((along < ONCOMING).sum())
        if mine != theirs:
            return axis if mine > theirs else -axis
        paths, position = self.engine.paths, self.engine.humans.position
        first, second = int(pair[0]), int(pair[1])
        first_left = paths.remaining_length(first, position[first])
        second_left = paths.remaining_length(second, position[second])
        return axis if first_left <= second_left else -axis

    def _leading(self, rows: IntArray, ways: FloatArray, centre: FloatArray
                 ) -> tuple[FloatArray, BoolArray]:
        """For the walkers `rows` (going `ways`): how far each is from `centre`, and whether
        its way leads through it, short of it (within QUEUE m: the centre ahead, and its
        path passing within THROUGH m of it, every THROUGH / 2 m of it up to QUEUE m on)."""
        position = self.engine.humans.position
        to_centre = centre - position[rows]
        distance = physics.lengths(to_centre)
        leads = (distance < QUEUE) & (np.einsum("ij,ij->i", to_centre, ways) > 0.0)
        on = rows[leads]
        if on.size:
            paths = self.engine.paths
            along = paths.points_along(on, position,
                                       np.arange(0.0, QUEUE + THROUGH / 2, THROUGH / 2))
            nearest = physics.lengths((along - centre).reshape(-1, 2)).reshape(
                len(along), -1).min(axis=0)
            leads[leads] = nearest < THROUGH
        return distance, leads

    # ---- turns ---------------------------------------------------------------------------

    def _keep_turns(self, jam: _Jam, near: IntArray, ways: FloatArray) -> None:
        """Who goes and who waits at `jam` now, of the walkers `near` it (going `ways`): the
        turn passes, or the jam ends, or the stream given the turn walks on."""
        self._still_waiting(jam)
        distance, leads = self._leading(near, ways, jam.centre)
        if not jam.cleared:
            going = self._going(jam, near, ways, leads & (distance < REACH))
            self._queue(jam, near, leads, going)
            if not going and not jam.waiting:
                self._jams.remove(jam)
                return
            if not going or (jam.waiting
                             and self.engine.tick - jam.since >= self.engine.ticks(TURN)):
                self._pass_turn(jam)
        if jam.cleared and self._hand_over(jam, near, ways):
            ways = self._ways(near)   # those let go have new paths
            distance, leads = self._leading(near, ways, jam.centre)
        self._hold_back(jam, near, ways, leads & (distance < REACH))

    def _still_waiting(self, jam: _Jam) -> None:
        """Those waiting at `jam` who have been given another walk meanwhile wait no longer;
        the others' stuck time starts again (waiting is not being stuck)."""
        engine, paths = self.engine, self.engine.paths
        for waiting in (jam.waiting, jam.cleared):
            for row, (version, began) in list(waiting.items()):
                if paths.version[row] != version or not engine.humans.moving[row]:
                    del waiting[row]
                elif engine.tick - began >= engine.ticks(WAIT_AT_MOST):
                    del waiting[row]   # it has waited long enough: on, stuck time running
                    jam.waited.add(row)
                    self._walk_on(row)
                else:
                    engine.anchor[row] = engine.humans.position[row]
                    engine.anchor_tick[row] = engine.tick

    def _going(self, jam: _Jam, near: IntArray, ways: FloatArray, heading: BoolArray
               ) -> set[int]:
        """The rows of the walkers `near` `jam` (going `ways`) of the stream whose turn it is
        still `heading` through it."""
        going = near[heading & (ways @ jam.way > -ONCOMING)]
        return set(going.tolist()) - set(jam.waiting)

    def _queue(self, jam: _Jam, near: IntArray, leads: BoolArray, going: set[int]) -> None:
        """Walkers queued for `jam` (those of `near` whose way `leads` through it within
        QUEUE m) make progress while someone gets through it: their stuck time starts no
        earlier than that."""
        engine = self.engine
        left = np.array(sorted(jam.going - going - set(jam.waiting)), dtype=np.intp)
        if left.size and bool((((engine.humans.position[left] - jam.centre) @ jam.way) > 0.0)
                              .any()):
            jam.moved = engine.tick   # someone got through (not: turned away)
        jam.going = going
        queued = near[leads]
        engine.anchor_tick[queued] = np.maximum(engine.anchor_tick[queued], jam.moved)

    def _pass_turn(self, jam: _Jam) -> None:
        """The waiting stream's turn, once the other has come out (`_hand_over`)."""
        jam.way = -jam.way
        jam.since = self.engine.tick
        jam.cleared, jam.waiting = jam.waiting, {}

    def _hand_over(self, jam: _Jam, near: IntArray, ways: FloatArray) -> bool:
        """The stream whose turn it now is walks on once the other's last walkers have come
        out of the narrow place (none of them within HANDOVER m past the centre), or after
        HANDOVER_AT_MOST s. Whether it did."""
        to_centre = jam.centre - self.engine.humans.position[near]
        ahead = np.einsum("ij,ij->i", to_centre, ways)
        coming_out = ((ways @ jam.way < ONCOMING) & (ahead > -HANDOVER) & (ahead <= 0.0)
                      & (physics.lengths(to_centre) < REACH)
                      & ~np.isin(near, [*jam.waiting, *jam.cleared]))
        if coming_out.any() and (self.engine.tick - jam.since
                                 < self.engine.ticks(HANDOVER_AT_MOST)):
            return False
        for row in sorted(jam.cleared):
            self._walk_on(row)
        jam.cleared.clear()
        jam.since = self.engine.tick
        return True

    def _hold_back(self, jam: _Jam, near: IntArray, ways: FloatArray, heading: BoolArray
                   ) -> None:
        """Walkers `near` `jam` (going `ways`) of the stream whose turn it is not, `heading`
        through it, wait aside."""
        against = np.flatnonzero(heading & (ways @ jam.way < ONCOMING))
        waiting = self.waiting | jam.waited
        for k in against.tolist():
            row = int(near[k])
            if row not in waiting:
                self._wait_aside(jam, row, ways[k])

    def _wait_aside(self, jam: _Jam, row: int, way: FloatArray) -> None:
        """Walker `row`, going `way`, steps back from `jam`'s centre and aside to a point where
        its body fits in sight, and waits there; where none does, it waits where it is."""
        engine = self.engine
        here = engine.humans.position[row]
        aside = next((point for point in _points_aside(here, way, jam.centre)
                      if ways_round.reachable(engine, row, point)), here)
        engine.paths.set_path(row, np.array([here, aside]))
        jam.waiting[row] = (int(engine.paths.version[row]), engine.tick)

    def _walk_on(self, row: int) -> None:
        """Walker `row`, done waiting, plans on to its goal; where no plan is found from where
        it stands, it walks straight at it (and is given up if it stays stuck there)."""
        engine = self.engine
        if engine.plan_to_goal(row) is not None:
            engine.paths.set_path(row, np.array([engine.humans.position[row],
                                                 engine.humans.goal[row]]))


def _face_to_face(position: FloatArray, ways: FloatArray) -> IntArray:
    """(P, 2) index pairs of the walkers at `position`, going `ways`, within MEET m of each
    other who come at each other head-on, each with the other ahead; in order."""
    pairs = cKDTree(position).query_pairs(MEET, output_type="ndarray")
    if not len(pairs):
        return np.zeros((0, 2), dtype=np.intp)
    pairs = pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))]
    first, second = ways[pairs[:, 0]], ways[pairs[:, 1]]
    offset = position[pairs[:, 1]] - position[pairs[:, 0]]
    ahead = HEAD_ON_AHEAD * physics.lengths(offset)
    facing = ((np.einsum("ij,ij->i", first, second) < HEAD_ON)
              & (np.einsum("ij,ij->i", offset, first) > ahead)
              & (np.einsum("ij,ij->i", offset, second) < -ahead))
    return np.asarray(pairs[facing], dtype=np.intp)


def _points_aside(here: FloatArray, way: FloatArray, centre: FloatArray) -> list[FloatArray]:
    """Where someone at `here`, going `way`, may wait for others to come out of `centre`, best
    first: ASIDE m back from the centre and across to one's right, then to one's left (most
    to the side first, then nearer), straight back last."""
    back = here - centre
    span = math.hypot(back[0], back[1])
    if span == 0.0:
        back, span = -way, 1.0
    back = back / span
    right = np.array([back[1], -back[0]])   # across the line to the centre, on one's right
    if right @ np.array([way[1], -way[0]]) < 0.0:
        right = -right
    points: list[FloatArray] = []
    for side in (1.0, -1.0):
        for angle in ASIDE_ANGLES:
            direction = back * math.cos(angle) + side * right * math.sin(angle)
            points.extend(here + direction * distance for distance in (ASIDE, ASIDE / 2))
    points.extend(here + back * distance for distance in (ASIDE, ASIDE / 2))
    return points
