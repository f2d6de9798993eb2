"""Running a compiled scenario with its log: the one way every front end runs a scenario.

    from hubero_dsl.pipeline import compile_file
    from hubero_dsl.simulate import simulate

    result = simulate(compile_file("scenarios/living_room.hub"), variant="ellipse",
                      log="run.mcap")

`hubero run`, `hubero test`, sweeps, scripts and benchmarks all call `simulate`, so a run
behaves the same from each of them: the same simulation, the same observers, the same log.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from contextlib import ExitStack
from pathlib import Path
from typing import TYPE_CHECKING

from hubero_dsl.sim.loop import Observer, RunResult, run_program
from hubero_dsl.sim.simulation import Simulation

if TYPE_CHECKING:
    from hubero_dsl.controllers.base import RobotController
    from hubero_dsl.log.sinks import MessageSink
    from hubero_dsl.model.program import Program

DEFAULT_LOG_RATE = 10.0  # Hz


def simulate(program: Program, *, variant: str | None = None, seed: int | None = None,
             log: str | Path | None = None, log_rate: float = DEFAULT_LOG_RATE,
             observers: Sequence[Observer] = (), writer_process: bool | None = None,
             controllers: Mapping[str, type | RobotController] | None = None,
             live: MessageSink | None = None) -> RunResult:
    """Run one variant of `program` with one seed to its end, writing an MCAP log to `log`
    (none when None). `observers` are called after every tick, after the log's.

    `writer_process` chooses where the log is encoded: None lets the writer decide (a process
    of its own where the platform can fork one), False keeps it in this process (as a sweep's
    workers need). The log is complete under its name only when the run ended; an exception,
    Ctrl-C or SIGTERM leaves no file there. `controllers` hands robots to the caller's own
    controllers (classes or instances), by robot name. `live` (a `log.live.LiveServer`)
    gets the log's messages too, as they are written, also when `log` is None.
    """
    sim = Simulation(program, variant=variant, seed=seed, controllers=controllers)
    with ExitStack() as stack:
        everyone: list[Observer] = []
        run_log = None
        if log is not None or live is not None:
            from hubero_dsl.log.writer import RunLog

            run_log = stack.enter_context(RunLog(log, sim, rate_hz=log_rate,
                                                 writer_process=writer_process, live=live))
            everyone.append(run_log.observe)
        everyone.extend(observers)
        result = run_program(sim, everyone)
        if run_log is not None:
            run_log.close(result)
    return result
