"""The social force local planner (Helbing & Molnar 1995), vectorised over the whole crowd.

Each steered human i accelerates by the sum of

* a goal term: relaxation towards the desired velocity, with an arrival slow-down
  (`direct.goal_acceleration`);
* social repulsion from every neighbour j within its interaction range,
  A * exp((r_ij - d_ij) / B) along the line from j to i, where r_ij is the extent of i's
  personal space towards j (at i's heading) plus j's body radius: an ellipse pushes people
  further away in front than beside, and a larger personal space keeps people further apart.
  The push is weighted by where j appears in i's view, lambda + (1 - lambda)(1 + cos phi)/2,
  and further by `outside_view_weight` when j is outside the field of view;
* repulsion from walls read off the grid's distance field, A_wall * exp((radius - clearance)
  / B_wall) along the direction away from the nearest obstacle (body radius only: comfort
  around walls is the global planner's business);
* body contact (Helbing, Farkas & Vicsek 2000): a normal push k * overlap and sliding friction
  kappa * overlap * (relative tangential velocity), against bodies and walls alike.

Two additions to the 1995 model make head-on encounters work: pushes between people (and from
robots) are computed at the pair's closest approach within `anticipation` seconds at their
current velocities (collision prediction in the spirit of Zanlungo, Ikeda & Kanda 2011), so
people on a collision course turn aside early; and a small `side_preference` sidestep breaks the
deadlock of two people walking exactly at each other. Where two streams meet (a corridor
walked both ways), `oncoming_side_preference` has people keep to the right of those coming the
other way, from a few metres before they meet, as pedestrians do (Moussaid et al. 2009
measured the preference for one side in face-to-face avoidance), so that the streams lock up
head-on less often. It is off by default. A last guard removes any velocity that would carry a
body into a wall within the step.

Robots are rows of the crowd that repel humans and are never steered. Neighbours come from a
k-d tree (`neighbours.py`), so a tick costs O(N) in the number of close pairs; each pair's
geometry is computed once and applied both ways; there is no loop over humans or pairs; and
pair terms are summed per row, so the result does not depend on row order. Parameters that are
the same for everyone are kept as scalars, which spares a gather per pair in the common case.

Units: the model is written as accelerations (per unit mass), so A and A_wall are in m/s^2,
k in 1/s^2 and kappa in 1/(m s). Defaults: A = 2.1 and B = 0.3 m take Helbing & Molnar's
(1995) V0 = 2.1 m^2/s^2 and sigma = 0.3 m as the push at the edge of the personal space and its
decay length; A_wall = 10 takes their U0 = 10 m^2/s^2 likewise, and B_wall = 0.08 m is Helbing,
Farkas & Vicsek's (2000) decay length for walls (JuPedSim's too): Helbing & Molnar's R = 0.2 m
pushes a walker back from both jambs of a door 0.6 m wide harder than its drive pulls it on;
k = 1500 and kappa = 3000 are Helbing, Farkas & Vicsek's (2000) k = 1.2e5 kg/s^2 and
kappa = 2.4e5 kg/(m s) for an 80 kg pedestrian. Outside the field of view Helbing & Molnar
weigh influences by c = 0.5; here the anisotropy lambda already weakens what is behind, so
what is outside the view is damped further, by 0.2 by default. lambda = 0.35 is a moderate
choice of ours: someone straight behind counts about a third as much as someone straight
ahead. The goal term's relaxation time comes from the Drive (0.54 s by default, after Helbing
& Molnar's 0.5 s).

Stability at dt = 0.05 s: the contact terms are stiff (k dt^2 = 3.75 with the literature value),
so per step the stiffness is capped at k dt^2 <= 0.5 and the friction rate at
kappa * overlap * dt <= 0.5; with these an explicit step cannot overshoot an overlap, and speeds
are clipped to max_speed in any case.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, fields, replace
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np
import numpy.typing as npt
from pydantic import ConfigDict, Field, JsonValue

from hubero_dsl.planners.base import Crowd, Drive, PlannerParams
from hubero_dsl.planners.direct import (
    ARRIVAL_RADIUS,
    ARRIVAL_RADIUS_DOC,
    check_drive,
    clip_speed,
    goal_acceleration,
    params_as,
)
from hubero_dsl.planners.neighbours import NeighbourPairs, PairFinder, closest_approach
from hubero_dsl.world.personal_space import extent_in_body_frame
from hubero_dsl.world.shapes import ShapeArrays, ShapeKind

if TYPE_CHECKING:
    from hubero_dsl.world.grid import OccupancyGrid

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]
BoolArray = npt.NDArray[np.bool_]
# A per-row quantity: one float when it is the same for every row (the common case, which
# spares a gather per pair), else an array indexed by Crowd row.
Column = FloatArray | float
# The push of each pair in one direction, (x, y).
Pushes = tuple[FloatArray, FloatArray]

# Largest exponent of the repulsion terms: beyond it the push is already far above anything
# max_speed lets through, and exp() must not overflow to inf (inf * 0 would be NaN).
_MAX_EXPONENT = 30.0
# Walls further than this many B_wall beyond the body push less than A_wall * e^-12: skipped.
_WALL_REACH_IN_B = 12.0
# Per-step caps on the contact terms (see the module docstring).
_STIFFNESS_STEP_CAP = 0.5
_FRICTION_STEP_CAP = 0.5
# Up to this many close pairs both directions are pushed in one pass (see `_PairPush.both_ways`).
_JOINED_PAIRS = 64
_ONCOMING_REACH = 2.0  # m over which keeping to one side of the oncoming fades
_CIRCLE = int(ShapeKind.CIRCLE)  # a plain int compares with arrays faster than the enum


# The dimension of a parameter, for tools that show or convert values.
_LENGTH: dict[str, JsonValue] = {"dimension": "length"}
_TIME: dict[str, JsonValue] = {"dimension": "time"}
_ACCELERATION: dict[str, JsonValue] = {"dimension": "acceleration"}


class SocialForceParams(PlannerParams):
    """Parameters of the social force planner, in acceleration form (per unit mass)."""

    model_config = ConfigDict(extra="forbid", frozen=True, populate_by_name=True)

    A: float = Field(default=2.1, ge=0.0, json_schema_extra=_ACCELERATION, description=(
        "Push from a person at the edge of one's personal space, m/s^2 (Helbing & Molnar "
        "1995: V0 = 2.1)."))
    B: float = Field(default=0.3, gt=0.0, json_schema_extra=_LENGTH, description=(
        "Decay length of the push from people, m (Helbing & Molnar 1995: sigma = 0.3 m)."))
    A_wall: float = Field(default=10.0, ge=0.0, json_schema_extra=_ACCELERATION, description=(
        "Push from a wall touching the body, m/s^2 (Helbing & Molnar 1995: U0 = 10)."))
    B_wall: float = Field(default=0.08, gt=0.0, json_schema_extra=_LENGTH, description=(
        "Decay length of the push from walls, m (Helbing, Farkas & Vicsek 2000: B = 0.08 m)."))
    lambda_: float = Field(default=0.35, alias="lambda", ge=0.0, le=1.0, description=(
        "Anisotropy: weight of a person straight behind relative to one straight ahead "
        "(1 = isotropic). Written `lambda` in scenarios."))
    outside_view_weight: float = Field(default=0.2, ge=0.0, le=1.0, description=(
        "Extra weight of people outside the field of view (Helbing & Molnar 1995 use 0.5)."))
    k: float = Field(default=1500.0, ge=0.0, description=(
        "Body compression per metre of overlap, 1/s^2 (Helbing et al. 2000: 1.2e5 kg/s^2 "
        "for 80 kg). The step caps it for stability: k dt^2 <= 0.5, so at most 0.5 / dt^2 "
        "acts (200 at 50 ms, 5000 at 10 ms); the default 1500 acts in full below 18 ms."))
    kappa: float = Field(default=3000.0, ge=0.0, description=(
        "Sliding friction per metre of overlap, 1/(m s) (Helbing et al. 2000: 2.4e5 kg/(m s) "
        "for 80 kg). The step caps it for stability: kappa * overlap * dt <= 0.5, so it acts "
        "in full only on overlaps below 0.5 / (kappa dt) (3.3 mm at 3000 and 50 ms)."))
    arrival_radius: float = Field(default=ARRIVAL_RADIUS, gt=0.0, json_schema_extra=_LENGTH,
                                  description=ARRIVAL_RADIUS_DOC)
    side_preference: float = Field(default=0.1, ge=-1.0, le=1.0, description=(
        "Sidestep to the right from someone ahead, as a fraction of their push (negative: to "
        "the left); breaks the deadlock of people walking dead-on at each other."))
    oncoming_side_preference: float = Field(default=0.0, ge=-1.0, le=1.0, description=(
        "Keeping to the right of people who walk the other way (negative: to the left): a "
        "sidestep of this fraction of A (times avoidance_strength) from someone ahead within "
        "interaction_range, as strong as their ways are opposed, falling as exp(-d / 2 m) "
        "with d their distance at closest approach; with 1 two streams in a corridor lock up "
        "less often. 0 (the default) leaves it out."))
    anticipation: float = Field(default=0.5, ge=0.0, json_schema_extra=_TIME, description=(
        "Horizon of collision prediction, s: people and robots push from where they will be "
        "closest within it at the current velocities (0 = the plain distance of Helbing & "
        "Molnar)."))
    space_at_rest: float = Field(default=1.0, ge=0.0, le=1.0, description=(
        "Share of the personal space beyond the body that someone standing still keeps; it "
        "grows with speed to the whole at the desired speed (1 = always whole; below 1, "
        "people in a slow, dense crowd close up, as in Chraibi et al.'s 2010 speed-dependent "
        "body)."))
    time_gap: float = Field(default=0.0, ge=0.0, le=10.0, json_schema_extra=_TIME,
                            description=(
        "Time gap kept to whoever is in one's path, s: the desired speed is capped at the "
        "distance one can walk towards the target before touching them, divided by it "
        "(Tordeux, Chraibi & Seyfried's 2016 collision-free speed model; 0 = no cap)."))
    time_gap_lane: float = Field(default=1.0, gt=0.0, le=1.0, description=(
        "Half-width of the lane ahead in which someone sets the time gap, as a share of the "
        "two bodies' radii: 1 = anyone one would touch walking on (the corridor of Tordeux et "
        "al.'s model); 0.5 = only someone whose centre is within about a body's width of "
        "one's line, so that people in a bottleneck follow in staggered lanes closer than "
        "their shoulders (the zipper effect, Hoogendoorn & Daamen 2005)."))

    @classmethod
    def inert_above(cls, step: float) -> dict[str, float]:
        # kappa's cap depends on the overlap as well, so no single value of it is inert
        return {"k": _STIFFNESS_STEP_CAP / (step * step)}


@dataclass(frozen=True, slots=True)
class _RowParams:
    """The parameter models as columns over Crowd rows."""

    A: Column
    inverse_decay: Column
    A_wall: Column
    inverse_wall_decay: Column
    view_base: Column    # lambda + (1 - lambda) / 2: the weight of someone at phi = 90 deg
    view_slope: Column   # (1 - lambda) / 2, the weight per unit of cos phi
    outside_view_weight: Column
    k: Column
    kappa: Column
    arrival_radius: Column
    side_preference: Column
    oncoming_side_preference: Column
    anticipation: Column
    space_at_rest: Column
    time_gap: Column
    time_gap_lane: Column

    @staticmethod
    def from_models(models: list[SocialForceParams]) -> _RowParams:
        def values(name: str) -> FloatArray:
            return np.array([getattr(m, name) for m in models], dtype=np.float64)

        anisotropy = values("lambda_")
        return _RowParams(
            A=_column(values("A")), inverse_decay=_column(1.0 / values("B")),
            A_wall=_column(values("A_wall")), inverse_wall_decay=_column(1.0 / values("B_wall")),
            view_base=_column((1.0 + anisotropy) / 2.0),
            view_slope=_column((1.0 - anisotropy) / 2.0),
            outside_view_weight=_column(values("outside_view_weight")),
            k=_column(values("k")), kappa=_column(values("kappa")),
            arrival_radius=_column(values("arrival_radius")),
            side_preference=_column(values("side_preference")),
            oncoming_side_preference=_column(values("oncoming_side_preference")),
            anticipation=_column(values("anticipation")),
            space_at_rest=_column(values("space_at_rest")),
            time_gap=_column(values("time_gap")),
            time_gap_lane=_column(values("time_gap_lane")))

    def padded(self, rows: int) -> _RowParams:
        """Columns long enough for `rows` bodies; bodies without a model get the defaults.

        Such bodies (robots) are never steered, so their entries are read but never used.
        """
        defaults = _RowParams.from_models([SocialForceParams()])
        changes: dict[str, FloatArray] = {}
        for f in fields(self):
            column = getattr(self, f.name)
            if isinstance(column, np.ndarray) and column.shape[0] < rows:
                fill = np.full(rows - column.shape[0], getattr(defaults, f.name))
                changes[f.name] = np.concatenate([column, fill])
        return replace(self, **changes)


def _rows_of(params: _RowParams) -> int:
    """How many rows the columns cover; all-float columns cover any number."""
    lengths = [c.shape[0] for f in fields(params)
               if isinstance(c := getattr(params, f.name), np.ndarray)]
    return min(lengths) if lengths else np.iinfo(np.intp).max


def _column(values: FloatArray) -> Column:
    """`values` as a Column: a float when they are all equal (or there are none)."""
    if values.size == 0 or (values == values[0]).all():
        return float(values[0]) if values.size else 0.0
    return values


def _at(column: Column, index: IntArray) -> Column:
    return column if isinstance(column, float) else column[index]


def _drive_column(values: FloatArray, rows: IntArray, count: int) -> Column:
    """A Drive field (one value per steered human) as a Column over all Crowd rows."""
    column = _column(values)
    if isinstance(column, float):
        return column
    by_row = np.zeros(count)
    by_row[rows] = values
    return by_row


class SocialForcePlanner:
    """Helbing & Molnar's social force model with personal-space shapes, body contact, walls."""

    name: ClassVar[str] = "social_force"
    Params: ClassVar[type[PlannerParams]] = SocialForceParams

    def __init__(self, grid: OccupancyGrid, params: list[PlannerParams]) -> None:
        self.grid = grid
        models = params_as(SocialForceParams, params, self.name)
        self._models = models
        self._rows_with_params = len(models)
        self._params = _RowParams.from_models(models or [SocialForceParams()])
        self._padded = self._params
        self._pair_finder = PairFinder()
        self._shapes: tuple[ShapeArrays, FloatArray, _CrowdShapes] | None = None

    @classmethod
    def joined(cls, planners: list[SocialForcePlanner]) -> SocialForcePlanner:
        """One planner for the stacked crowds of `planners` (see `base.joined_planner`):
        their rows' parameters in order; pairs never cross worlds."""
        return cls(planners[0].grid, [m for p in planners for m in p._models])

    def velocities(self, crowd: Crowd, drive: Drive, dt: float) -> FloatArray:
        """(K, 2) new velocities for the humans in `drive`, never faster than max_speed."""
        check_drive(crowd, drive, self._rows_with_params)
        params = self._params_for(crowd.count)
        rows = drive.index
        velocity = crowd.velocity[rows]
        pairs = self._pair_finder.find(crowd.position, self._reach(crowd, drive), crowd.world)
        acceleration = goal_acceleration(crowd.position[rows], velocity,
                                         _keep_time_gap(crowd, drive, params, pairs),
                                         _at(params.arrival_radius, rows), dt)
        # Terms that are zero are skipped rather than added; adding 0.0 once keeps the sums
        # bit for bit what adding every term gives (it turns -0.0 into 0.0, as they would).
        if pairs.count:
            per_row = _social_acceleration(crowd, drive, params, pairs, self._shapes_of(crowd))
            contact = _contact_acceleration(crowd, params, pairs, dt)
            if contact is not None:
                per_row += contact
            acceleration += per_row[rows]
        else:
            acceleration += 0.0
        walls = self._nearby_walls(crowd, rows, params)
        if walls.slot.size:
            acceleration[walls.slot] += _wall_acceleration(crowd, drive, params, walls, dt)
        new_velocity = clip_speed(velocity + acceleration * dt, drive.max_speed)
        new_velocity = _stop_at_walls(new_velocity, walls, dt)
        # robots follow their scripts: a drive that names one leaves it as it is
        if crowd.is_robot.any():
            robots = crowd.is_robot[rows]
            new_velocity[robots] = velocity[robots]
        return new_velocity

    def _shapes_of(self, crowd: Crowd) -> _CrowdShapes:
        """What the pair kernel needs to know of the crowd's shapes and radii, worked out again
        only when the crowd brings other arrays (the engine hands the same ones every tick;
        neither is changed in place during a run)."""
        cached = self._shapes
        if (cached is None or cached[0] is not crowd.personal_space
                or cached[1] is not crowd.radius):
            space = crowd.personal_space
            shapes = _CrowdShapes(circles=bool((space.kind == _CIRCLE).all()),
                                  radius=_column(crowd.radius), extent=_column(space.a))
            cached = self._shapes = (space, crowd.radius, shapes)
        return cached[2]

    def _params_for(self, count: int) -> _RowParams:
        """Parameter columns covering `count` rows (robots may come without a model)."""
        if count > self._rows_with_params and _rows_of(self._padded) < count:
            self._padded = self._params.padded(count)
        return self._padded

    @staticmethod
    def _reach(crowd: Crowd, drive: Drive) -> FloatArray:
        """How far each row looks; rows nobody steers look as far as the furthest (their
        reactions are computed with the rest and then dropped, which is cheaper than masking).
        """
        ranges = drive.interaction_range
        if crowd.is_robot.any():
            ranges = np.where(crowd.is_robot[drive.index], 0.0, ranges)
        reach = np.full(crowd.count, float(ranges.max()) if ranges.size else 0.0)
        reach[drive.index] = ranges
        return reach

    def _nearby_walls(self, crowd: Crowd, rows: IntArray, params: _RowParams) -> _NearbyWalls:
        """The steered humans with a wall close enough to matter, and where it is."""
        if rows.size == 0:
            return _NO_WALLS
        position = crowd.position[rows]
        radius = crowd.radius[rows]
        reach = _WALL_REACH_IN_B / _at(params.inverse_wall_decay, rows) + radius
        # The test below keeps a human when its clearance is under its reach plus half a cell;
        # humans whose cells are surely clearer than the largest such distance (with a margin
        # for rounding) are never looked at more closely.
        grid = self.grid
        maybe, clearance, away = grid.walls_within(
            position, float(reach.max()) + 0.5 * grid.resolution + 1e-6)
        if maybe.size == 0:
            return _NO_WALLS
        if maybe.size < rows.size:
            radius, reach = radius[maybe], reach[maybe]
        # clearance runs to the centre of the nearest occupied cell; its face is half a cell
        # nearer
        gap = clearance - 0.5 * grid.resolution - radius
        close = (gap < reach - radius).nonzero()[0]
        if close.size == 0:
            return _NO_WALLS
        if close.size == maybe.size:
            return _NearbyWalls(maybe, away, gap)
        return _NearbyWalls(maybe[close], away[close], gap[close])


@dataclass(frozen=True, slots=True)
class _NearbyWalls:
    """Steered humans near a wall: their slots, the unit vector away from it, the gap to it."""

    slot: IntArray
    away: FloatArray   # (W, 2)
    gap: FloatArray    # (W,) clearance minus body radius, negative when touching


_NO_WALLS = _NearbyWalls(np.zeros(0, dtype=np.intp), np.zeros((0, 2)), np.zeros(0))


def _wall_acceleration(crowd: Crowd, drive: Drive, params: _RowParams, walls: _NearbyWalls,
                       dt: float) -> FloatArray:
    """(W, 2) exponential push from the nearest obstacle plus contact once the body touches
    it, for the humans in `walls`."""
    near, away, gap = walls.slot, walls.away, walls.gap
    rows = drive.index[near]
    push = (_at(params.A_wall, rows) * drive.obstacle_strength[near]
            * np.exp(np.minimum(-gap * _at(params.inverse_wall_decay, rows), _MAX_EXPONENT)))
    if not (gap < 0.0).any():
        # no contact: the contact terms are zeros, which change no sum they are added to
        return np.asarray(away * push[:, None], dtype=np.float64)
    overlap = np.maximum(-gap, 0.0)
    push += _capped(_at(params.k, rows) * dt * dt, _STIFFNESS_STEP_CAP) / (dt * dt) * overlap
    tangent = np.column_stack([-away[:, 1], away[:, 0]])
    sliding = np.einsum("ij,ij->i", crowd.velocity[rows], tangent)
    friction = _capped(_at(params.kappa, rows) * overlap * dt, _FRICTION_STEP_CAP) / dt
    return np.asarray(away * push[:, None] - tangent * (friction * sliding)[:, None],
                      dtype=np.float64)


def _stop_at_walls(velocity: FloatArray, walls: _NearbyWalls, dt: float) -> FloatArray:
    """Remove any speed towards a wall that would carry a body into it within this step.

    The exponential push and the contact terms keep bodies out of walls in ordinary walking;
    this guard covers the rest (a running human, a crowd pressing someone against a wall).
    It only removes velocity, so max_speed still holds.
    """
    if walls.slot.size == 0:
        return velocity
    towards = -np.einsum("ij,ij->i", velocity[walls.slot], walls.away)
    excess = towards - np.maximum(walls.gap, 0.0) / dt
    blocked = excess > 0.0
    if blocked.any():
        slots = walls.slot[blocked]
        velocity[slots] += walls.away[blocked] * excess[blocked, None]
    return velocity


def _capped(value: Column, cap: float) -> Column:
    return np.minimum(value, cap) if isinstance(value, np.ndarray) else min(value, cap)


@dataclass(frozen=True, slots=True)
class _CrowdShapes:
    """Whether every personal space is a circle, and the body radius and personal-space extent
    as Columns (floats when everyone shares them)."""

    circles: bool
    radius: Column
    extent: Column


class _PairPush:
    """The social push of one tick, computed once per close pair and applied both ways."""

    def __init__(self, crowd: Crowd, drive: Drive, params: _RowParams, pairs: NeighbourPairs,
                 shapes: _CrowdShapes) -> None:
        count, rows = crowd.count, drive.index
        self.crowd, self.params, self.pairs = crowd, params, pairs
        self.strength = _product(params.A, _drive_column(drive.avoidance_strength, rows, count))
        self.cos_half_view = _drive_column(np.cos(drive.field_of_view / 2.0), rows, count)
        self.cos_heading, self.sin_heading = np.cos(crowd.heading), np.sin(crowd.heading)
        self.drive = drive
        self.ways: FloatArray | None = None  # each body's way to its target, on first use
        self.inverse_distance = 1.0 / pairs.distance
        self.neg_inverse_distance = np.negative(self.inverse_distance)
        horizon = params.anticipation
        self.shared_horizon = isinstance(horizon, float)
        if self.shared_horizon:  # the closest approach is the same seen from either side
            self.ahead = closest_approach(pairs, crowd.velocity, horizon)
        space = crowd.personal_space
        self.circles = shapes.circles
        self.space_scale = _space_scale(crowd, drive, params.space_at_rest)
        radius = shapes.radius
        # with circles of one size, one radius and one decay, the closeness term is symmetric
        self.shared_closeness: FloatArray | None = None
        same_circles = (self.circles and isinstance(shapes.extent, float)
                        and self.space_scale is None)
        if (same_circles and self.shared_horizon and isinstance(radius, float)
                and isinstance(params.inverse_decay, float) and isinstance(self.strength, float)):
            comfort = float(space.a[0]) + radius
            self.shared_closeness = self.strength * self._closeness(comfort, self.ahead[2],
                                                                    params.inverse_decay)

    @staticmethod
    def _closeness(comfort: Column, distance: FloatArray, inverse_decay: Column) -> FloatArray:
        return np.asarray(np.exp(np.minimum((comfort - distance) * inverse_decay,
                                            _MAX_EXPONENT)), dtype=np.float64)

    def both_ways(self) -> tuple[Pushes, Pushes]:
        """The push on each pair's first body from its second, and on the second from the first.

        A few pairs (a small crowd) are pushed both ways in one pass over arrays twice as long,
        which spares half the numpy calls; many pairs in two passes, where joining the arrays
        would cost more than the calls it spares. Either way every element is computed alike.
        """
        pairs = self.pairs
        ahead = self.ahead if self.shared_horizon else None
        if pairs.count > _JOINED_PAIRS:
            return (self._directed(pairs.first, pairs.second, 1.0, pairs,
                                   self.neg_inverse_distance, ahead, self.shared_closeness),
                    self._directed(pairs.second, pairs.first, -1.0, pairs, self.inverse_distance,
                                   ahead, self.shared_closeness))
        doubled = _doubled(pairs)
        receiver = np.concatenate((pairs.first, pairs.second))
        push_x, push_y = self._directed(
            receiver, np.concatenate((pairs.second, pairs.first)), _signs(pairs.count), doubled,
            np.concatenate((self.neg_inverse_distance, self.inverse_distance)),
            None if ahead is None else _twice_each(ahead),
            None if self.shared_closeness is None else _twice(self.shared_closeness))
        half = pairs.count
        return (push_x[:half], push_y[:half]), (push_x[half:], push_y[half:])

    def _directed(self, receiver: IntArray, other: IntArray, sign: Column,
                  pairs: NeighbourPairs, signed_inverse: FloatArray,
                  ahead: tuple[FloatArray, FloatArray, FloatArray] | None,
                  closeness: FloatArray | None) -> Pushes:
        """Push on `receiver` from `other` per pair; `sign` (+1 or -1, per pair or for all)
        orients the pair's vectors and `signed_inverse` is -sign / distance."""
        params = self.params
        if ahead is None:
            ahead = closest_approach(pairs, self.crowd.velocity,
                                     _at(params.anticipation, receiver))
        ahead_x, ahead_y, distance = ahead
        cos_heading, sin_heading = self.cos_heading[receiver], self.sin_heading[receiver]
        # where the other is seen now, as cos phi: towards the other is -sign * offset
        seen_ahead = pairs.offset_x * cos_heading
        seen_ahead += pairs.offset_y * sin_heading
        seen_ahead *= signed_inverse
        if closeness is not None:
            push = closeness
        else:
            forward = -sign * (ahead_x * cos_heading + ahead_y * sin_heading)
            left = sign * (ahead_x * sin_heading - ahead_y * cos_heading)
            comfort = self._extent(receiver, forward, left) + self.crowd.radius[other]
            push = _at(self.strength, receiver) * self._closeness(
                comfort, distance, _at(params.inverse_decay, receiver))
        weight = _at(params.view_base, receiver) + _at(params.view_slope, receiver) * seen_ahead
        unseen = seen_ahead < _at(self.cos_half_view, receiver)
        np.multiply(weight, _at(params.outside_view_weight, receiver), out=weight, where=unseen)
        push = push * weight
        # a preference for one side breaks the deadlock of two people walking dead-on at each
        # other: each also sidesteps to its right (left when negative) from whoever is ahead
        sidestep = np.maximum(seen_ahead, 0.0)
        sidestep *= push
        sidestep *= _at(params.side_preference, receiver)
        keep_side = params.oncoming_side_preference
        if not isinstance(keep_side, float) or keep_side:  # 0: left out, bit for bit
            sidestep += self._keep_to_the_side(receiver, other, distance, seen_ahead)
        if not isinstance(sign, float) or sign < 0:  # times -1 exactly; times +1 changes nothing
            push *= sign
        along_x = push * ahead_x
        along_x += sidestep * sin_heading
        along_y = push * ahead_y
        along_y -= sidestep * cos_heading
        return along_x, along_y

    def _keep_to_the_side(self, receiver: IntArray, other: IntArray, distance: FloatArray,
                          seen_ahead: FloatArray) -> FloatArray:
        """The sidestep of each pair's receiver from an other ahead who walks the other way:
        oncoming_side_preference * A * avoidance_strength * (how opposed their ways are) *
        exp(-distance at their closest approach / _ONCOMING_REACH), weighted by how straight
        ahead the other is. It reaches further than the push, so that people move over before
        they meet, and it stays bounded when they are close."""
        if self.ways is None:
            self.ways = self._ways()
        ways = self.ways
        opposed = ways[receiver, 0] * ways[other, 0]
        opposed += ways[receiver, 1] * ways[other, 1]
        np.negative(opposed, out=opposed)
        np.maximum(opposed, 0.0, out=opposed)
        opposed *= np.exp(distance * (-1.0 / _ONCOMING_REACH))
        opposed *= _at(self.strength, receiver)
        opposed *= _at(self.params.oncoming_side_preference, receiver)
        opposed *= np.maximum(seen_ahead, 0.0)
        return opposed

    def _ways(self) -> FloatArray:
        """Each body's unit direction towards its target (its next waypoint); zero for the
        bodies this call does not steer (robots, people standing, people of another planner),
        who walk at nobody. Ways, not velocities: in a jostling crowd someone pushed back is
        not coming the other way."""
        crowd, drive = self.crowd, self.drive
        ways = np.zeros((crowd.count, 2))
        to_target = drive.target - crowd.position[drive.index]
        length = np.hypot(to_target[:, 0], to_target[:, 1])
        ways[drive.index] = to_target / np.maximum(length, 1e-9)[:, None]
        return ways

    def _extent(self, receiver: IntArray, forward: FloatArray, left: FloatArray) -> Column:
        space = self.crowd.personal_space
        if self.circles:  # the radius is the extent in every direction
            extent = np.asarray(space.a[receiver], dtype=np.float64)
        else:
            extent = extent_in_body_frame(space.kind[receiver], space.a[receiver],
                                          space.b[receiver], space.offset[receiver], forward,
                                          left)
        if self.space_scale is None:
            return extent
        body = self.crowd.radius[receiver]
        return body + (extent - body) * self.space_scale[receiver]


def _space_scale(crowd: Crowd, drive: Drive, at_rest: Column) -> FloatArray | None:
    """Per Crowd row, the share of the personal space beyond the body kept at the current
    speed: `at_rest` standing still, rising linearly to 1 at the desired speed; None when
    everyone keeps the whole (the default), and 1 for rows nobody steers (robots)."""
    if isinstance(at_rest, float) and at_rest >= 1.0:
        return None
    rows = drive.index
    speed = np.hypot(crowd.velocity[rows, 0], crowd.velocity[rows, 1])
    pace = np.minimum(speed / np.maximum(drive.desired_speed, 1e-9), 1.0)
    scale = np.ones(crowd.count)
    kept = _at(at_rest, rows)
    scale[rows] = kept + (1.0 - kept) * pace
    return scale


def _keep_time_gap(crowd: Crowd, drive: Drive, params: _RowParams,
                   pairs: NeighbourPairs) -> Drive:
    """`drive` with each desired speed capped at the free distance ahead over the time gap.

    The free distance is how far a human can walk straight towards its target before its body
    touches a neighbour's (within its interaction range) whose centre lies in its lane: closer
    to that line than `time_gap_lane` times the two radii (1: anyone it would touch); the cap
    makes speed fall with headway, as in Tordeux et al.'s collision-free speed model, whose
    speed-headway relation reproduces the fundamental diagram of corridors and bottlenecks.
    """
    gap = params.time_gap
    if pairs.count == 0 or (isinstance(gap, float) and gap <= 0.0):
        return drive
    rows = drive.index
    to_target = drive.target - crowd.position[rows]
    heading = np.zeros((crowd.count, 2))
    heading[rows] = to_target / np.maximum(np.hypot(to_target[:, 0], to_target[:, 1]),
                                           1e-9)[:, None]
    contact = crowd.radius[pairs.first] + crowd.radius[pairs.second]
    free = np.full(crowd.count, np.inf)
    # offsets point from second to first: the first sees the second at -offset
    for receiver, sign, reacts in ((pairs.first, -1.0, pairs.first_reacts),
                                   (pairs.second, 1.0, pairs.second_reacts)):
        along = sign * (pairs.offset_x * heading[receiver, 0]
                        + pairs.offset_y * heading[receiver, 1])
        across_squared = pairs.distance * pairs.distance - along * along
        lane = contact * _at(params.time_gap_lane, receiver)
        in_path = (along > 0.0) & (across_squared < lane * lane)
        if reacts is not None:
            in_path &= reacts
        hit = in_path.nonzero()[0]
        if hit.size:
            walk = along[hit] - np.sqrt(contact[hit] ** 2 - across_squared[hit])
            np.minimum.at(free, receiver[hit], np.maximum(walk, 0.0))
    cap = free[rows] / np.maximum(_at(gap, rows), 1e-9)
    # a time gap of 0 (for some rows only) means no cap
    cap = np.where(_at(gap, rows) > 0.0, cap, np.inf)
    return replace(drive, desired_speed=np.minimum(drive.desired_speed, cap))


def _product(first: Column, second: Column) -> Column:
    if isinstance(first, float) and isinstance(second, float):
        return first * second
    return np.asarray(first * second, dtype=np.float64)


def _social_acceleration(crowd: Crowd, drive: Drive, params: _RowParams,
                         pairs: NeighbourPairs, shapes: _CrowdShapes) -> FloatArray:
    """(N, 2) sum over neighbours of the anisotropic exponential push, per Crowd row."""
    count = crowd.count
    if pairs.count == 0:
        return np.zeros((count, 2))
    on_first, on_second = _PairPush(crowd, drive, params, pairs, shapes).both_ways()
    return _sum_both_ways(pairs, on_first, on_second, count)


@functools.cache
def _signs(count: int) -> FloatArray:
    """(2 * count,) +1 then -1: the direction of each half of a joined pass."""
    sign = np.concatenate((np.ones(count), np.full(count, -1.0)))
    sign.setflags(write=False)
    return sign


def _twice(values: npt.NDArray[Any]) -> npt.NDArray[Any]:
    return np.concatenate((values, values))


def _twice_each(arrays: tuple[FloatArray, FloatArray, FloatArray]
                ) -> tuple[FloatArray, FloatArray, FloatArray]:
    return _twice(arrays[0]), _twice(arrays[1]), _twice(arrays[2])


def _doubled(pairs: NeighbourPairs) -> NeighbourPairs:
    """The pairs listed twice, for pushing both ways in one pass."""
    return NeighbourPairs(_twice(pairs.first), _twice(pairs.second), _twice(pairs.offset_x),
                          _twice(pairs.offset_y), _twice(pairs.distance), None, None)


def _sum_both_ways(pairs: NeighbourPairs, on_first: tuple[FloatArray, FloatArray],
                   on_second: tuple[FloatArray, FloatArray], count: int) -> FloatArray:
    """(N, 2) per-row sums of pair terms; directions a receiver does not react to are dropped."""
    first_x, first_y = on_first
    second_x, second_y = on_second
    if pairs.first_reacts is not None and pairs.second_reacts is not None:
        first_x, first_y = first_x * pairs.first_reacts, first_y * pairs.first_reacts
        second_x, second_y = second_x * pairs.second_reacts, second_y * pairs.second_reacts
    total = np.empty((count, 2))
    total[:, 0] = (np.bincount(pairs.first, weights=first_x, minlength=count)
                   + np.bincount(pairs.second, weights=second_x, minlength=count))
    total[:, 1] = (np.bincount(pairs.first, weights=first_y, minlength=count)
                   + np.bincount(pairs.second, weights=second_y, minlength=count))
    return total


def _contact_acceleration(crowd: Crowd, params: _RowParams, pairs: NeighbourPairs,
                          dt: float) -> FloatArray | None:
    """(N, 2) Helbing's body compression and sliding friction for overlapping bodies; None
    when no two bodies touch."""
    count = crowd.count
    if pairs.count == 0:
        return None
    radius = crowd.radius
    overlap = radius[pairs.first] + radius[pairs.second] - pairs.distance
    touching = (overlap > 0.0).nonzero()[0]
    if touching.size == 0:
        return None
    pairs = _subset(pairs, touching)
    overlap = overlap[touching]
    unit_x, unit_y = pairs.offset_x / pairs.distance, pairs.offset_y / pairs.distance
    relative = crowd.velocity[pairs.second] - crowd.velocity[pairs.first]
    # sliding speed of the second past the first along t = (-unit_y, unit_x); by symmetry the
    # first slides past the second at the same speed along -t
    sliding = relative[:, 1] * unit_x - relative[:, 0] * unit_y

    def one_way(receiver: IntArray, sign: float) -> tuple[FloatArray, FloatArray]:
        stiffness = _capped(_at(params.k, receiver) * dt * dt, _STIFFNESS_STEP_CAP) / (dt * dt)
        friction = _capped(_at(params.kappa, receiver) * overlap * dt, _FRICTION_STEP_CAP) / dt
        normal = sign * stiffness * overlap
        along = sign * friction * sliding
        return normal * unit_x - along * unit_y, normal * unit_y + along * unit_x

    return _sum_both_ways(pairs, one_way(pairs.first, 1.0), one_way(pairs.second, -1.0), count)


def _subset(pairs: NeighbourPairs, keep: IntArray) -> NeighbourPairs:
    first_reacts = pairs.first_reacts[keep] if pairs.first_reacts is not None else None
    second_reacts = pairs.second_reacts[keep] if pairs.second_reacts is not None else None
    return NeighbourPairs(pairs.first[keep], pairs.second[keep], pairs.offset_x[keep],
                          pairs.offset_y[keep], pairs.distance[keep], first_reacts,
                          second_reacts)
