"""The humans' state as numpy arrays, and vectorised path following.

Row i of every array is human i (sorted as declared in the scenario); robots are appended after
the humans only when a `Crowd` snapshot is built for the planners. Behaviours change these
arrays on events (a task starts, a goal is reached); every tick the engine reads them whole.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from hubero_dsl.sim.physics import lengths
from hubero_dsl.world.shapes import Shape, ShapeArrays

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]
BoolArray = npt.NDArray[np.bool_]

NO_GOAL = np.nan

Sight = Callable[[FloatArray, FloatArray], BoolArray]  # where a wall hides `there` from `here`
# where the straight way from `here` to `there` is clear for the bodies of rows `rows`
WayClear = Callable[[FloatArray, FloatArray, IntArray], BoolArray]


@dataclass(eq=False)
class HumanArrays:
    """Kinematic state, parameters and the current drive of every human."""

    names: list[str]
    position: FloatArray          # (N, 2)
    velocity: FloatArray          # (N, 2)
    heading: FloatArray           # (N,)
    posture: npt.NDArray[np.int8]
    radius: FloatArray
    shapes: list[Shape]
    personal_space: ShapeArrays
    speed: FloatArray             # desired walking speed
    max_speed: FloatArray
    run_speed: FloatArray
    relaxation_time: FloatArray
    goal_tolerance: FloatArray
    goal_strength: FloatArray
    avoidance_strength: FloatArray
    obstacle_strength: FloatArray
    interaction_range: FloatArray
    field_of_view: FloatArray
    # drive, set by behaviours
    moving: BoolArray             # steered by the local planner this tick
    with_group: BoolArray         # walking on its group's task, with its companions
    desired_speed: FloatArray     # m/s while moving
    goal: FloatArray              # (N, 2) final goal of the current walk (nan: none)
    stop_distance: FloatArray     # arrive when this close to the goal
    heading_goal: FloatArray      # heading to turn to (nan: none)
    teleop_velocity: FloatArray   # (N, 2) velocity commanded through the API
    teleop: BoolArray
    path_length: FloatArray       # metres walked so far
    reaction: npt.NDArray[np.int8] | None = None   # index into REACTIONS; None: all regular
    # who is in the scene; None: everyone, always (no flows). The absent wait far outside the
    # map, where nobody meets them (`hubero_dsl.sim.flows`), and are not logged.
    present: BoolArray | None = None

    @property
    def count(self) -> int:
        return len(self.names)


class PathPool:
    """Every human's global path in one array, followed waypoint by waypoint without loops.

    A human's path occupies rows [start, end) of `points`, the cursor at the waypoint walked
    to; each tick the cursor moves past the waypoints already within `lookahead` (and back
    when one passed is needed again, `retreat`). New paths are appended; the pool is compacted
    when it grows large, so re-planning (follow re-plans every second) does not leak memory.
    """

    def __init__(self, count: int) -> None:
        self.points: FloatArray = np.zeros((0, 2))
        self.start: IntArray = np.zeros(count, dtype=np.intp)
        self.cursor: IntArray = np.zeros(count, dtype=np.intp)
        self.end: IntArray = np.zeros(count, dtype=np.intp)
        self.careful: BoolArray = np.zeros(count, dtype=bool)  # sent back to a corner
        # which path each human follows, counted up by every new path: compacting the pool
        # moves `start` and `cursor`, so they do not say whether a path is still the same
        self.version: npt.NDArray[np.int64] = np.zeros(count, dtype=np.int64)
        self._dropped: IntArray = np.zeros(count, dtype=np.intp)  # passed, then compacted away

    def set_path(self, human: int, waypoints: FloatArray) -> None:
        if len(self.points) > 4096 and len(self.points) > 8 * max(1, int(self.live_rows())):
            self._compact()
        start = len(self.points)
        self.points = np.concatenate([self.points, np.asarray(waypoints, dtype=np.float64)])
        self.start[human] = self.cursor[human] = start
        self.end[human] = start + len(waypoints)
        self._renew(human)

    def clear(self, human: int) -> None:
        self.start[human] = self.cursor[human] = self.end[human] = 0
        self._renew(human)

    def _renew(self, human: int) -> None:
        self.careful[human] = False
        self.version[human] += 1
        self._dropped[human] = 0

    def passed(self, human: int) -> int:
        """How many waypoints of its path human `human` has passed."""
        return int(self.cursor[human] - self.start[human] + self._dropped[human])

    def has_path(self) -> BoolArray:
        return self.end > self.cursor

    def live_rows(self) -> int:
        return int(np.sum(self.end - self.cursor))

    def advance(self, position: FloatArray, lookahead: float, hidden: Sight | None = None
                ) -> None:
        """Move each cursor past waypoints within `lookahead` (never past the last one).

        `hidden(here, there)` says where a wall stands on the straight line between: someone
        sent back to a corner (`retreat`) passes it only once the waypoint after it is no
        longer hidden from where they stand, or they would be steered into the wall again.
        """
        for _ in range(4):  # a few passes skip several short segments in one tick
            rows = np.flatnonzero(self.end - self.cursor > 1)
            if not rows.size:
                return
            passing = rows[lengths(self.points[self.cursor[rows]] - position[rows]) < lookahead]
            careful = passing[self.careful[passing]]
            if careful.size and hidden is not None:
                blind = hidden(position[careful], self.points[self.cursor[careful] + 1])
                passing = np.setdiff1d(passing, careful[blind], assume_unique=True)
            if not passing.size:
                return
            self.cursor[passing] += 1
            self.careful[passing] = False

    def see_past(self, rows: IntArray, position: FloatArray, clear: WayClear) -> None:
        """Move the cursors of `rows` past each waypoint whose next one they can walk to
        straight from `position` (their rows of it; `clear(here, there, rows)` says where the
        straight way is clear for their bodies): someone drawn off their plan by others (a
        group keeping together) would otherwise turn back to a waypoint they left behind."""
        for _ in range(4):  # a few passes skip several waypoints in one tick
            rows = rows[self.end[rows] - self.cursor[rows] > 1]
            if not rows.size:
                return
            rows = rows[clear(position[rows], self.points[self.cursor[rows] + 1], rows)]
            self.cursor[rows] += 1
            self.careful[rows] = False

    def retreat(self, rows: IntArray, position: FloatArray, hidden: Sight, reach: float
                ) -> IntArray:
        """Send humans `rows` whose target is `hidden` from `position` (their rows of it) back
        to the last waypoint they passed that is not, and is within `reach`: pushed back round
        a corner just after passing it, they walk to the corner again (and pass it only once
        they see past it) rather than press into the wall. A path's first point, where the
        human stood when it was planned, is no corner: nobody is sent back there; nor is
        anyone who sees none of their last few waypoints nearby. Returns those: the rows
        whose target is hidden and who were sent back nowhere."""
        if rows.size:
            rows = rows[hidden(position[rows], self.points[self.cursor[rows]])]
        lost = []
        for back in range(1, 5):  # the few corners of a bend, as `advance` passes them
            cornerless = self.cursor[rows] - back <= self.start[rows]
            lost.append(rows[cornerless])
            rows = rows[~cornerless]
            if not rows.size:
                break
            corner = self.points[self.cursor[rows] - back]
            here = position[rows]
            found = (lengths(corner - here) < reach) & ~hidden(here, corner)
            self.cursor[rows[found]] -= back
            self.careful[rows[found]] = True
            rows = rows[~found]
        return np.sort(np.concatenate([*lost, rows]))

    def current_targets(self, rows: IntArray) -> FloatArray:
        return self.points[self.cursor[rows]]

    def points_ahead(self, rows: IntArray, position: FloatArray, distance: float
                     ) -> FloatArray:
        """For each human of `rows`, the point `distance` m on along its path from
        `position` (their rows of it), through its waypoints from the cursor on; its last
        waypoint when the path ends sooner."""
        here = position[rows].astype(np.float64)
        left = np.full(len(rows), float(distance))
        cursor = self.cursor[rows].copy()
        going = np.flatnonzero(cursor < self.end[rows])
        while going.size:
            step = self.points[cursor[going]] - here[going]
            length = lengths(step)
            short = length >= left[going]   # the point lies on this segment
            ends = going[short]
            if ends.size:
                fraction = left[ends] / np.maximum(length[short], 1e-12)
                here[ends] += step[short] * fraction[:, None]
            on = going[~short]
            here[on] += step[~short]
            left[on] -= length[~short]
            cursor[on] += 1
            going = on[cursor[on] < self.end[rows[on]]]
        return here

    def points_along(self, rows: IntArray, position: FloatArray, distances: FloatArray
                     ) -> FloatArray:
        """(D, K, 2): `points_ahead` of the humans of `rows` at each of `distances`."""
        return np.stack([self.points_ahead(rows, position, float(d)) for d in distances])

    def remaining_length(self, human: int, position: FloatArray) -> float:
        segment = self.points[self.cursor[human]:self.end[human]]
        if len(segment) == 0:
            return 0.0
        first = float(np.linalg.norm(segment[0] - position))
        return first + float(np.linalg.norm(np.diff(segment, axis=0), axis=1).sum())

    def waypoints(self, human: int) -> FloatArray:
        return self.points[self.cursor[human]:self.end[human]]

    def _compact(self) -> None:
        self._dropped += self.cursor - self.start
        lengths = self.end - self.cursor
        pieces = [self.points[c:e] for c, e in zip(self.cursor, self.end, strict=True)]
        self.points = np.concatenate(pieces) if pieces else np.zeros((0, 2))
        starts = np.concatenate([[0], np.cumsum(lengths)[:-1]]).astype(np.intp)
        self.start, self.cursor = starts, starts.copy()  # the waypoints passed are gone
        self.end = starts + lengths
