"""Planner plugins of a third party: checked as they are named, answered for as they run.

A broken plugin is the user's error, told with the planner's name: at its line when `check`
cannot load it, or as the run's error (exit 1, the time it happened) when it raises, exits or
answers something that is no plan or no velocities. It reads the crowd without writing it.
The plugins are registered here as entry points would register them (`plugin_planners.py`).
"""

from __future__ import annotations

from collections.abc import Iterator
from importlib.metadata import EntryPoint
from pathlib import Path

import numpy as np
import pytest

from hubero_dsl.cli.main import main
from hubero_dsl.pipeline import CheckResult, check_source
from hubero_dsl.planners import registry
from hubero_dsl.planners.guard import PlannerError
from hubero_dsl.simulate import simulate
from tests.lang.conftest import CASE_PATH, REPO_ROOT, ROOM
from tests.planners import plugin_planners

MODULE = plugin_planners.__name__
WALK = "activity { actor1 move_to (5.0, 1.2) }\n"


@pytest.fixture(autouse=True)
def installed(monkeypatch: pytest.MonkeyPatch) -> Iterator[None]:
    """hubero's own planners and the test's, as if a package had registered them."""
    own = {group: registry._entry_points(group) for group in
           (registry.GLOBAL_GROUP, registry.LOCAL_GROUP)}
    theirs = {registry.GLOBAL_GROUP: plugin_planners.GLOBAL,
              registry.LOCAL_GROUP: plugin_planners.LOCAL}
    points = {group: {**own[group], **{name: EntryPoint(name, f"{MODULE}:{cls}", group)
                                       for name, cls in theirs[group].items()}}
              for group in own}
    monkeypatch.setattr(registry, "_entry_points", lambda group: points[group])
    registry._load.cache_clear()  # nothing loaded under these names before counts
    yield
    registry._load.cache_clear()  # and the test's planners stay nobody else's


def defaults(global_planner: str = "navfn", local_planner: str = "social_force") -> str:
    return f"defaults {{ global_planner {global_planner}; local_planner {local_planner} }}"


def checked(**planners: str) -> CheckResult:
    return check_source(ROOM + defaults(**planners) + "\n" + WALK, CASE_PATH)


def run_error(**planners: str) -> str:
    result = checked(**planners)
    assert result.program is not None, result.diagnostics
    with pytest.raises(PlannerError) as failed:
        simulate(result.program)
    return failed.value.message


def test_working_plugins_walk_the_humans_there() -> None:
    result = checked(global_planner="qa_straight", local_planner="qa_direct")
    assert result.program is not None, result.diagnostics
    assert simulate(result.program).state.value == "completed"


@pytest.mark.parametrize(("planner", "told"), [
    ("qa_plan_raises", "raised ZeroDivisionError: division by zero"),
    ("qa_plan_exits", "raised SystemExit: 0"),  # sys.exit(0) ended hubero with status 0
    ("qa_plan_nan", "not a Plan of (K, 2) finite waypoints"),
    ("qa_plan_list", "returned [(6.3, 2.5), (5.0, 1.2)], not a Plan of (K, 2) finite"),
    ("qa_plan_outside", "returned waypoints outside the map (x -5.77 .. 8.51"),
    ("qa_plan_huge", "returned a plan of 10,000,000 waypoints (at most 100,000)"),
])
def test_a_global_planner_that_fails_is_the_runs_error(planner: str, told: str) -> None:
    message = run_error(global_planner=planner)
    assert message.startswith(f"at t = 0 s, global planner '{planner}', asked for a plan "
                              "from (6.3, 2.5) to (5, 1.2), ")
    assert told in message


@pytest.mark.parametrize(("planner", "told"), [
    ("qa_set_up_raises", "local planner 'qa_set_up_raises' failed as it was set up: "
                         "ValueError: no licence"),
    ("qa_teleports", "local planner 'qa_teleports' raised ValueError: assignment destination "
                     "is read-only"),
    ("qa_wrong_shape", "local planner 'qa_wrong_shape' returned array([0., 0.]), not a (1, 2) "
                       "array of finite velocities"),
    ("qa_words", "local planner 'qa_words' returned 'fast', not a (1, 2) array"),
])
def test_a_local_planner_that_fails_is_the_runs_error(planner: str, told: str) -> None:
    assert told in run_error(local_planner=planner)


def test_a_local_planners_velocities_are_capped_at_the_humans_max_speed() -> None:
    result = checked(global_planner="qa_straight", local_planner="qa_too_fast")
    assert result.program is not None
    fastest: list[float] = []

    def observe(sim: object) -> None:
        humans = sim.engine.humans  # type: ignore[attr-defined]
        fastest.append(float((np.hypot(*humans.velocity.T) - humans.max_speed).max()))

    simulate(result.program, observers=[observe])
    assert fastest and max(fastest) <= 1e-9


def test_a_plugin_writing_into_its_copy_of_the_crowd_on_purpose_moves_nobody() -> None:
    result = checked(global_planner="qa_straight", local_planner="qa_bypasses")
    assert result.program is not None
    assert simulate(result.program).state.value == "completed"


def test_a_plugin_that_cannot_join_its_copies_is_named() -> None:
    from hubero_dsl.planners.guard import GuardedLocalPlanner

    guarded = [GuardedLocalPlanner(plugin_planners.JoinRaises(None, []), "qa_join_raises")
               for _ in range(2)]
    with pytest.raises(PlannerError, match="local planner 'qa_join_raises' failed as it was "
                                           "set up: RuntimeError: cannot join"):
        GuardedLocalPlanner.joined(guarded)


def test_a_plugins_failure_says_when_also_to_a_simulation_stepped_by_hand() -> None:
    from hubero_dsl.sim.simulation import Simulation

    result = checked(local_planner="qa_words")
    assert result.program is not None
    sim = Simulation(result.program)
    with pytest.raises(PlannerError, match=r"^at t = 0 s, local planner 'qa_words' returned"):
        for _ in range(3):
            sim.step()


@pytest.mark.parametrize(("planners", "code", "told"), [
    ({"local_planner": "qa_required"}, "E110",
     "local planner plugin 'qa_required': its `Params` must give every field a default, as "
     "hubero builds it with none given; these have none: gain"),
    ({"global_planner": "qa_not_installed"}, "E110",
     "global planner plugin 'qa_not_installed' cannot be loaded: AttributeError"),
    ({"global_planner": "qa_no_params"}, "E110",
     "global planner plugin 'qa_no_params': its `Params` must be a subclass of "
     "hubero_dsl.planners.base.PlannerParams, not None"),
    ({"global_planner": "qa_plain_params"}, "E110", "its `Params` must be a subclass of"),
    ({"local_planner": "qa_straight"}, "E101",
     "'qa_straight' is a global planner, not a local one"),
    ({"global_planner": "qa_direct"}, "E101", "'qa_direct' is a local planner, not a global one"),
])
def test_check_tells_a_plugin_that_is_no_planner_where_it_is_named(
        planners: dict[str, str], code: str, told: str) -> None:
    (error,) = checked(**planners).errors
    name = next(iter(planners.values()))
    assert error.span is not None and (error.code, error.span.line) == (code, 5)
    assert error.span.column == defaults(**planners).index(name) + 1
    assert told in error.message


def test_a_plugin_that_exits_fails_the_run_and_hubero_test_goes_on(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # `sys.exit(0)` in a plugin's plan ended `hubero run` and `hubero test` silently, exit 0
    room = ROOM.replace("../../maps/living_room.yaml", str(REPO_ROOT / "maps" / "living_room.yaml"))
    broken, fine = tmp_path / "exits.hub", tmp_path / "fine.hub"
    for path, planner in ((broken, "qa_plan_exits"), (fine, "qa_straight")):
        path.write_text(room + f"defaults {{ global_planner {planner} }}\n" + WALK,
                        encoding="utf-8")
    out = tmp_path / "out"
    out.mkdir()
    assert main(["run", str(broken), "-o", str(out / "run.mcap")]) == 1
    assert "global planner 'qa_plan_exits'" in capsys.readouterr().err
    assert not list(out.iterdir())  # no log, not even a part of one
    assert main(["test", str(broken), str(fine)]) == 1
    told = capsys.readouterr().out
    assert "ERROR" in told and "PASS" in told and told.rstrip().endswith("1 passed, 1 failed")
