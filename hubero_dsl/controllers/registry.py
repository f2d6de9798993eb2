"""Finding robot controllers by name: built-in and third-party controllers register the same
way, under the entry-point group `hubero.controllers` (see pyproject.toml). A scenario file
names a controller; it never names Python code. Names are listed without importing anything;
a controller is imported when its class or parameters are first needed.
"""

from __future__ import annotations

import importlib
from functools import cache
from importlib.metadata import EntryPoint, entry_points
from typing import TYPE_CHECKING

from hubero_dsl.errors import OUTSIDE_STOPS, InputError, failure_of

if TYPE_CHECKING:
    from hubero_dsl.controllers.base import ControllerParams

GROUP = "hubero.controllers"


@cache
def _entry_points() -> dict[str, EntryPoint]:
    return {entry.name: entry for entry in sorted(entry_points(group=GROUP),
                                                   key=lambda e: e.name)}


def controller_names() -> list[str]:
    """Installed controllers, without importing them."""
    return sorted(_entry_points())


@cache
def controller_class(name: str) -> type:
    """The class registered as `name` (InputError when it cannot be loaded)."""
    entry = _entry_points().get(name)
    if entry is None:
        raise InputError(f"no robot controller named '{name}' (installed: "
                         f"{', '.join(controller_names()) or 'none'})")
    try:
        loaded = entry.load()
    except OUTSIDE_STOPS:
        raise
    except BaseException as exc:  # a broken plugin must not take hubero down
        raise InputError(f"robot controller plugin '{name}' cannot be loaded: "
                         f"{failure_of(exc)}") from None
    return _checked(loaded, f"robot controller plugin '{name}'")


def controller_params(name: str) -> type[ControllerParams] | None:
    """The parameter model of a registered controller, or None when there is no such name."""
    if name not in _entry_points():
        return None
    from hubero_dsl.controllers.base import params_of

    params: type[ControllerParams] = params_of(controller_class(name))
    return params


def import_controller(target: str) -> type:
    """A user's own controller class handed over as `MODULE:CLASS` (on the command line or
    through the API; never from a scenario file). InputError when it cannot be imported."""
    module_name, colon, class_name = target.partition(":")
    if not colon or not module_name or not class_name:
        raise InputError(f"'{target}' is not of the form MODULE:CLASS")
    try:
        loaded = getattr(importlib.import_module(module_name), class_name)
    except OUTSIDE_STOPS:
        raise
    except BaseException as exc:  # user code: a bad-input error, not a crash
        raise InputError(f"controller '{target}' cannot be imported: "
                         f"{failure_of(exc)}") from None
    return _checked(loaded, f"controller '{target}'")


def _checked(loaded: object, what: str) -> type:
    from hubero_dsl.controllers.base import ControllerParams, params_of

    if not isinstance(loaded, type):
        raise InputError(f"{what} is not a class")
    if not callable(getattr(loaded, "command", None)):
        raise InputError(f"{what} has no command(observation) method")
    params = params_of(loaded)
    if not (isinstance(params, type) and issubclass(params, ControllerParams)):
        raise InputError(f"{what}: its `Params` must be a subclass of "
                         "hubero_dsl.controllers.base.ControllerParams (or left out, for a "
                         f"controller without parameters), not {params!r}")
    return loaded
