"""Planning a sweep: seeds, variant selection, parameters, and folder names safe everywhere."""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

import pytest

from hubero_dsl.errors import InputError
from hubero_dsl.pipeline import compile_file
from hubero_dsl.sweep.plan import (
    MAX_RUNS,
    parse_seeds,
    plan_sweep,
    safe_name,
    select_variants,
    split_variant_list,
    variant_folders,
)
from tests.sweep.conftest import PLAIN, SWEPT, Write


@pytest.mark.parametrize(("text", "seeds"), [
    ("1..5", (1, 2, 3, 4, 5)), ("3", (3,)), ("1,2,5", (1, 2, 5)), ("0", (0,)),
    (" 7 .. 9 , 2 ", (2, 7, 8, 9)), ("5,1..3,2", (1, 2, 3, 5)), ("4..4", (4,)),
])
def test_seeds_are_ranges_and_lists_sorted_once(text: str, seeds: tuple[int, ...]) -> None:
    assert parse_seeds(text) == seeds


@pytest.mark.parametrize(("text", "says"), [
    ("", "empty"), ("1-5", "'1-5' is not a seed"), ("a", "'a' is not a seed"),
    ("-1", "not a seed"), ("1,,2", "'' is not a seed"), ("5..1", "write it upwards (1..5)"),
    ("1...3", "not a seed"), ("1.5", "not a seed"), (f"0..{MAX_RUNS}", "at most"),
    # thousands of digits: int() itself refuses them (an internal error before)
    ("1," + "9" * 4400, "'9999999999999999999999999999999999999...' is not a seed"),
    ("9" * 19, "of at most 18 digits"),
])
def test_bad_seeds_say_what_is_wrong(text: str, says: str) -> None:
    with pytest.raises(InputError, match="--seeds") as caught:
        parse_seeds(text)
    assert says in caught.value.message


def test_variants_all_in_file_order_or_the_scenario_as_written() -> None:
    available = ["b", "a=1 m/s,c=2"]
    assert select_variants(available, None) == available
    assert select_variants([], None) == [None]
    assert select_variants(available, ["a=1 m/s,c=2", "b"]) == available  # file order


def test_unknown_variants_list_the_known_ones() -> None:
    with pytest.raises(InputError) as caught:
        select_variants(["x=1,y=2", "b"], ["x=1", "b", "nope"])
    assert caught.value.message == "unknown variant 'x=1', 'nope' (variants: x=1,y=2; b)"
    with pytest.raises(InputError, match="this scenario has no variants"):
        select_variants([], ["fast"])
    with pytest.raises(InputError, match="no variant selected"):
        select_variants(["a"], [])


def test_variant_lists_split_on_semicolons_because_sweep_names_have_commas() -> None:
    assert split_variant_list("all") is None
    assert split_variant_list("speed=1.0 m/s,k=0.5; slow ;") == ["speed=1.0 m/s,k=0.5", "slow"]


def test_folder_names_are_safe_and_unique() -> None:
    assert safe_name("speed=1.0 m/s,avoidance_strength=0.5") == \
        "speed=1.0m_s,avoidance_strength=0.5"
    assert safe_name(None) == "default"
    assert safe_name("..") == "_.."
    assert safe_name("CON") == "_CON"
    long = "x=" + "9" * 200
    assert len(safe_name(long)) == 80 + 9 and safe_name(long) != safe_name(long + "8")
    folders = variant_folders(["a b", "ab", "AB", "c"])
    assert folders["c"] == "c"
    assert len({name.lower() for name in folders.values()}) == 4
    assert folders["ab"].startswith("ab-") and folders["a b"].startswith("ab-")


def test_a_plan_lists_every_variant_by_seed_with_its_parameters(write_scenario: Write) -> None:
    path = write_scenario(SWEPT)
    program = compile_file(path)
    plan = plan_sweep(path, program, list(program.variants), [3, 1])
    # a named variant and a sweep multiply: one variant per combination
    assert plan.variants == ("slow,avoidance_strength=0.5", "slow,avoidance_strength=1.5")
    assert [(r.variant, r.seed) for r in plan.runs] == [
        ("slow,avoidance_strength=0.5", 1), ("slow,avoidance_strength=0.5", 3),
        ("slow,avoidance_strength=1.5", 1), ("slow,avoidance_strength=1.5", 3)]
    assert plan.runs[2].log == "runs/slow,avoidance_strength=1.5/seed-1.mcap"
    assert plan.parameters["slow,avoidance_strength=0.5"] == {
        "speed": 0.6, "b.personal_space": {"shape": "ellipse", "semi_major": 0.6,
                                           "semi_minor": 0.4, "offset": 0.0},
        "avoidance_strength": 0.5}
    assert plan.scenario == str(path) and os.path.isabs(plan.scenario_path)
    assert plan.source_sha256 == hashlib.sha256(path.read_bytes()).hexdigest()


def test_a_scenario_without_variants_is_planned_once_per_seed(write_scenario: Write,
                                                              tmp_path: Path,
                                                              monkeypatch: pytest.MonkeyPatch
                                                              ) -> None:
    write_scenario(PLAIN)
    monkeypatch.chdir(tmp_path)
    program = compile_file("s.hub")
    plan = plan_sweep("s.hub", program, select_variants([], None), [program.seed])
    assert [(r.variant, r.seed, r.log) for r in plan.runs] == [
        (None, 9, "runs/default/seed-9.mcap")]
    assert plan.parameters == {None: {}}
    assert plan.scenario == "s.hub" and plan.scenario_path == str(tmp_path / "s.hub")


def test_too_many_runs_are_refused_before_anything_runs(write_scenario: Write) -> None:
    program = compile_file(write_scenario(SWEPT))
    with pytest.raises(InputError, match="a sweep runs at most"):
        plan_sweep("s.hub", program, list(program.variants), range(MAX_RUNS // 2 + 1))
