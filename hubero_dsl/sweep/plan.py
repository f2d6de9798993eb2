"""What a sweep runs: the seeds and variants asked for, and one `RunSpec` per variant x seed.

    seeds = parse_seeds("1..20")                     # (1, 2, ..., 20)
    variants = select_variants(program, ["fast"])    # [None] when the scenario has no variants
    plan = plan_sweep("scenarios/x.hub", program, variants, seeds)

A plan is plain data (strings and numbers) so that it pickles cheaply to worker processes and
Dask workers: they get the scenario's text and absolute path, never the compiled `Program`
(which holds numpy arrays and shapely polygons), and compile it themselves.

Log paths are `runs/VARIANT/seed-N.mcap` relative to the output folder, with VARIANT made safe
for any file system (`speed=1.0 m/s,k=0.5` -> `speed=1.0m_s,k=0.5`); names that would collide
once made safe (also ignoring case) get a short hash of the real name.
"""

from __future__ import annotations

import hashlib
import os
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from hubero_dsl.errors import InputError

if TYPE_CHECKING:
    from hubero_dsl.model.program import ParamValue, Program

MAX_RUNS = 100_000  # a typo like 1..10000000 should fail at once, not after filling the disk
MAX_NAME_LENGTH = 80  # characters of a variant's folder name before it is cut and hashed
DEFAULT_FOLDER = "default"  # the folder of the scenario as written (no variants)

_UNSAFE = re.compile(r"[^A-Za-z0-9._,=+-]")
_RESERVED = frozenset({"CON", "PRN", "AUX", "NUL", *(f"COM{i}" for i in range(1, 10)),
                       *(f"LPT{i}" for i in range(1, 10))})


def variant_label(variant: str | None) -> str:
    """A variant's name as tables and messages show it; the scenario as written has none."""
    return variant if variant is not None else "(as written)"


@dataclass(frozen=True, slots=True)
class RunSpec:
    """One run of the sweep: a variant (None: the scenario as written) with a seed."""

    variant: str | None
    seed: int
    log: str  # relative to the output folder, with '/' separators


@dataclass(frozen=True, slots=True)
class SweepPlan:
    """Everything needed to run a sweep and write its index, as plain data."""

    scenario: str                    # the path as the user gave it (for the index)
    scenario_path: str               # absolute, for workers (whose working folder may differ)
    source: str                      # the scenario's text: every worker compiles the same text
    source_sha256: str
    variants: tuple[str | None, ...]  # in the order of the file
    parameters: Mapping[str | None, Mapping[str, Any]]  # per variant, JSON-safe
    runs: tuple[RunSpec, ...]        # sorted by (variant order, seed)


# ---- seeds ---------------------------------------------------------------------------------


def parse_seeds(text: str) -> tuple[int, ...]:
    """`1..20`, `3`, `1,2,5` or a mix (`1..3,10`): the seeds, sorted, each once."""
    from hubero_dsl.model.params import SEED_DIGITS  # here: its module brings numpy with it

    seed = rf"(\d{{1,{SEED_DIGITS}}})"
    seed_item = re.compile(rf"^\s*{seed}\s*(?:\.\.\s*{seed}\s*)?$")
    if not text.strip():
        raise InputError("--seeds is empty: give seeds like 1..20, 3 or 1,2,5")
    seeds: set[int] = set()
    for item in text.split(","):
        match = seed_item.match(item)
        if match is None:
            shown = item.strip() if len(item.strip()) <= 40 else item.strip()[:37] + "..."
            raise InputError(f"--seeds: '{shown}' is not a seed or a range; give seeds "
                             "like 1..20, 3 or 1,2,5 (whole numbers from 0, of at most "
                             f"{SEED_DIGITS} digits)")
        first = int(match[1])
        last = int(match[2]) if match[2] is not None else first
        if last < first:
            raise InputError(f"--seeds: the range {first}..{last} is empty; write it upwards "
                             f"({last}..{first})")
        if last - first + 1 > MAX_RUNS:
            raise InputError(f"--seeds: {first}..{last} is {last - first + 1} seeds; a sweep "
                             f"runs at most {MAX_RUNS}")
        seeds.update(range(first, last + 1))
        if len(seeds) > MAX_RUNS:
            raise InputError(f"--seeds: more than {MAX_RUNS} seeds")
    return tuple(sorted(seeds))


# ---- variants ------------------------------------------------------------------------------


def select_variants(available: Sequence[str], names: Sequence[str] | None
                    ) -> list[str | None]:
    """The variants to run, in the order of the file; `names=None` means all of them.

    A scenario without variants runs once as written (None). Unknown names are an InputError.
    """
    if names is None:
        return list(available) or [None]
    if not names:
        raise InputError("no variant selected: name at least one, or use --variants all")
    unknown = [name for name in names if name not in available]
    if unknown:
        from hubero_dsl.model.program import unknown_variants

        raise InputError(unknown_variants(unknown, available))
    wanted = set(names)
    return [name for name in available if name in wanted]


def split_variant_list(text: str) -> list[str] | None:
    """`--variants`: `all` (None), or names separated by `;` (sweep names contain commas)."""
    if text.strip() == "all":
        return None
    return [name.strip() for name in text.split(";") if name.strip()]


def variant_parameters(program: Program, variant: str | None) -> dict[str, Any]:
    """What the variant sets, flat and JSON-safe: `speed`, `social_force.A`, `actor1.speed`."""
    if variant is None:
        return {}
    settings: dict[str, Any] = {}
    for layer in program.variants[variant].layers:
        for key, value in layer.values.items():
            settings[key] = json_value(value)
        for human, values in layer.per_human.items():
            for key, value in values.items():
                settings[f"{human}.{key}"] = json_value(value)
    return settings


def json_value(value: ParamValue) -> Any:
    """A parameter as JSON: numbers and names as they are, shapes as objects, distributions
    as their text (`normal(1.3, 0.1)`)."""
    from hubero_dsl.log.schemas import shape_json
    from hubero_dsl.model.program import Distribution

    if isinstance(value, Distribution):
        return value.describe()
    if isinstance(value, bool | int | float | str):
        return value
    return shape_json(value)


# ---- the plan ------------------------------------------------------------------------------


def plan_sweep(scenario: str | Path, program: Program, variants: Sequence[str | None],
               seeds: Sequence[int]) -> SweepPlan:
    """Every variant x seed, in the order of the file and then by seed."""
    if len(variants) * len(seeds) > MAX_RUNS:
        raise InputError(f"{len(variants)} variants x {len(seeds)} seeds is "
                         f"{len(variants) * len(seeds)} runs; a sweep runs at most {MAX_RUNS}")
    folders = variant_folders(variants)
    runs = tuple(RunSpec(variant, seed, f"runs/{folders[variant]}/seed-{seed}.mcap")
                 for variant in variants for seed in sorted(seeds))
    text = program.source.text
    return SweepPlan(
        scenario=str(scenario), scenario_path=os.path.abspath(scenario), source=text,
        source_sha256=hashlib.sha256(text.encode("utf-8")).hexdigest(),
        variants=tuple(variants),
        parameters={variant: variant_parameters(program, variant) for variant in variants},
        runs=runs)


def variant_folders(variants: Sequence[str | None]) -> dict[str | None, str]:
    """A folder name per variant, safe on any file system and unique even ignoring case."""
    safe = {variant: safe_name(variant) for variant in variants}
    counts: dict[str, int] = {}
    for name in safe.values():
        counts[name.lower()] = counts.get(name.lower(), 0) + 1
    return {variant: name if counts[name.lower()] == 1 else _hashed(name, variant)
            for variant, name in safe.items()}


def safe_name(variant: str | None) -> str:
    """`speed=1.0 m/s` -> `speed=1.0m_s`: spaces dropped, other unsafe characters `_`."""
    if variant is None:
        return DEFAULT_FOLDER
    name = _UNSAFE.sub("_", variant.replace(" ", ""))
    if name.startswith(".") or not name or name.upper() in _RESERVED:
        name = "_" + name  # no hidden folders, no '..', nothing Windows refuses
    if len(name) > MAX_NAME_LENGTH:
        name = _hashed(name[:MAX_NAME_LENGTH], variant)
    return name


def _hashed(name: str, variant: str | None) -> str:
    digest = hashlib.sha256((variant or "").encode("utf-8")).hexdigest()[:8]
    return f"{name}-{digest}"
