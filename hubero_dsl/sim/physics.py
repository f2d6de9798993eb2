"""Moving bodies for one tick: integrate velocities, keep bodies apart and out of walls, turn.

All functions take and return whole arrays; nothing here loops over humans, except the
shortcuts for a few bodies (up to FEW_BODIES), which test them one by one in floats because
numpy's calls on arrays that small cost more than the arithmetic.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, overload

import numpy as np
import numpy.typing as npt
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from hubero_dsl.planners.neighbours import PairFinder

if TYPE_CHECKING:
    from hubero_dsl.world.grid import OccupancyGrid

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]
IntArray = npt.NDArray[np.intp]
Point = tuple[float, float]

TURN_RATE = 2.5          # rad/s a human turns at
WALL_MARGIN = 0.02       # m of clearance a body centre keeps beyond "free"
# The clearance a body centre keeps from walls, as a share of its radius and a margin: a
# person may brush furniture (shoulders turn, arms tuck in); a robot's rigid footprint may
# touch a wall but never enter it.
HUMAN_WALL_KEEP = (0.5, WALL_MARGIN)
ROBOT_WALL_KEEP = (1.0, 0.0)
STILL = 0.1              # m/s below which a body counts as standing
FEW_BODIES = 8           # up to this many, wall and overlap tests run in floats
CROWDED_GOAL = 1.5       # m from a goal within which a stuck walker looks for who stands there
QUEUE_GAP = 1.0          # m between bodies at most, of people queued one behind another
PRESSED_GAP = 0.5        # m between bodies at most, of one kept off a goal by another
SAME_GOAL = 0.5          # m between two walkers' goals at most, of two sent to one point


class BodySeparation:
    """`separate_bodies` tick after tick, cheap on the common tick when nobody overlaps.

    Close pairs come from a Verlet list (`PairFinder`) that is rebuilt only after someone has
    moved half the skin; when none of them overlaps, the positions are returned as they are,
    exactly as `separate_bodies` would. Otherwise `separate_bodies` does the work, so the
    result is the same bit for bit. A few bodies (a robot among a household) are checked pair
    by pair in floats instead, which costs less than the arrays' calls.
    """

    def __init__(self, skin: float = 0.6) -> None:
        self._finder = PairFinder(skin=skin)

    def __call__(self, position: FloatArray, radius: FloatArray,
                 movable: BoolArray) -> FloatArray:
        if len(position) < 2:
            return position
        if len(position) <= FEW_BODIES:
            if not any_overlap(position.tolist(), radius.tolist()):
                return position
            return separate_bodies(position, radius, movable)
        reach = np.full(len(position), 2.0 * float(radius.max()))
        pairs = self._finder.find(position, reach)
        if pairs.count == 0 or not (radius[pairs.first] + radius[pairs.second]
                                    > pairs.distance).any():
            return position
        return separate_bodies(position, radius, movable)


def any_overlap(position: list[Point], radius: list[float]) -> bool:
    """Whether any two of a few bodies overlap, checked in floats pair by pair."""
    bodies = list(zip(position, radius, strict=True))
    for i, ((xi, yi), ri) in enumerate(bodies):
        for (xj, yj), rj in bodies[i + 1:]:
            if math.hypot(xi - xj, yi - yj) < ri + rj:
                return True
    return False


def gathered_round(goal: Point, position: FloatArray, radius: FloatArray,
                   still: BoolArray) -> BoolArray:
    """The bodies standing round `goal`: still ones within CROWDED_GOAL of it and, in turn,
    still ones within QUEUE_GAP of one of those (a queue, the rings of a crowd gathered at a
    point)."""
    rows = still.nonzero()[0]
    gathered = np.zeros(len(position), dtype=bool)
    seeds = lengths(position[rows] - np.asarray(goal)) <= CROWDED_GOAL
    if not seeds.any():
        return gathered
    where, size = position[rows], radius[rows]
    pairs = cKDTree(where).query_pairs(r=2.0 * float(size.max()) + QUEUE_GAP,
                                       output_type="ndarray")
    gap = lengths(where[pairs[:, 0]] - where[pairs[:, 1]]) - size[pairs[:, 0]] - size[pairs[:, 1]]
    pairs = pairs[gap <= QUEUE_GAP]
    links = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])),
                       shape=(len(rows), len(rows)))
    _, part = connected_components(links, directed=False)
    gathered[rows[np.isin(part, part[seeds])]] = True
    return gathered


def separate_bodies(position: FloatArray, radius: FloatArray, movable: BoolArray) -> FloatArray:
    """Push overlapping bodies apart (each movable one takes its share of the overlap).

    A position correction after the social forces: forces make overlap rare, this makes it
    impossible to persist. Neighbours come from a k-d tree, so the cost stays O(N).
    """
    if len(position) < 2:
        return position
    tree = cKDTree(position)
    pairs = tree.query_pairs(r=2.0 * float(radius.max()), output_type="ndarray")
    if len(pairs) == 0:
        return position
    i, j = pairs[:, 0], pairs[:, 1]
    delta = position[i] - position[j]
    distance = np.linalg.norm(delta, axis=1)
    overlap = radius[i] + radius[j] - distance
    hit = overlap > 0
    if not hit.any():
        return position
    i, j, delta, distance, overlap = i[hit], j[hit], delta[hit], distance[hit], overlap[hit]
    # coincident centres: separate along a fixed direction so the result is deterministic
    direction = np.where(distance[:, None] > 1e-9, delta / np.maximum(distance, 1e-9)[:, None],
                         np.array([1.0, 0.0]))
    share_i = movable[i].astype(float)
    share_j = movable[j].astype(float)
    total = np.maximum(share_i + share_j, 1e-9)
    corrected = position.copy()
    np.add.at(corrected, i, direction * (overlap * share_i / total)[:, None])
    np.add.at(corrected, j, -direction * (overlap * share_j / total)[:, None])
    return corrected


def contact_fractions(old: FloatArray, new: FloatArray, radius: FloatArray,
                      bodies: FloatArray, body_radius: FloatArray,
                      pairs: tuple[IntArray, IntArray]) -> FloatArray:
    """(M,) share of each move old -> new (rows of (M, 2)) that its body (`radius`) makes
    before it touches one of `bodies` (rows of (K, 2), radii `body_radius`) that `pairs` (move
    rows, body rows) sets it against, where the move ends inside that body: 1 where it ends
    inside none. A move that starts overlapping the body may go on only if it does not close
    on it (0 else)."""
    move, body = pairs
    step = (new - old)[move]
    offset = old[move] - bodies[body]
    reach = radius[move] + body_radius[body]
    a = (step * step).sum(axis=1)
    b = 2.0 * (offset * step).sum(axis=1)
    c = (offset * offset).sum(axis=1) - reach * reach
    end = offset + step
    inside = (end * end).sum(axis=1) < reach * reach
    closing = b < 0.0
    root = np.sqrt(np.maximum(b * b - 4.0 * a * c, 0.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        entry = np.where(a > 0.0, (-b - root) / (2.0 * a), np.inf)
    pair_share = np.where(c <= 0.0, np.where(closing, 0.0, 1.0),
                          np.where(closing & (b * b > 4.0 * a * c), np.clip(entry, 0.0, 1.0),
                                   1.0))
    pair_share = np.where(inside, pair_share, 1.0)
    share = np.ones(len(old))
    np.minimum.at(share, move, pair_share)
    return share


def few_contact_fractions(old: list[Point], new: list[Point], radius: list[float],
                          bodies: list[Point], body_radius: list[float]) -> list[float]:
    """`contact_fractions` for a few moves and bodies (every pair), in floats with the arrays'
    arithmetic, bit for bit."""
    shares = []
    for (x0, y0), (x1, y1), r in zip(old, new, radius, strict=True):
        sx, sy = x1 - x0, y1 - y0
        a = sx * sx + sy * sy
        share = 1.0
        for (bx, by), br in zip(bodies, body_radius, strict=True):
            ox, oy = x0 - bx, y0 - by
            reach = r + br
            ex, ey = ox + sx, oy + sy
            if not ex * ex + ey * ey < reach * reach:
                continue  # the move does not end inside this body
            b = 2.0 * (ox * sx + oy * sy)
            c = (ox * ox + oy * oy) - reach * reach
            if c <= 0.0:
                share = min(share, 0.0 if b < 0.0 else 1.0)
            elif b < 0.0 and b * b > 4.0 * a * c:
                root = math.sqrt(max(b * b - 4.0 * a * c, 0.0))
                share = min(share, min(max((-b - root) / (2.0 * a), 0.0), 1.0))
        shares.append(share)
    return shares


def keep_out_of_walls(grid: OccupancyGrid, old: FloatArray, new: FloatArray,
                      radius: FloatArray, *, keep: tuple[float, float] = HUMAN_WALL_KEEP,
                      slides: BoolArray | None = None) -> FloatArray:
    """Where a move would put a body into a wall, slide along it or stay.

    A body centre must keep `keep` = (share, margin) of clearance: that share of its radius
    plus the margin (people may brush furniture, robots may not; centres never enter occupied
    cells). The full move is tried, then each axis alone for the bodies that `slides` (all by
    default: a differential-drive robot cannot move sideways), then no move. Bodies whose cell
    is far enough from every wall are accepted at once (`OccupancyGrid.surely_clear`); only
    the others pay for interpolated clearances; a few bodies are handled in floats. Returns
    `new` itself when nobody is stopped.
    """
    if len(new) <= FEW_BODIES and (kept := _few_kept_out_of_walls(
            grid, old, new, radius, keep, slides)) is not None:
        return kept
    step = lengths(new - old)
    moved = step > 0
    if not moved.any():  # nobody moves: there is nothing to stop (the common tick at rest)
        return new
    needed = keep[0] * radius + keep[1]
    near_wall = ~grid.surely_clear(new, needed)
    # a move longer than the clearance it starts from might pass through a thin wall: check it
    # too (a push from a robot, or a large step), not just where it ends
    long_moves = moved & ~grid.surely_clear(old, step + needed)
    check = (near_wall | long_moves).nonzero()[0]
    if check.size == 0:
        return new
    result = new.copy()
    result[check] = _slide_along_walls(grid, old[check], new[check], needed[check],
                                       None if slides is None else slides[check])
    return result


@dataclass(frozen=True, slots=True)
class _Move:
    """One body's move that needs a closer look, in floats."""

    x0: float
    y0: float
    x1: float
    y1: float
    needed: float
    slides: bool


def _few_kept_out_of_walls(grid: OccupancyGrid, old: FloatArray, new: FloatArray,
                           radius: FloatArray, keep: tuple[float, float],
                           slides: BoolArray | None) -> FloatArray | None:
    """`keep_out_of_walls` for a few bodies, row by row in floats with the arrays' arithmetic;
    None when a coordinate is not finite (the arrays handle those)."""
    stops = wall_stops(grid, old.tolist(), new.tolist(), radius.tolist(), keep=keep,
                       slides=None if slides is None else slides.tolist())
    if stops is None:
        return None
    if not stops:
        return new
    result = new.copy()
    result[list(stops)] = list(stops.values())
    return result


def wall_stops(grid: OccupancyGrid, old: list[Point], new: list[Point], radius: list[float],
               *, keep: tuple[float, float] = HUMAN_WALL_KEEP, slides: list[bool] | None = None
               ) -> dict[int, Point] | None:
    """`keep_out_of_walls` for a few bodies given as floats: where each body whose move a wall
    stops or bends ends instead, by row ({} when no wall is in anyone's way); None when a
    coordinate is not finite (the arrays handle those). The same answers as the arrays, bit
    for bit (tests/sim/test_physics.py)."""
    rows: list[int] = []
    moves: list[_Move] = []
    for row, ((x0, y0), (x1, y1), r) in enumerate(zip(old, new, radius, strict=True)):
        if not math.isfinite(x0 + y0 + x1 + y1):
            return None
        dx, dy = x1 - x0, y1 - y0
        step = math.sqrt(dx * dx + dy * dy)
        if step == 0.0:
            continue
        needed = keep[0] * r + keep[1]
        if not (grid.surely_clear_point(x1, y1, needed)
                and grid.surely_clear_point(x0, y0, step + needed)):
            rows.append(row)
            moves.append(_Move(x0, y0, x1, y1, needed, slides is None or slides[row]))
    if not moves:
        return {}
    return dict(zip(rows, _few_slid_along_walls(grid, moves), strict=True))


def _few_slid_along_walls(grid: OccupancyGrid, moves: list[_Move]) -> list[Point]:
    """`_slide_along_walls` for a few moves, in floats: the full move, then x alone, then y
    alone, then none, each tried for the moves the one before did not fit. A trial is sampled
    for walls on its way only when it ends somewhere acceptable (a body pressed into a corner
    fails every trial at its end), as often as the arrays would sample it: every half cell of
    the longest trial of its round."""
    before = [grid.clearance_at_point(m.x0, m.y0) for m in moves]
    result = [(m.x0, m.y0) for m in moves]
    pending = list(range(len(moves)))
    for trial, trial_of in enumerate((lambda m: (m.x1, m.y1), lambda m: (m.x1, m.y0),
                                      lambda m: (m.x0, m.y1))):
        if trial:  # an axis alone: only for those that may slide
            pending = [k for k in pending if moves[k].slides]
        trials = [trial_of(moves[k]) for k in pending]
        fractions: tuple[float, ...] | None = None
        still = []
        for k, (x, y) in zip(pending, trials, strict=True):
            move = moves[k]
            if grid.is_free_point(x, y) and ((clear := grid.clearance_at_point(x, y))
                                             >= move.needed or clear >= before[k]):
                if fractions is None:
                    fractions = grid.segment_fractions(max(
                        float(np.hypot(tx - moves[t].x0, ty - moves[t].y0))
                        for t, (tx, ty) in zip(pending, trials, strict=True)))
                if not grid.crosses_obstacle_point(move.x0, move.y0, x, y, fractions):
                    result[k] = (x, y)
                    continue
            still.append(k)
        pending = still
        if not pending:
            break
    return result


def _slide_along_walls(grid: OccupancyGrid, old: FloatArray, new: FloatArray,
                       needed: FloatArray, slides: BoolArray | None = None) -> FloatArray:
    """`keep_out_of_walls` for the bodies near a wall, row by row with exact clearances."""
    before = grid.clearance_at(old)

    def acceptable(rows: npt.NDArray[np.intp], trial: FloatArray) -> BoolArray:
        # enough room, or at least not closer to the wall than before (a body that starts
        # near a wall may always move away from it); never a centre in an occupied cell, and
        # never through one on the way
        clear = grid.clearance_at(trial)
        free = grid.is_free(trial) & ~grid.crosses_obstacle(old[rows], trial)
        return free & ((clear >= needed[rows]) | (clear >= before[rows]))

    result = new.copy()
    bad = ~acceptable(np.arange(len(new)), result)
    if not bad.any():
        return result
    for axis in (0, 1):
        rows = (bad if slides is None else bad & slides).nonzero()[0]
        trial = old[rows].copy()
        trial[:, axis] = new[rows, axis]
        fits = acceptable(rows, trial)
        result[rows[fits]] = trial[fits]
        bad[rows[fits]] = False
    rows = bad.nonzero()[0]
    result[rows] = old[rows]
    return result


def walkers_change(desired_speed: FloatArray | float, relaxation_time: FloatArray | float,
                   dt: float) -> FloatArray | float:
    """The most a walker's velocity changes in a tick when a reaction or its group, not the
    social force, sets where it goes: its desired speed per relaxation time (about 2.5 m/s^2
    by default), the pace at which the social force's goal term starts it walking."""
    return dt * desired_speed / relaxation_time


def capped(vectors: FloatArray, limit: FloatArray) -> FloatArray:
    """Each row scaled down to at most `limit` long (a speed limit on velocities)."""
    return vectors * np.minimum(1.0, limit / np.maximum(lengths(vectors), 1e-9))[:, None]


def lengths(vectors: FloatArray) -> FloatArray:
    """(N,) length of each row of (N, 2) vectors.

    Bit for bit what `np.linalg.norm(vectors, axis=1)` gives (the root of x*x + y*y), at a
    fraction of its cost on the few rows of a small crowd.
    """
    x, y = vectors[:, 0], vectors[:, 1]
    squared = x * x
    squared += y * y
    return np.sqrt(squared, out=squared)


@overload
def wrap_angle(angle: float) -> float: ...
@overload
def wrap_angle(angle: FloatArray) -> FloatArray: ...
def wrap_angle(angle: float | FloatArray) -> float | FloatArray:
    """The angle in [-pi, pi): element-wise for an array, in floats for a float."""
    return (angle + np.pi) % (2.0 * np.pi) - np.pi


def turn_towards(heading: FloatArray, wanted: FloatArray, turning: BoolArray,
                 dt: float) -> FloatArray:
    """Turn the `turning` rows towards `wanted` at TURN_RATE."""
    difference = wrap_angle(wanted - heading)
    # maximum/minimum rather than np.clip: the same values (NaN included), with less overhead
    step = np.minimum(np.maximum(difference, -TURN_RATE * dt), TURN_RATE * dt)
    return np.where(turning, wrap_angle(heading + step), heading)
