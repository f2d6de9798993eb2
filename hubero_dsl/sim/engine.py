"""The engine: the world's state, and the services behaviours use to command humans.

A tick is array work, split in three so that a vector environment can do each part for all its
copies at once: robots advance, every walking human's next waypoint is found and what the
local planners are to be asked is gathered (`Lockstep.begin_step`, then `Engine.steering`);
the local planners turn targets into velocities (`steer`, all humans of a planner at once);
bodies move, are kept apart and out of walls, and turn, then events (arrived, aligned, timer,
stuck) are detected with array comparisons, and only the humans with an event wake their
behaviour (`Lockstep.end_step`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from scipy.spatial import cKDTree

from hubero_dsl.errors import MapError, SimulationError
from hubero_dsl.planners.base import Crowd, Drive, NoPath
from hubero_dsl.sim import physics
from hubero_dsl.sim.arrays import BoolArray, FloatArray, HumanArrays, IntArray, PathPool
from hubero_dsl.sim.behaviours import GROUP_SPACING, Behaviour
from hubero_dsl.sim.reactions import Reactions
from hubero_dsl.sim.right_of_way import RightOfWay
from hubero_dsl.sim.robots import Robots
from hubero_dsl.sim.status import Posture, TaskEvent, TaskHandle, TaskStatus
from hubero_dsl.sim.ways_round import WaysRound
from hubero_dsl.world.grid import REACH_MARGIN
from hubero_dsl.world.shapes import ShapeArrays, lateral_extent

if TYPE_CHECKING:
    from shapely.geometry import Polygon

    from hubero_dsl.model.tasks import Task
    from hubero_dsl.planners.base import GlobalPlanner, LocalPlanner
    from hubero_dsl.world.grid import OccupancyGrid

NEVER = np.iinfo(np.int64).max
LOOKAHEAD = 0.6         # m: a waypoint this close counts as passed
SQUEEZE = 0.2           # of its social push a walker keeps, squeezing past people standing
SQUEEZE_CLEAR = 2.0     # m from a robot (centre to centre) within which it keeps all of it
GROUP_PULL = 3.0        # 1/s: m/s towards the group's centre per metre too far from it
# Members walking on their group's task keep abreast (`Engine._walk_abreast`)
ABREAST_LANE = 0.6      # m across the group's way at least: a companion in the next lane
ABREAST_CLOSE = 1.0     # s over which a lead is closed
ABREAST_SLOWEST = 0.2   # of its desired speed, the slowest one waiting walks
ABREAST_ROOM = 1.0      # m further on where there must still be room for two
ABREAST_WAKE = 1.5      # m: closer than this behind a companion in its lane, one is held up
ABREAST_ARRIVING = 0.5  # m from its place: one there walks on to it rather than wait
ABREAST_ONE_WAY = 0.8   # the mean of the members' unit ways at least this long: one way
STAYING_TASKS = frozenset({"stand", "talk"})  # tasks after which one is still where one arrived
MOVING_ROBOT_TASKS = frozenset({"move_to", "follow"})  # a robot on these is on its way
WAY_MARGIN = 0.1        # m off walls beyond the body, for a member to walk straight on
SEE_PAST_EVERY = 0.25   # s between looks past a group walker's next waypoint
GIVING_WAY = "giving_way"   # the state of a walker waiting for its turn in a jam


@dataclass(frozen=True, slots=True)
class Part:
    """Humans one local planner steers this tick: their Crowd rows and what they want."""

    planner: str
    rows: IntArray
    drive: Drive


@dataclass(frozen=True, slots=True)
class Steering:
    """What a tick asks of the local planners: everyone as a Crowd, and who each steers."""

    crowd: Crowd | None  # None: not gathered (`JointSteering` stacks the engines' bodies)
    parts: list[Part]


class Engine:
    """Owns the arrays and advances them tick by tick. Deterministic: no clock, seeded draws."""

    def __init__(self, *, grid: OccupancyGrid, humans: HumanArrays, robots: Robots, dt: float,
                 global_planners: list[GlobalPlanner], local_planners: dict[str, LocalPlanner],
                 local_planner_of: list[str], follow_replan: FloatArray,
                 rng_for: Callable[[str, int], np.random.Generator],
                 stuck_time: float = 20.0,
                 groups: Mapping[str, IntArray] | None = None) -> None:
        self.grid = grid
        self.humans = humans
        self.robots = robots
        self.dt = dt
        self.tick = 0
        self.stuck_time = stuck_time
        self.follow_replan = follow_replan
        self._global = global_planners            # one per human (shared instances)
        self._local = local_planners              # by name
        self._local_mask = {name: np.array([n == name for n in local_planner_of], dtype=bool)
                            for name in sorted(local_planners)}
        # the common case: one local planner steers everyone, so no mask is needed
        self._only_local = (local_planner_of[0] if len(set(local_planner_of)) == 1
                            and local_planner_of[0] in local_planners else None)
        self._not_robot = np.zeros(humans.count, dtype=bool)
        self._not_robot.setflags(write=False)
        self._crowd_shapes: tuple[ShapeArrays, ShapeArrays, ShapeArrays] | None = None
        self._separation = physics.BodySeparation()
        self.groups = dict(groups or {})  # a group's name -> its members' rows
        self._reactions = (Reactions(humans.reaction, dt) if humans.reaction is not None
                           else None)
        self._rng_for = rng_for
        self._rngs: dict[tuple[str, int], np.random.Generator] = {}
        count = humans.count
        self.paths = PathPool(count)
        self.behaviour: list[Behaviour | None] = [None] * count
        self.handle: list[TaskHandle | None] = [None] * count
        self.wake_tick = np.full(count, NEVER, dtype=np.int64)
        self.anchor = humans.position.copy()
        self.anchor_tick = np.zeros(count, dtype=np.int64)
        self.squeeze_until = np.zeros(count, dtype=np.int64)  # `squeeze_round_standing`
        self._squeezes_end = 0  # the tick the last squeeze under way ends
        self.events: list[TaskEvent] = []
        self.listeners: list[Callable[[TaskEvent], None]] = []
        self._goal_cells: dict[tuple[int, bytes], IntArray] = {}
        self.removed: set[str] = set()
        # a crowd's or group's member -> the point they were sent to together, where its walk
        # succeeded: it counts as having reached it (conditions' `reaches`) until it is given
        # a task that is neither `stand` nor `talk`
        self.together_at: dict[int, tuple[float, float]] = {}
        self._group_goals: dict[tuple[str, int], tuple[float, float] | None] = {}
        self._gathered_tick = -1  # `_gathered_round`'s answers, for this tick only
        self._gathered: dict[tuple[tuple[float, float], bytes], BoolArray] = {}
        self.ways_round = WaysRound(self, LOOKAHEAD)  # for walkers held up near walls
        self.right_of_way = RightOfWay(self)  # for streams jammed head-on
        self._look_again = max(1, self.ticks(SEE_PAST_EVERY))
        self._row_of = {name: row for row, name in enumerate(humans.names)}

    # ---- time ----------------------------------------------------------------------------

    @property
    def time(self) -> float:
        return self.tick * self.dt

    def ticks(self, seconds: float) -> int:
        return max(0, round(seconds / self.dt))

    # ---- services for behaviours ---------------------------------------------------------

    def index_of(self, name: str) -> int:
        return self._row_of[name]

    def position_of(self, target: tuple[float, float] | str) -> tuple[float, float] | None:
        if not isinstance(target, str):
            return (float(target[0]), float(target[1]))
        if target in self.removed:
            return None
        row = self._row_of.get(target)
        if row is not None:
            x, y = self.humans.position[row].tolist()  # floats, without numpy's scalars
            return (x, y)
        if target in self.groups:  # a group's centre: where its members face when talking
            x, y = self.humans.position[self.groups[target]].mean(axis=0)
            return (float(x), float(y))
        return self.robots.position_of(target)

    def velocity_of(self, name: str) -> tuple[float, float]:
        """How a human, a group (its members' mean) or a robot moves now; (0, 0) for anyone
        else."""
        row = self._row_of.get(name)
        if row is not None and name not in self.removed:
            vx, vy = self.humans.velocity[row].tolist()
            return (vx, vy)
        if name in self.groups:
            vx, vy = self.humans.velocity[self.groups[name]].mean(axis=0)
            return (float(vx), float(vy))
        if name in self.robots.names:
            vx, vy = self.robots.velocity[self.robots.index_of(name)]
            return (float(vx), float(vy))
        return (0.0, 0.0)

    def locator(self, target: tuple[float, float] | str
                ) -> Callable[[], tuple[float, float] | None]:
        """`position_of(target)` as a function, a human's row found once (a condition asks
        where someone is every tick)."""
        row = self._row_of.get(target) if isinstance(target, str) else None
        if row is None:
            return lambda: self.position_of(target)

        def human() -> tuple[float, float] | None:
            if target in self.removed:
                return None
            x, y = self.humans.position[row].tolist()
            return (x, y)
        return human

    def goal_tolerance_of(self, name: str) -> float:
        """How close `name` must come to a target to have reached it."""
        if name in self._row_of:
            return float(self.humans.goal_tolerance[self._row_of[name]])
        if name in self.robots.names:
            return self.robots.specs[self.robots.index_of(name)].goal_tolerance
        return 0.0

    def body_radius_of(self, name: str) -> float:
        if name in self._row_of:
            return float(self.humans.radius[self._row_of[name]])
        return self.robots.radius_of(name)

    def walking_speed(self, index: int, running: bool = False) -> float:
        source = self.humans.run_speed if running else self.humans.speed
        return float(source[index])

    def walk_to(self, index: int, goal: tuple[float, float], speed: float, stop_distance: float,
                *, abort: bool = True, with_group: bool = False) -> str | None:
        """Plan and start walking; on failure abort the task (or just return the reason)."""
        humans = self.humans
        reason = self.plan_path(index, goal)
        if reason is not None:
            if abort:
                self.finish(index, TaskStatus.ABORTED, reason)
            return reason
        humans.moving[index] = True
        self.squeeze_until[index] = 0  # a new walk is not squeezing past anyone yet
        humans.with_group[index] = with_group
        humans.teleop[index] = False
        humans.desired_speed[index] = speed
        humans.goal[index] = goal
        humans.stop_distance[index] = stop_distance
        humans.heading_goal[index] = np.nan
        self.anchor[index] = humans.position[index]
        self.anchor_tick[index] = self.tick
        return None

    def plan_to_goal(self, index: int) -> str | None:
        """A new path for walker `index` from where it stands to its goal (None, as when it
        has no goal), or why there is none."""
        goal = self.humans.goal[index]
        if not np.isfinite(goal).all():
            return None
        return self.plan_path(index, (float(goal[0]), float(goal[1])))

    def squeeze_round_standing(self, index: int, reach: float, seconds: float) -> bool:
        """Walker `index`, hemmed in by bodies standing still (within `reach` m of its own,
        surface to surface), gets a new path to its goal round them, as if they were walls,
        and for `seconds` keeps SQUEEZE of its social push from others: with all of it, the
        personal spaces of a group that stopped round it to talk held it where it stood, a
        way between them or not. False, and nothing changed, when nobody stands so near or
        no such way leads to its goal."""
        from hubero_dsl.planners.navfn import plan_round_discs

        h = self.humans
        goal = h.goal[index]
        if not np.isfinite(goal).all():
            return False
        _, position, radius, still = self._bodies_at_rest()
        here = h.position[index]
        near = still & (physics.lengths(position - here) - radius - h.radius[index] < reach)
        near[index] = False
        if not near.any():
            return False
        waypoints = plan_round_discs(
            self.grid, position[near], radius[near], (float(here[0]), float(here[1])),
            (float(goal[0]), float(goal[1])), body_radius=float(h.radius[index]),
            comfort_radius=float(h.radius[index]))
        if waypoints is None:
            return False
        self.paths.set_path(index, waypoints)
        self.squeeze_until[index] = self.tick + self.ticks(seconds)
        self._squeezes_end = max(self._squeezes_end, int(self.squeeze_until[index]))
        return True

    def plan_path(self, index: int, goal: tuple[float, float],
              via: tuple[float, float] | None = None) -> str | None:
        """A new path for walker `index` from where it stands (by way of `via`) to `goal`
        (None), or why there is none."""
        humans = self.humans
        here = (float(humans.position[index, 0]), float(humans.position[index, 1]))
        try:
            plan = self._global[index].plan(
                via or here, goal, body_radius=float(humans.radius[index]),
                comfort_radius=lateral_extent(humans.shapes[index]))
        except NoPath as exc:
            return exc.reason
        self.paths.set_path(index, plan.waypoints if via is None
                            else np.concatenate([[here], plan.waypoints]))
        return None

    def hold_short(self, index: int, stalled: BoolArray | None = None) -> None:
        """Walker `index`, stalled near its goal: its task is told when someone stands there
        (`stalled`: the walkers who have made no progress either; those of them sent to the
        same point, within SAME_GOAL, count as standing)."""
        behaviour = self.behaviour[index]
        if behaviour is None:
            return
        if stalled is not None:  # those sent to its own point, not itself
            h = self.humans
            stalled = stalled & (physics.lengths(h.goal - h.goal[index]) <= physics.SAME_GOAL)
            stalled[index] = False
        if blocker := self.standing_at_goal(index, stalled):
            behaviour.on_held_at_goal(self, blocker)

    def standing_at_goal(self, index: int, stalled: BoolArray | None = None) -> str | None:
        """`standing_at` for walker `index` and its goal (None when it has none), queues
        behind those standing there included."""
        h = self.humans
        goal = h.goal[index]
        if not np.isfinite(goal).all():
            return None
        return self.standing_at((float(goal[0]), float(goal[1])), h.position[index],
                                float(h.stop_distance[index]), float(h.radius[index]), stalled)

    def standing_at(self, goal: tuple[float, float], here: FloatArray, stop_distance: float,
                    radius: float | None = None, stalled: BoolArray | None = None
                    ) -> str | None:
        """Who stands between a body at `here` and its `goal`: within CROWDED_GOAL (beyond
        `stop_distance`) of it, the body standing still (a human not walking, a robot at rest)
        nearest to the goal and nearer to it than `here`; farther, given the body's `radius`,
        the one it queues behind: nearer the goal, within QUEUE_GAP of it, and gathered round
        the goal (`physics.gathered_round`); near it, nobody nearer, given `radius`, someone
        standing in the ring who keeps it off the goal, within PRESSED_GAP of it. The humans
        of `stalled`, walkers who make no progress, count as standing: two sent to one point
        push each other off it for good, each walking, and the one further from it is the one
        to stop short (then the nearer one the one kept off)."""
        than = math.dist(here, goal)
        queued = than > physics.CROWDED_GOAL + stop_distance
        if queued and radius is None:
            return None
        names, position, size, still = self._bodies_at_rest()
        if stalled is not None:
            still = still.copy()
            still[:len(stalled)] |= stalled
        distance = physics.lengths(position - np.asarray(goal))
        ahead = still & (distance < than)
        if queued and ahead.any():
            gap = physics.lengths(position - here) - size - (radius or 0.0)
            ahead &= gap <= physics.QUEUE_GAP
            if ahead.any():
                ahead &= self._gathered_round(goal, position, size, still)
        elif not queued and radius is not None and not ahead.any():
            # nearest of all, but kept off the goal by someone standing beside it, in the
            # goal's ring too: as near as those standing there allow
            gap = physics.lengths(position - here) - size - radius
            ahead = still & (distance <= physics.CROWDED_GOAL + stop_distance) \
                & (gap <= physics.PRESSED_GAP)
        rows = ahead.nonzero()[0]
        if not len(rows):
            return None
        return names[int(rows[np.argmin(distance[rows])])]

    def _gathered_round(self, goal: tuple[float, float], position: FloatArray,
                        radius: FloatArray, still: BoolArray) -> BoolArray:
        """`physics.gathered_round`, once a tick for a goal and who stands still: every
        walker queued for one goal asks it, and within a tick nobody moves (one who stops
        short changes who stands still, and so the answer)."""
        key = (goal, np.packbits(still).tobytes())
        if self._gathered_tick != self.tick:
            self._gathered_tick, self._gathered = self.tick, {}
        if key not in self._gathered:
            self._gathered[key] = physics.gathered_round(goal, position, radius, still)
        return self._gathered[key]

    def at_rest_beside(self, rows: IntArray, gap: float) -> BoolArray:
        """Which humans of `rows` have a body at rest (`_bodies_at_rest`) within `gap` of
        theirs, surface to surface."""
        _, position, radius, still = self._bodies_at_rest()
        beside = np.zeros(len(rows), dtype=bool)
        if not still.any():
            return beside
        reach = float(self.humans.radius[rows].max()) + float(radius[still].max()) + gap
        near = cKDTree(position[still]).query_ball_point(self.humans.position[rows], reach)
        here, own = self.humans.position[rows], self.humans.radius[rows]
        at, size = position[still], radius[still]
        for k, found in enumerate(near):
            if found:
                surface = physics.lengths(at[found] - here[k]) - size[found] - own[k]
                beside[k] = bool((surface <= gap).any())
        return beside

    def _bodies_at_rest(self) -> tuple[list[str], FloatArray, FloatArray, BoolArray]:
        """Every body's name, position and radius, humans' then robots', and which stand still
        (a human present and not walking, a robot at rest and not on its way somewhere: one
        that waits or yields to pass is no one gathered round a goal)."""
        h = self.humans
        names, position, radius, still = list(h.names), h.position, h.radius, ~h.moving
        if h.present is not None:
            still &= h.present
        if self.robots.count:
            r = self.robots
            names += r.names
            position = np.concatenate([position, r.position])
            radius = np.concatenate([radius, r.radius])
            still = np.concatenate([still, self._robots_at_rest()])
        return names, position, radius, still

    def _robots_at_rest(self) -> BoolArray:
        """Which robots stand still: at rest and not on their way somewhere (one that waits
        or yields to pass is on its way)."""
        r = self.robots
        settled = [task is None or task.task.kind not in MOVING_ROBOT_TASKS for task in r.tasks]
        return (physics.lengths(r.velocity) < physics.STILL) & np.asarray(settled, dtype=bool)

    def arrived_together(self, index: int, goal: tuple[float, float]) -> None:
        """Human `index`, sent to `goal` with its crowd or group, stopped where the others let
        it (its place abreast, short of those standing there): it has reached `goal`."""
        self.together_at[index] = goal

    def fits(self, index: int, point: tuple[float, float]) -> bool:
        """Whether human `index`'s body fits at `point`, clear of walls."""
        return self.grid.clearance_at_point(*point) > float(self.humans.radius[index])

    def _way_clear(self, here: FloatArray, there: FloatArray, rows: IntArray) -> BoolArray:
        """Where the straight way from `here` to `there` keeps the bodies of humans `rows`
        (each with its planning margin) off walls, sampled every half cell."""
        fractions = np.asarray(self.grid.segment_fractions(
            float(physics.lengths(there - here).max(initial=0.0))))
        points = here[:, None, :] + (there - here)[:, None, :] * fractions[None, :, None]
        clearance = self.grid.clearance_at(points.reshape(-1, 2)).reshape(len(rows), -1)
        room = self.humans.radius[rows] + WAY_MARGIN
        clear: BoolArray = np.all(clearance >= room[:, None], axis=1)
        return clear

    def in_sight(self, a: tuple[float, float], b: tuple[float, float]) -> bool:
        """Whether no wall stands on the straight line from `a` to `b`."""
        return not bool(self.grid.crosses_obstacle(np.array([a]), np.array([b]))[0])

    def fsm_states(self) -> list[str]:
        """Every human's behaviour state ('walking', 'talking', ...; 'idle' without a task),
        'giving_way' while waiting for its turn in a jam (`right_of_way`)."""
        states = [_state_of(b) for b in self.behaviour]
        for row in self.right_of_way.waiting:
            states[row] = GIVING_WAY
        return states

    def fsm_state(self, index: int) -> str:
        """`fsm_states` of human `index` alone."""
        if index in self.right_of_way.waiting:
            return GIVING_WAY
        return _state_of(self.behaviour[index])

    def halt(self, index: int) -> None:
        humans = self.humans
        humans.moving[index] = False
        humans.teleop[index] = False
        humans.goal[index] = np.nan
        self.paths.clear(index)

    def face(self, index: int, heading: float) -> None:
        self.humans.heading_goal[index] = heading

    def face_point(self, index: int, point: tuple[float, float]) -> None:
        x, y = self.humans.position[index]
        if math.hypot(point[0] - x, point[1] - y) > 1e-6:
            self.face(index, math.atan2(point[1] - y, point[0] - x))

    def set_posture(self, index: int, posture: Posture) -> None:
        self.humans.posture[index] = posture

    def set_timer(self, index: int, seconds: float) -> None:
        self.set_timer_tick(index, self.tick + max(1, self.ticks(seconds)))

    def set_timer_tick(self, index: int, tick: int) -> None:
        self.wake_tick[index] = tick

    def rng(self, purpose: str, index: int) -> np.random.Generator:
        """The human's own random stream for `purpose`: created once, then drawn from, so
        every draw is new and the sequence depends only on the seed and the human's name."""
        key = (purpose, index)
        if key not in self._rngs:
            self._rngs[key] = self._rng_for(purpose, index)
        return self._rngs[key]

    def group_goal(self, group: str, leg: int, index: int, area: Polygon | None
                   ) -> tuple[float, float] | None:
        """Leg `leg` of group `group`'s wander: drawn by the first member who needs it (its
        `random_goal`), then the same for every member, so that they stroll together."""
        key = (group, leg)
        if key not in self._group_goals:
            self._group_goals[key] = self.random_goal(index, area)
        return self._group_goals[key]

    def random_goal(self, index: int, area: Polygon | None) -> tuple[float, float] | None:
        """A random free point the human can reach, inside `area` (if given)."""
        cells = self._reachable_cells(index, area)
        if len(cells) == 0:
            return None
        pick = cells[int(self.rng("move_around", index).integers(len(cells)))]
        x, y = self.grid.cell_to_world(pick)
        return (float(x), float(y))

    def _reachable_cells(self, index: int, area: Polygon | None) -> IntArray:
        """Free cells reachable from the human (inside `area`), cached per region and area:
        every wanderer of a run draws from the same few arrays."""
        radius = float(self.humans.radius[index]) + REACH_MARGIN
        position = (float(self.humans.position[index, 0]), float(self.humans.position[index, 1]))
        try:
            # someone standing close to a wall is nearer to it than the margin reachable cells
            # keep: they draw from the region of the nearest cell that keeps it
            start, _ = self.grid.nearest_free(position, radius)
        except MapError:
            return np.zeros((0, 2), dtype=np.intp)
        reachable = self.grid.reachable_mask(start, radius)
        key = (id(reachable), area.wkb if area is not None else b"")
        cells = self._goal_cells.get(key)
        if cells is None:
            mask = reachable if area is None else reachable & self._area_mask(area)
            cells = np.argwhere(mask)
            self._goal_cells[key] = cells
        return cells

    def _area_mask(self, area: Polygon) -> np.ndarray:
        """The grid cells whose centres lie in `area` (tested only inside its bounding box)."""
        import shapely

        mask = np.zeros(self.grid.shape, dtype=bool)
        xmin, ymin, xmax, ymax = area.bounds
        (r0, c0), (r1, c1) = self.grid.world_to_cell([(xmin, ymin), (xmax, ymax)])
        r0, c0 = max(r0, 0), max(c0, 0)
        r1, c1 = min(r1, mask.shape[0] - 1), min(c1, mask.shape[1] - 1)
        if r1 < r0 or c1 < c0:
            return mask
        rows, cols = np.mgrid[r0:r1 + 1, c0:c1 + 1]
        centres = self.grid.cell_to_world(np.stack([rows.ravel(), cols.ravel()], axis=1))
        inside = shapely.contains_xy(area, centres[:, 0], centres[:, 1])
        mask[r0:r1 + 1, c0:c1 + 1] = inside.reshape(rows.shape)
        return mask

    # ---- commanding ----------------------------------------------------------------------

    def command(self, index: int, behaviour: Behaviour, handle: TaskHandle) -> None:
        """Give human `index` a new task, preempting the one it has."""
        current = self.handle[index]
        if current is not None and not current.done:
            self.finish(index, TaskStatus.PREEMPTED, f"replaced by {handle.kind}")
        if not behaviour.keeps_posture:
            self.humans.posture[index] = Posture.STANDING
        if behaviour.kind not in STAYING_TASKS:
            self.together_at.pop(index, None)
        behaviour.index = index
        self.behaviour[index] = behaviour
        self.handle[index] = handle
        self._set_status(handle, TaskStatus.ACTIVE, "")
        behaviour.start(self)

    def finish(self, index: int, status: TaskStatus, reason: str = "") -> None:
        handle = self.handle[index]
        if handle is None or handle.done:
            return
        self.behaviour[index] = None
        self.handle[index] = None
        self.halt(index)
        self.humans.heading_goal[index] = np.nan
        self.wake_tick[index] = NEVER
        self._set_status(handle, status, reason)

    def cancel(self, handle: TaskHandle, reason: str = "cancelled") -> None:
        self.abort(handle, reason, TaskStatus.PREEMPTED)

    def abort(self, handle: TaskHandle, reason: str,
              status: TaskStatus = TaskStatus.ABORTED) -> None:
        """End `handle`'s task (a human's or a robot's) if it is still the actor's current one."""
        actor = handle.human
        if actor in self._row_of:
            index = self._row_of[actor]
            if self.handle[index] is handle:
                self.finish(index, status, reason)
        elif actor in self.robots.names:
            current = self.robots.current(actor)
            if current is not None and current.handle is handle:
                self.finish_robot(actor, status, reason)

    # ---- robots' tasks -------------------------------------------------------------------

    def command_robot(self, index: int, task: Task, handle: TaskHandle) -> None:
        """Give robot `index` a new task, preempting the one it has."""
        name = self.robots.names[index]
        current = self.robots.current(name)
        if current is not None:
            self.finish_robot(name, TaskStatus.PREEMPTED, f"replaced by {handle.kind}")
        self.robots.start(name, task, handle, self.tick, self.dt, self.body_radius_of)
        self._set_status(handle, TaskStatus.ACTIVE, "")

    def finish_robot(self, name: str, status: TaskStatus, reason: str = "") -> None:
        current = self.robots.current(name)
        if current is None:
            return
        self.robots.clear(name)
        self._set_status(current.handle, status, reason)

    def _set_status(self, handle: TaskHandle, status: TaskStatus, reason: str) -> None:
        handle.status = status
        handle.reason = reason
        if status is TaskStatus.ACTIVE:
            handle.started_at = self.time
        elif status.is_final:
            handle.ended_at = self.time
        event = TaskEvent(self.tick, self.time, handle.task_id, handle.human, handle.kind,
                          status, reason, handle.span)
        self.events.append(event)
        for listener in self.listeners:
            listener(event)
        handle._notify()

    # ---- one tick ------------------------------------------------------------------------

    def steering(self, crowd: bool = True) -> Steering | None:
        """A tick's first part once the robots have moved (`Lockstep.begin_step`): walkers
        pass their waypoints, and what the local planners are to be asked is gathered (None:
        nobody walks), everyone as a Crowd unless `crowd` is False. `steer` asks them, and
        `Lockstep.end_step` moves everyone."""
        humans = self.humans
        self._gathered_tick = -1  # the robots have moved since the tick's end looked
        rows = humans.moving.nonzero()[0]
        if not len(rows):
            return None
        self.paths.advance(humans.position, LOOKAHEAD, self.grid.crosses_obstacle)
        if self.groups and not self.tick % self._look_again:
            # kept together, members leave their own plans' lines: a look now and then
            self.paths.see_past(rows[humans.with_group[rows]], humans.position, self._way_clear)
        self.ways_round.look(rows)
        self.right_of_way.look(rows)
        if self._only_local is not None:
            parts = [(self._only_local, rows)]
        else:
            parts = [(name, (mask & humans.moving).nonzero()[0])
                     for name, mask in self._local_mask.items()]
        return Steering(self.crowd() if crowd else None, [Part(name, steer, self._drive(steer))
                                       for name, steer in parts if len(steer)])

    def steer(self, steering: Steering | None) -> list[FloatArray]:
        """The local planners' velocities for each part of `steering`."""
        if steering is None:
            return []
        crowd = steering.crowd if steering.crowd is not None else self.crowd()
        return [self._local[part.planner].velocities(crowd, part.drive, self.dt)
                for part in steering.parts]

    def local_planner(self, name: str) -> LocalPlanner:
        return self._local[name]

    def diverged(self, moved: FloatArray) -> None:
        """Raise for the humans whose position `moved` is not a finite number: an error of the
        run (the parameters drove the model out of range), never written to the log as a
        jump."""
        bad = [self.humans.names[i] for i in np.flatnonzero(~np.isfinite(moved).all(axis=1))]
        shown = ", ".join(bad[:5]) + (f" and {len(bad) - 5} more" if len(bad) > 5 else "")
        raise SimulationError(
            f"the simulation diverged at t = {self.time + self.dt:g} s: the position of {shown} "
            "is not a finite number (check the force parameters and the step)")

    def velocities(self, steering: Steering | None, steered: list[FloatArray]) -> FloatArray:
        """Every human's velocity this tick: the local planners' answers (`steered`, one per
        part of `steering`) kept together in groups and adjusted to robots, teleoperation's
        where it drives, zero for the others."""
        humans = self.humans
        velocity = np.zeros(humans.velocity.shape)
        if steering is not None:
            for part, part_velocity in zip(steering.parts, steered, strict=True):
                velocity[part.rows] = part_velocity
            if self.groups:
                velocity = self._walk_abreast(self._keep_together(velocity))
            if self._reactions is not None and self.robots.count:
                velocity = self._react(velocity, steering.parts)
        if humans.teleop.any():
            teleop = humans.teleop.nonzero()[0]
            velocity[teleop] = humans.teleop_velocity[teleop]
        return velocity

    def _keep_together(self, velocity: FloatArray) -> FloatArray:
        """Members walking on their group's task who fall apart are drawn to their walking
        companions' centre (the attraction of Moussaid et al. 2010, as a velocity): farther
        than (n - 1) / 2 spacings from it, a member's walk shifts towards it by GROUP_PULL per
        metre too far."""
        h = self.humans
        for rows in self.groups.values():
            walking = rows[h.moving[rows] & h.with_group[rows]]
            if len(walking) < 2:
                continue
            centre = h.position[walking].mean(axis=0)
            offset = centre - h.position[walking]
            distance = physics.lengths(offset)
            slack = (len(walking) - 1) / 2 * GROUP_SPACING
            far = distance > slack
            if far.any():
                pull = offset[far] / distance[far, None] * (
                    GROUP_PULL * (distance[far] - slack))[:, None]
                moved = velocity[walking[far]] + pull * self._relaxing(walking[far])[:, None]
                velocity[walking[far]] = physics.capped(moved, h.max_speed[walking[far]])
        return velocity

    def _walk_abreast(self, velocity: FloatArray) -> FloatArray:
        """Members walking on their group's task keep abreast where there is room, after
        Moussaid et al.'s gaze rule (a walker who must turn its head to see a companion
        slows): one ahead of a companion beside it walks no faster than the companion walks
        its way, less its lead over ABREAST_CLOSE, and the one behind hurries by as much (the
        companions ahead hold it back as any walkers ahead do), so they close up level at
        about the slower one's pace."""
        h = self.humans
        for rows in self.groups.values():
            walking = rows[h.moving[rows] & h.with_group[rows]]
            found = self._abreast(walking) if len(walking) > 1 else None
            if found is None:
                continue
            way, lead, beside = found
            pace = np.maximum(velocity[walking] @ way, 0.0)
            lag = np.where(beside.T, lead.T, 0.0).max(axis=1)
            # one in the middle of a line, behind a companion and level with another, closes
            # up on the one ahead: it may outpace the one behind by its own lag
            cap = np.where(beside, pace[None, :] - (lead - lag[:, None]) / ABREAST_CLOSE,
                           np.inf).min(axis=1)
            cap = np.clip(cap, ABREAST_SLOWEST * h.desired_speed[walking], h.max_speed[walking])
            # held back at a walker's pace, by at most its desired speed per relaxation time a
            # tick: a cap set outright braked from 1.2 to 0.3 m/s within a tick as a companion
            # came level and fell behind, every second or two
            braking = physics.walkers_change(h.desired_speed[walking],
                                             h.relaxation_time[walking], self.dt)
            cap = np.maximum(cap, physics.lengths(h.velocity[walking]) - braking)
            # one about to reach its place waits there, standing: crawling to it keeps it in
            # the way of those coming up behind
            arriving = physics.lengths(h.goal[walking] - h.position[walking]) < ABREAST_ARRIVING
            cap[arriving] = h.max_speed[walking[arriving]]
            moved = velocity[walking] + (lag / ABREAST_CLOSE * self._relaxing(walking)
                                         )[:, None] * way
            velocity[walking] = physics.capped(moved, cap)
        return velocity

    def _relaxing(self, rows: IntArray) -> FloatArray:
        """The share of a change of desired velocity the social force makes in a tick:
        a shift of the walk added to each tick's velocity as it is would pile up, tick after
        tick, to relaxation time / step times itself (ten times, by default)."""
        return self.dt / self.humans.relaxation_time[rows]

    def _abreast(self, walking: IntArray) -> tuple[FloatArray, FloatArray, BoolArray] | None:
        """The group's way, how far each walker is ahead of each other along it (i ahead of
        j), and who walks beside whom: in the next lane (ABREAST_LANE across the way) with room
        to walk level (j's place level with i, and ABREAST_ROOM further on, clear of walls: not
        in a door or a corridor too narrow for two). None when they do not go one way (stepping
        into a talking circle)."""
        h = self.humans
        # the group's way: the mean of the members' ways to their next waypoints (each one's
        # own differs as it keeps its lane, and a small turn of it would read a companion
        # beside as one behind; velocities die away in a jam)
        ahead = self.paths.current_targets(walking) - h.position[walking]
        way = (ahead / np.maximum(physics.lengths(ahead), 1e-9)[:, None]).mean(axis=0)
        if math.hypot(*way) < ABREAST_ONE_WAY:
            return None
        way /= math.hypot(*way)
        offset = h.position[walking][None, :, :] - h.position[walking][:, None, :]
        lead = -offset @ way
        across = np.abs(offset[..., 0] * way[1] - offset[..., 1] * way[0])
        beside = (across >= ABREAST_LANE) & (lead > 0)
        # one walking in a companion's wake (its lane, close behind) is held up by that
        # companion: waiting for it would hold it up the more
        in_wake = ((across < ABREAST_LANE) & (lead > 0) & (lead < ABREAST_WAKE)).any(axis=0)
        beside[:, in_wake] = False
        if beside.any():
            i, j = np.nonzero(beside)
            level = h.position[walking[j]] + lead[i, j, None] * way
            radius = h.radius[walking[j]]
            beside[i, j] = ((self.grid.clearance_at(level) > radius)
                            & (self.grid.clearance_at(level + ABREAST_ROOM * way) > radius))
        return way, lead, beside

    def _react(self, velocity: FloatArray, parts: list[Part]) -> FloatArray:
        """Humans' reactions to robots: the impassive are steered as if there were no robot,
        the others' velocities adjusted (`hubero_dsl.sim.reactions`)."""
        reactions = self._reactions
        assert reactions is not None
        if reactions.impassive.any():
            h = self.humans
            alone = Crowd(position=h.position, velocity=h.velocity, heading=h.heading,
                          radius=h.radius, personal_space=h.personal_space,
                          is_robot=self._not_robot)
            for part in parts:
                rows = part.rows[reactions.impassive[part.rows]]
                if len(rows):
                    velocity[rows] = self._local[part.planner].velocities(
                        alone, self._drive(rows), self.dt)
        r = self.robots
        return reactions.adjust(velocity, self.humans, r.position, r.velocity, r.radius,
                                self.tick)

    def _squeezing(self) -> BoolArray | None:
        """The walkers squeezing past people standing (`squeeze_round_standing`) with no
        robot within SQUEEZE_CLEAR m of them, centre to centre: the push they keep less of is
        everyone's, and a robot, at rest or on the move, is no one to squeeze past. None:
        nobody."""
        if self.tick >= self._squeezes_end:  # nobody: no arrays looked at, tick after tick
            return None
        squeezing = self.squeeze_until > self.tick
        if self.robots.count:
            rows = squeezing.nonzero()[0]
            near = cKDTree(self.robots.position).query_ball_point(
                self.humans.position[rows], SQUEEZE_CLEAR, return_length=True)
            squeezing[rows] = near == 0
        return squeezing if squeezing.any() else None

    def _drive(self, rows: IntArray) -> Drive:
        h = self.humans
        avoidance = h.avoidance_strength
        squeezing = self._squeezing()
        if squeezing is not None:
            avoidance = np.where(squeezing, avoidance * SQUEEZE, avoidance)
        if len(rows) == h.count:  # everyone: the arrays themselves (planners never write them)
            return Drive(index=rows, target=self.paths.current_targets(rows),
                         desired_speed=h.desired_speed,
                         max_speed=np.maximum(h.max_speed, h.desired_speed),
                         relaxation_time=h.relaxation_time, goal_strength=h.goal_strength,
                         avoidance_strength=avoidance,
                         obstacle_strength=h.obstacle_strength,
                         interaction_range=h.interaction_range, field_of_view=h.field_of_view)
        return Drive(index=rows, target=self.paths.current_targets(rows),
                     desired_speed=h.desired_speed[rows],
                     max_speed=np.maximum(h.max_speed[rows], h.desired_speed[rows]),
                     relaxation_time=h.relaxation_time[rows], goal_strength=h.goal_strength[rows],
                     avoidance_strength=avoidance[rows],
                     obstacle_strength=h.obstacle_strength[rows],
                     interaction_range=h.interaction_range[rows],
                     field_of_view=h.field_of_view[rows])

    def crowd(self) -> Crowd:
        """Every body now: humans, then robots (which planners treat as moving obstacles).

        Without robots the humans' own arrays are the crowd (planners never write them).
        """
        h, r = self.humans, self.robots
        if not r.count:
            return Crowd(position=h.position, velocity=h.velocity, heading=h.heading,
                         radius=h.radius, personal_space=h.personal_space,
                         is_robot=self._not_robot)
        return Crowd(position=np.concatenate([h.position, r.position]),
                     velocity=np.concatenate([h.velocity, r.velocity]),
                     heading=np.concatenate([h.heading, r.heading]),
                     radius=np.concatenate([h.radius, r.radius]),
                     personal_space=self._everyones_shapes(),
                     is_robot=np.concatenate([np.zeros(h.count, bool), np.ones(r.count, bool)]))

    def _everyones_shapes(self) -> ShapeArrays:
        """Humans' then robots' personal spaces, joined once for as long as neither changes."""
        h, r = self.humans.personal_space, self.robots.personal_space
        cached = self._crowd_shapes
        if cached is None or cached[0] is not h or cached[1] is not r:
            cached = self._crowd_shapes = (h, r, ShapeArrays.stacked([h, r]))
        return cached[2]

    def separated(self, moved: FloatArray, movable: np.ndarray) -> FloatArray:
        """The humans at `moved` pushed apart from each other and from the robots (which do
        not move); `moved` itself when nobody overlaps."""
        r = self.robots
        count = self.humans.count + r.count
        if count < 2:
            return moved
        if not r.count:
            return self._separation(moved, self.humans.radius, movable)
        if count <= physics.FEW_BODIES and not physics.any_overlap(
                moved.tolist() + r.position.tolist(),
                self.humans.radius.tolist() + r.radius.tolist()):
            return moved  # a household and its robot, nobody touching: no arrays joined
        everyone = np.concatenate([moved, r.position])
        radius = np.concatenate([self.humans.radius, r.radius])
        can_move = np.concatenate([movable, np.zeros(r.count, bool)])
        separated = self._separation(everyone, radius, can_move)
        return moved if separated is everyone else separated[: self.humans.count]

    def wake(self, index: int, arrived: bool, aligned: bool, stuck: bool, timer: bool) -> None:
        """Human `index`'s events of this tick, handed to its behaviour."""
        h = self.humans
        behaviour = self.behaviour[index]
        if arrived:
            h.moving[index] = False
            self.paths.clear(index)
        if aligned:
            h.heading_goal[index] = np.nan
        if timer:
            self.wake_tick[index] = NEVER
        if behaviour is None:
            return
        if stuck:
            self.anchor_tick[index] = self.tick
            behaviour.on_stuck(self)
        elif arrived:
            behaviour.on_arrived(self)
        elif aligned:
            behaviour.on_aligned(self)
        if timer and self.behaviour[index] is behaviour:
            behaviour.on_timer(self)


def _state_of(behaviour: Behaviour | None) -> str:
    return behaviour.state if behaviour is not None else "idle"
