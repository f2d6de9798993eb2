"""Who is near whom this tick: close pairs of bodies from a k-d tree over the whole crowd.

A k-d tree over all Crowd rows (humans and robots) answers one fixed-radius pair query that
returns each close pair once, so the cost grows with the number of close pairs, not with N^2.
`PairFinder` keeps the candidates of one query for the next ticks while nobody has moved far
(a Verlet list), which spares most queries.

Each pair can act in two directions (the first body reacting to the second, and the second to
the first); a direction counts only when the other body lies within the receiver's own
interaction range. Geometry is computed once per pair and shared by both directions, which
halves the work of the planners that use it.

A crowd of at most `_SMALL` bodies fits in one leaf of the k-d tree, whose pair query returns
every close pair in row order, (0, 1), (0, 2), ..., (1, 2), ...: for such crowds every pair is a
candidate, in that same order, and no tree is built.

Bodies of several simulations can be steered in one call (a vector environment's copies, each
a *world* of its own): bodies of different worlds are never paired. Their tree is built in
three dimensions, each world a layer further apart than any query reaches, and its pairs are
listed in row order, so that a world of at most `_SMALL` bodies meets its pairs in the order
it would alone.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy.spatial import cKDTree

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]
BoolArray = npt.NDArray[np.bool_]

_SMALL = 16  # scipy's default leaf size: the tree of a crowd this small is a single leaf


@dataclass(frozen=True, slots=True)
class NeighbourPairs:
    """P close pairs, each once. Offsets and unit vectors point from `second` to `first`."""

    first: IntArray       # (P,) Crowd rows
    second: IntArray      # (P,)
    offset_x: FloatArray  # (P,) x_first - x_second
    offset_y: FloatArray
    distance: FloatArray  # (P,) centre distance, m (>= 1e-9: coincident bodies are nudged)
    first_reacts: BoolArray | None   # (P,) whether first reacts to second; None = every pair
    second_reacts: BoolArray | None  # (P,) whether second reacts to first; None = every pair

    @property
    def count(self) -> int:
        return int(self.first.shape[0])


class PairFinder:
    """Finds close pairs tick after tick, querying the k-d tree only now and then.

    A Verlet list: the tree is asked for pairs within the query radius plus `skin`, and those
    candidates are reused, with fresh distances, until some body has moved more than skin / 2
    since (or the radius or the number of bodies changes). Until then no pair can have come
    within the radius unseen, so the pairs found are exactly those a fresh query would give.
    """

    def __init__(self, skin: float = 0.6) -> None:
        self.skin = skin
        self._built_at: FloatArray | None = None
        self._built_radius = 0.0
        self._candidates = (np.zeros(0, dtype=np.intp), np.zeros(0, dtype=np.intp))

    def find(self, position: FloatArray, reach: FloatArray,
             world: IntArray | None = None) -> NeighbourPairs:
        """Every pair of rows closer than the larger reach of the two, with who reacts to whom.

        `reach` is (N,): how far each body looks (0 for one that reacts to no one). Coincident
        bodies get a deterministic direction (+x from the second to the first), so they still
        push apart. `world` (N,), when given, says which simulation each row belongs to: rows
        of different worlds are never paired (it must not change while `position` keeps its
        shape, as a vector environment's stack of copies does not).
        """
        count = position.shape[0]
        query_radius = float(reach.max()) if count else 0.0
        if count < 2 or query_radius <= 0.0:
            return _no_pairs()
        if count <= _SMALL and world is None:
            return _pairs_within(position, reach, query_radius, *_all_pairs(count))
        if self._stale(position, query_radius):
            self._candidates = _candidates(position, query_radius + self.skin, world)
            self._built_at, self._built_radius = position.copy(), query_radius
        return _pairs_within(position, reach, query_radius, *self._candidates)

    def _stale(self, position: FloatArray, query_radius: float) -> bool:
        built_at = self._built_at
        if (built_at is None or built_at.shape != position.shape
                or query_radius != self._built_radius):
            return True
        moved = position - built_at
        furthest_squared = float(np.max(moved[:, 0] * moved[:, 0] + moved[:, 1] * moved[:, 1]))
        return bool(furthest_squared > (self.skin / 2.0) ** 2)


def _candidates(position: FloatArray, radius: float, world: IntArray | None
                ) -> tuple[IntArray, IntArray]:
    """Pairs of rows closer than `radius`, from a k-d tree; within each world, in row order."""
    if world is None:
        tree = cKDTree(position, balanced_tree=False, compact_nodes=False)
        first, second = tree.query_pairs(radius, output_type="ndarray").T.copy()
        return first, second
    layers = np.column_stack([position, world * (2.0 * radius + 1.0)])
    tree = cKDTree(layers, balanced_tree=False, compact_nodes=False)
    found = tree.query_pairs(radius, output_type="ndarray")
    order = np.lexsort((found[:, 1], found[:, 0]))  # by first row, then second
    return found[order, 0].astype(np.intp), found[order, 1].astype(np.intp)


@functools.cache
def _all_pairs(count: int) -> tuple[IntArray, IntArray]:
    """Every pair of `count` rows, in the order a one-leaf k-d tree reports them."""
    first, second = np.triu_indices(count, 1)
    first, second = first.astype(np.intp), second.astype(np.intp)
    first.setflags(write=False)
    second.setflags(write=False)
    return first, second


def close_pairs(position: FloatArray, reach: FloatArray) -> NeighbourPairs:
    """`PairFinder.find` without a memory: one fresh k-d tree query."""
    return PairFinder(skin=0.0).find(position, reach)


def _pairs_within(position: FloatArray, reach: FloatArray, query_radius: float,
                  first: IntArray, second: IntArray) -> NeighbourPairs:
    """The candidate pairs closer than `query_radius`, with their geometry and reactions."""
    # gathers from contiguous 1-D columns, and sqrt rather than hypot: several times faster
    x, y = np.ascontiguousarray(position[:, 0]), np.ascontiguousarray(position[:, 1])
    offset_x = x[first] - x[second]
    offset_y = y[first] - y[second]
    distance = np.sqrt(offset_x * offset_x + offset_y * offset_y)
    inside = (distance <= query_radius).nonzero()[0]
    if inside.size < distance.size:
        first, second = first[inside], second[inside]
        offset_x, offset_y, distance = offset_x[inside], offset_y[inside], distance[inside]
    coincident = (distance < 1e-9).nonzero()[0]
    if coincident.size:
        offset_x[coincident], offset_y[coincident] = 1e-9, 0.0
        distance[coincident] = 1e-9
    if reach.min() >= query_radius:  # everyone reacts to everyone found
        return NeighbourPairs(first, second, offset_x, offset_y, distance, None, None)
    first_reacts = distance <= reach[first]
    second_reacts = distance <= reach[second]
    keep = (first_reacts | second_reacts).nonzero()[0]
    return NeighbourPairs(first[keep], second[keep], offset_x[keep], offset_y[keep],
                          distance[keep], first_reacts[keep], second_reacts[keep])


def _no_pairs() -> NeighbourPairs:
    empty_int = np.zeros(0, dtype=np.intp)
    empty = np.zeros(0, dtype=np.float64)
    return NeighbourPairs(empty_int, empty_int, empty, empty, empty, None, None)


def closest_approach(pairs: NeighbourPairs, velocity: FloatArray,
                     horizon: FloatArray | float) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Unit vector from second to first, and their distance, at their closest approach.

    Both bodies keep their current velocities; the closest approach is sought within
    [0, horizon] seconds (`horizon` per pair or one for all). With horizon 0 this is the
    current geometry. A dead-on collision course keeps the current direction rather than an
    undefined one.
    """
    velocity_x = np.ascontiguousarray(velocity[:, 0])
    velocity_y = np.ascontiguousarray(velocity[:, 1])
    closing_x = velocity_x[pairs.first]
    closing_x -= velocity_x[pairs.second]
    closing_y = velocity_y[pairs.first]
    closing_y -= velocity_y[pairs.second]
    closing_squared = closing_x * closing_x
    closing_squared += closing_y * closing_y
    closing_squared += 1e-12
    when = pairs.offset_x * closing_x
    when += pairs.offset_y * closing_y
    when /= closing_squared
    np.negative(when, out=when)
    np.maximum(when, 0.0, out=when)
    np.minimum(when, horizon, out=when)
    offset_x = closing_x * when
    offset_x += pairs.offset_x
    offset_y = closing_y * when
    offset_y += pairs.offset_y
    distance = np.sqrt(offset_x * offset_x + offset_y * offset_y)
    undefined = (distance < 1e-6).nonzero()[0]
    if undefined.size:
        offset_x[undefined] = pairs.offset_x[undefined]
        offset_y[undefined] = pairs.offset_y[undefined]
        distance[undefined] = np.maximum(distance[undefined], 1e-9)
        scale = distance[undefined] / pairs.distance[undefined]
        offset_x[undefined] *= scale
        offset_y[undefined] *= scale
    inverse = 1.0 / distance
    return offset_x * inverse, offset_y * inverse, distance
