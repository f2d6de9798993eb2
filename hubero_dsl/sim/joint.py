"""Steering the walkers of many simulations with one call per local planner.

A vector environment's copies each keep their own engine, scheduler and arrays, but the part
of a tick that costs most, the local planner's pass over the crowd, is made for all of them at
once: their crowds are stacked into one, each copy a world of its own (`Crowd.world`: bodies of
different copies never meet), and one joined planner (`joined_planner`) steers every walker of
every copy in one call, so numpy's fixed cost per call is paid once per tick instead of once
per copy. A planner class that cannot be joined steers each copy alone, as a single run does.

Every copy's crowd is in the stack, walkers or not, so that the stack keeps its rows (and the
planner its neighbour lists) from tick to tick while no copy starts a new episode. A copy of
up to 16 bodies is steered bit for bit as it would be alone; a larger one meets the same
neighbours, whose pushes may be summed in another order (a difference in the last digits).
"""

from __future__ import annotations

import dataclasses
import itertools

import numpy as np

from hubero_dsl.planners.base import Crowd, Drive, LocalPlanner, joined_planner
from hubero_dsl.sim.arrays import BoolArray, FloatArray, HumanArrays, IntArray
from hubero_dsl.sim.engine import Engine, Steering
from hubero_dsl.sim.robots import Robots
from hubero_dsl.world.shapes import ShapeArrays


class JointSteering:
    """`Engine.steer` for many engines at once; keeps each planner's joined form while the
    engines keep their planners (a new episode brings new ones)."""

    def __init__(self) -> None:
        self._joined: dict[str, tuple[list[LocalPlanner], LocalPlanner | None]] = {}
        # the stack's personal spaces, whether each row is a robot, its world and where each
        # world starts, kept for as long as the engines' shape arrays are the same objects
        # (held here, so that none of them is freed and another takes its place unnoticed)
        self._layout: tuple[list[ShapeArrays], ShapeArrays, BoolArray, IntArray,
                            list[int]] | None = None

    def steer(self, engines: list[Engine], steerings: list[Steering | None]
              ) -> list[list[FloatArray]]:
        """What `engine.steer(steering)` gives, for each engine and its steering."""
        parts = {i: steering.parts for i, steering in enumerate(steerings)
                 if steering is not None}
        answers = [[np.zeros((0, 2))] * len(parts.get(i, [])) for i in range(len(engines))]
        if not parts:
            return answers
        stack, starts = self._stacked(engines)
        for name in sorted({part.planner for copy in parts.values() for part in copy}):
            asked = [(i, j) for i, copy in parts.items() for j, part in enumerate(copy)
                     if part.planner == name]
            planner = self._planner(name, engines)
            if planner is None:  # steered copy by copy, as a single run is
                for i, j in asked:
                    answers[i][j] = engines[i].local_planner(name).velocities(
                        engines[i].crowd(), parts[i][j].drive, engines[i].dt)
                continue
            drive = _stacked_drive([parts[i][j].drive for i, j in asked],
                                   [starts[i] for i, _ in asked])
            velocity = planner.velocities(stack, drive, engines[0].dt)
            ends = np.cumsum([len(parts[i][j].rows) for i, j in asked]).tolist()
            for (i, j), start, end in zip(asked, [0, *ends[:-1]], ends, strict=True):
                answers[i][j] = velocity[start:end]
        return answers

    def _stacked(self, engines: list[Engine]) -> tuple[Crowd, list[int]]:
        """Every engine's crowd (humans, then robots), one after another, each a world of its
        own, and the row where each starts; the rows' shapes, kinds and worlds are joined
        again only when they change."""
        bodies: list[HumanArrays | Robots] = [b for e in engines for b in (e.humans, e.robots)]
        spaces = [b.personal_space for b in bodies]
        kept = self._layout
        if kept is None or len(kept[0]) != len(spaces) or any(
                a is not b for a, b in zip(kept[0], spaces, strict=True)):
            sizes = [len(b.radius) for b in bodies]
            counts = [e.humans.count + e.robots.count for e in engines]
            kept = self._layout = (spaces, ShapeArrays.stacked(spaces),
                                   np.repeat(np.tile([False, True], len(engines)), sizes),
                                   np.repeat(np.arange(len(engines)), counts),
                                   list(itertools.accumulate(counts, initial=0)))
        _, shapes, is_robot, world, starts = kept
        return Crowd(position=np.concatenate([b.position for b in bodies]),
                     velocity=np.concatenate([b.velocity for b in bodies]),
                     heading=np.concatenate([b.heading for b in bodies]),
                     radius=np.concatenate([b.radius for b in bodies]),
                     personal_space=shapes, is_robot=is_robot, world=world), starts

    def _planner(self, name: str, engines: list[Engine]) -> LocalPlanner | None:
        planners = [engine.local_planner(name) for engine in engines]
        kept = self._joined.get(name)
        if kept is not None and len(kept[0]) == len(planners) and all(
                a is b for a, b in zip(kept[0], planners, strict=True)):
            return kept[1]
        joined = joined_planner(planners)
        self._joined[name] = (planners, joined)
        return joined


def _stacked_drive(drives: list[Drive], offsets: list[int]) -> Drive:
    """The drives one after another, their rows moved to where their crowds are stacked."""
    columns = {f.name: np.concatenate([getattr(d, f.name) for d in drives])
               for f in dataclasses.fields(Drive) if f.name != "index"}
    index = np.concatenate([d.index + offset for d, offset in zip(drives, offsets,
                                                                  strict=True)])
    return Drive(index=index, **columns)
