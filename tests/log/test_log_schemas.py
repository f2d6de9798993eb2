"""Every message matches its schema: Foxglove's official ones (vendored) and hubero's own.

jsonschema checks types and required fields; Foxglove's schemas allow extra properties, so a
misspelt field would pass it. `assert_same_fields` therefore also checks that every object in a
message has exactly the fields its schema lists, all the way down.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import jsonschema
import pytest
from mcap.reader import make_reader

from hubero_dsl.log import schemas as s
from tests.log.conftest import BLOCKED, LoggedMeeting, World, write_log

FOXGLOVE_DIR = Path(s.__file__).parent / "foxglove"
CROWDED = """\
scenario "log test: a crowd and a flow"
map "room.yaml"
seed 3
step 50 ms
time_limit 6 s
crowd visitors 6 in rect((1, 1), (4, 6))
flow passers from rect((6, 1), (9, 3)) to (8.0, 7.0) rate 1 /s for 4 s
activity main {
    visitors move_to (8.0, 4.0)
}
"""


def assert_same_fields(value: Any, schema: dict[str, Any], where: str = "") -> None:
    if "oneOf" in schema and "properties" not in schema:
        if isinstance(value, dict):  # hubero's nullable objects: check the object branch
            (branch,) = [b for b in schema["oneOf"] if b.get("type") == "object"]
            assert_same_fields(value, branch, where)
        return
    if "properties" in schema:
        assert isinstance(value, dict), where
        assert set(value) == set(schema["properties"]), \
            f"{where}: fields {sorted(value)} != schema {sorted(schema['properties'])}"
        for key, item in value.items():
            assert_same_fields(item, schema["properties"][key], f"{where}.{key}")
    elif schema.get("type") == "array" and "items" in schema:
        for index, item in enumerate(value):
            assert_same_fields(item, schema["items"], f"{where}[{index}]")


def logged_messages(path: Path) -> dict[str, list[Any]]:
    """Decoded messages by schema name."""
    by_schema: dict[str, list[Any]] = {}
    with path.open("rb") as stream:
        for schema, _, message in make_reader(stream).iter_messages():
            assert schema is not None
            by_schema.setdefault(schema.name, []).append(json.loads(message.data))
    return by_schema


@pytest.fixture(scope="module")
def every_message(meeting: LoggedMeeting, world: World,
                  tmp_path_factory: pytest.TempPathFactory) -> dict[str, list[Any]]:
    folder = tmp_path_factory.mktemp("more")
    found = logged_messages(meeting.log)
    for name, text in (("blocked", BLOCKED), ("crowded", CROWDED)):
        write_log(world.scenario(f"{name}.hub", text), folder / f"{name}.mcap")
        for schema, values in logged_messages(folder / f"{name}.mcap").items():
            found.setdefault(schema, []).extend(values)
    return found


def test_vendored_files_are_foxglove_schemas() -> None:
    for name, file in s.FOXGLOVE_FILES.items():
        schema = json.loads((FOXGLOVE_DIR / file).read_text(encoding="utf-8"))
        assert schema["title"] == name
        jsonschema.validators.validator_for(schema).check_schema(schema)
    assert (FOXGLOVE_DIR / "README.md").read_text().count("MIT") >= 1


def test_field_names_are_foxglove_s() -> None:
    # the names the issue lists, read from the official schema rather than trusted
    grid = s.foxglove_schema(s.GRID)["properties"]
    assert list(grid) == ["timestamp", "frame_id", "pose", "column_count", "cell_size",
                          "row_stride", "cell_stride", "fields", "data"]
    assert list(s.foxglove_schema(s.POSE_IN_FRAME)["properties"]) == \
        ["timestamp", "frame_id", "pose"]
    assert list(s.foxglove_schema(s.LOG)["properties"]) == \
        ["timestamp", "level", "message", "name", "file", "line"]


@pytest.mark.parametrize("name", [*sorted(s.FOXGLOVE_FILES), s.HUMAN_STATE, s.CROWD_STATE,
                                  s.TASK_EVENT])
def test_every_message_matches_its_schema(every_message: dict[str, list[Any]],
                                          name: str) -> None:
    schema = s.schema_of(name)
    validator = jsonschema.validators.validator_for(schema)(schema)
    values = every_message[name]
    assert values, f"no {name} message was written"
    for value in values:
        validator.validate(value)
        assert_same_fields(value, schema, name)


def test_own_schemas_are_valid_and_closed() -> None:
    for name in (s.HUMAN_STATE, s.CROWD_STATE, s.TASK_EVENT):
        schema = s.schema_of(name)
        jsonschema.validators.validator_for(schema).check_schema(schema)
        assert schema["title"] == name
        assert schema["additionalProperties"] is False
        assert set(schema["required"]) == set(schema["properties"])


def test_a_wrong_field_would_be_caught() -> None:
    pose = {"timestamp": {"sec": 0, "nsec": 0}, "frame_id": "map",
            "pose": {"position": {"x": 0, "y": 0, "z": 0},
                     "orientation": {"x": 0, "y": 0, "z": 0, "w": 1}}}
    assert_same_fields(pose, s.foxglove_schema(s.POSE_IN_FRAME))
    pose["pose"]["orientation"]["W"] = pose["pose"]["orientation"].pop("w")
    with pytest.raises(AssertionError, match="fields"):
        assert_same_fields(pose, s.foxglove_schema(s.POSE_IN_FRAME))
