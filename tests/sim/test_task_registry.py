"""The task registry: every kind has a behaviour, and a new kind is one entry and one behaviour.

The test adds a kind (`wave`) the way a contributor would, touching only the registry and the
behaviours' table, and uses it from a scenario file and from the API: the checker, the graph
verification, the scheduler, the human API and the log all take it without another change.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from hubero_dsl.errors import SimulationError
from hubero_dsl.log.reader import load_run
from hubero_dsl.model.tasks import TASKS, OptionSpec, TargetRule, TaskKind, ValueKind
from hubero_dsl.pipeline import check_source
from hubero_dsl.sim.behaviours import BEHAVIOURS, Behaviour, Stand, Timing, World
from hubero_dsl.sim.simulation import Simulation
from hubero_dsl.sim.status import TaskStatus
from hubero_dsl.simulate import simulate
from tests.sim.conftest import ScenarioFactory


class Wave(Stand):
    """Stand where you are, facing someone, and wave for a while."""

    kind = "wave"

    def start(self, engine: World) -> None:
        super().start(engine)
        self.state = "waving"


WAVE = TaskKind("wave", "stand and wave at someone", TargetRule.BODY,
                (OptionSpec("for", "duration", ValueKind.TIME),))


@pytest.fixture
def wave_registered(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(TASKS, "wave", WAVE)
    monkeypatch.setitem(BEHAVIOURS, "wave",
                        lambda task: Wave(Timing(task.get("duration")), task.target))


def test_every_kind_has_a_behaviour_and_every_behaviour_a_kind() -> None:
    assert set(BEHAVIOURS) == set(TASKS)


@pytest.mark.parametrize("kind", sorted(TASKS))
def test_a_kind_builds_a_behaviour_of_that_kind(kind: str) -> None:
    from hubero_dsl.model.tasks import Task

    spec = TASKS[kind]
    target = None if spec.target is TargetRule.NONE else "bob"
    behaviour = BEHAVIOURS[kind](Task(kind, target, {"duration": 1.0}
                                      if spec.argument("duration") else {}))
    assert isinstance(behaviour, Behaviour)
    assert behaviour.kind == kind


@pytest.mark.usefixtures("wave_registered")
def test_a_new_kind_runs_from_a_scenario_file(scenario: ScenarioFactory, tmp_path: Path) -> None:
    program = scenario(
        "human alice at (2, 2)\nhuman bob at (6, 2)\n"
        "activity { greet: alice wave bob for 1.5 s; alice move_to (3, 3) }\n"
        "expect greet done within 5 s\n")
    log = tmp_path / "wave.mcap"
    result = simulate(program, log=log)
    assert result.succeeded
    waves = [e for e in result.events if e.kind == "wave"]
    assert [e.status for e in waves] == [TaskStatus.ACTIVE, TaskStatus.SUCCEEDED]
    assert waves[1].time == pytest.approx(1.5)
    assert any(e.kind == "wave" for e in load_run(log).events)


@pytest.mark.usefixtures("wave_registered")
def test_a_new_kind_is_checked_like_the_others(room_map: Path) -> None:
    header = f'scenario "t"\nmap "{room_map}"\nhuman alice at (2, 2)\nhuman bob at (6, 2)\n'
    codes = {text: {d.code for d in check_source(header + text, "t.hub").errors}
             for text in ("activity { alice wave bob }",              # no natural end
                          "activity { alice wave for 2 s }",          # needs its target
                          "activity { alice wave bob speed 1 m/s for 1 s }",  # no such option
                          "activity { alice wave bob for 2 m }")}  # wrong dimension
    assert codes == {"activity { alice wave bob }": {"E306"},
                     "activity { alice wave for 2 s }": {"E205"},
                     "activity { alice wave bob speed 1 m/s for 1 s }": {"E107"},
                     "activity { alice wave bob for 2 m }": {"E201"}}


@pytest.mark.usefixtures("wave_registered")
def test_a_new_kind_is_in_the_api(scenario: ScenarioFactory) -> None:
    sim = Simulation(scenario("human alice at (2, 2)\nhuman bob at (6, 2)\n"),
                     activities=False)
    task = sim.human("alice").do("wave", "bob", duration=0.5)
    assert task.description == "wave bob"
    assert sim.human("alice").state == "waving"
    assert sim.run_until(lambda: task.done, time_limit=2.0)
    with pytest.raises(SimulationError, match="wave takes no 'speed'"):
        sim.human("alice").do("wave", "bob", speed=1.0)


def test_an_unknown_kind_is_refused_by_the_api(scenario: ScenarioFactory) -> None:
    sim = Simulation(scenario("human alice at (2, 2)\n"), activities=False)
    with pytest.raises(SimulationError, match="unknown task 'dance'"):
        sim.human("alice").do("dance")
