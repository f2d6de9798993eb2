"""The measured experiments: their geometry, units, frame rates and steady states, read from the
file's name, and their trajectories loaded with PedPy.

    experiment = experiment_for(Path("uo-180-180-070.txt"))
    trajectory = load_trajectory(experiment)        # a pedpy.TrajectoryData, in metres

Two series are known. `uo-AAA-BBB-CCC` (Jülich, 2009): a corridor `BBB` cm wide and 8 m long
walked in -y, an entrance `AAA` cm wide at y = +4 m, an exit `CCC` cm wide and 0.3 m deep at
y = -4 m, both centred on the corridor (the entrance where tracking begins, y = 8 m: see
`_corridor`); coordinates in cm at 16 frames/s. `UNI_CORR_500`: a
corridor 5 m wide (walls y = 0 and y = 5 m) walked in -x; metres at 25 frames/s. The shipped
copies (`hubero_dsl/validation/data/`, see its README for licence and citation) are
xz-compressed; a path given by the user is read as the plain text PedPy reads.
"""

from __future__ import annotations

import lzma
import re
import tempfile
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from shapely.geometry import LineString, Polygon, box
from shapely.ops import unary_union

from hubero_dsl.errors import InputError
from hubero_dsl.files import regular_file

if TYPE_CHECKING:
    from shapely.geometry.base import BaseGeometry

MAX_TRAJECTORY_BYTES = 64 * 2**20  # a recording larger than this is refused, not read
# Frames a recording may span: over an hour at 25 frames/s, where experiments last minutes.
# PedPy's analyses build a row per frame of the span, so a forged frame number costs memory.
MAX_FRAMES = 100_000
# People who walk through the place cover most of its length along the walking direction; all
# of them within this share of it means coordinates in the wrong unit (100 times too small)
SCALE_SHARE = 0.1
SCALE_PEOPLE = 10
SHIPPED = ("uo-050-180-180", "uo-100-180-180", "uo-145-180-180", "uo-180-180-070",
           "uo-180-180-120", "traj_UNI_CORR_500_01")
# Frames in steady state, from the data's documentation; other files use every frame.
STEADY_FRAMES = {"uo-050-180-180": (211, 800), "uo-100-180-180": (200, 790),
                 "uo-145-180-180": (300, 1097), "uo-180-180-070": (500, 1399),
                 "uo-180-180-120": (300, 1099)}
PEDPY_HINT = "install it with: pip install 'hubero[validate]' (or pip install pedpy)"

_UO = re.compile(r"uo-(\d{3})-(\d{3})-(\d{3})")
_UNI = re.compile(r"UNI_CORR_(\d{3})")


@dataclass(frozen=True)
class Experiment:
    """One recording and the place it was made in, in metres.

    `walkable` is where people were tracked (PedPy's walkable area); `room` is the walkable
    space a rebuild simulates: `walkable` and `sink`: the entrance and, beyond the exit, a
    room people walk into and stay in, so that those who left never block the exit.
    `direction` is the unit vector of the walking direction."""

    name: str
    path: Path
    unit: str                 # "cm" or "m", as the file stores coordinates
    frame_rate: float         # frames per second
    walkable: Polygon
    sink: BaseGeometry
    measurement_area: Polygon
    measurement_line: LineString
    direction: tuple[float, float]
    steady: tuple[int, int] | None
    entrance_width: float
    exit_width: float
    free_flow: str            # the shipped recording of the series whose speeds are desired

    @property
    def room(self) -> BaseGeometry:
        return unary_union([self.walkable, self.sink])


def pedpy() -> Any:
    """The pedpy module, or InputError (exit 2) saying how to install it."""
    try:
        import pedpy as module
    except ImportError:
        raise InputError(f"hubero validate needs PedPy, which is not installed: "
                         f"{PEDPY_HINT}") from None
    return module


def shipped_path(name: str) -> Path:
    """The shipped copy of a recording (an .xz file inside the package)."""
    return Path(str(resources.files("hubero_dsl.validation") / "data" / f"{name}.txt.xz"))


def shipped() -> list[Experiment]:
    return [experiment_for(shipped_path(name)) for name in SHIPPED]


def experiment_for(path: Path) -> Experiment:
    """The experiment a file records, told by its name; InputError for a name of no series."""
    name = path.name.removesuffix(".xz").removesuffix(".txt")
    if (match := _UO.search(name)) is not None:
        entrance, width, exit_ = (int(group) / 100.0 for group in match.groups())
        return _corridor(name, path, entrance, width, exit_)
    if (match := _UNI.search(name)) is not None:
        return _wide_corridor(name, path, int(match.group(1)) / 100.0)
    raise InputError(f"{path}: cannot tell which experiment this is from its name: name it "
                     f"uo-AAA-BBB-CCC.txt (Jülich corridor, entrance/width/exit in cm, "
                     f"coordinates in cm at 16 fps) or traj_UNI_CORR_WWW_NN.txt (corridor WWW "
                     f"cm wide, metres at 25 fps)")


def _corridor(name: str, path: Path, entrance: float, width: float,
              exit_: float) -> Experiment:
    """The uo corridor: 8 m long, walked in -y, an entrance and an exit centred on it."""
    if not (0 < entrance <= width and 0 < exit_ <= width):
        raise InputError(f"{path}: entrance and exit ({entrance:g} m, {exit_:g} m) must be "
                         f"open and no wider than the corridor ({width:g} m)")
    centre, wide = width / 2, (-1.0, width + 1.0)
    walkable = unary_union([
        box(wide[0], 4.0, wide[1], 8.0),                           # before the corridor
        box(0.0, -4.0, width, 4.0),                                # the corridor
        box(centre - exit_ / 2, -4.3, centre + exit_ / 2, -4.0),   # the exit
        box(wide[0], -6.5, wide[1], -4.3),                         # after the exit
    ])
    # The entrance lies where tracking begins: people first appear at y = 7.7-8 m, and at
    # y = 4 m they already spread wider than AAA (1.2 m in uo-050), so it is not there.
    entrance_door = box(centre - entrance / 2, 8.0, centre + entrance / 2, 8.3)
    sink = unary_union([entrance_door, box(centre - 5.0, -16.0, centre + 5.0, -6.5)])
    return Experiment(name=name, path=path, unit="cm", frame_rate=16.0,
                      walkable=_polygon(walkable), sink=sink,
                      measurement_area=box(0.0, -2.0, width, 0.0),
                      measurement_line=LineString([(0.0, 0.0), (width, 0.0)]),
                      direction=(0.0, -1.0), steady=STEADY_FRAMES.get(name),
                      entrance_width=entrance, exit_width=exit_, free_flow="uo-050-180-180")


def _wide_corridor(name: str, path: Path, width: float) -> Experiment:
    """UNI_CORR: walls at y = 0 and y = width, walked in -x from x = 4.7 to -5.5 m."""
    walkable = box(-6.0, 0.0, 5.5, width)
    sink = box(-18.0, -2.0, -6.0, width + 2.0)
    return Experiment(name=name, path=path, unit="m", frame_rate=25.0, walkable=walkable,
                      sink=sink, measurement_area=box(-1.0, 0.0, 1.0, width),
                      measurement_line=LineString([(0.0, 0.0), (0.0, width)]),
                      direction=(-1.0, 0.0), steady=None,
                      entrance_width=width, exit_width=width,
                      free_flow="traj_UNI_CORR_500_01")


def _polygon(geometry: BaseGeometry) -> Polygon:
    if not isinstance(geometry, Polygon):  # the parts above always touch: one polygon
        raise AssertionError(f"corridor is not one polygon: {geometry.geom_type}")
    return geometry


def load_trajectory(experiment: Experiment) -> Any:
    """The recording as a pedpy.TrajectoryData (metres), read by PedPy's own loader.

    InputError for a file that is missing, not regular, too large or not a trajectory."""
    module = pedpy()
    path = experiment.path
    regular_file(path, "trajectory file")
    if path.stat().st_size > MAX_TRAJECTORY_BYTES:
        raise InputError(f"trajectory file {path} is larger than "
                         f"{MAX_TRAJECTORY_BYTES // 2**20} MiB, the most hubero reads")
    unit = (module.TrajectoryUnit.CENTIMETER if experiment.unit == "cm"
            else module.TrajectoryUnit.METER)
    with tempfile.TemporaryDirectory(prefix="hubero-validate-") as folder:
        text_path = path
        if path.suffix == ".xz":
            text_path = Path(folder) / path.stem
            text_path.write_bytes(lzma.decompress(path.read_bytes()))
        try:
            trajectory = module.load_trajectory(trajectory_file=text_path,
                                                default_frame_rate=experiment.frame_rate,
                                                default_unit=unit)
        except (module.PedPyError, ValueError, OSError, lzma.LZMAError) as exc:
            raise InputError(f"{path}: not a trajectory file PedPy can read: "
                             f"{_first_line(exc)}") from None
    if len(trajectory.data) == 0:
        raise InputError(f"{path}: the trajectory file holds no positions")
    _check_positions(trajectory, experiment)
    return trajectory


def _check_positions(trajectory: Any, experiment: Experiment) -> None:
    """InputError for a recording PedPy's analyses cannot take: a span of more than
    `MAX_FRAMES` frames, a person at two places in one frame, a position outside the
    experiment's walkable area (PedPy's Voronoi cells need every point inside it, which also
    rules out positions that are not finite or absurdly far), or nobody in its steady frames."""
    unreadable = f"{experiment.path}: not a trajectory file hubero can read"
    data = trajectory.data
    frames = data["frame"]
    if frames.max() - frames.min() >= MAX_FRAMES:
        raise InputError(f"{unreadable}: its frames span {frames.min()} to {frames.max()}, "
                         f"more than {MAX_FRAMES:,} frames")
    twice = data[data.duplicated(["id", "frame"])]
    if len(twice):
        raise InputError(f"{unreadable}: person {twice['id'].iloc[0]} has two positions in "
                         f"frame {twice['frame'].iloc[0]}")
    p = pedpy()
    walkable = p.WalkableArea(list(experiment.walkable.exterior.coords)[:-1])
    outside = p.get_invalid_trajectory(traj_data=trajectory, walkable_area=walkable)
    if len(outside):
        first = outside.iloc[0]
        raise InputError(f"{unreadable}: {len(outside)} of its positions lie outside the "
                         f"{experiment.name} experiment's walkable area (the first: person "
                         f"{first['id']}, frame {first['frame']}, at ({first['x']:g}, "
                         f"{first['y']:g}) m)")
    _check_scale(data, experiment, unreadable)
    if experiment.steady is not None:
        first_frame, last_frame = experiment.steady
        if not ((frames >= first_frame) & (frames <= last_frame)).any():
            raise InputError(f"{unreadable}: nobody is measured in the steady frames "
                             f"{first_frame}-{last_frame} of {experiment.name}")


def _check_scale(data: Any, experiment: Experiment, unreadable: str) -> None:
    """InputError for a recording of SCALE_PEOPLE or more whose people all stay within a tenth
    of the place's length along the walking direction: its coordinates are not in the series'
    unit (a file in metres read as centimetres is a hundred times too small, and lies inside
    the place). Fewer people say too little to judge by."""
    if data["id"].nunique() < SCALE_PEOPLE:
        return
    along = np.asarray(experiment.direction)
    walked = data[["x", "y"]].to_numpy() @ along
    place = np.asarray(experiment.walkable.exterior.coords) @ along
    if np.ptp(walked) < SCALE_SHARE * np.ptp(place):
        raise InputError(f"{unreadable}: its people span only {np.ptp(walked):.3g} m along the "
                         f"walking direction of a place {np.ptp(place):.3g} m long; are its "
                         f"coordinates in {experiment.unit}, as the {experiment.name} "
                         f"series stores them?")


def _first_line(exc: BaseException) -> str:
    text = str(getattr(exc, "message", None) or exc).strip()
    return text.splitlines()[0] if text else type(exc).__name__
