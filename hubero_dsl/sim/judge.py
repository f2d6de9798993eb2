"""Judging a run's `expect`s: conditions tick by tick, metrics of the whole run at its end.

`Judge` is what the run loop and the Gymnasium environment both use. It observes the
simulation after every tick (conditions as they hold, and every body's position when some
expectation is a metric), and `finish` decides what is left: `always` holds unless it failed,
metrics (`expect min_distance(cart) >= 0.2 m`) are computed over the recorded tracks
(`hubero_dsl.socialnav`) and compared.
"""

from __future__ import annotations

import math
import operator
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from hubero_dsl.model.activities import Expectation, ExpectMode
from hubero_dsl.model.conditions import Condition, MetricCompare
from hubero_dsl.planners.navfn import reference_plan_length
from hubero_dsl.socialnav import Track, member_indices, social_metrics

if TYPE_CHECKING:
    from hubero_dsl.sim.simulation import Simulation

PlanQuery = tuple[tuple[float, float], tuple[float, float], float]
METRIC_DECIMALS = 9

COMPARE: dict[str, Callable[[float, float], bool]] = {
    "<": operator.lt, "<=": operator.le, ">": operator.gt, ">=": operator.ge}


@dataclass
class Verdict:
    """One `expect`, judged as the run goes: holds / fails and when it was decided."""

    expectation: Expectation
    held: bool | None = None      # None: not decided yet
    decided_at: float | None = None
    value: float | None = None    # a metric's value, for the summary

    @property
    def text(self) -> str:
        return self.expectation.text

    def observe(self, holds: bool, time: float) -> None:
        if self.held is not None:
            return
        mode, deadline = self.expectation.mode, self.expectation.deadline
        if mode is ExpectMode.ALWAYS and not holds:
            self.held, self.decided_at = False, time
        elif mode is not ExpectMode.ALWAYS and holds:
            if mode is ExpectMode.WITHIN and deadline is not None and time > deadline + 1e-9:
                self.held, self.decided_at = False, deadline
            else:
                self.held, self.decided_at = True, time
        elif mode is ExpectMode.WITHIN and deadline is not None and time > deadline + 1e-9:
            self.held, self.decided_at = False, deadline

    def finish(self, time: float) -> None:
        if self.held is None:
            self.held = self.expectation.mode is ExpectMode.ALWAYS
            self.decided_at = time


@dataclass
class Tracks:
    """Every body's position at every tick, recorded for metrics."""

    time: list[float] = field(default_factory=list)
    humans: list[np.ndarray] = field(default_factory=list)
    robots: list[np.ndarray] = field(default_factory=list)
    # reference plan lengths by (start, goal, body radius): several runs may share them
    plan_lengths: dict[PlanQuery, float | None] = field(default_factory=dict)
    # metrics by (subject, other, ticks recorded): every expectation on one subject, and the
    # Gymnasium env's episode info, read one computation
    _metrics: dict[tuple[str, str | None, int], dict[str, float]] = field(
        default_factory=dict, repr=False)

    def record(self, sim: Simulation) -> None:
        self.time.append(sim.time)
        humans = sim.engine.humans
        position = humans.position.copy()
        if humans.present is not None:   # a flow's absent members wait off the map: absent
            position[~humans.present] = np.nan
        self.humans.append(position)
        self.robots.append(sim.engine.robots.position.copy())

    def tracks(self, sim: Simulation) -> dict[str, Track]:
        """Every body's track by name, humans then robots (the recordings stacked once)."""
        engine, time = sim.engine, np.asarray(self.time)
        tracks: dict[str, Track] = {}
        for names, positions, radius in ((engine.humans.names, self.humans, engine.humans.radius),
                                         (engine.robots.names, self.robots, engine.robots.radius)):
            if names:
                stacked = np.stack(positions)   # (ticks, bodies, 2)
                tracks |= {name: Track(time, stacked[:, index], float(radius[index]))
                           for index, name in enumerate(names)}
        return tracks

    def metrics(self, sim: Simulation, subject: str, other: str | None = None
                ) -> dict[str, float]:
        """The social-navigation metrics of `subject` among every human (or `other` only)."""
        key = (subject, other, len(self.time))
        if key not in self._metrics:
            self._metrics[key] = self._computed_metrics(sim, subject, other)
        return self._metrics[key]

    def _computed_metrics(self, sim: Simulation, subject: str, other: str | None
                          ) -> dict[str, float]:
        tracks = self.tracks(sim) if self.time else {}
        track = tracks.get(subject)
        if track is None:
            return {}
        names = [other] if other is not None else [
            h for h in sim.engine.humans.names if h != subject]
        present = [n for n in names if n in tracks]
        goal, tolerance, plan_length = None, 0.2, None
        if subject in sim.engine.robots.names:
            spec = sim.engine.robots.specs[sim.engine.robots.index_of(subject)]
            goal, tolerance = spec.goal, spec.goal_tolerance
            plan_length = self._plan_length(sim, track, goal)
        return social_metrics(track, [tracks[n] for n in present], goal=goal,
                              goal_tolerance=tolerance,
                              groups=member_indices(sim.program.groups.values(), present,
                                                    subject),
                              clearance=sim.engine.grid.clearance_at, plan_length=plan_length)

    def _plan_length(self, sim: Simulation, track: Track, goal: tuple[float, float] | None
                     ) -> float | None:
        """The reference plan's length from the subject's start to its goal, planned once."""
        if goal is None:
            return None
        start = (float(track.position[0, 0]), float(track.position[0, 1]))
        query = (start, goal, track.radius)
        if query not in self.plan_lengths:
            self.plan_lengths[query] = reference_plan_length(sim.engine.grid, start, goal,
                                                             track.radius)
        return self.plan_lengths[query]


class Judge:
    """The verdicts of a run's expectations, and what they need recorded."""

    def __init__(self, sim: Simulation, record_tracks: bool = False,
                 plan_lengths: dict[PlanQuery, float | None] | None = None) -> None:
        """`plan_lengths`: reference plan lengths known from other runs on the same map (the
        Gymnasium env's episodes share theirs), filled in as this run finds more."""
        self.sim = sim
        self.verdicts = [Verdict(e) for e in sim.program.expectations]
        # the verdicts judged tick by tick (metrics wait for the end), and, from the first
        # tick on, the undecided ones with their conditions' tests (`Conditions.test`)
        self._ticking = [(v, condition) for v in self.verdicts
                         if not isinstance(condition := v.expectation.condition, MetricCompare)]
        self._watched: list[tuple[Verdict, Callable[[], bool]]] | None = None
        wants = record_tracks or len(self._ticking) < len(self.verdicts)  # a metric's expect
        self.tracks: Tracks | None = (Tracks(plan_lengths={} if plan_lengths is None
                                             else plan_lengths) if wants else None)
        if self.tracks is not None:
            self.tracks.record(sim)

    def observe(self) -> None:
        """After a tick: the undecided expectations' conditions as they hold now (`record`
        keeps the positions the metrics need)."""
        sim = self.sim
        if self._watched is None:
            self._watched = [(verdict, self._test(condition))
                             for verdict, condition in self._ticking]
        if not self._watched:
            return
        time = sim.time
        for verdict, holds in self._watched:
            verdict.observe(holds(), time)
        if any(verdict.held is not None for verdict, _ in self._watched):
            self._watched = [watched for watched in self._watched if watched[0].held is None]

    def _test(self, condition: Condition) -> Callable[[], bool]:
        assert self.sim.scheduler is not None  # a run with conditions to watch has activities
        return self.sim.scheduler.conditions.test(condition)

    def record(self) -> None:
        if self.tracks is not None and (not self.tracks.time
                                        or self.tracks.time[-1] != self.sim.time):
            self.tracks.record(self.sim)

    def finish(self) -> list[Verdict]:
        sim = self.sim
        for verdict in self.verdicts:
            condition = verdict.expectation.condition
            if isinstance(condition, MetricCompare) and self.tracks is not None:
                value = self.tracks.metrics(sim, condition.subject, condition.other).get(
                    condition.metric, math.nan)
                # a metric at a limit the run enforces (max_speed of a robot capped at 1 m/s)
                # comes out a few units in the last place over it: compared at 1e-9
                value = round(value, METRIC_DECIMALS) if math.isfinite(value) else value
                verdict.value = value
                verdict.held = COMPARE[condition.operator](
                    value, round(condition.threshold, METRIC_DECIMALS))
                verdict.decided_at = sim.time
            verdict.finish(sim.time)
        return self.verdicts
