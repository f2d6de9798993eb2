"""Running a scenario to its end: the loop, the expectations, and the result.

`run_program` steps a `Simulation` until its scheduler says the run is over, judging every
`expect` on the way (`hubero_dsl.sim.judge`), and returns a `RunResult` (with the robots'
social-navigation metrics). Observers (the MCAP writer, a progress bar) are
called after every tick with the simulation, so everything they record is at hand.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from hubero_dsl.errors import SimulationError
from hubero_dsl.planners.guard import PlannerError
from hubero_dsl.sim.judge import Judge, Verdict
from hubero_dsl.sim.scheduler import RunState, Scheduler
from hubero_dsl.sim.simulation import Simulation
from hubero_dsl.sim.status import TaskEvent, TaskStatus

Observer = Callable[[Simulation], None]


@dataclass
class HumanSummary:
    """How one actor (a human, or a robot) did: tasks, last status, distance, busy time."""

    name: str
    tasks_done: int
    tasks_total: int
    last_status: str
    path_length: float
    busy_time: float


@dataclass
class RunResult:
    state: RunState
    reason: str
    time: float
    ticks: int
    variant: str | None
    seed: int
    events: list[TaskEvent]
    expectations: list[Verdict] = field(default_factory=list)
    humans: list[HumanSummary] = field(default_factory=list)
    robots: list[HumanSummary] = field(default_factory=list)
    robot_metrics: dict[str, dict[str, float]] = field(default_factory=dict)

    @property
    def succeeded(self) -> bool:
        return self.state is RunState.COMPLETED and all(e.held for e in self.expectations)

    @property
    def expectations_hold(self) -> bool:
        return all(e.held for e in self.expectations)


def run_program(sim: Simulation, observers: Sequence[Observer] = ()) -> RunResult:
    """Run to the end: every activity done, the time limit, or a stopping failure."""
    scheduler = sim.scheduler
    if scheduler is None:
        raise SimulationError("run_program runs a scenario's activities: this simulation was "
                              "made with activities=False (step it, or run_until, yourself)")
    # robots' social-navigation metrics go in the summary; a crowd is too large to record
    record = sim.engine.robots.count > 0 and sim.engine.humans.count <= MAX_RECORDED_HUMANS
    judge = Judge(sim, record_tracks=record)
    try:
        _run(sim, scheduler, judge, observers)
    except PlannerError as exc:
        raise exc.at(sim.time) from None
    verdicts = judge.finish()
    robot_metrics = {name: judge.tracks.metrics(sim, name) for name in sim.engine.robots.names} \
        if judge.tracks is not None else {}
    return RunResult(scheduler.state, scheduler.reason, sim.time, sim.tick, sim.variant,
                     sim.seed, list(sim.events), verdicts, summarise(sim),
                     summarise_robots(sim), robot_metrics)


def _run(sim: Simulation, scheduler: Scheduler, judge: Judge,
         observers: Sequence[Observer]) -> None:
    while True:
        scheduler.update()  # also decides when the run is over (done, failed, timed out)
        judge.observe()
        if scheduler.state is not RunState.RUNNING:
            return
        sim.advance()
        scheduler.after_step()
        judge.record()
        for observer in observers:
            observer(sim)


MAX_RECORDED_HUMANS = 2000  # beyond, robots' metrics come from the log (hubero_dsl.analysis)


def summarise(sim: Simulation) -> list[HumanSummary]:
    """Per human: tasks finished of those given, the last status, metres walked, time spent on
    tasks (a task still on when the run ended up to its end). A task the activities had
    reached when the run stopped, but which never started, counts as given and is PENDING."""
    engine = sim.engine
    currents = [h.status.value if h is not None else None for h in engine.handle]
    return _summaries(sim.events, engine.humans.names, currents, engine.humans.path_length,
                      sim.time, _reached(sim))


def summarise_robots(sim: Simulation) -> list[HumanSummary]:
    """Per robot, the same as for humans."""
    robots = sim.engine.robots
    currents = [t.handle.status.value if t is not None else None for t in robots.tasks]
    return _summaries(sim.events, robots.names, currents, robots.path_length, sim.time,
                      _reached(sim))


def _reached(sim: Simulation) -> Counter[str]:
    """Per actor, the tasks reached but never started (none while the run goes on)."""
    scheduler = sim.scheduler
    return Counter(scheduler.reached() if scheduler is not None else ())


def _summaries(events: list[TaskEvent], names: list[str], currents: list[str | None],
               path_length: npt.NDArray[np.float64], now: float,
               reached: Counter[str]) -> list[HumanSummary]:
    summaries = []
    events_of: dict[str, list[TaskEvent]] = {}  # one pass over the events, not one per actor
    for event in events:
        events_of.setdefault(event.human, []).append(event)
    for index, name in enumerate(names):
        own = events_of.get(name, [])
        finals = [e for e in own if e.status.is_final]
        starts = {e.task_id: e.time for e in own if e.status is TaskStatus.ACTIVE}
        busy = sum(e.time - starts.get(e.task_id, e.time) for e in finals)
        ended = {e.task_id for e in finals}  # a task still on at the end counts up to it
        busy += sum(now - start for task, start in starts.items() if task not in ended)
        total = len(starts) + reached[name]
        done = sum(1 for e in finals if e.status is not TaskStatus.ABORTED)
        last = TaskStatus.PENDING.value if reached[name] else \
            currents[index] or (finals[-1].status.value if finals else "-")
        summaries.append(HumanSummary(name, done, total, last, float(path_length[index]), busy))
    return summaries
