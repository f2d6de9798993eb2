"""What a hubero run log holds: its topics, their schemas, and how values become JSON.

Every message is JSON (MCAP message encoding `json`) described by a JSON Schema (schema encoding
`jsonschema`). Where Foxglove defines a message type, the log uses it under its exact name with
the official schema (vendored in `foxglove/`, see its README): `/map` foxglove.Grid,
`/scene` foxglove.SceneUpdate, `/tf` foxglove.FrameTransforms, `/humans/NAME/pose`
foxglove.PoseInFrame, `/crowds/NAME/poses` foxglove.PosesInFrame, `/log` foxglove.Log. hubero's
own schemas cover the rest: `/humans/NAME/state` hubero.HumanState, `/crowds/NAME/state`
hubero.CrowdState (in logs with crowds or flows), `/robots/NAME/state` hubero.RobotState (in
logs with robots) and `/tasks` hubero.TaskEvent.

Frames: everything is in the fixed frame `map` (the map's coordinates, z up); `/tf` places one
frame per human written one by one (`human/NAME`) and per robot (`robot/NAME`) in it, so scene
bodies drawn in those frames follow them.

JSON is canonical: object keys sorted, no spaces, ASCII only, and numbers rounded to
`DECIMALS` places (0.1 mm, 0.1 mrad) and written with Python's shortest round-trip repr (or
`%.4f` in the per-tick templates), which is the same on every platform. Times are simulation
time in integer nanoseconds from the start of the run: nothing in a log depends on the clock.
"""

from __future__ import annotations

import base64
import json
import math
from functools import cache
from importlib import resources
from typing import TYPE_CHECKING, Any

import numpy as np

from hubero_dsl.errors import LogError
from hubero_dsl.sim.status import Posture, TaskStatus
from hubero_dsl.world.shapes import Circle, Ellipse, Rectangle

if TYPE_CHECKING:
    from hubero_dsl.world.grid import OccupancyGrid

FORMAT = "hubero-run-log"
FORMAT_VERSION = 2  # 2: crowds and flows share aggregate topics
METADATA_NAME = "hubero"          # the provenance record
RESULT_METADATA_NAME = "hubero.result"  # how the run ended, written when it ends
MAP_FRAME = "map"
DECIMALS = 4
NUMBER = "%.4f"                   # the fixed float format of the per-tick templates

MAP_TOPIC = "/map"
SCENE_TOPIC = "/scene"
TF_TOPIC = "/tf"
TASKS_TOPIC = "/tasks"
LOG_TOPIC = "/log"

GRID = "foxglove.Grid"
SCENE_UPDATE = "foxglove.SceneUpdate"
FRAME_TRANSFORMS = "foxglove.FrameTransforms"
POSE_IN_FRAME = "foxglove.PoseInFrame"
POSES_IN_FRAME = "foxglove.PosesInFrame"
LOG = "foxglove.Log"
HUMAN_STATE = "hubero.HumanState"
CROWD_STATE = "hubero.CrowdState"
ROBOT_STATE = "hubero.RobotState"
TASK_EVENT = "hubero.TaskEvent"

FOXGLOVE_FILES = {GRID: "Grid.json", SCENE_UPDATE: "SceneUpdate.json",
                  FRAME_TRANSFORMS: "FrameTransforms.json", POSE_IN_FRAME: "PoseInFrame.json",
                  POSES_IN_FRAME: "PosesInFrame.json", LOG: "Log.json"}
TOPIC_SCHEMAS = {MAP_TOPIC: GRID, SCENE_TOPIC: SCENE_UPDATE, TF_TOPIC: FRAME_TRANSFORMS,
                 TASKS_TOPIC: TASK_EVENT, LOG_TOPIC: LOG}

# A human's status in /humans/NAME/state: its current task's, or its last task's when it has
# none, or IDLE before its first task. Codes index this tuple.
IDLE = "IDLE"
STATUS_NAMES: tuple[str, ...] = (IDLE, *(status.value for status in TaskStatus))
STATUS_CODE = {name: code for code, name in enumerate(STATUS_NAMES)}
POSTURE_NAMES: tuple[str, ...] = tuple(posture.name for posture in Posture)

# foxglove.Log levels
LOG_INFO, LOG_WARNING, LOG_ERROR = 2, 3, 4


def human_pose_topic(name: str) -> str:
    return f"/humans/{name}/pose"


def human_state_topic(name: str) -> str:
    return f"/humans/{name}/state"


def robot_state_topic(name: str) -> str:
    return f"/robots/{name}/state"


def human_frame(name: str) -> str:
    return f"human/{name}"


def robot_frame(name: str) -> str:
    return f"robot/{name}"


# ---- JSON ------------------------------------------------------------------------------------


def dumps(value: Any) -> str:
    """Canonical JSON: sorted keys, compact, ASCII; NaN and infinities are refused."""
    return json.dumps(value, sort_keys=True, separators=(",", ":"), allow_nan=False)


def number(value: float) -> float:
    """A float as the log writes it: rounded to DECIMALS places, -0.0 made 0.0."""
    return round(float(value), DECIMALS) + 0.0


def nanoseconds(seconds: float) -> int:
    return round(seconds * 1e9)


def timestamp(ns: int) -> dict[str, int]:
    return {"nsec": ns % 1_000_000_000, "sec": ns // 1_000_000_000}


def timestamp_json(ns: int) -> str:
    return f'{{"nsec":{ns % 1_000_000_000},"sec":{ns // 1_000_000_000}}}'


def yaw_quaternion(heading: float) -> dict[str, float]:
    """A rotation about z by `heading` radians (x, y are 0)."""
    return {"w": number(math.cos(heading / 2.0)), "x": 0.0, "y": 0.0,
            "z": number(math.sin(heading / 2.0))}


def shape_json(shape: Circle | Ellipse | Rectangle) -> dict[str, Any]:
    if isinstance(shape, Circle):
        return {"shape": "circle", "radius": shape.radius}
    if isinstance(shape, Ellipse):
        return {"shape": "ellipse", "semi_major": shape.semi_major,
                "semi_minor": shape.semi_minor, "offset": shape.offset}
    return {"shape": "rectangle", "length": shape.length, "width": shape.width}


def shape_from_json(value: dict[str, Any]) -> Circle | Ellipse | Rectangle:
    kind = value.get("shape")
    if kind == "circle":
        return Circle(float(value["radius"]))
    if kind == "ellipse":
        return Ellipse(float(value["semi_major"]), float(value["semi_minor"]),
                       float(value["offset"]))
    if kind == "rectangle":
        return Rectangle(float(value["length"]), float(value["width"]))
    raise ValueError(f"unknown shape {kind!r}")


# ---- schemas ---------------------------------------------------------------------------------


@cache
def foxglove_schema(name: str) -> dict[str, Any]:
    """Foxglove's official JSON Schema of `name` (e.g. "foxglove.Grid"), as vendored."""
    text = resources.files("hubero_dsl.log").joinpath("foxglove", FOXGLOVE_FILES[name])
    schema: dict[str, Any] = json.loads(text.read_text(encoding="utf-8"))
    return schema


def schema_of(name: str) -> dict[str, Any]:
    """The JSON Schema embedded in the log for schema `name`, Foxglove's or hubero's."""
    if name in FOXGLOVE_FILES:
        return foxglove_schema(name)
    return {HUMAN_STATE: HUMAN_STATE_SCHEMA, CROWD_STATE: CROWD_STATE_SCHEMA,
            ROBOT_STATE: ROBOT_STATE_SCHEMA, TASK_EVENT: TASK_EVENT_SCHEMA}[name]


def schema_bytes(name: str) -> bytes:
    return dumps(schema_of(name)).encode("ascii")


_TIME = {"type": "object", "title": "time",
         "properties": {"sec": {"type": "integer", "minimum": 0},
                        "nsec": {"type": "integer", "minimum": 0, "maximum": 999999999}},
         "required": ["sec", "nsec"], "additionalProperties": False,
         "description": "Simulation time since the start of the run"}


def _vector2(description: str) -> dict[str, Any]:
    return {"type": "object", "description": description,
            "properties": {"x": {"type": "number"}, "y": {"type": "number"}},
            "required": ["x", "y"], "additionalProperties": False}


# what every body's state holds: when, where, how fast, which way
_BODY_STATE: dict[str, Any] = {
        "timestamp": _TIME,
        "position": _vector2("Position in the map frame, metres"),
        "velocity": _vector2("Velocity in the map frame, metres per second"),
        "heading": {"type": "number",
                    "description": "Heading in the map frame, radians, 0 along +x, "
                                   "counter-clockwise"},
}

HUMAN_STATE_SCHEMA: dict[str, Any] = {
    "title": HUMAN_STATE,
    "description": "One human's state at one tick of a hubero run",
    "type": "object",
    "properties": {
        **_BODY_STATE,
        "posture": {"enum": list(POSTURE_NAMES), "description": "Body posture"},
        "status": {"enum": list(STATUS_NAMES),
                   "description": "Status of the current task, or of the last one when the "
                                  "human has none (IDLE before the first)"},
        "fsm_state": {"type": "string",
                      "description": "State of the task's behaviour (walking, aligning, "
                                     "talking, ...); idle without a task"},
        "task": {"description": "The current task, null when the human has none",
                 "oneOf": [{"type": "null"}, {
                     "type": "object",
                     "properties": {"id": {"type": "integer"}, "kind": {"type": "string"},
                                    "description": {"type": "string"},
                                    "line": {"type": "integer", "minimum": 0,
                                             "description": "Source line of the step, 0 "
                                                            "when given through the API"}},
                     "required": ["id", "kind", "description", "line"],
                     "additionalProperties": False}]},
    },
    "required": ["timestamp", "position", "velocity", "heading", "posture", "status",
                 "fsm_state", "task"],
    "additionalProperties": False,
}


def _column(items: dict[str, Any], description: str) -> dict[str, Any]:
    return {"type": "array", "items": items, "description": description}


_NUMBERS = {"type": "number"}
CROWD_STATE_SCHEMA: dict[str, Any] = {
    "title": CROWD_STATE,
    "description": "The state of every member of a crowd or flow present at one tick of a "
                   "hubero run, as parallel arrays: element i of each is names[i]'s",
    "type": "object",
    "properties": {
        "timestamp": _TIME,
        "names": _column({"type": "string"}, "The members in the scene, in member order"),
        "x": _column(_NUMBERS, "Position x in the map frame, metres"),
        "y": _column(_NUMBERS, "Position y in the map frame, metres"),
        "vx": _column(_NUMBERS, "Velocity x in the map frame, metres per second"),
        "vy": _column(_NUMBERS, "Velocity y in the map frame, metres per second"),
        "heading": _column(_NUMBERS, "Heading in the map frame, radians, 0 along +x, "
                                     "counter-clockwise"),
        "posture": _column({"enum": list(POSTURE_NAMES)}, "Body posture"),
        "status": _column({"enum": list(STATUS_NAMES)},
                          "Status of the current task, or of the last one (IDLE before the "
                          "first)"),
        "fsm_state": _column({"type": "string"}, "State of the task's behaviour; idle "
                                                 "without a task"),
        "task_id": _column({"type": "integer"}, "The current task's id (its events are on "
                                                "/tasks), 0 when none"),
    },
    "required": ["timestamp", "names", "x", "y", "vx", "vy", "heading", "posture", "status",
                 "fsm_state", "task_id"],
    "additionalProperties": False,
}

ROBOT_STATE_SCHEMA: dict[str, Any] = {
    "title": ROBOT_STATE,
    "description": "One robot's state at one tick of a hubero run",
    "type": "object",
    "properties": {
        **_BODY_STATE,
        "controller": {"type": "string", "description": "The controller driving it"},
        "status": {"enum": list(STATUS_NAMES),
                   "description": "Status of the current task, or of the last one when the "
                                  "robot has none (IDLE before the first)"},
        "task": {"type": "string",
                 "description": "The current task's description, '' when it has none"},
    },
    "required": ["timestamp", "position", "velocity", "heading", "controller", "status",
                 "task"],
    "additionalProperties": False,
}

TASK_EVENT_SCHEMA: dict[str, Any] = {
    "title": TASK_EVENT,
    "description": "A status change of one task of a hubero run",
    "type": "object",
    "properties": {
        "timestamp": _TIME,
        "tick": {"type": "integer", "minimum": 0},
        "task_id": {"type": "integer"},
        "human": {"type": "string"},
        "kind": {"type": "string", "description": "The task: move_to, talk, ..."},
        "status": {"enum": [status.value for status in TaskStatus]},
        "reason": {"type": "string", "description": "Why it ended this way (may be empty)"},
        "file": {"type": "string", "description": "Scenario file of the step ('' for API "
                                                  "tasks)"},
        "line": {"type": "integer", "minimum": 0},
        "column": {"type": "integer", "minimum": 0},
        "end_line": {"type": "integer", "minimum": 0},
        "end_column": {"type": "integer", "minimum": 0},
        "source_line": {"type": "string", "description": "The step's line of source text"},
    },
    "required": ["timestamp", "tick", "task_id", "human", "kind", "status", "reason", "file",
                 "line", "column", "end_line", "end_column", "source_line"],
    "additionalProperties": False,
}


# ---- the map ---------------------------------------------------------------------------------

# Cell values of /map, as nav_msgs/OccupancyGrid has them (INT8 in foxglove.Grid).
FREE, OCCUPIED, UNKNOWN = 0, 100, -1
INT8 = 2  # foxglove.NumericType


def grid_message(grid: OccupancyGrid) -> dict[str, Any]:
    """The occupancy grid as a foxglove.Grid: row 0 is the lowest y, cells along +x."""
    cells = np.where(grid.occupied, OCCUPIED, FREE).astype(np.int8)
    if grid.unknown is not None:
        cells[grid.unknown] = UNKNOWN
    cols = grid.shape[1]
    return {
        "timestamp": timestamp(0),
        "frame_id": MAP_FRAME,
        "pose": {"position": {"x": float(grid.origin[0]), "y": float(grid.origin[1]), "z": 0.0},
                 "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}},
        "column_count": cols,
        "cell_size": {"x": float(grid.resolution), "y": float(grid.resolution)},
        "row_stride": cols,
        "cell_stride": 1,
        "fields": [{"name": "occupancy", "offset": 0, "type": INT8}],
        "data": base64.b64encode(np.ascontiguousarray(cells).tobytes()).decode("ascii"),
    }


def grid_from_message(message: dict[str, Any], source: str) -> OccupancyGrid:
    """The OccupancyGrid a /map message holds (the inverse of `grid_message`); LogError for a
    grid of more cells than a map may have, before its cells are decoded."""
    from hubero_dsl.world.grid import MAX_MAP_CELLS, OccupancyGrid

    cols = int(message["column_count"])
    count = _decoded_size(message["data"])
    if count > MAX_MAP_CELLS:
        raise LogError(f"{source}: a grid of {count:,} cells ({cols:,} a row), more than the "
                       f"{MAX_MAP_CELLS:,} a map may have: hubero does not read it")
    cells = np.frombuffer(base64.b64decode(message["data"], validate=True), dtype=np.int8)
    if cols <= 0 or len(cells) % cols or int(message["cell_stride"]) != 1:
        raise ValueError("map cells do not fill whole rows")
    cells = cells.reshape(-1, cols)
    position = message["pose"]["position"]
    unknown = cells == UNKNOWN
    return OccupancyGrid(cells != FREE, float(message["cell_size"]["x"]),
                         (float(position["x"]), float(position["y"])), source=source,
                         unknown=unknown if unknown.any() else None)


def _decoded_size(text: str) -> int:
    """How many bytes base64 `text` decodes to, without decoding it (a forged log may hold a
    few kilobytes that compress gigabytes of cells)."""
    return len(text) // 4 * 3 - text[-2:].count("=")
