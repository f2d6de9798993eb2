"""Finding planners: built-in and third-party planners register the same way, through the
entry-point groups `hubero_dsl.global_planners` and `hubero_dsl.local_planners` (see
pyproject.toml). Names are listed without importing any planner, so checking a scenario stays
cheap; a planner is imported when its class or parameters are first needed.
"""

from __future__ import annotations

from functools import cache
from importlib.metadata import EntryPoint, entry_points
from typing import TYPE_CHECKING

from pydantic import ValidationError

from hubero_dsl.errors import OUTSIDE_STOPS, InputError, failure_of

if TYPE_CHECKING:
    from hubero_dsl.planners.base import GlobalPlanner, LocalPlanner, PlannerParams

GLOBAL_GROUP = "hubero_dsl.global_planners"
LOCAL_GROUP = "hubero_dsl.local_planners"


@cache
def _entry_points(group: str) -> dict[str, EntryPoint]:
    return {entry.name: entry for entry in sorted(_planner_entry_points()[group],
                                                   key=lambda e: e.name)}


@cache
def _planner_entry_points() -> dict[str, tuple[EntryPoint, ...]]:
    """Both groups' entry points from one scan of the installed distributions: each scan reads
    every distribution's metadata, a noticeable part of compiling a first scenario."""
    everything = entry_points()  # EntryPoints; on Python 3.11 SelectableGroups, which selects too
    return {group: tuple(everything.select(group=group)) for group in (GLOBAL_GROUP, LOCAL_GROUP)}


@cache
def _load(group: str, name: str) -> type:
    what = f"{_KIND[group]} planner plugin '{name}'"
    entry = _entry_points(group).get(name)
    if entry is None:
        raise InputError(f"no {_KIND[group]} planner named '{name}'")
    try:
        loaded = entry.load()
    except OUTSIDE_STOPS:
        raise
    except BaseException as exc:  # a broken third-party plugin must not take hubero down
        raise InputError(f"{what} cannot be loaded: {failure_of(exc)}") from None
    return _checked(loaded, what, _METHOD[group])


_KIND = {GLOBAL_GROUP: "global", LOCAL_GROUP: "local"}
_METHOD = {GLOBAL_GROUP: "plan", LOCAL_GROUP: "velocities"}


def _checked(loaded: object, what: str, method: str) -> type:
    """The class a plugin registered, if it is a planner; InputError saying what it lacks."""
    from hubero_dsl.planners.base import PlannerParams

    if not isinstance(loaded, type):
        raise InputError(f"{what} is not a class")
    if not callable(getattr(loaded, method, None)):
        raise InputError(f"{what} has no {method}() method")
    params = getattr(loaded, "Params", None)
    if not (isinstance(params, type) and issubclass(params, PlannerParams)):
        raise InputError(f"{what}: its `Params` must be a subclass of "
                         f"hubero_dsl.planners.base.PlannerParams, not {params!r}")
    try:  # robots, and humans given none of its parameters, take them all as defaults
        params()
    except OUTSIDE_STOPS:
        raise
    except ValidationError as exc:
        missing = [".".join(map(str, e["loc"])) for e in exc.errors() if e["type"] == "missing"]
        if missing:
            raise InputError(f"{what}: its `Params` must give every field a default, as "
                             "hubero builds it with none given; these have none: "
                             f"{', '.join(missing)}") from None
        problems = "; ".join(f"{'.'.join(map(str, e['loc'])) or 'Params'}: {e['msg']}"
                             for e in exc.errors())
        raise InputError(f"{what}: its `Params` cannot be built with no values: "
                         f"{problems}") from None
    except BaseException as exc:  # user code
        raise InputError(f"{what}: its `Params` cannot be built with no values: "
                         f"{_first_line(failure_of(exc))}") from None
    return loaded


def _first_line(text: str) -> str:
    return text.splitlines()[0] if text else text


def check_plugin(kind: str, name: str) -> None:
    """InputError when the `kind` ("global" or "local") planner `name` is a plugin that cannot
    be loaded or is no planner. hubero's own planners are not imported: checking a scenario
    stays cheap."""
    group = GLOBAL_GROUP if kind == "global" else LOCAL_GROUP
    entry = _entry_points(group).get(name)
    if entry is not None and not entry.value.startswith(OWN_PACKAGE):
        _load(group, name)


OWN_PACKAGE = "hubero_dsl."  # hubero's own planners' modules: not plugins


def global_planner_names() -> list[str]:
    """Installed global planners, without importing them."""
    return sorted(_entry_points(GLOBAL_GROUP))


def local_planner_names() -> list[str]:
    """Installed local planners, without importing them."""
    return sorted(_entry_points(LOCAL_GROUP))


def global_planner(name: str) -> type[GlobalPlanner]:
    return _load(GLOBAL_GROUP, name)


def local_planner(name: str) -> type[LocalPlanner]:
    return _load(LOCAL_GROUP, name)


def planner_params(name: str) -> type[PlannerParams] | None:
    """The parameter model of a planner of either kind, or None when no such planner exists."""
    if name in _entry_points(GLOBAL_GROUP):
        return global_planner(name).Params
    if name in _entry_points(LOCAL_GROUP):
        return local_planner(name).Params
    return None
