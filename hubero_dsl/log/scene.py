"""The `/scene` topic: what Foxglove's 3D panel draws, as foxglove.SceneUpdate snapshots.

Entities, one set per run (ids sorted):

- `human/NAME`, drawn in the human's own frame (`frame_locked`, placed by `/tf`): the body as a
  cylinder coloured by task status (shorter when sitting, on its side when lying), an arrow
  along the heading, the personal-space outline as a line loop, and the name as a label;
- `plan/NAME`, in `map`: the current goal as a sphere and the rest of the global path as a
  line strip (both empty when the human has none);
- `robot/NAME`, in the robot's frame: a cylinder, an arrow and a label.

Members of crowds and flows have no entities: they are drawn from their crowd's poses
(`crowds.py`).

Because bodies live in moving frames, a body entity changes only when the human's status colour
or posture does, and a plan entity only when its path or goal does. A snapshot of every entity is
published when anything changed (and at the start), so that the last `/scene` message before any
time is the whole picture: Foxglove shows the right scene after a seek. Entities are cached as
JSON text and re-encoded only when their own inputs change.
"""

from __future__ import annotations

import math
from functools import lru_cache
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from hubero_dsl.log.schemas import (
    STATUS_NAMES,
    dumps,
    human_frame,
    number,
    robot_frame,
)
from hubero_dsl.sim.status import Posture
from hubero_dsl.world.personal_space import outline
from hubero_dsl.world.shapes import Shape

if TYPE_CHECKING:
    from hubero_dsl.log.frames import FrameState

TIME_MARK = '"@time@"'   # where each snapshot's timestamp goes (no name can contain '@')
OUTLINE_POINTS = 32
BODY_HEIGHT = {Posture.STANDING: 1.7, Posture.SITTING: 1.2, Posture.LYING: 1.7}
ROBOT_HEIGHT = 0.5
STATUS_COLOURS: dict[str, tuple[float, float, float]] = {
    "IDLE": (0.6, 0.6, 0.6), "PENDING": (0.9, 0.8, 0.2), "ACTIVE": (0.2, 0.7, 0.3),
    "SUCCEEDED": (0.2, 0.45, 0.9), "PREEMPTED": (0.95, 0.55, 0.1),
    "ABORTED": (0.9, 0.15, 0.15)}
SPACE_COLOUR = {"r": 0.3, "g": 0.5, "b": 1.0, "a": 0.8}
PATH_COLOUR = {"r": 1.0, "g": 0.6, "b": 0.0, "a": 0.9}
ROBOT_COLOUR = {"r": 0.35, "g": 0.35, "b": 0.45, "a": 1.0}
LABEL_COLOUR = {"r": 1.0, "g": 1.0, "b": 1.0, "a": 1.0}
IDENTITY = {"w": 1.0, "x": 0.0, "y": 0.0, "z": 0.0}
ON_ITS_SIDE = {"w": number(math.sqrt(0.5)), "x": 0.0, "y": number(math.sqrt(0.5)), "z": 0.0}


def _colour(rgb: tuple[float, float, float], alpha: float = 1.0) -> dict[str, float]:
    return {"r": rgb[0], "g": rgb[1], "b": rgb[2], "a": alpha}


def _pose(x: float = 0.0, y: float = 0.0, z: float = 0.0,
          orientation: dict[str, float] | None = None) -> dict[str, Any]:
    return {"position": {"x": number(x), "y": number(y), "z": number(z)},
            "orientation": orientation or IDENTITY}


def _points(xy: npt.NDArray[np.float64], z: float) -> list[dict[str, float]]:
    rounded = np.round(xy, 4) + 0.0
    return [{"x": x, "y": y, "z": z} for x, y in rounded.tolist()]


def entity(entity_id: str, frame_id: str, *, frame_locked: bool,
           **primitives: list[dict[str, Any]]) -> dict[str, Any]:
    """A foxglove.SceneEntity with every field present (unused primitive lists empty)."""
    value: dict[str, Any] = {
        "timestamp": "@time@", "frame_id": frame_id, "id": entity_id,
        "lifetime": {"sec": 0, "nsec": 0}, "frame_locked": frame_locked,
        "metadata": [{"key": "kind", "value": entity_id.split("/", 1)[0]}]}
    for kind in ("arrows", "cubes", "spheres", "cylinders", "lines", "triangles", "texts",
                 "models"):
        value[kind] = primitives.get(kind, [])
    return value


def _arrow(length: float, colour: dict[str, float]) -> dict[str, Any]:
    return {"pose": _pose(z=0.05), "shaft_length": number(length * 0.7),
            "shaft_diameter": 0.05, "head_length": number(length * 0.3), "head_diameter": 0.12,
            "color": colour}


def _label(text: str, height: float) -> dict[str, Any]:
    return {"pose": _pose(z=height + 0.3), "billboard": True, "font_size": 14.0,
            "scale_invariant": True, "color": LABEL_COLOUR, "text": text}


NAME_MARK = "@name@"  # where a human's name goes in a cached body (names cannot contain '@')


@lru_cache(maxsize=4096)
def _body_template(radius: float, shape: Shape, posture: int, status: str) -> str:
    """A body entity with `NAME_MARK` for the name: humans alike share one encoding."""
    return body_entity(NAME_MARK, radius, shape, posture, status)


def named_body(name: str, radius: float, shape: Shape, posture: int, status: str) -> str:
    """`body_entity(name, ...)`, from the cached template of its look."""
    escaped = dumps(name)[1:-1]
    return _body_template(radius, shape, posture, status).replace(NAME_MARK, escaped)


def body_entity(name: str, radius: float, shape: Shape, posture: int, status: str) -> str:
    """The JSON of one human's body entity, in its own frame."""
    colour = _colour(STATUS_COLOURS[status])
    height = BODY_HEIGHT[Posture(posture)]
    if posture == Posture.LYING:
        cylinder_pose = _pose(z=radius, orientation=ON_ITS_SIDE)
        size = {"x": number(2 * radius), "y": number(2 * radius), "z": height}
        height = 2 * radius
    else:
        cylinder_pose = _pose(z=height / 2)
        size = {"x": number(2 * radius), "y": number(2 * radius), "z": height}
    space = outline(shape, (0.0, 0.0), 0.0, n=OUTLINE_POINTS)
    frame = human_frame(name)
    return dumps(entity(
        frame, frame, frame_locked=True,
        cylinders=[{"pose": cylinder_pose, "size": size, "bottom_scale": 1.0,
                    "top_scale": 1.0, "color": colour}],
        arrows=[_arrow(max(0.5, 2.5 * radius), colour)],
        lines=[{"type": 1, "pose": _pose(), "thickness": 0.02, "scale_invariant": False,
                "points": _points(space, 0.02), "color": SPACE_COLOUR, "colors": [],
                "indices": []}],
        texts=[_label(name, height)]))


def absent_entity(entity_id: str, frame_id: str, *, frame_locked: bool) -> str:
    """An entity with nothing to draw: replaces a removed human's body or an ended plan."""
    return dumps(entity(entity_id, frame_id, frame_locked=frame_locked))


def plan_entity(name: str, goal: npt.NDArray[np.float64],
                waypoints: npt.NDArray[np.float64]) -> str:
    """The JSON of one human's goal and remaining global path, in the map frame."""
    spheres = []
    if not np.isnan(goal).any():
        spheres = [{"pose": _pose(float(goal[0]), float(goal[1]), 0.1),
                    "size": {"x": 0.2, "y": 0.2, "z": 0.2}, "color": PATH_COLOUR}]
    lines = []
    if len(waypoints) >= 2:
        lines = [{"type": 0, "pose": _pose(), "thickness": 0.03, "scale_invariant": False,
                  "points": _points(waypoints, 0.02), "color": PATH_COLOUR, "colors": [],
                  "indices": []}]
    return dumps(entity(f"plan/{name}", "map", frame_locked=False, spheres=spheres,
                        lines=lines))


def robot_entity(name: str, radius: float) -> str:
    frame = robot_frame(name)
    return dumps(entity(
        frame, frame, frame_locked=True,
        cylinders=[{"pose": _pose(z=ROBOT_HEIGHT / 2),
                    "size": {"x": number(2 * radius), "y": number(2 * radius),
                             "z": ROBOT_HEIGHT},
                    "bottom_scale": 1.0, "top_scale": 1.0, "color": ROBOT_COLOUR}],
        arrows=[_arrow(max(0.5, 2.5 * radius), ROBOT_COLOUR)],
        texts=[_label(name, ROBOT_HEIGHT)]))


class SceneBuilder:
    """Keeps every entity's JSON and says, once per frame, whether the scene changed."""

    def __init__(self, humans: list[str], radius: list[float], shapes: list[Shape],
                 robots: list[str], robot_radius: list[float]) -> None:
        self._names = humans
        self._row = {name: row for row, name in enumerate(humans)}
        self._radius = radius
        self._shapes = shapes
        count = len(humans)
        self._body: list[str] = [""] * count
        self._plan: list[str] = [""] * count
        self._body_key = np.full((count, 3), -1, dtype=np.int64)  # posture, status, removed
        self._cursor = np.full(count, -1, dtype=np.intp)
        self._end = np.full(count, -1, dtype=np.intp)
        self._goal = np.full((count, 2), np.inf)
        self._waypoints: list[npt.NDArray[np.float64]] = [np.zeros((0, 2))] * count
        self._robots = [robot_entity(name, radius)
                        for name, radius in zip(robots, robot_radius, strict=True)]
        # human/ < plan/ < robot/: bodies by name, then plans by name, then robots by name
        self._order = sorted(range(count), key=lambda i: humans[i])
        self._robot_order = sorted(range(len(robots)), key=lambda i: robots[i])

    def snapshot(self, frame: FrameState, status: npt.NDArray[np.int8]) -> str | None:
        """The whole scene as SceneUpdate JSON (timestamp marks in place), or None if unchanged."""
        bodies = self._update_bodies(frame, status)
        plans = self._update_plans(frame)
        if not (bodies or plans):
            return None
        order = self._order
        entities = [self._body[i] for i in order] + [self._plan[i] for i in order]
        entities += [self._robots[i] for i in self._robot_order]
        return '{"deletions":[],"entities":[' + ",".join(entities) + "]}"

    def _update_bodies(self, frame: FrameState, status: npt.NDArray[np.int8]) -> bool:
        removed = np.zeros(len(self._names), dtype=np.int64)
        if frame.removed:
            removed[[self._row[name] for name in frame.removed if name in self._row]] = 1
        key = np.column_stack([frame.posture.astype(np.int64), status.astype(np.int64),
                               removed])
        changed = np.flatnonzero((key != self._body_key).any(axis=1))
        for i in changed.tolist():
            name = self._names[i]
            if removed[i]:
                self._body[i] = absent_entity(human_frame(name), human_frame(name),
                                              frame_locked=True)
            else:
                self._body[i] = named_body(name, self._radius[i], self._shapes[i],
                                           int(frame.posture[i]), STATUS_NAMES[status[i]])
        self._body_key = key
        return len(changed) > 0

    def _update_plans(self, frame: FrameState) -> bool:
        for i, waypoints in frame.paths.items():
            self._waypoints[i] = waypoints
        goal = frame.goal
        same_goal = (goal == self._goal) | (np.isnan(goal) & np.isnan(self._goal))
        changed = np.flatnonzero((frame.cursor != self._cursor) | (frame.end != self._end)
                                 | ~same_goal.all(axis=1))
        for i in changed.tolist():
            self._plan[i] = plan_entity(self._names[i], goal[i], self._waypoints[i])
        self._cursor, self._end, self._goal = frame.cursor, frame.end, goal
        return len(changed) > 0
