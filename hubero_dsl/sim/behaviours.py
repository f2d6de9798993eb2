"""What each task makes a human do: HuBeRo's task set as small event-driven state machines.

A behaviour never runs every tick. It sets a human's drive in the arrays (walk to a goal along a
planned path, stop, turn to a heading) and is woken only by events the engine detects with array
operations: its timer ran out, the human arrived, finished turning, or made no progress. This is
the paper's aa.cs FSM: each behaviour names its current `state` for the log.

`BEHAVIOURS` maps every task kind of the registry (`hubero_dsl.model.tasks.TASKS`) to the
function that builds its behaviour from a `Task`; a new task kind registers one here with
`@builds("kind")`. Behaviours reach the world only through `World`, the services the engine
offers them, so this module does not depend on the engine.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol

import numpy as np

from hubero_dsl.model.tasks import Target, Task
from hubero_dsl.sim.physics import STILL
from hubero_dsl.sim.status import Posture, TaskStatus, stuck_reason

if TYPE_CHECKING:
    from shapely.geometry import Polygon

    from hubero_dsl.sim.arrays import FloatArray, HumanArrays, IntArray


class World(Protocol):
    """What a behaviour may ask of the engine: time, positions, and commands for its human."""

    humans: HumanArrays
    tick: int
    stuck_time: float
    follow_replan: FloatArray
    groups: dict[str, IntArray]

    def ticks(self, seconds: float) -> int: ...
    def position_of(self, target: Target) -> tuple[float, float] | None: ...
    def velocity_of(self, name: str) -> tuple[float, float]: ...
    def body_radius_of(self, name: str) -> float: ...
    def walking_speed(self, index: int, running: bool = False) -> float: ...
    def walk_to(self, index: int, goal: tuple[float, float], speed: float, stop_distance: float,
                *, abort: bool = True, with_group: bool = False) -> str | None: ...
    def standing_at_goal(self, index: int) -> str | None: ...
    def arrived_together(self, index: int, goal: tuple[float, float]) -> None: ...
    def halt(self, index: int) -> None: ...
    def face(self, index: int, heading: float) -> None: ...
    def face_point(self, index: int, point: tuple[float, float]) -> None: ...
    def set_posture(self, index: int, posture: Posture) -> None: ...
    def set_timer(self, index: int, seconds: float) -> None: ...
    def set_timer_tick(self, index: int, tick: int) -> None: ...
    def random_goal(self, index: int, area: Polygon | None) -> tuple[float, float] | None: ...
    def group_goal(self, group: str, leg: int, index: int, area: Polygon | None
                   ) -> tuple[float, float] | None: ...
    def fits(self, index: int, point: tuple[float, float]) -> bool: ...
    def in_sight(self, a: tuple[float, float], b: tuple[float, float]) -> bool: ...
    def finish(self, index: int, status: TaskStatus, reason: str = "") -> None: ...

FACE_REFRESH = 0.2  # s between re-aims at a moving target
GROUP_SPACING = 0.7  # m between neighbours of a group walking abreast
# A group's talking circle (an F-formation)
IN_PLACE = 0.1         # m: a member this near its place on the circle is in it
JOIN_SLACK = 1.0       # s beyond the walk to its place a member takes to reach it
CIRCLE_GAP = 0.4       # m between neighbours' bodies on the circle
CIRCLE_RADIUS = 0.6    # m: the smallest circle, two people about 1.2 m apart (personal distance)
FORMED_DISTANCE = 0.4  # m from the centre at least, for a group already formed
FORMED_SLACK = 0.6     # m beyond its talking circle at most, for a group already formed
FORMED_GAP = math.radians(45.0)  # between neighbours' bearings from the centre, at least


@dataclass(frozen=True, slots=True)
class Timing:
    """How long a task lasts: `duration` seconds, or until stopped from outside (None)."""

    duration: float | None = None


class Behaviour:
    """Base: a task for human `index`. Subclasses override the hooks they need."""

    kind = "idle"
    keeps_posture = False  # starting it does not make a sitting or lying human stand up

    def __init__(self, timing: Timing = Timing()) -> None:
        self.timing = timing
        self.index = -1
        self.state = "pending"

    def start(self, engine: World) -> None:
        self.state = "active"
        self._start_timer(engine)

    def _start_timer(self, engine: World) -> None:
        if self.timing.duration is not None:
            engine.set_timer(self.index, self.timing.duration)

    def on_timer(self, engine: World) -> None:
        engine.finish(self.index, TaskStatus.SUCCEEDED)

    def on_arrived(self, engine: World) -> None:
        """The human came within its stop distance of the goal."""

    def on_aligned(self, engine: World) -> None:
        """The human finished turning to its heading goal."""

    def on_stuck(self, engine: World) -> None:
        engine.finish(self.index, TaskStatus.ABORTED, stuck_reason(engine.stuck_time))

    def on_held_at_goal(self, engine: World, blocker: str) -> None:
        """The human has made no progress for a while near its goal, and someone (`blocker`)
        stands there. Most tasks wait for their stuck time all the same."""


class Stand(Behaviour):
    """Stand still, optionally facing a target (re-aimed while it moves)."""

    kind = "stand"

    def __init__(self, timing: Timing = Timing(), facing: Target | None = None) -> None:
        super().__init__(timing)
        self.facing = facing
        self.deadline: int | None = None

    def start(self, engine: World) -> None:
        engine.halt(self.index)
        self.state = "standing"
        if self.timing.duration is not None:
            self.deadline = engine.tick + engine.ticks(self.timing.duration)
        self._aim(engine)

    def _aim(self, engine: World) -> None:
        if self.facing is not None:
            where = engine.position_of(self.facing)
            if where is None:
                engine.finish(self.index, TaskStatus.ABORTED, f"'{self.facing}' disappeared")
                return
            engine.face_point(self.index, where)
        self._next_wake(engine)

    def _next_wake(self, engine: World) -> None:
        refresh = engine.ticks(FACE_REFRESH) if isinstance(self.facing, str) else None
        candidates = [t for t in (self.deadline, None if refresh is None else engine.tick
                                  + refresh) if t is not None]
        if candidates:
            engine.set_timer_tick(self.index, min(candidates))

    def on_timer(self, engine: World) -> None:
        if self.deadline is not None and engine.tick >= self.deadline:
            engine.finish(self.index, TaskStatus.SUCCEEDED)
        else:
            self._aim(engine)


class Talk(Stand):
    """Stand and face the person spoken to. Told to talk in its own group (the group's name as
    the one spoken to), a member first steps to its place on a circle round the group's
    centre, then faces the centre: an F-formation (Kendon 1990), its o-space the circle's
    inside."""

    kind = "talk"

    def start(self, engine: World) -> None:
        place = self._place_on_circle(engine)
        if place is not None:  # it faces the members' centre as they stand when in place
            way = math.dist(place, engine.humans.position[self.index].tolist())
            speed = engine.walking_speed(self.index)
            if way > IN_PLACE and engine.walk_to(self.index, place, speed, IN_PLACE,
                                                 abort=False) is None:
                self.state = "joining"
                # the others' bodies may keep it short of its place: it talks from where it
                # got to once the way there should have been walked
                joined_by = engine.tick + engine.ticks(way / speed + JOIN_SLACK)
                if self.timing.duration is not None:  # the talk's time runs from its start
                    self.deadline = engine.tick + engine.ticks(self.timing.duration)
                engine.set_timer_tick(self.index, min(joined_by, self.deadline or joined_by))
                return
        super().start(engine)
        self.state = "talking"

    def _place_on_circle(self, engine: World) -> tuple[float, float] | None:
        """This member's place on its group's talking circle; None when it is not told to
        talk in a group of its own, or its place is in a wall."""
        rows = engine.groups.get(self.facing) if isinstance(self.facing, str) else None
        if rows is None or self.index not in rows:
            return None
        h = engine.humans
        if in_formation(h.position[rows], h.radius[rows]):
            return None  # already round their centre (as a scenario placed them): they face it
        places = talking_circle(h.position[rows], h.radius[rows])
        place = places[int(np.flatnonzero(rows == self.index)[0])]
        return place if engine.fits(self.index, place) else None

    def on_arrived(self, engine: World) -> None:
        self._in_place(engine)

    def on_stuck(self, engine: World) -> None:
        self._in_place(engine)  # as near its place as the others let it: it talks from there

    def on_timer(self, engine: World) -> None:
        if self.state == "joining" and (self.deadline is None or engine.tick < self.deadline):
            self._in_place(engine)
            return
        super().on_timer(engine)

    def _in_place(self, engine: World) -> None:
        engine.halt(self.index)
        self.state = "talking"
        self._aim(engine)


def in_formation(position: FloatArray, radius: FloatArray) -> bool:
    """Whether people already stand round their centre, as in an F-formation, open or closed:
    each some way from it but near enough to talk (no farther than the circle they would
    form, and a little), no one behind another (a line, or a group arrived abreast, is not:
    its middle stands on the centre, its ends in line)."""
    centre = position.mean(axis=0)
    offset = position - centre
    distance = np.hypot(offset[:, 0], offset[:, 1])
    farthest = _circle_size(len(position), radius) + FORMED_SLACK
    if (distance < FORMED_DISTANCE).any() or (distance > farthest).any():
        return False
    bearing = np.sort(np.arctan2(offset[:, 1], offset[:, 0]))
    gaps = np.diff(np.append(bearing, bearing[0] + 2.0 * math.pi))
    return bool(gaps.min() >= FORMED_GAP)


def talking_circle(position: FloatArray, radius: FloatArray) -> list[tuple[float, float]]:
    """Places on a circle round the members' centre, evenly spread, each member's in the order
    of their bearings from the centre and turned to be nearest where they stand."""
    count = len(position)
    centre = position.mean(axis=0)
    bearing = np.arctan2(position[:, 1] - centre[1], position[:, 0] - centre[0])
    order = np.argsort(bearing, kind="stable")
    spread = 2.0 * math.pi * np.arange(count) / count
    turn = bearing[order] - spread  # the circle's turn that puts each exactly where it is
    start = math.atan2(float(np.sin(turn).mean()), float(np.cos(turn).mean()))
    size = _circle_size(count, radius)
    angle = np.empty(count)
    angle[order] = start + spread
    places = centre + size * np.column_stack([np.cos(angle), np.sin(angle)])
    return [(float(x), float(y)) for x, y in places]


def _circle_size(count: int, radius: FloatArray) -> float:
    """The radius of the talking circle of `count` people of body radii `radius`: CIRCLE_GAP
    between neighbours' bodies, CIRCLE_RADIUS at least."""
    return max(CIRCLE_RADIUS, (2.0 * float(radius.max()) + CIRCLE_GAP)
               / (2.0 * math.sin(math.pi / count)))


def _place_abreast(engine: World, group: str, index: int, goal: tuple[float, float]
                   ) -> tuple[float, float]:
    """Member `index`'s place at its group's goal: side by side across the way there from the
    members' centre, GROUP_SPACING apart, in the order they stand across that way now (so that
    nobody crosses another's way); the goal itself where that place is in a wall or behind one
    (a door, a corner)."""
    rows = engine.groups.get(group)
    if rows is None or len(rows) < 2 or index not in rows:
        return goal
    position = engine.humans.position[rows]
    centre = position.mean(axis=0)
    length = math.hypot(goal[0] - centre[0], goal[1] - centre[1])
    if length < 1e-9:
        return goal
    across = np.array([centre[1] - goal[1], goal[0] - centre[0]]) / length
    order = np.argsort(position @ across, kind="stable").tolist()
    shift = (order.index(rows.tolist().index(index)) - (len(rows) - 1) / 2) * GROUP_SPACING
    place = (goal[0] + float(across[0]) * shift, goal[1] + float(across[1]) * shift)
    return place if engine.fits(index, place) and engine.in_sight(goal, place) else goal


class MoveTo(Behaviour):
    """Walk to a goal along a global plan; then turn to the heading, if one was asked."""

    kind = "move_to"

    def __init__(self, target: Target, heading: float | None = None, speed: float | None = None,
                 running: bool = False, group: str | None = None,
                 together: bool = False) -> None:
        super().__init__()
        self.target = target
        self.heading = heading
        self.speed = speed
        self.running = running
        self.group = group  # the group whose task this is: its members walk together
        self.together = together  # a crowd's or group's task: the others go there too

    def start(self, engine: World) -> None:
        goal = engine.position_of(self.target)
        if goal is None:
            engine.finish(self.index, TaskStatus.ABORTED, f"'{self.target}' does not exist")
            return
        self.state = "running" if self.running else "walking"
        speed = self.speed or engine.walking_speed(self.index, running=self.running)
        tolerance = engine.humans.goal_tolerance[self.index]
        if isinstance(self.target, str):  # a body: stop beside it, not on it
            tolerance += engine.body_radius_of(self.target) + engine.humans.radius[self.index]
        if self.group is not None and not isinstance(self.target, str):
            place = _place_abreast(engine, self.group, self.index, goal)
            if place != goal and engine.walk_to(self.index, place, speed, float(tolerance),
                                                abort=False, with_group=True) is None:
                return  # else the group's goal itself: its place cannot be planned to
        engine.walk_to(self.index, goal, speed, float(tolerance),
                       with_group=self.group is not None)

    def on_arrived(self, engine: World) -> None:
        if self.heading is None:
            self._succeed(engine)
            return
        self.state = "aligning"
        engine.face(self.index, self.heading)

    def on_aligned(self, engine: World) -> None:
        self._succeed(engine)

    def _succeed(self, engine: World, reason: str = "") -> None:
        """The walk ends here; one of many sent to a point has reached it where it stops."""
        if self.together and not isinstance(self.target, str):
            engine.arrived_together(self.index, self.target)
        engine.finish(self.index, TaskStatus.SUCCEEDED, reason)

    def on_held_at_goal(self, engine: World, blocker: str) -> None:
        # queued behind those standing on the goal: stop there, not after the stuck time
        self._stop_short(engine, blocker)

    def on_stuck(self, engine: World) -> None:
        # a goal others stand on (a counter, a door, a group talking there) is reached as
        # people reach it: as near as those standing there allow, not after pushing through
        blocker = engine.standing_at_goal(self.index)
        if blocker is None:
            super().on_stuck(engine)
        else:
            self._stop_short(engine, blocker)

    def _stop_short(self, engine: World, blocker: str) -> None:
        if self.heading is None:
            self._succeed(engine, f"stopped short of a goal taken by {blocker}")
        else:
            engine.halt(self.index)
            self.on_arrived(engine)


class Posed(MoveTo):
    """sit_down / lie_down: go there (if told where), then hold the posture for the time."""

    def __init__(self, posture: Posture, timing: Timing, at: Target | None,
                 heading: float | None) -> None:
        super().__init__(at or (0.0, 0.0), heading)
        self.kind = "sit_down" if posture is Posture.SITTING else "lie_down"
        self.keeps_posture = at is None  # told where: it stands up and walks there first
        self.posture = posture
        self.timing = timing
        self.at = at

    def start(self, engine: World) -> None:
        if self.at is None:
            self.on_arrived(engine)
        else:
            super().start(engine)

    def on_stuck(self, engine: World) -> None:
        # a seat someone else takes is not taken beside it: stuck, and who sits there said
        engine.finish(self.index, TaskStatus.ABORTED,
                      stuck_reason(engine.stuck_time, engine.standing_at_goal(self.index)))

    def on_held_at_goal(self, engine: World, blocker: str) -> None:
        Behaviour.on_held_at_goal(self, engine, blocker)  # a taken seat: its stuck time

    def on_arrived(self, engine: World) -> None:
        if self.heading is not None and self.state != "aligning":
            self.state = "aligning"
            engine.face(self.index, self.heading)
            return
        self._take_posture(engine)

    def on_aligned(self, engine: World) -> None:
        self._take_posture(engine)

    def _take_posture(self, engine: World) -> None:
        engine.halt(self.index)
        engine.set_posture(self.index, self.posture)
        self.state = "sitting" if self.posture is Posture.SITTING else "lying"
        self._start_timer(engine)


class MoveAround(Behaviour):
    """Wander: random reachable goals inside an area, drawn from the run's seed."""

    kind = "move_around"

    def __init__(self, timing: Timing, area: Polygon | None, times: int | None,
                 group: str | None = None) -> None:
        super().__init__(timing)
        self.area = area
        self.times = times
        self.reached = 0
        self.group = group  # a group's stroll: its members share each goal, walking abreast
        self.leg = 0        # goals drawn so far

    def start(self, engine: World) -> None:
        self._start_timer(engine)
        self._next_goal(engine)

    def _next_goal(self, engine: World) -> None:
        goal = engine.random_goal(self.index, self.area) if self.group is None else \
            engine.group_goal(self.group, self.leg, self.index, self.area)
        self.leg += 1
        if goal is None:
            engine.finish(self.index, TaskStatus.ABORTED,
                          "no reachable free point in the area to walk to")
            return
        self.state = "wandering"
        speed = engine.walking_speed(self.index)
        tolerance = float(engine.humans.goal_tolerance[self.index])
        if self.group is not None:  # its place beside the others, as a group's move_to
            place = _place_abreast(engine, self.group, self.index, goal)
            if place != goal and engine.walk_to(self.index, place, speed, tolerance,
                                                abort=False, with_group=True) is None:
                return
        engine.walk_to(self.index, goal, speed, tolerance, with_group=self.group is not None)

    def on_arrived(self, engine: World) -> None:
        self.reached += 1
        if self.times is not None and self.reached >= self.times:
            engine.finish(self.index, TaskStatus.SUCCEEDED)
        else:
            self._next_goal(engine)

    def on_held_at_goal(self, engine: World, blocker: str) -> None:
        if self.group is not None:  # a companion stands on the shared goal: as good as there
            self.on_arrived(engine)
        else:  # someone stands on the spot it drew: wander elsewhere, not push for it
            self._next_goal(engine)

    def on_stuck(self, engine: World) -> None:
        self._next_goal(engine)  # wandering has no fixed goal: pick another one


class Follow(Behaviour):
    """Follow a human or robot at a distance, re-planning every `follow_replan`."""

    kind = "follow"

    def __init__(self, timing: Timing, target: str, distance: float) -> None:
        super().__init__(timing)
        self.target = target
        self.distance = distance
        self.deadline: int | None = None

    def start(self, engine: World) -> None:
        if self.timing.duration is not None:
            self.deadline = engine.tick + engine.ticks(self.timing.duration)
        self._replan(engine)

    def _replan(self, engine: World) -> None:
        where = engine.position_of(self.target)
        if where is None:
            engine.finish(self.index, TaskStatus.ABORTED, f"target '{self.target}' disappeared")
            return
        here = engine.humans.position[self.index]
        gap = float(np.hypot(where[0] - here[0], where[1] - here[1]))
        walking = math.hypot(*engine.velocity_of(self.target)) > STILL
        if gap <= self.distance + engine.humans.goal_tolerance[self.index] and not walking:
            self.state = "waiting"      # close to a target standing still: wait, facing it
            engine.halt(self.index)
            engine.face_point(self.index, where)
        else:
            self.state = "following"
            reason = engine.walk_to(self.index, self._ahead(engine, where),
                                    engine.walking_speed(self.index), self.distance, abort=False)
            if reason is not None:      # the target stands where we cannot go: wait
                self.state = "waiting"
                engine.halt(self.index)
        # waiting, it looks again soon: a target that walks on is followed at once, not a
        # re-plan later and as far behind as it walked meanwhile
        again = FACE_REFRESH if self.state == "waiting" else float(
            engine.follow_replan[self.index])
        self._wake_in(engine, again)

    def _wake_in(self, engine: World, seconds: float) -> None:
        wake = engine.tick + max(1, engine.ticks(seconds))
        engine.set_timer_tick(self.index, wake if self.deadline is None
                              else min(wake, self.deadline))

    def _ahead(self, engine: World, where: tuple[float, float]) -> tuple[float, float]:
        """Where the target will be at the next re-plan, if it goes on as it goes (and a body
        fits there): walking to where it was, one trails it by the distance it walks in
        between, a metre at 1 m/s re-planned every second."""
        vx, vy = engine.velocity_of(self.target)
        lead = float(engine.follow_replan[self.index])
        ahead = (where[0] + vx * lead, where[1] + vy * lead)
        return ahead if engine.fits(self.index, ahead) else where

    def on_timer(self, engine: World) -> None:
        if self.deadline is not None and engine.tick >= self.deadline:
            engine.finish(self.index, TaskStatus.SUCCEEDED)
        else:
            self._replan(engine)

    def on_arrived(self, engine: World) -> None:
        self.state = "waiting"
        engine.halt(self.index)
        self._wake_in(engine, FACE_REFRESH)

    def on_stuck(self, engine: World) -> None:
        self.state = "waiting"
        engine.halt(self.index)


class Teleop(Behaviour):
    """Velocity comes from the Python API (`HumanHandle.set_velocity`)."""

    kind = "teleop"

    def start(self, engine: World) -> None:
        engine.halt(self.index)
        engine.humans.teleop[self.index] = True
        self.state = "teleoperated"
        self._start_timer(engine)


BehaviourFactory = Callable[[Task], Behaviour]
BEHAVIOURS: dict[str, BehaviourFactory] = {}


def builds(kind: str) -> Callable[[BehaviourFactory], BehaviourFactory]:
    """Register the function that builds the behaviour of task kind `kind`."""
    def register(factory: BehaviourFactory) -> BehaviourFactory:
        BEHAVIOURS[kind] = factory
        return factory
    return register


@builds("stand")
def _stand(task: Task) -> Behaviour:
    return Stand(Timing(task.get("duration")), task.get("facing"))


@builds("move_to")
def _move_to(task: Task) -> Behaviour:
    assert task.target is not None
    return MoveTo(task.target, task.get("heading"), task.get("speed"),
                  group=task.group, together=task.together)


@builds("run_to")
def _run_to(task: Task) -> Behaviour:
    assert task.target is not None
    behaviour = MoveTo(task.target, task.get("heading"), running=True,
                       group=task.group, together=task.together)
    behaviour.kind = "run_to"
    return behaviour


@builds("move_around")
def _move_around(task: Task) -> Behaviour:
    return MoveAround(Timing(task.get("duration")), task.get("area"), task.get("times"),
                      group=task.group)


@builds("follow")
def _follow(task: Task) -> Behaviour:
    assert isinstance(task.target, str)
    return Follow(Timing(task.get("duration")), task.target, task.get("distance"))


@builds("talk")
def _talk(task: Task) -> Behaviour:
    return Talk(Timing(task.get("duration")), task.get("to"))


@builds("sit_down")
def _sit_down(task: Task) -> Behaviour:
    return Posed(Posture.SITTING, Timing(task.get("duration")), task.get("at"),
                 task.get("heading"))


@builds("lie_down")
def _lie_down(task: Task) -> Behaviour:
    return Posed(Posture.LYING, Timing(task.get("duration")), task.get("at"),
                 task.get("heading"))


@builds("teleop")
def _teleop(task: Task) -> Behaviour:
    return Teleop(Timing(task.get("duration")))


def heading_towards(origin: np.ndarray, point: tuple[float, float]) -> float:
    return math.atan2(point[1] - float(origin[1]), point[0] - float(origin[0]))
