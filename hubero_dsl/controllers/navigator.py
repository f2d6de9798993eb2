"""`controller navigator`: the reference robot navigator.

It plans on the map with the navfn planner (the body radius is the robot's, plus a comfort
margin from walls), follows the plan waypoint by waypoint, and avoids people locally: people
near its way push its heading aside (a social-force-like repulsion that decays with the surface
gap), and it slows down, then stops, rather than come closer to anyone than `safety_margin`,
predicting both bodies' motion at constant velocity over `horizon` seconds. It re-plans when its
goal moves or every `replan_period`. A unicycle robot turns towards the wanted direction and
drives forward only as far as it faces it.

It is a baseline to compare a robot's own navigation against, not a tuned planner: it stops
for people who cross its way, and waits there until they have passed.
"""

from __future__ import annotations

import math
from typing import ClassVar

import numpy as np
from pydantic import Field

from hubero_dsl.controllers.base import ControllerParams, Observation, RobotBody
from hubero_dsl.planners.base import NoPath
from hubero_dsl.planners.navfn import NavfnParams, NavfnPlanner


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

    def command(self, observation: Observation) -> tuple[float, float]:
        goal = observation.goal
        if goal is None:
            return (0.0, 0.0)
        here = np.asarray(observation.position)
        if float(np.hypot(*(np.asarray(goal) - here))) <= observation.stop_distance:
            return (0.0, 0.0)
        if self._must_plan(goal, observation.time):
            self._plan(observation.position, goal, observation.time)
        if self.problem is not None or len(self.waypoints) == 0:
            return (0.0, 0.0)
        wanted = self._along_plan(here, observation)
        wanted = self._avoid(here, wanted, observation)
        return self._as_command(wanted, observation.heading)

    # ---- the plan ----------------------------------------------------------------------------

    def _must_plan(self, goal: tuple[float, float], time: float) -> bool:
        moved = self.planned_goal is None or math.dist(goal, self.planned_goal) > 0.25
        return moved or time >= self.next_plan

    def _plan(self, start: tuple[float, float], goal: tuple[float, float], time: float) -> None:
        self.planned_goal, self.next_plan = goal, time + self.params.replan_period
        try:
            plan = self.planner.plan(start, goal, body_radius=self.body.radius,
                                     comfort_radius=self.body.radius + self.params.comfort)
        except NoPath as exc:
            self.problem, self.waypoints = exc.reason, np.zeros((0, 2))
            return
        self.problem, self.waypoints, self.cursor = None, plan.waypoints, 0

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
        others = observation.people + observation.robots
        if not others:
            return wanted
        position = np.array([o.position for o in others])
        velocity = np.array([o.velocity for o in others])
        reach = np.array([o.radius for o in others]) + self.body.radius
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
        return wanted * self._safe_fraction(here, wanted, position, velocity, reach)

    def _safe_fraction(self, here: np.ndarray, wanted: np.ndarray, position: np.ndarray,
                       velocity: np.ndarray, reach: np.ndarray) -> float:
        """How much of `wanted` keeps every gap at least `safety_margin` over the horizon
        (bodies moving at constant velocity); 0 stops the robot where it is."""
        margin = reach + self.params.safety_margin
        for scale in (1.0, 0.75, 0.5, 0.25, 0.0):
            relative = velocity - wanted * scale          # others' motion seen from the robot
            offset = position - here
            speed2 = np.maximum((relative ** 2).sum(axis=1), 1e-12)
            t = np.clip(-(offset * relative).sum(axis=1) / speed2, 0.0, self.params.horizon)
            closest = offset + relative * t[:, None]
            closest_distance = np.hypot(closest[:, 0], closest[:, 1])
            now = np.hypot(offset[:, 0], offset[:, 1])
            # unsafe: it comes closer than the margin, and closer than it is now
            unsafe = (closest_distance < margin) & (closest_distance < now - 1e-6)
            if not unsafe.any():
                return scale
        return 0.0

    # ---- kinematics --------------------------------------------------------------------------

    def _as_command(self, wanted: np.ndarray, heading: float) -> tuple[float, float]:
        if self.body.kinematics == "holonomic":
            return (float(wanted[0]), float(wanted[1]))
        speed = float(np.hypot(*wanted))
        if speed < 1e-9:
            return (0.0, 0.0)
        error = math.remainder(math.atan2(wanted[1], wanted[0]) - heading, math.tau)
        return (speed * max(0.0, math.cos(error)), self.params.turn_gain * error)
