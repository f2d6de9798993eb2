"""What made a run, as its log records it: the metadata record and the attachments (the
scenario's source, the map's YAML and image)."""

from __future__ import annotations

import hashlib
import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

import yaml

from hubero_dsl import __version__
from hubero_dsl.errors import LogError
from hubero_dsl.log import schemas as s
from hubero_dsl.world.shapes import Circle, Ellipse, Rectangle

if TYPE_CHECKING:
    from hubero_dsl.model.program import Program, RobotSpec
    from hubero_dsl.sim.simulation import Simulation

MEDIA_TYPES = {".yaml": "application/yaml", ".yml": "application/yaml",
               ".pgm": "image/x-portable-graymap", ".png": "image/png", ".bmp": "image/bmp",
               ".jpg": "image/jpeg", ".jpeg": "image/jpeg", ".tif": "image/tiff",
               ".tiff": "image/tiff", ".gif": "image/gif", ".ppm": "image/x-portable-pixmap"}


def logged_source_path(program: Program) -> str:
    """The scenario file as a log names it: its name, the same however it was reached (the
    path typed, the folder it lies in), so that a file logs the same bytes wherever it is
    run; the text itself is attached beside."""
    return Path(program.source.path).name or "scenario.hub"


def provenance(sim: Simulation, rate_hz: float
               ) -> tuple[dict[str, str], list[tuple[str, str, bytes]]]:
    """The metadata record and the attachments (scenario, map YAML, map image)."""
    program = sim.program
    source_name = logged_source_path(program)
    source = program.source.text.encode("utf-8")
    map_yaml, image_path, image = read_map_files(program.map_path)
    names = {"source": f"source/{source_name}", "map": f"map/{program.map_path.name}",
             "map_image": f"map/{image_path.name}"}
    metadata = {
        "format": s.FORMAT, "format_version": str(s.FORMAT_VERSION),
        "hubero_version": __version__, "title": program.title,
        "source_path": logged_source_path(program),
        "source_sha256": hashlib.sha256(source).hexdigest(),
        "map_path": program.map_written or str(program.map_path),
        "map_sha256": hashlib.sha256(map_yaml).hexdigest(),
        "map_image_sha256": hashlib.sha256(image).hexdigest(),
        "seed": str(sim.seed), "variant": sim.variant or "",
        "variants": s.dumps(list(program.variants)),
        "params": s.dumps(params_json(sim.params)),
        "step": repr(sim.engine.dt), "time_limit": repr(program.time_limit),
        "on_failure": program.on_failure, "log_rate_hz": repr(rate_hz),
        "humans": s.dumps(list(sim.engine.humans.names)),
        "robots": s.dumps(list(sim.engine.robots.names)),
        "attachments": s.dumps(names),
    }
    if specs := sim.engine.robots.specs:  # only then, like sets
        metadata["robot_params"] = s.dumps({spec.name: robot_params_json(spec)
                                            for spec in specs})
    if sets := program.people_sets():  # only then: the logs of other scenarios keep their bytes
        metadata["sets"] = s.dumps({name: {"kind": kind, "members": list(members)}
                                    for name, (kind, members) in sorted(sets.items())})
    media = MEDIA_TYPES.get(image_path.suffix.lower(), "application/octet-stream")
    attachments = [(names["source"], "text/plain", source),
                   (names["map"], "application/yaml", map_yaml),
                   (names["map_image"], media, image)]
    return metadata, attachments


def read_map_files(yaml_path: Path) -> tuple[bytes, Path, bytes]:
    """The map's YAML bytes, its image's path and bytes, to attach them to the log."""
    try:
        text = yaml_path.read_bytes()
        image_name = yaml.safe_load(text)["image"]
        image_path = Path(image_name)
        if not image_path.is_absolute():
            image_path = yaml_path.parent / image_path
        return text, image_path, image_path.read_bytes()
    except (OSError, yaml.YAMLError, KeyError, TypeError) as exc:
        raise LogError(f"cannot attach map {yaml_path} to the log: {exc}") from None


def params_json(params: dict[str, dict[str, Any]]) -> dict[str, dict[str, Any]]:
    """Every human's resolved parameters as JSON values (shapes as objects)."""
    def value(v: Any) -> Any:
        if isinstance(v, Circle | Ellipse | Rectangle):
            return s.shape_json(v)
        if isinstance(v, bool | int | float | str):
            return v
        return str(v)

    return {human: {key: value(v) for key, v in values.items()}
            for human, values in params.items()}


def robot_params_json(spec: RobotSpec) -> dict[str, Any]:
    """A robot's resolved parameters as JSON values: what the metrics of a log need of it (its
    goal, body and limits); an unset limit (infinite) is null."""
    def finite(value: float) -> float | None:
        return value if math.isfinite(value) else None

    return {"radius": spec.radius, "speed": spec.speed, "kinematics": spec.kinematics,
            "controller": spec.controller, "controller_params": dict(spec.controller_params),
            "goal": list(spec.goal) if spec.goal is not None else None,
            "goal_tolerance": spec.goal_tolerance, "max_speed": finite(spec.max_speed),
            "max_acceleration": finite(spec.max_acceleration),
            "max_angular_speed": finite(spec.max_angular_speed),
            "sensor_range": finite(spec.sensor_range), "field_of_view": spec.field_of_view}
