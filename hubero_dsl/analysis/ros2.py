"""A run log as a ROS 2 bag: standard messages a ROS 2 stack already reads.

`export_ros2(log, folder)` writes a rosbag2 (MCAP storage, with its `metadata.yaml`) with the
`rosbags` library, typed for ROS 2 Humble:

| topic | type | when |
|---|---|---|
| `/clock` | `rosgraph_msgs/msg/Clock` | every frame |
| `/map` | `nav_msgs/msg/OccupancyGrid` | once, at time 0 (offered transient local) |
| `/tf` | `tf2_msgs/msg/TFMessage` | every frame: `human/NAME` and `robot/NAME` in `map` |
| `/people` | `people_msgs/msg/People` | every frame: name, position, velocity |
| `/people/poses`, `/robots/poses` | `geometry_msgs/msg/PoseArray` | every frame |
| `/people/markers` | `visualization_msgs/msg/MarkerArray` | every frame |

Stamps are simulated time (the bag starts at 0 s, as the log does) and `/clock` carries it, so
`ros2 bag play --clock` drives a stack with `use_sim_time`. The occupancy grid is ROS's: 0 free,
100 occupied, -1 unknown. The markers replace the picture each frame (a DELETEALL first, then
a body cylinder, a personal-space outline and a name per human, a cylinder per robot), so the
people who leave a run (flows) disappear. `people_msgs` is not in ROS's core: its types are
registered from the .msg text of the `people` package (wg-perception/people).

The bag is written into a temporary folder beside `folder` and renamed into place at the end:
an export that fails leaves nothing under the name.
"""

from __future__ import annotations

import math
from collections import defaultdict
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from hubero_dsl.errors import InputError
from hubero_dsl.files import scratch_folder_beside
from hubero_dsl.log import schemas as s
from hubero_dsl.log.reader import LoggedRun, load_run
from hubero_dsl.world.personal_space import outline
from hubero_dsl.world.shapes import Circle, Shape

if TYPE_CHECKING:
    from rosbags.rosbag2 import Writer
    from rosbags.typesys.store import Typestore

FloatArray = npt.NDArray[np.float64]

PERSON_MSG = """string name
geometry_msgs/Point position
geometry_msgs/Point velocity
float64 reliability
string[] tagnames
string[] tags
"""
PEOPLE_MSG = """std_msgs/Header header
people_msgs/Person[] people
"""
BODY_HEIGHT = 1.7   # m, as the log's scene draws a standing person
ROBOT_HEIGHT = 0.5
OUTLINE_POINTS = 32
DEFAULT_RADIUS = 0.2  # m, a body whose radius the log does not give
# visualization_msgs/msg/Marker's constants (its .msg definition)
ARROW, CYLINDER, LINE_STRIP, TEXT_VIEW_FACING = 0, 3, 4, 9
ADD, DELETEALL = 0, 3


@dataclass(frozen=True)
class Body:
    """One human or robot at one frame."""

    name: str
    kind: str           # "human" or "robot"
    x: float
    y: float
    heading: float
    vx: float
    vy: float
    radius: float
    shape: Shape | None  # the personal space (humans)


def export_ros2(log: str | Path, folder: str | Path) -> Path:
    """Write the run in `log` as a rosbag2 in `folder` (which must not exist, or be empty)."""
    try:
        from rosbags.rosbag2 import StoragePlugin, Writer
    except ImportError:
        raise InputError("exporting a ROS 2 bag needs the rosbags package: "
                         "pip install 'hubero[ros]'") from None
    named = Path(folder)
    if named.is_symlink() and not named.exists():
        raise InputError(f"{named} is a symbolic link to {named.readlink()}, which does not "
                         "exist: give a new folder, or link to an empty one")
    if named.exists() and (not named.is_dir() or any(named.iterdir())):
        raise InputError(f"{named} exists and is not an empty folder: a bag is written into "
                         "a new folder")
    run = load_run(log)
    target = named.resolve()   # a link to an empty folder: the bag goes where it leads
    parent = target.parent
    if not parent.is_dir():
        what = "is not a folder" if parent.exists() else "does not exist"
        raise InputError(f"cannot write {named}: {parent} {what}")
    with scratch_folder_beside(target, shown=named) as work:
        bag = work / "bag"
        with Writer(bag, version=8, storage_plugin=StoragePlugin.MCAP) as writer:
            _write(writer, run, _typestore())
        if target.exists():
            target.rmdir()
        bag.rename(target)
    return named


def _typestore() -> Typestore:
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    typestore = get_typestore(Stores.ROS2_HUMBLE)
    typestore.register({**get_types_from_msg(PERSON_MSG, "people_msgs/msg/Person"),
                        **get_types_from_msg(PEOPLE_MSG, "people_msgs/msg/People")})
    return typestore


def _write(writer: Writer, run: LoggedRun, typestore: Typestore) -> None:
    from rosbags.interfaces import (
        Qos,
        QosDurability,
        QosHistory,
        QosLiveliness,
        QosReliability,
        QosTime,
    )

    never = QosTime(0, 0)
    latched = Qos(history=QosHistory.KEEP_LAST, depth=1, reliability=QosReliability.RELIABLE,
                  durability=QosDurability.TRANSIENT_LOCAL, deadline=never, lifespan=never,
                  liveliness=QosLiveliness.AUTOMATIC, liveliness_lease_duration=never,
                  avoid_ros_namespace_conventions=False)
    messages = _Messages(typestore)
    topics = {"/clock": "rosgraph_msgs/msg/Clock", "/tf": "tf2_msgs/msg/TFMessage",
              "/people": "people_msgs/msg/People", "/people/poses": "geometry_msgs/msg/PoseArray",
              "/robots/poses": "geometry_msgs/msg/PoseArray",
              "/people/markers": "visualization_msgs/msg/MarkerArray"}
    map_connection = writer.add_connection("/map", "nav_msgs/msg/OccupancyGrid",
                                           typestore=typestore, offered_qos_profiles=[latched])
    connections = {topic: writer.add_connection(topic, kind, typestore=typestore)
                   for topic, kind in topics.items()}
    writer.write(map_connection, 0, typestore.serialize_cdr(
        messages.grid(run), "nav_msgs/msg/OccupancyGrid"))
    for ns, bodies in _frames(run):
        stamp = messages.time(ns)
        for topic, message in (("/clock", messages.clock(stamp)),
                               ("/tf", messages.transforms(stamp, bodies)),
                               ("/people", messages.people(stamp, bodies)),
                               ("/people/poses", messages.poses(stamp, bodies, "human")),
                               ("/robots/poses", messages.poses(stamp, bodies, "robot")),
                               ("/people/markers", messages.markers(stamp, bodies))):
            writer.write(connections[topic], ns, typestore.serialize_cdr(message, topics[topic]))


def _frames(run: LoggedRun) -> list[tuple[int, list[Body]]]:
    """Every frame of the run (nanoseconds, with the bodies present then), in time order:
    frames nobody is in too (a flow's people not come yet, or all gone)."""
    params = run.metadata.params
    at: dict[int, list[Body]] = defaultdict(list, {ns: [] for ns in run.frames.tolist()})
    for name, track in run.humans.items():
        radius = float(params.get(name, {}).get("radius", DEFAULT_RADIUS))  # type: ignore[arg-type]
        shape = params.get(name, {}).get("personal_space")
        space = shape if isinstance(shape, Shape) else Circle(radius)
        for i, ns in enumerate(np.rint(track.time * 1e9).astype(np.int64).tolist()):
            (x, y), (vx, vy) = track.position[i].tolist(), track.velocity[i].tolist()
            at[ns].append(Body(name, "human", x, y, float(track.heading[i]), vx, vy, radius,
                               space))
    for name, robot in run.robots.items():
        for i, ns in enumerate(np.rint(robot.time * 1e9).astype(np.int64).tolist()):
            x, y = robot.position[i].tolist()  # the log keeps robots' positions only
            at[ns].append(Body(name, "robot", x, y, float(robot.heading[i]), 0.0, 0.0,
                               robot.radius or DEFAULT_RADIUS, None))
    return sorted(at.items())


class _Messages:
    """Builds the ROS messages of a frame with the typestore's classes."""

    def __init__(self, typestore: Typestore) -> None:
        self.types = typestore.types

    def _new(self, kind: str, **fields: Any) -> Any:
        return self.types[kind](**fields)

    def time(self, ns: int) -> Any:
        return self._new("builtin_interfaces/msg/Time", sec=ns // 1_000_000_000,
                         nanosec=ns % 1_000_000_000)

    def header(self, stamp: Any) -> Any:
        return self._new("std_msgs/msg/Header", stamp=stamp, frame_id=s.MAP_FRAME)

    def point(self, x: float, y: float, z: float = 0.0) -> Any:
        return self._new("geometry_msgs/msg/Point", x=x, y=y, z=z)

    def pose(self, x: float, y: float, heading: float, z: float = 0.0) -> Any:
        return self._new("geometry_msgs/msg/Pose", position=self.point(x, y, z),
                         orientation=self._quaternion(heading))

    def _quaternion(self, heading: float) -> Any:
        return self._new("geometry_msgs/msg/Quaternion", x=0.0, y=0.0,
                         z=math.sin(heading / 2), w=math.cos(heading / 2))

    def clock(self, stamp: Any) -> Any:
        return self._new("rosgraph_msgs/msg/Clock", clock=stamp)

    def grid(self, run: LoggedRun) -> Any:
        grid = run.grid
        cells = np.where(grid.occupied, 100, 0).astype(np.int8)
        if grid.unknown is not None:
            cells[grid.unknown] = -1
        rows, cols = grid.shape
        info = self._new("nav_msgs/msg/MapMetaData", map_load_time=self.time(0),
                         resolution=grid.resolution, width=cols, height=rows,
                         origin=self.pose(grid.origin[0], grid.origin[1], 0.0))
        return self._new("nav_msgs/msg/OccupancyGrid", header=self.header(self.time(0)),
                         info=info, data=cells.reshape(-1))

    def transforms(self, stamp: Any, bodies: list[Body]) -> Any:
        return self._new("tf2_msgs/msg/TFMessage", transforms=[self._new(
            "geometry_msgs/msg/TransformStamped", header=self.header(stamp),
            child_frame_id=f"{b.kind}/{b.name}",
            transform=self._new("geometry_msgs/msg/Transform",
                                translation=self._new("geometry_msgs/msg/Vector3",
                                                      x=b.x, y=b.y, z=0.0),
                                rotation=self._quaternion(b.heading)))
            for b in bodies])

    def people(self, stamp: Any, bodies: list[Body]) -> Any:
        return self._new("people_msgs/msg/People", header=self.header(stamp), people=[
            self._new("people_msgs/msg/Person", name=b.name, position=self.point(b.x, b.y),
                      velocity=self.point(b.vx, b.vy), reliability=1.0, tagnames=[], tags=[])
            for b in bodies if b.kind == "human"])

    def poses(self, stamp: Any, bodies: list[Body], kind: str) -> Any:
        return self._new("geometry_msgs/msg/PoseArray", header=self.header(stamp), poses=[
            self.pose(b.x, b.y, b.heading) for b in bodies if b.kind == kind])

    def markers(self, stamp: Any, bodies: list[Body]) -> Any:
        markers = [self._marker(stamp, "all", 0, ARROW, action=DELETEALL)]
        for index, body in enumerate(bodies):
            height = BODY_HEIGHT if body.kind == "human" else ROBOT_HEIGHT
            colour = (0.2, 0.7, 0.3) if body.kind == "human" else (0.35, 0.35, 0.45)
            markers.append(self._marker(
                stamp, f"{body.kind}s", 3 * index, CYLINDER,
                self.pose(body.x, body.y, body.heading, height / 2),
                (2 * body.radius, 2 * body.radius, height), colour))
            markers.append(self._marker(
                stamp, "labels", 3 * index + 1, TEXT_VIEW_FACING,
                self.pose(body.x, body.y, 0.0, height + 0.3), (0.3, 0.3, 0.3), (1, 1, 1),
                text=body.name))
            if body.shape is not None:
                ring = outline(body.shape, (body.x, body.y), body.heading, OUTLINE_POINTS)
                markers.append(self._marker(
                    stamp, "personal_spaces", 3 * index + 2, LINE_STRIP,
                    self.pose(0.0, 0.0, 0.0), (0.02, 0.0, 0.0), (0.3, 0.5, 1.0),
                    points=[self.point(x, y, 0.02) for x, y in [*ring, ring[0]]]))
        return self._new("visualization_msgs/msg/MarkerArray", markers=markers)

    def _marker(self, stamp: Any, ns: str, ident: int, kind: int, pose: Any = None,
                scale: tuple[float, float, float] = (1.0, 1.0, 1.0),
                colour: tuple[float, float, float] = (1.0, 1.0, 1.0), *, text: str = "",
                points: list[Any] | None = None, action: int = ADD) -> Any:
        marker = self.types["visualization_msgs/msg/Marker"]
        return marker(
            header=self.header(stamp), ns=ns, id=ident, type=kind, action=action,
            pose=pose if pose is not None else self.pose(0.0, 0.0, 0.0),
            scale=self._new("geometry_msgs/msg/Vector3", x=scale[0], y=scale[1], z=scale[2]),
            color=self._new("std_msgs/msg/ColorRGBA", r=colour[0], g=colour[1], b=colour[2],
                            a=1.0),
            lifetime=self._new("builtin_interfaces/msg/Duration", sec=0, nanosec=0),
            frame_locked=False, points=points or [], colors=[], texture_resource="",
            texture=self._new("sensor_msgs/msg/CompressedImage",
                              header=self.header(self.time(0)), format="",
                              data=np.zeros(0, dtype=np.uint8)),
            uv_coordinates=[], text=text, mesh_resource="",
            mesh_file=self._new("visualization_msgs/msg/MeshFile", filename="",
                                data=np.zeros(0, dtype=np.uint8)),
            mesh_use_embedded_materials=False)
