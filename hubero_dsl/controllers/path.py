"""`controller path`: the robot drives its declared route, `path P -> P -> ... [loop]`, at its
`speed`, stopping at the last waypoint (or starting over with `loop`). It takes no tasks."""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from hubero_dsl.controllers.base import ControllerParams, Observation, RobotBody


class PathController:
    Params: ClassVar[type[ControllerParams]] = ControllerParams

    def __init__(self, body: RobotBody, params: ControllerParams) -> None:
        self.body = body
        self.waypoint = 0

    def command(self, observation: Observation) -> tuple[float, float]:
        path, dt, speed = self.body.path, self.body.dt, self.body.speed
        if not path or self.waypoint >= len(path):
            return (0.0, 0.0)
        offset = np.asarray(path[self.waypoint]) - np.asarray(observation.position)
        distance = float(np.linalg.norm(offset))
        if distance <= speed * dt:  # reached within this tick: land on it, aim at the next
            self.waypoint += 1
            if self.body.loop and self.waypoint >= len(path):
                self.waypoint = 0
            step = offset / dt
        else:
            step = offset / distance * speed
        return (float(step[0]), float(step[1]))
