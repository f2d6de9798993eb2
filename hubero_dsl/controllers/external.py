"""`controller external`: the robot is driven from outside, by the Python API
(`Simulation.set_robot_velocity`, `RobotHandle.set_velocity`) or the Gymnasium environment.
Until it is told a velocity it stands still."""

from __future__ import annotations

from typing import ClassVar

from hubero_dsl.controllers.base import ControllerParams, Observation, RobotBody


class ExternalController:
    Params: ClassVar[type[ControllerParams]] = ControllerParams

    def __init__(self, body: RobotBody, params: ControllerParams) -> None:
        self.body = body

    def command(self, observation: Observation) -> tuple[float, float]:
        return (0.0, 0.0)
