"""How walking humans react to robots: HuNavSim's reactions, per human (`robot_reaction`).

The local planner steers everyone with robots as moving obstacles (`regular`). Humans with
another reaction have that velocity adjusted while a robot is near (surface gap below
`NOTICE`):

- `impassive`: ignores robots until contact; the planner steers it as if there were none (the
  bodies still cannot overlap).
- `scared`: keeps a wider distance: an extra push away from the robot, `SCARED_PUSH` m/s at
  contact decaying over `SCARED_RANGE`.
- `surprised`: once per encounter, stops and turns to face a robot that comes within
  `STARTLED`, for `SURPRISE` seconds, then carries on.
- `curious`: once per encounter, walks towards the robot for up to `CURIOSITY` seconds,
  stopping `CLOSE` from it, then carries on.
- `threatening`: once per encounter, walks into the robot's way (to the point just ahead of a
  moving robot) for up to `MENACE` seconds, then carries on.

An encounter ends when the robot is more than `FORGOTTEN` away. All of it is deterministic.

A reaction that sends a person somewhere (approach, step into the way) sets the velocity the
person wants; the person changes its velocity towards it by at most its desired speed per
relaxation time (about 2.5 m/s^2 by default), and slows down on arriving within `ARRIVING` of
the point it goes to. Set outright, a threatening person ahead of a turning robot turned round
within a tick, at tens of m/s^2. A surprised person freezes: it stops within the tick.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from hubero_dsl.model.params import REACTIONS
from hubero_dsl.sim import physics
from hubero_dsl.sim.arrays import FloatArray, HumanArrays

REGULAR, IMPASSIVE, SURPRISED, CURIOUS, SCARED, THREATENING = range(len(REACTIONS))
NOTICE = 3.0          # m: a robot nearer than this (surface gap) draws a reaction
FORGOTTEN = 4.0       # m: further than this, an encounter is over
STARTLED = 1.5        # m: how near a robot surprises
SURPRISE = 2.0        # s a surprised human stands and looks
CURIOSITY = 5.0       # s a curious human approaches
CLOSE = 0.6           # m: the gap a curious human keeps
MENACE = 40.0         # s a threatening human blocks a robot's way (HuNavSim's BT timer)
SCARED_PUSH = 1.5     # m/s away from a robot at contact
SCARED_RANGE = 1.0    # m over which that push decays (e-fold)
ARRIVING = 0.5        # m: nearer than this to its point, a reacting person slows (as walkers do)


class Reactions:
    """Per-human state of the reactions, and the adjustment of each tick's velocities."""

    def __init__(self, reaction: npt.NDArray[np.int8], dt: float) -> None:
        self.reaction = reaction
        self.dt = dt
        count = len(reaction)
        self.until = np.zeros(count, dtype=np.int64)     # tick a surprise or curiosity ends
        self.spent = np.zeros(count, dtype=bool)         # reacted in this encounter already
        self.impassive = reaction == IMPASSIVE

    def adjust(self, velocity: FloatArray, humans: HumanArrays, robot_position: FloatArray,
               robot_velocity: FloatArray, robot_radius: FloatArray, tick: int) -> FloatArray:
        """The velocities with every reacting human's reaction to its nearest robot applied."""
        rows = np.flatnonzero((self.reaction != REGULAR) & (self.reaction != IMPASSIVE)
                              & humans.moving)
        if not len(rows) or not len(robot_position):
            return velocity
        offset = robot_position[None, :, :] - humans.position[rows, None, :]   # (K, R, 2)
        centre = np.hypot(offset[..., 0], offset[..., 1])
        gap = centre - humans.radius[rows, None] - robot_radius[None, :]
        nearest = np.argmin(gap, axis=1)
        near_gap = gap[np.arange(len(rows)), nearest]
        self.spent[rows[near_gap > FORGOTTEN]] = False
        velocity = velocity.copy()
        for k, i in enumerate(rows):
            if near_gap[k] > NOTICE and self.until[i] <= tick:
                continue
            j = int(nearest[k])
            toward = offset[k, j] / max(float(centre[k, j]), 1e-9)
            velocity[i] = self._react(int(i), velocity[i], toward, float(near_gap[k]),
                                      robot_position[j], robot_velocity[j], humans, tick)
        return velocity

    def _react(self, i: int, velocity: FloatArray, toward: FloatArray, gap: float,
               robot: FloatArray, robot_velocity: FloatArray, humans: HumanArrays,
               tick: int) -> FloatArray:
        kind, speed = int(self.reaction[i]), float(humans.desired_speed[i])
        if kind == SCARED:
            push = -toward * SCARED_PUSH * np.exp(-max(gap, 0.0) / SCARED_RANGE)
            return _capped(velocity + push, float(humans.max_speed[i]))
        if kind == SURPRISED:
            if not self.spent[i] and gap < STARTLED:
                self.spent[i], self.until[i] = True, tick + round(SURPRISE / self.dt)
            if self.until[i] > tick:  # stand, and turn to look at the robot
                wanted = np.array([np.arctan2(toward[1], toward[0])])
                humans.heading[i] = physics.turn_towards(
                    humans.heading[i:i + 1], wanted, np.ones(1, dtype=bool), self.dt)[0]
                return np.zeros(2)
            return velocity
        if kind == CURIOUS:
            if not self.spent[i]:
                self.spent[i], self.until[i] = True, tick + round(CURIOSITY / self.dt)
            if self.until[i] > tick:
                # up to CLOSE from the robot, slowing on the way there
                wanted = toward * speed * min(1.0, max(gap - CLOSE, 0.0) / ARRIVING)
                return self._relaxed(i, wanted, humans)
            return velocity
        # threatening: to the point just ahead of the robot, in its way, for MENACE seconds
        # of an encounter (HuNavSim's timer), then its own way again
        if not self.spent[i]:
            self.spent[i], self.until[i] = True, tick + round(MENACE / self.dt)
        moving = float(np.hypot(*robot_velocity))
        if moving < 0.05 or self.until[i] <= tick:
            return velocity
        ahead = robot + robot_velocity / moving * (float(humans.radius[i]) + 0.8)
        way = ahead - humans.position[i]
        distance = float(np.hypot(*way))
        wanted = way / max(distance, 1e-9) * speed * min(1.0, distance / ARRIVING)
        return self._relaxed(i, wanted, humans)

    def _relaxed(self, i: int, wanted: FloatArray, humans: HumanArrays) -> FloatArray:
        """Human i's velocity this tick on its way to `wanted`: changed by at most its desired
        speed per relaxation time (reaching `wanted` exactly, unlike an exponential approach,
        so that a stop is a stop)."""
        current = humans.velocity[i]
        most = physics.walkers_change(float(humans.desired_speed[i]),
                                      float(humans.relaxation_time[i]), self.dt)
        return current + _capped(wanted - current, float(most))


def _capped(velocity: FloatArray, limit: float) -> FloatArray:
    speed = float(np.hypot(*velocity))
    return velocity if speed <= limit else velocity * (limit / speed)
