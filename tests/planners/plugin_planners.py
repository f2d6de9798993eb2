"""Planner plugins of a third party, good and broken, for tests/planners/test_plugins.py (which
registers them as entry points would)."""

from __future__ import annotations

import sys
from typing import Any, ClassVar

import numpy as np
from pydantic import BaseModel

from hubero_dsl.planners.base import Crowd, Drive, Plan, PlannerParams


class Straight:
    """A global planner: the straight segment, walls or not."""

    name: ClassVar[str] = "qa_straight"
    Params: ClassVar[type[PlannerParams]] = PlannerParams

    def __init__(self, grid: Any, params: PlannerParams) -> None:
        self.grid = grid

    def plan(self, start: tuple[float, float], goal: tuple[float, float], *,
             body_radius: float, comfort_radius: float) -> Plan:
        return Plan(self.answer(start, goal))

    def answer(self, start: tuple[float, float], goal: tuple[float, float]) -> Any:
        return np.array([start, goal], dtype=np.float64)


class PlanRaises(Straight):
    def answer(self, start: tuple[float, float], goal: tuple[float, float]) -> Any:
        return 1 / 0


class PlanExits(Straight):
    def answer(self, start: tuple[float, float], goal: tuple[float, float]) -> Any:
        sys.exit(0)


class PlanNaN(Straight):
    def answer(self, start: tuple[float, float], goal: tuple[float, float]) -> Any:
        return np.array([start, (np.nan, np.nan), goal])


class PlanOutside(Straight):
    def answer(self, start: tuple[float, float], goal: tuple[float, float]) -> Any:
        return np.array([start, (1e300, 0.0), goal])


class PlanHuge(Straight):
    def answer(self, start: tuple[float, float], goal: tuple[float, float]) -> Any:
        return np.zeros((10**7, 2)) + start  # followed waypoint by waypoint: a hung run


class PlanList(Straight):
    def plan(self, start: tuple[float, float], goal: tuple[float, float], *,
             body_radius: float, comfort_radius: float) -> Plan:
        return [start, goal]  # type: ignore[return-value]


class NoParams:
    name = "qa_no_params"

    def plan(self, start: Any, goal: Any, **sizes: float) -> Plan:
        return Plan(np.array([start, goal]))


class PlainParams(NoParams):
    class Params(BaseModel):
        gain: float = 1.0


class Direct:
    """A local planner: straight at the target at the desired speed."""

    name: ClassVar[str] = "qa_direct"
    Params: ClassVar[type[PlannerParams]] = PlannerParams

    def __init__(self, grid: Any, params: list[PlannerParams]) -> None:
        self.count = len(params)

    def velocities(self, crowd: Crowd, drive: Drive, dt: float) -> Any:
        offset = drive.target - crowd.position[drive.index]
        length = np.maximum(np.hypot(offset[:, 0], offset[:, 1]), 1e-9)
        return offset / length[:, None] * drive.desired_speed[:, None]


class SetUpRaises(Direct):
    def __init__(self, grid: Any, params: list[PlannerParams]) -> None:
        raise ValueError("no licence")


class Teleports(Direct):
    def velocities(self, crowd: Crowd, drive: Drive, dt: float) -> Any:
        crowd.position[:] = 0.0  # people moved by writing where they are
        return super().velocities(crowd, drive, dt)


class WrongShape(Direct):
    def velocities(self, crowd: Crowd, drive: Drive, dt: float) -> Any:
        return np.zeros(2)


class Words(Direct):
    def velocities(self, crowd: Crowd, drive: Drive, dt: float) -> Any:
        return "fast"


class TooFast(Direct):
    def velocities(self, crowd: Crowd, drive: Drive, dt: float) -> Any:
        return super().velocities(crowd, drive, dt) * 1e6


class Bypasses(Direct):
    def velocities(self, crowd: Crowd, drive: Drive, dt: float) -> Any:
        velocity = super().velocities(crowd, drive, dt)
        crowd.position.flags.writeable = True  # on purpose: it writes a copy, moves nobody
        crowd.position[:] = 0.0
        return velocity


class JoinRaises(Direct):
    @classmethod
    def joined(cls, planners: list[Any]) -> Any:
        raise RuntimeError("cannot join")


class Required(Direct):
    class Params(PlannerParams):
        gain: float


GLOBAL = {"qa_straight": "Straight", "qa_plan_raises": "PlanRaises",
          "qa_plan_exits": "PlanExits", "qa_plan_nan": "PlanNaN",
          "qa_plan_outside": "PlanOutside", "qa_plan_list": "PlanList", "qa_plan_huge": "PlanHuge",
          "qa_no_params": "NoParams", "qa_plain_params": "PlainParams",
          "qa_not_installed": "Missing"}
LOCAL = {"qa_direct": "Direct", "qa_set_up_raises": "SetUpRaises",
         "qa_teleports": "Teleports", "qa_wrong_shape": "WrongShape", "qa_words": "Words",
         "qa_too_fast": "TooFast", "qa_bypasses": "Bypasses", "qa_join_raises": "JoinRaises",
         "qa_required": "Required"}
