"""`hubero calibrate`: a deterministic fit, its defaults block, and bad input."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("pedpy")

from hubero_dsl.errors import InputError
from hubero_dsl.pipeline import compile_source
from hubero_dsl.sweep.executors import SerialExecutor
from hubero_dsl.validation import calibrate as calibration
from hubero_dsl.validation.calibrate import (
    FITTABLE,
    Calibration,
    calibrate,
    chosen,
    loss,
    starting_values,
)
from hubero_dsl.validation.experiments import shipped_path

Cli = Callable[..., Any]
FREE_FLOW = str(shipped_path("uo-050-180-180"))


def test_loss_is_the_mean_square_and_a_file_without_bins_costs_one() -> None:
    assert loss([[0.1, -0.3], [0.2]]) == pytest.approx((0.01 + 0.09 + 0.04) / 3)
    assert loss([[0.5], []]) == pytest.approx((0.25 + 1.0) / 2)


def test_unknown_or_repeated_parameters_are_refused() -> None:
    with pytest.raises(InputError, match="can be fitted are relaxation_time"):
        chosen(["relaxation"])
    with pytest.raises(InputError, match="named twice"):
        chosen(["relaxation_time", "relaxation_time"])


def test_the_defaults_block_is_valid_language() -> None:
    fitted = {"relaxation_time": 0.4, "social_force.A": 1.5, "social_force.B": 0.12,
              "personal_space": 0.3, "speed_scale": 1.1}
    block = Calibration(fitted, 0.01, 5, (), ()).defaults_block(["uo-050-180-180"])
    assert "# desired speeds: the measured ones times 1.100" in block
    map_yaml = Path(__file__).resolve().parents[2] / "maps" / "rimea_corridor.yaml"
    program = compile_source(f'scenario "x"\nmap "{map_yaml}"\n{block}'
                             'human a at (1.0, 1.0)\n')
    params = program.resolved_params()["a"]
    assert params["relaxation_time"] == pytest.approx(0.4)
    assert params["social_force.B"] == pytest.approx(0.12)
    assert set(FITTABLE) >= set(fitted)


@pytest.mark.parametrize("end", ["low", "high"])
def test_every_fittable_parameter_at_its_bounds_is_a_valid_value(end: str) -> None:
    # the search's bounds lie within what the language accepts, so no set it tries is refused
    fitted = {f.name: getattr(f, end) for f in FITTABLE.values()}
    block = Calibration(fitted, 0.01, 5, (), ()).defaults_block(["uo-050-180-180"])
    map_yaml = Path(__file__).resolve().parents[2] / "maps" / "rimea_corridor.yaml"
    program = compile_source(f'scenario "x"\nmap "{map_yaml}"\n{block}'
                             'human a at (1.0, 1.0)\n')
    params = program.resolved_params()["a"]
    for name, value in fitted.items():
        if name.startswith("social_force."):
            assert params[name] == value


def test_the_block_holds_the_values_exactly_as_they_were_run() -> None:
    fitted = {"relaxation_time": 0.2318, "social_force.space_at_rest": 0.7951,
              "personal_space": 0.4432}
    block = Calibration(fitted, 0.01, 5, (), ()).defaults_block(["uo-050-180-180"])
    assert "relaxation_time 0.2318 s" in block and "circle(radius: 0.4432 m)" in block
    map_yaml = Path(__file__).resolve().parents[2] / "maps" / "rimea_corridor.yaml"
    program = compile_source(f'scenario "x"\nmap "{map_yaml}"\n{block}'
                             'human a at (1.0, 1.0)\n')
    params = program.resolved_params()["a"]
    assert params["relaxation_time"] == 0.2318
    assert params["social_force.space_at_rest"] == 0.7951


def test_with_several_seeds_the_error_is_taken_over_all_their_runs(
        monkeypatch: pytest.MonkeyPatch) -> None:
    runs: list[tuple[str, int]] = []

    def errors(path: str, seed: int, values: tuple[tuple[str, float], ...]) -> list[float]:
        runs.append((path, seed))
        value = dict(values)["relaxation_time"]
        return [value - 0.6 + 0.2 * (seed - 3)]  # seed 3 fits best at 0.6, seed 4 at 0.4

    monkeypatch.setattr(calibration, "file_errors", errors)
    result = calibrate([Path("a.txt")], [], fit=chosen(["relaxation_time"]), seed=3, seeds=2,
                       evaluations=12, executor=SerialExecutor())
    assert {seed for _, seed in runs} == {3, 4}
    best = result.fitted["relaxation_time"]
    assert 0.45 < best < 0.55  # the compromise between the two seeds, not either's optimum
    (report,) = result.train
    assert report.fitted_loss == pytest.approx(loss([[best - 0.6, best - 0.4]]))


def test_a_search_from_given_values_starts_there_and_spends_its_budget_there(
        monkeypatch: pytest.MonkeyPatch) -> None:
    tried: list[dict[str, float]] = []

    def errors(path: str, seed: int, values: tuple[tuple[str, float], ...]) -> list[float]:
        tried.append(dict(values))
        return [dict(values)["relaxation_time"] - 0.9]

    monkeypatch.setattr(calibration, "file_errors", errors)
    fit = chosen(["relaxation_time", "social_force.A"])
    start = starting_values(fit, "relaxation_time=0.8")
    result = calibrate([Path("a.txt")], [], fit=fit, seed=1, evaluations=10,
                       executor=SerialExecutor(), start=start)
    # the given value and the default of the one not given; then the search, no survey
    assert tried[0] == {"relaxation_time": 0.8, "social_force.A": 2.1}
    assert all(abs(t["relaxation_time"] - 0.8) <= 0.15 * 1.0 + 1e-9 for t in tried[:3])
    assert abs(result.fitted["relaxation_time"] - 0.9) < 0.1


def test_a_small_fit_is_deterministic_and_reports_held_out_errors(cli: Cli,
                                                                  tmp_path: Path) -> None:
    out = tmp_path / "fitted.hub"
    argv = ("calibrate", "--train", FREE_FLOW, "--test", FREE_FLOW, "--fit", "relaxation_time",
            "--evaluations", "3", "--executor", "serial", "--json")
    first = cli(*argv, "-o", str(out))
    assert first.status == 0, first.err
    report = json.loads(first.out)
    assert set(report["fitted"]) == {"relaxation_time"}
    assert 0.2 <= report["fitted"]["relaxation_time"] <= 1.2
    assert report["evaluations"] <= 3
    (held_out,) = report["test"]
    assert held_out["file"] == "uo-050-180-180"
    assert held_out["fitted_loss"] == pytest.approx(report["train"][0]["fitted_loss"])
    assert out.read_text(encoding="utf-8").splitlines()[-1] == "}"
    assert cli(*argv).out == first.out


@pytest.mark.parametrize(("argv", "message"), [
    (("--fit", "nonsense"), "can be fitted are"),
    (("--evaluations", "0"), "--evaluations must be"),
    (("--seed", "-2"), "--seed must be"),
    (("--seeds", "0"), "--seeds must be"),
    (("--jobs", "0"), "--jobs must be from 1 to 256, got 0"),
    (("--jobs", "100000"), "--jobs must be from 1 to 256, got 100000"),
    (("--train", FREE_FLOW, "--start", "relaxation_time=9"), "must be a number from 0.2 to 1.2"),
    (("--train", FREE_FLOW, "--start", "relaxation_time=fast"), "must be a number from"),
    (("--train", FREE_FLOW, "--start", "social_force.B_wall=0.1"), "--start takes NAME=VALUE"),
    (("--train", FREE_FLOW, "--start", "relaxation_time"), "--start takes NAME=VALUE"),
    (("--train", FREE_FLOW, "--start", "relaxation_time=0.3,relaxation_time=0.4"), "twice"),
    (("--train", "corridor.txt"), "cannot tell which experiment"),
    (("--train", "uo-050-180-180.txt"), "trajectory file not found"),
    (("--train", FREE_FLOW, "-o", "no/such/dir/f.hub"), "cannot be written"),
])
def test_bad_input_exits_2(cli: Cli, argv: tuple[str, ...], message: str) -> None:
    outcome = cli("calibrate", "--executor", "serial", *argv)
    assert outcome.status == 2
    assert message in outcome.err


def test_each_fittable_parameters_default_is_the_one_runs_take() -> None:
    # the "hubero's defaults" side of a calibration's report is measured with these
    from hubero_dsl.model.params import HUMAN_PARAMS
    from hubero_dsl.planners.social_force import SocialForceParams
    from hubero_dsl.validation.calibrate import FITTABLE

    for fittable in FITTABLE.values():
        planner, _, field = fittable.name.rpartition(".")
        if planner == "social_force":
            default = SocialForceParams.model_fields[field].default
        elif fittable.name == "personal_space":
            default = HUMAN_PARAMS["personal_space"].default.radius
        elif fittable.name == "speed_scale":  # a factor on measured speeds, not a parameter
            default = 1.0
        else:
            default = HUMAN_PARAMS[fittable.name].default
        assert fittable.default == pytest.approx(default), fittable.name
