"""The human parameters of the language: their names, dimensions, defaults and valid ranges.

This table is shared by the checker (which validates what a scenario writes) and by the engine
(which resolves the values a run uses). Planner-specific parameters (`social_force.A`) are
declared by each planner's own pydantic model, not here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import StrEnum

from hubero_dsl.model.units import Dimension
from hubero_dsl.world.shapes import Circle, Shape


class ParamKind(StrEnum):
    QUANTITY = "quantity"   # a number with a unit (or a distribution of them)
    SHAPE = "shape"         # a personal-space shape
    PLANNER = "planner"     # the name of a registered planner
    CHOICE = "choice"       # one of a few names


@dataclass(frozen=True, slots=True)
class ParamSpec:
    name: str
    kind: ParamKind
    doc: str
    dimension: Dimension = Dimension.NUMBER
    default: float | str | Shape = 0.0
    positive: bool = True          # must be > 0 (quantities)
    maximum: float = math.inf      # inclusive upper bound, SI
    choices: tuple[str, ...] = ()  # the names a CHOICE takes


def _q(name: str, dim: Dimension, default: float, doc: str, *, maximum: float = math.inf,
       positive: bool = True) -> ParamSpec:
    return ParamSpec(name, ParamKind.QUANTITY, doc, dim, default, positive, maximum)


# A seed has at most this many digits, in a file and on the command line alike: any longer is
# no seed anyone means (and int() of thousands of digits raises).
SEED_DIGITS = 18

# m: a person this far pushes with a force that decays over tenths of a metre (social force's
# B), so nothing measurable, while a crowd's pairs within the range grow with its square
INTERACTION_RANGE_MAX = 10.0

# How a human reacts to robots, as HuNavSim's agents do (docs/language.md, "Robot reactions").
REACTIONS = ("regular", "impassive", "surprised", "curious", "scared", "threatening")

HUMAN_PARAMS: dict[str, ParamSpec] = {spec.name: spec for spec in (
    _q("speed", Dimension.SPEED, 1.29, "desired walking speed (Moussaid et al. 2009)"),
    _q("max_speed", Dimension.SPEED, 1.8, "the most others' push raises a walker's speed to "
       "(never below the speed it is asked to walk at)"),
    _q("run_speed", Dimension.SPEED, 3.0, "desired speed of run_to"),
    _q("radius", Dimension.LENGTH, 0.2, "body radius: the part that collides", maximum=2.0),
    ParamSpec("personal_space", ParamKind.SHAPE, "personal-space shape, aligned with the heading",
              default=Circle(0.5)),
    _q("relaxation_time", Dimension.TIME, 0.54, "how fast velocity adapts (Helbing 1995)"),
    _q("goal_tolerance", Dimension.LENGTH, 0.2, "how close counts as arrived"),
    _q("goal_strength", Dimension.NUMBER, 1.0, "motivation to reach the goal (gain)"),
    _q("avoidance_strength", Dimension.NUMBER, 1.0, "desire to avoid other people (gain)",
       positive=False),
    _q("obstacle_strength", Dimension.NUMBER, 1.0, "repulsion from walls and furniture (gain)",
       positive=False),
    _q("interaction_range", Dimension.LENGTH, 3.0, "people further away are ignored",
       maximum=INTERACTION_RANGE_MAX),
    _q("field_of_view", Dimension.ANGLE, math.radians(200.0), "angle people are seen within",
       maximum=2 * math.pi),
    _q("follow_replan", Dimension.TIME, 1.0, "how often follow re-plans its path"),
    ParamSpec("global_planner", ParamKind.PLANNER, "global planner plugin", default="navfn"),
    ParamSpec("local_planner", ParamKind.PLANNER, "local planner plugin", default="social_force"),
    ParamSpec("robot_reaction", ParamKind.CHOICE, "how the human reacts to robots (HuNavSim's "
              "reactions)", default="regular", choices=REACTIONS),
)}

ROBOT_PARAMS: dict[str, ParamSpec] = {spec.name: spec for spec in (
    _q("radius", Dimension.LENGTH, 0.3, "robot body radius", maximum=5.0),
    _q("speed", Dimension.SPEED, 0.5, "cruise speed: along the scripted path, and the "
       "navigator's desired speed"),
    _q("max_speed", Dimension.SPEED, math.inf, "speed never exceeded, whatever the controller "
       "asks (unlimited unless set)"),
    _q("max_acceleration", Dimension.ACCELERATION, math.inf, "how fast the speed may change "
       "(unlimited unless set; a bare number is in m/s^2)"),
    _q("max_angular_speed", Dimension.ANGULAR_SPEED, math.inf, "how fast a unicycle robot may "
       "turn (unlimited unless set; a bare number is in rad/s)"),
    _q("goal_tolerance", Dimension.LENGTH, 0.2, "how close counts as arrived for move_to"),
    _q("sensor_range", Dimension.LENGTH, 5.0, "people and robots further away are not seen by "
       "the controller"),
    _q("field_of_view", Dimension.ANGLE, 2 * math.pi, "angle the controller sees people within",
       maximum=2 * math.pi),
)}

KINEMATICS = ("holonomic", "unicycle")  # `kinematics NAME`: how a robot's commands move it
