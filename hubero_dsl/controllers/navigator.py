"""`controller navigator`: the reference robot navigator.

It plans on the map with the navfn planner (the body radius is the robot's, plus a comfort
margin from walls), follows the plan waypoint by waypoint, and avoids people locally: people
near its way push its heading aside (a social-force-like repulsion that decays with the surface
gap), and it slows down, then stops, rather than come closer to anyone than `safety_margin`,
predicting both bodies' motion at constant velocity over `horizon` seconds. When someone walks
at it even as it stands, it steps aside or backs away (at `escape_speed`, clear of walls) rather
than wait to be walked into. Kept waiting for `detour_after` seconds, it plans round the people
and robots standing still near it, as if they were obstacles, until its goal changes. It
re-plans when its goal moves or every `replan_period`. A unicycle robot turns towards the
wanted direction and drives forward only as far as it faces it (it backs up to step out of
someone's way).

It is a baseline to compare a robot's own navigation against, not a tuned planner: it stops
for people who cross its way, and waits there until they have passed or it can go round.
"""

from __future__ import annotations

import math
from typing import ClassVar

import numpy as np
from pydantic import Field

from hubero_dsl.controllers.base import ControllerParams, Observation, RobotBody
from hubero_dsl.planners.base import NoPath
from hubero_dsl.planners.navfn import NavfnParams, NavfnPlanner, plan_round_discs

_ESCAPE_ANGLES = np.linspace(0.0, 2.0 * math.pi, 16, endpoint=False)
ESCAPE_DIRECTIONS = np.column_stack([np.cos(_ESCAPE_ANGLES), np.sin(_ESCAPE_ANGLES)])
WALL_GAP = 0.02  # m the body keeps from walls (navfn plans keep its lethal margin, 0.05)
BRUSH = 0.0  # m a body may brush a wall by: none, as the engine stops a robot at the wall
WALL_LOOKAHEAD = 0.5  # s ahead that the body's clearance from walls is checked
STILL_SPEED = 0.2   # m/s: people slower than this are gone round, not waited for
DETOUR_RANGE = 3.0  # m (surface gap): the people a detour goes round
ESCAPE_HYSTERESIS = 0.25  # of a step's score, by which the last step's way may trail the best


class NavigatorParams(ControllerParams):
    safety_margin: float = Field(default=0.3, ge=0.0, json_schema_extra={"dimension": "length"},
                                 description="surface gap to people it never closes, m")
    horizon: float = Field(default=1.5, gt=0.0, json_schema_extra={"dimension": "time"},
                           description="how far ahead it predicts people's motion, s")
    avoidance_range: float = Field(default=1.5, ge=0.0,
                                   json_schema_extra={"dimension": "length"},
                                   description="surface gap within which people push its "
                                               "heading aside, m")
    avoidance_gain: float = Field(default=0.8, ge=0.0,
                                  description="strength of that push, relative to its speed")
    comfort: float = Field(default=0.1, ge=0.0, json_schema_extra={"dimension": "length"},
                           description="extra clearance from walls its plans prefer, m")
    lookahead: float = Field(default=0.5, gt=0.0, json_schema_extra={"dimension": "length"},
                             description="a waypoint this close counts as passed, m")
    replan_period: float = Field(default=2.0, gt=0.0, json_schema_extra={"dimension": "time"},
                                 description="how often it re-plans to its goal, s")
    turn_gain: float = Field(default=2.5, gt=0.0,
                             description="unicycle: turn rate per radian of heading error, 1/s")
    detour_after: float = Field(default=3.0, gt=0.0, json_schema_extra={"dimension": "time"},
                                description="after waiting this long for people in its way, it "
                                            "plans round those standing still, s")
    escape_distance: float = Field(default=1.0, ge=0.0,
                                   json_schema_extra={"dimension": "length"},
                                   description="how far it steps out of someone's way at most, "
                                               "m")
    escape_speed: float = Field(default=0.4, ge=0.0, json_schema_extra={"dimension": "speed"},
                                description="speed at which it steps out of the way of someone "
                                            "walking at it, m/s (0: it only stops)")


class Navigator:
    Params: ClassVar[type[ControllerParams]] = NavigatorParams

    def __init__(self, body: RobotBody, params: ControllerParams) -> None:
        self.body = body
        self.params = (params if isinstance(params, NavigatorParams)
                       else NavigatorParams.model_validate(params.model_dump()))
        self.planner = NavfnPlanner(body.grid, NavfnParams())
        self.waypoints = np.zeros((0, 2))
        self.cursor = 0
        self.planned_goal: tuple[float, float] | None = None
        self.next_plan = 0.0
        self.problem: str | None = None   # why it cannot go on (read when its task is stuck)
        self.escaping = False             # stepping out of someone's way this tick
        self.escape_origin: np.ndarray | None = None  # where its steps out of the way began
        self.escape_way: int | None = None  # the direction (of ESCAPE_DIRECTIONS) it stepped
        self.blocked_for = 0.0            # s stopped for people in its way
        self.detouring = False            # its plans go round people standing still

    def command(self, observation: Observation) -> tuple[float, float]:
        goal = observation.goal
        here = np.asarray(observation.position)
        if goal is None or float(np.hypot(*(np.asarray(goal) - here))) \
                <= observation.stop_distance:
            self._forget_escape()  # the next goal's steps aside start afresh
            return (0.0, 0.0)
        if self.blocked_for >= self.params.detour_after:
            self.detouring, self.blocked_for, self.next_plan = True, 0.0, observation.time
        if self._must_plan(goal, observation.time):
            self._plan(observation, goal)
        if self.problem is not None or len(self.waypoints) == 0:
            self._forget_escape()
            return (0.0, 0.0)
        planned = self._along_plan(here, observation)
        self.escaping = False
        wanted = self._avoid(here, planned, observation)
        stopped = float(np.hypot(*wanted)) < 1e-9 < float(np.hypot(*planned))
        self.blocked_for = self.blocked_for + self.body.dt if stopped else 0.0
        if not (self.escaping or stopped):
            self._forget_escape()  # on its way again
        forward, turn = self._as_command(wanted, observation.heading, reverse=self.escaping)
        if self.body.kinematics == "unicycle" and forward != 0.0 and not self.escaping:
            # a unicycle drives along its heading, not along `wanted`: check that motion too
            heading = observation.heading + turn * self.body.dt
            moving = forward * np.array([math.cos(heading), math.sin(heading)])
            if self._unsafe_among(here, moving, observation) or self._into_wall(here, moving):
                forward = 0.0  # turn on the spot first
        return forward, turn

    def _unsafe_among(self, here: np.ndarray, moving: np.ndarray,
                      observation: Observation) -> bool:
        others = self._others(observation)
        return others is not None and self._unsafe(here, moving, *others)

    def _others(self, observation: Observation
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """The people and robots it senses: positions, velocities, and the centre distance
        at which each would touch it; None when there are none."""
        others = observation.people + observation.robots
        if not others:
            return None
        return (np.array([o.position for o in others]), np.array([o.velocity for o in others]),
                np.array([o.radius for o in others]) + self.body.radius)

    # ---- the plan ----------------------------------------------------------------------------

    def _must_plan(self, goal: tuple[float, float], time: float) -> bool:
        moved = self.planned_goal is None or math.dist(goal, self.planned_goal) > 0.25
        if moved:  # a new goal: the people in the old way, and steps aside, may not matter
            self.detouring = False
            self._forget_escape()
        return moved or time >= self.next_plan

    def _forget_escape(self) -> None:
        self.escape_origin = self.escape_way = None

    def _plan(self, observation: Observation, goal: tuple[float, float]) -> None:
        self.planned_goal = goal
        self.next_plan = observation.time + self.params.replan_period
        start = observation.position
        try:
            plan = self._detour(observation, goal) if self.detouring else None
            if plan is None:
                plan = self.planner.plan(
                    start, goal, body_radius=self.body.radius,
                    comfort_radius=self.body.radius + self.params.comfort).waypoints
        except NoPath as exc:
            self.problem, self.waypoints = exc.reason, np.zeros((0, 2))
            return
        self.problem, self.waypoints, self.cursor = None, plan, 0

    def _detour(self, observation: Observation, goal: tuple[float, float]
                ) -> np.ndarray | None:
        """A plan round the people and robots standing (nearly) still near it, as if they were
        obstacles of their size plus the safety margin; None when there are none or no such
        plan (it then takes the map's plan and waits)."""
        still = [p for p in observation.people + observation.robots
                 if math.hypot(*p.velocity) < STILL_SPEED
                 and p.gap(observation.position, self.body.radius) < DETOUR_RANGE]
        if not still:
            return None
        return plan_round_discs(
            self.body.grid, [p.position for p in still],
            [p.radius + self.params.safety_margin for p in still], observation.position, goal,
            body_radius=self.body.radius, comfort_radius=self.body.radius + self.params.comfort)

    def _along_plan(self, here: np.ndarray, observation: Observation) -> np.ndarray:
        """The velocity along the plan: towards the next waypoint not yet passed, slowing down
        over the last metre."""
        last = len(self.waypoints) - 1
        while self.cursor < last and np.hypot(*(self.waypoints[self.cursor] - here)) \
                < self.params.lookahead:
            self.cursor += 1
        offset = self.waypoints[self.cursor] - here
        distance = float(np.hypot(*offset))
        if distance < 1e-9:
            return np.zeros(2)
        speed = min(observation.speed, self.body.max_speed)
        remaining = float(np.hypot(*(self.waypoints[-1] - here)))
        speed *= min(1.0, remaining)  # arrive, do not overshoot
        return offset / distance * speed

    # ---- people ------------------------------------------------------------------------------

    def _avoid(self, here: np.ndarray, wanted: np.ndarray,
               observation: Observation) -> np.ndarray:
        """`wanted` pushed aside by people near, kept off walls, then slowed or stopped (or
        turned into a step out of someone's way) so that no gap closes below the margin."""
        others = self._others(observation)
        if others is None:
            return self._off_walls(here, wanted)
        position, velocity, reach = others
        away = here - position
        distance = np.maximum(np.hypot(away[:, 0], away[:, 1]), 1e-9)
        gap = distance - reach
        speed = float(np.hypot(*wanted))
        near = gap < self.params.avoidance_range
        if near.any() and speed > 0:
            weight = np.exp(-np.maximum(gap[near], 0.0) / 0.5) / distance[near]
            push = (away[near] * weight[:, None]).sum(axis=0)
            wanted = wanted + push * self.params.avoidance_gain * speed
            norm = float(np.hypot(*wanted))
            if norm > speed:
                wanted = wanted / norm * speed
        wanted = self._off_walls(here, wanted)
        for scale in (1.0, 0.75, 0.5, 0.25):
            if not self._unsafe(here, wanted * scale, position, velocity, reach):
                return wanted * scale
        if not self._unsafe(here, np.zeros(2), position, velocity, reach):
            return np.zeros(2)  # stop and let them pass
        # someone walks at the robot even as it stands: standing would end in contact
        return self._escape(here, wanted, position, velocity, reach, observation)

    def _unsafe(self, here: np.ndarray, moving: np.ndarray, position: np.ndarray,
                velocity: np.ndarray, reach: np.ndarray) -> bool:
        """Whether, at velocity `moving`, some gap would fall below `safety_margin` within the
        horizon and below what it is now (bodies moving at constant velocity)."""
        closest, now = self._closest_approach(here, moving, position, velocity)
        margin = reach + self.params.safety_margin
        return bool(((closest < margin) & (closest < now - 1e-6)).any())

    def _closest_approach(self, here: np.ndarray, moving: np.ndarray, position: np.ndarray,
                          velocity: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Each other's centre distance at the closest approach within the horizon (both at
        constant velocity, the robot at `moving`), and now."""
        relative = velocity - moving          # others' motion seen from the robot
        offset = position - here
        speed2 = np.maximum((relative ** 2).sum(axis=1), 1e-12)
        t = np.clip(-(offset * relative).sum(axis=1) / speed2, 0.0, self.params.horizon)
        closest = offset + relative * t[:, None]
        return np.hypot(closest[:, 0], closest[:, 1]), np.hypot(offset[:, 0], offset[:, 1])

    def _escape(self, here: np.ndarray, wanted: np.ndarray, position: np.ndarray,
                velocity: np.ndarray, reach: np.ndarray, observation: Observation
                ) -> np.ndarray:
        """A step out of the way of whoever comes closest: preferably sideways to their
        motion, then away from them, then along the plan; clear of walls, and keeping every
        gap or at least widening the narrowest. At most `escape_distance` from where it began
        (herded along a corridor, it would only block the way further on); standing still when
        there is no such step. (A person walking at a stopped robot may not go round it.)"""
        speed = min(self.params.escape_speed, self.body.max_speed, observation.speed)
        if self.escape_origin is None:
            self.escape_origin = here.copy()
        if speed <= 0.0:
            return np.zeros(2)
        directions = ESCAPE_DIRECTIONS
        gaps = np.hypot(*(here - position).T) - reach
        nearest = int(np.argmin(gaps))
        threat = _unit(here - position[nearest])
        coming = _unit(velocity[nearest]) if np.hypot(*velocity[nearest]) > 0.05 else -threat
        score = np.abs(directions @ np.array([-coming[1], coming[0]])) \
            + 0.5 * (directions @ threat) + 0.25 * (directions @ _unit(wanted))
        standing = self._narrowest(here, np.zeros(2), position, velocity, reach)
        # the way it stepped last is taken again while it serves and scores nearly the best:
        # re-choosing every tick among near-equal scores flipped its step from side to side,
        # at 13 m/s^2
        ways = np.argsort(-score, kind="stable").tolist()
        if self.escape_way is not None and \
                score[self.escape_way] >= score[ways[0]] - ESCAPE_HYSTERESIS:
            ways.remove(self.escape_way)
            ways.insert(0, self.escape_way)
        for k in ways:
            step = directions[k] * speed
            if float(np.hypot(*(here + step * self.body.dt - self.escape_origin))) \
                    > self.params.escape_distance:
                continue
            if self._clear_of_walls(here, step) and (
                    not self._unsafe(here, step, position, velocity, reach)
                    or self._narrowest(here, step, position, velocity, reach) > standing + 0.05):
                self.escaping, self.escape_way = True, k
                return step
        self.escape_way = None
        return np.zeros(2)

    def _narrowest(self, here: np.ndarray, moving: np.ndarray, position: np.ndarray,
                   velocity: np.ndarray, reach: np.ndarray) -> float:
        """The smallest surface gap to anyone over the horizon, moving at `moving`."""
        closest, _ = self._closest_approach(here, moving, position, velocity)
        return float((closest - reach).min())

    def _off_walls(self, here: np.ndarray, wanted: np.ndarray) -> np.ndarray:
        """`wanted` without the part that would bring the body within `WALL_GAP` of a wall in
        the next `WALL_LOOKAHEAD` seconds (following a plan cuts corners; a push from people
        may point at a wall)."""
        ahead = here + wanted * WALL_LOOKAHEAD
        clearance, away = self.body.grid.clearance_and_direction_at(np.stack([here, ahead]))
        for gap, normal in zip(clearance.tolist(), away, strict=True):
            into = -float(wanted @ normal)
            if gap < self.body.radius + WALL_GAP and into > 0.0:
                wanted = wanted + normal * into
        return wanted

    def _into_wall(self, here: np.ndarray, moving: np.ndarray) -> bool:
        """Whether moving so would press the body into a wall by more than `BRUSH` (and
        nearer than it is) within `WALL_LOOKAHEAD` seconds."""
        clearance = self._clearance_along(here, moving, WALL_LOOKAHEAD, 6)
        return bool((clearance[1:] < np.minimum(self.body.radius - BRUSH, clearance[0])).any())

    def _clear_of_walls(self, here: np.ndarray, step: np.ndarray) -> bool:
        """Whether the body keeps off walls moving at `step` for the horizon."""
        clearance = self._clearance_along(here, step, self.params.horizon, 5)
        return bool((clearance[1:] > self.body.radius + WALL_GAP).all())

    def _clearance_along(self, here: np.ndarray, moving: np.ndarray, seconds: float,
                         samples: int) -> np.ndarray:
        """The body's clearance from walls at `samples` evenly spaced times from now to
        `seconds` ahead, moving at `moving` (the first is here)."""
        ahead = here + moving * np.linspace(0.0, seconds, samples)[:, None]
        return self.body.grid.clearance_at(ahead)

    # ---- kinematics --------------------------------------------------------------------------

    def _as_command(self, wanted: np.ndarray, heading: float, *, reverse: bool = False
                    ) -> tuple[float, float]:
        """A unicycle turns towards `wanted` and drives as far as it faces it; when `reverse`
        (stepping back out of someone's way) it may back up instead of turning round."""
        if self.body.kinematics == "holonomic":
            return (float(wanted[0]), float(wanted[1]))
        speed = float(np.hypot(*wanted))
        if speed < 1e-9:
            return (0.0, 0.0)
        error = math.remainder(math.atan2(wanted[1], wanted[0]) - heading, math.tau)
        if reverse and abs(error) > math.pi / 2:
            back = math.remainder(error - math.pi, math.tau)
            return (-speed * math.cos(back), self.params.turn_gain * back)
        return (speed * max(0.0, math.cos(error)), self.params.turn_gain * error)


def _unit(vector: np.ndarray) -> np.ndarray:
    return vector / max(float(np.hypot(*vector)), 1e-9)
