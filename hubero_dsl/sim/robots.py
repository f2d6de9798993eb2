"""Robots: moving objects that are not humans. They follow a scripted path, are driven from
Python (a controller class or `set_velocity`), or stay put. Humans see them as obstacles."""

from __future__ import annotations

import importlib
from typing import Any, Protocol

import numpy as np

from hubero_dsl.errors import InputError
from hubero_dsl.model.program import RobotSpec
from hubero_dsl.sim.arrays import FloatArray
from hubero_dsl.world.shapes import Circle, ShapeArrays


class RobotController(Protocol):
    """A class named by `controller "module:Class"`: asked for a velocity every tick."""

    def __init__(self, name: str) -> None: ...

    def velocity(self, time: float, position: tuple[float, float]) -> tuple[float, float]: ...


def load_controller(target: str, name: str) -> RobotController:
    module_name, _, class_name = target.partition(":")
    try:
        cls = getattr(importlib.import_module(module_name), class_name)
        controller: RobotController = cls(name)
    except Exception as exc:  # user code: any failure is a bad-input error, not a crash
        raise InputError(f"robot '{name}': controller \"{target}\" cannot be loaded: {exc}") \
            from None
    return controller


class Robots:
    """All robots as arrays; the few per-robot decisions (next waypoint) are cheap."""

    def __init__(self, specs: tuple[RobotSpec, ...]) -> None:
        self.specs = specs
        self.names = [s.name for s in specs]
        count = len(specs)
        self.position: FloatArray = np.array([s.start.xy for s in specs], float).reshape(count, 2)
        self.velocity: FloatArray = np.zeros((count, 2))
        self.heading: FloatArray = np.array([s.start.heading or 0.0 for s in specs], float)
        self.radius: FloatArray = np.array([s.radius for s in specs], float)
        self.speed: FloatArray = np.array([s.speed for s in specs], float)
        self.personal_space = ShapeArrays.from_shapes([Circle(s.radius) for s in specs])
        self.waypoint = np.zeros(count, dtype=np.intp)
        self.commanded: dict[int, tuple[float, float]] = {}
        self.controllers: dict[int, RobotController] = {
            i: load_controller(s.controller, s.name) for i, s in enumerate(specs) if s.controller}

    @property
    def count(self) -> int:
        return len(self.specs)

    def position_of(self, name: str) -> tuple[float, float] | None:
        if name not in self.names:
            return None
        x, y = self.position[self.names.index(name)]
        return (float(x), float(y))

    def radius_of(self, name: str) -> float:
        return float(self.radius[self.names.index(name)]) if name in self.names else 0.0

    def set_velocity(self, name: str, velocity: tuple[float, float]) -> None:
        self.commanded[self.names.index(name)] = velocity

    def advance(self, dt: float, time: float) -> None:
        for i, spec in enumerate(self.specs):
            self.velocity[i] = self._velocity(i, spec, dt, time)
        self.position = self.position + self.velocity * dt
        moving = np.linalg.norm(self.velocity, axis=1) > 1e-6
        self.heading = np.where(moving, np.arctan2(self.velocity[:, 1], self.velocity[:, 0]),
                                self.heading)

    def _velocity(self, i: int, spec: RobotSpec, dt: float, time: float) -> Any:
        if i in self.controllers:
            x, y = self.position[i]
            return np.asarray(self.controllers[i].velocity(time, (float(x), float(y))), float)
        if i in self.commanded:
            return np.asarray(self.commanded[i], float)
        if not spec.path or self.waypoint[i] >= len(spec.path):
            return np.zeros(2)
        target = np.asarray(spec.path[self.waypoint[i]])
        offset = target - self.position[i]
        distance = float(np.linalg.norm(offset))
        if distance <= self.speed[i] * dt:
            self.waypoint[i] += 1
            if spec.loop and self.waypoint[i] >= len(spec.path):
                self.waypoint[i] = 0
            return offset / dt
        return offset / distance * self.speed[i]
