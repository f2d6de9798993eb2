"""The pairwise metrics of `metrics.compute_metrics` for every actor at once, frame by frame.

Compared one pair at a time (the other's track interpolated at this actor's times), a crowd of
1000 took 100 s: three million interpolations. A log samples every actor at the same frames,
each from its first to its last frame without a gap (people of a flow come once and leave
once), so an actor's times are a run of consecutive frames of the log's grid, and "the other
interpolated at my times, where it was logged" is simply the other's own sample at the frames
both have. `on_grid` checks that this holds (hand-built tracks may sample otherwise: the caller
then compares pair by pair) and places everyone in one (T, A, 2) array, NaN where absent. Per
frame, then:

- `min_distances`: every pair's centre distance (a distance matrix), its running minimum;
- `collision_counts`: contact (distance below the sum of the radii plus `socialnav.CONTACT`)
  against the frame before;
- `intrusion_times`: the pairs closer than the owner's personal space reaches (a k-d tree),
  tested against the owner's shape turned to its heading.

The results are the pair-by-pair ones: same frames, same definitions.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt
from scipy.spatial import cKDTree
from scipy.spatial.distance import cdist

from hubero_dsl.socialnav import CONTACT
from hubero_dsl.world.personal_space import contains
from hubero_dsl.world.shapes import Shape, ShapeArrays

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]


@dataclass(frozen=True)
class Grid:
    """Every actor's position at every frame of the log (NaN where it was not logged)."""

    time: FloatArray      # (T,)
    position: FloatArray  # (T, A, 2)
    first: IntArray       # (A,) first frame of each actor (T when never logged)
    count: IntArray       # (A,) frames it was logged

    def frames(self, actor: int) -> slice:
        return slice(int(self.first[actor]), int(self.first[actor] + self.count[actor]))


def on_grid(times: list[FloatArray], positions: list[FloatArray]) -> Grid | None:
    """The actors on the log's frame grid, or None when some actor's times are not a run of
    consecutive grid frames (repeated times, gaps, a sampling of its own)."""
    if not times:
        return None
    grid = np.unique(np.concatenate(times))
    placed = np.full((len(grid), len(times), 2), np.nan)
    first = np.full(len(times), len(grid), dtype=np.intp)
    count = np.zeros(len(times), dtype=np.intp)
    for actor, (time, position) in enumerate(zip(times, positions, strict=True)):
        if not len(time):
            continue
        start = int(np.searchsorted(grid, time[0]))
        if start + len(time) > len(grid) or not np.array_equal(grid[start:start + len(time)],
                                                                time):
            return None
        placed[start:start + len(time), actor] = position
        first[actor], count[actor] = start, len(time)
    return Grid(grid, placed, first, count)


def min_distances(grid: Grid) -> FloatArray:
    """(A, A) closest centre distance of each pair over the frames both were logged; inf for
    pairs never logged together (and on the diagonal)."""
    actors = grid.position.shape[1]
    closest = np.full((actors, actors), np.inf)
    for frame in grid.position:
        closest = np.fmin(closest, cdist(frame, frame))  # NaN (someone absent) leaves it
    np.fill_diagonal(closest, np.inf)
    return closest


def collision_counts(grid: Grid, radius: FloatArray) -> IntArray:
    """(A,) episodes of overlapping bodies (runs of consecutive frames), per other actor and
    summed, over each actor's own frames."""
    actors = grid.position.shape[1]
    reach = radius[:, None] + radius[None, :] + CONTACT
    before = np.zeros((actors, actors), dtype=bool)
    starts = np.zeros(actors, dtype=np.intp)
    for frame in grid.position:
        overlap = cdist(frame, frame) < reach   # False where someone is absent (NaN)
        np.fill_diagonal(overlap, False)
        starts += (overlap & ~before).sum(axis=1)
        before = overlap
    return starts


def intrusion_times(grid: Grid, owners: IntArray, shapes: list[Shape],
                    heading: list[FloatArray]) -> FloatArray:
    """(len(owners),) time during which any other actor's centre lay inside the owner's
    personal space (each frame counts until the owner's next frame). `heading[k]` is owner k's
    heading at its own frames."""
    arrays = ShapeArrays.from_shapes(shapes)
    reach = float(np.max(np.abs(arrays.offset) + np.hypot(arrays.a, arrays.b))) \
        if shapes else 0.0
    row_of = np.full(grid.position.shape[1], -1, dtype=np.intp)
    row_of[owners] = np.arange(len(owners))
    facing = np.full((len(grid.time), len(owners)), np.nan)
    for k, owner in enumerate(owners.tolist()):
        facing[grid.frames(owner), k] = heading[k]
    inside = np.zeros((len(grid.time), len(owners)), dtype=bool)
    for t, frame in enumerate(grid.position):
        present = np.flatnonzero(~np.isnan(frame[:, 0]))
        pairs = cKDTree(frame[present]).query_pairs(reach, output_type="ndarray")
        if not len(pairs):
            continue
        pairs = present[np.concatenate([pairs, pairs[:, ::-1]])]  # both ways: (owner, other)
        pairs = pairs[row_of[pairs[:, 0]] >= 0]
        rows = row_of[pairs[:, 0]]
        hit = contains(ShapeArrays(arrays.kind[rows], arrays.a[rows], arrays.b[rows],
                                   arrays.offset[rows]),
                       facing[t, rows], frame[pairs[:, 0]], frame[pairs[:, 1]])
        inside[t, rows[hit]] = True
    durations = np.zeros_like(inside, dtype=np.float64)
    for k, owner in enumerate(owners.tolist()):
        own = grid.frames(owner)
        durations[own, k] = np.append(np.diff(grid.time[own]), 0.0)
    return (durations * inside).sum(axis=0)
