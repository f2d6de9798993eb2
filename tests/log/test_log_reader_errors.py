"""`load_run` on anything but a complete hubero log: a LogError that says what is wrong."""

from __future__ import annotations

from pathlib import Path

import pytest
from mcap.reader import make_reader
from mcap.writer import Writer

from hubero_dsl.errors import LogError
from hubero_dsl.log.reader import load_run
from tests.log.conftest import LoggedMeeting


def test_missing_file(tmp_path: Path) -> None:
    with pytest.raises(LogError, match=r"cannot read log .*missing\.mcap"):
        load_run(tmp_path / "missing.mcap")


def test_directory(tmp_path: Path) -> None:
    with pytest.raises(LogError, match="is a directory"):
        load_run(tmp_path)


def test_empty_file(tmp_path: Path) -> None:
    (tmp_path / "empty.mcap").write_bytes(b"")
    with pytest.raises(LogError, match="empty"):
        load_run(tmp_path / "empty.mcap")


def test_not_mcap(tmp_path: Path) -> None:
    path = tmp_path / "text.mcap"
    path.write_text("scenario \"not a log\"\n" * 20)
    with pytest.raises(LogError, match="not a readable hubero run log"):
        load_run(path)


@pytest.mark.parametrize("keep", [0.1, 0.5, 0.9, 0.999])
def test_truncated(meeting: LoggedMeeting, tmp_path: Path, keep: float) -> None:
    data = meeting.log.read_bytes()
    path = tmp_path / "truncated.mcap"
    path.write_bytes(data[:int(len(data) * keep)])
    with pytest.raises(LogError, match="truncated or corrupt"):
        load_run(path)


def test_corrupt_chunk(meeting: LoggedMeeting, tmp_path: Path) -> None:
    data = bytearray(meeting.log.read_bytes())
    middle = len(data) // 2
    data[middle:middle + 16] = bytes(16)
    path = tmp_path / "corrupt.mcap"
    path.write_bytes(bytes(data))
    with pytest.raises(LogError):
        load_run(path)


def test_another_tools_mcap(tmp_path: Path) -> None:
    path = tmp_path / "other.mcap"
    with path.open("wb") as stream:
        writer = Writer(stream)
        writer.start("", "another tool")
        schema = writer.register_schema("x", "jsonschema", b"{}")
        channel = writer.register_channel("/x", "json", schema)
        writer.add_message(channel, 0, b"{}", 0)
        writer.add_metadata("other", {"a": "b"})
        writer.finish()
    with pytest.raises(LogError, match="not a hubero run log"):
        load_run(path)


def test_a_newer_format_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "future.mcap"
    with path.open("wb") as stream:
        writer = Writer(stream)
        writer.start("", "hubero 9")
        writer.add_metadata("hubero", {"format": "hubero-run-log", "format_version": "99",
                                       "hubero_version": "9.0"})
        writer.finish()
    with pytest.raises(LogError, match="format 99"):
        load_run(path)


def _with_metadata(log: Path, path: Path, **changes: str) -> Path:
    """A copy of `log` whose provenance metadata has `changes` applied."""
    with log.open("rb") as source, path.open("wb") as stream:
        reader = make_reader(source)
        writer = Writer(stream)
        writer.start("", "copy")
        channels: dict[int, int] = {}
        for schema, channel, message in reader.iter_messages(log_time_order=False):
            if channel.id not in channels:
                assert schema is not None
                schema_id = writer.register_schema(schema.name, schema.encoding, schema.data)
                channels[channel.id] = writer.register_channel(
                    channel.topic, channel.message_encoding, schema_id)
            writer.add_message(channels[channel.id], message.log_time, message.data,
                               message.publish_time)
        for record in reader.iter_metadata():
            values = dict(record.metadata)
            writer.add_metadata(record.name, {**values, **changes}
                                if record.name == "hubero" else values)
        for attachment in reader.iter_attachments():
            writer.add_attachment(attachment.create_time, attachment.log_time,
                                  attachment.name, attachment.media_type, attachment.data)
        writer.finish()
    return path


@pytest.mark.parametrize("robot_params", [
    '{"r2": {"goal": "(8, 2)"}}', '{"r2": {"goal": [1, 2, 3]}}', '{"r2": {"goal": null, '
    '"goal_tolerance": "near"}}', '["r2"]', "not json"])
def test_a_robots_malformed_parameters_are_refused(meeting: LoggedMeeting, tmp_path: Path,
                                                   robot_params: str) -> None:
    tampered = _with_metadata(meeting.log, tmp_path / "tampered.mcap",
                              robot_params=robot_params)
    with pytest.raises(LogError, match="not a readable hubero run log"):
        load_run(tampered)


def test_a_copy_with_its_own_robot_parameters_reads_back(meeting: LoggedMeeting,
                                                         tmp_path: Path) -> None:
    copy = _with_metadata(meeting.log, tmp_path / "copy.mcap",
                          robot_params='{"r2": {"goal": [8, 2], "goal_tolerance": 0.3}}')
    assert load_run(copy).metadata.robot_goal("r2") == ((8.0, 2.0), 0.3)
