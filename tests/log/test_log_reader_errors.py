"""`load_run` on anything but a complete hubero log: a LogError that says what is wrong."""

from __future__ import annotations

import base64
import json
import re
import struct
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import pytest
import zstandard
from mcap.reader import make_reader
from mcap.writer import Writer

from hubero_dsl.errors import LogError
from hubero_dsl.log.reader import load_run
from tests.log.conftest import LoggedMeeting, hubero


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
    with pytest.raises(LogError, match="truncated or corrupt") as raised:
        load_run(path)
    assert not raised.value.message.rstrip().endswith(":"), raised.value.message  # says what


def test_corrupt_chunk(meeting: LoggedMeeting, tmp_path: Path) -> None:
    data = bytearray(meeting.log.read_bytes())
    middle = len(data) // 2
    data[middle:middle + 16] = bytes(16)
    path = tmp_path / "corrupt.mcap"
    path.write_bytes(bytes(data))
    with pytest.raises(LogError):
        load_run(path)


def test_any_flipped_byte_is_refused(meeting: LoggedMeeting, tmp_path: Path) -> None:
    # a byte outside the chunks (a schema, a summary record) was read as it came: the data
    # section's and the summary's CRCs were not checked
    data = meeting.log.read_bytes()
    path = tmp_path / "flipped.mcap"
    for where in range(0, len(data), max(1, len(data) // 300)):
        flipped = bytearray(data)
        flipped[where] ^= 0xFF
        path.write_bytes(bytes(flipped))
        with pytest.raises(LogError):
            load_run(path)
            pytest.fail(f"a flipped byte at {where} of {len(data)} was not seen")


def test_a_changed_attachment(meeting: LoggedMeeting, tmp_path: Path) -> None:
    # attachments lie outside the chunks, whose CRCs the MCAP library checks
    data = bytearray(meeting.log.read_bytes())
    where = data.find(b"scenario ")  # the attached scenario's first line
    assert where > 0
    data[where:where + 8] = b"@" * 8
    path = tmp_path / "changed.mcap"
    path.write_bytes(bytes(data))
    with pytest.raises(LogError, match="crc validation failed in DataEnd"):
        load_run(path)
    # from a writer that leaves the data section's CRC out (0), the attachment's own checksum
    summary_start = struct.unpack_from("<Q", data, len(data) - 8 - 29 + 9)[0]
    data[summary_start - 4:summary_start] = bytes(4)    # DataEnd's CRC, just before the summary
    path.write_bytes(bytes(data))
    with pytest.raises(LogError, match=r"truncated or corrupt\?\): its attachment source/"
                                       r".* is not what it was when written"):
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
    return _rewritten(log, path, changes)


Rewrite = Callable[[str, bytes], bytes]  # (topic, data) -> data


def _as_is(topic: str, data: bytes) -> bytes:
    return data


def _rewritten(log: Path, path: Path, changes: dict[str, str],
               message: Rewrite = _as_is) -> Path:
    """A copy of `log` whose provenance metadata has `changes` applied and whose messages'
    data are `message(topic, data)`."""
    with log.open("rb") as source, path.open("wb") as stream:
        reader = make_reader(source)
        writer = Writer(stream)
        writer.start("", "copy")
        channels: dict[int, int] = {}
        for schema, channel, record in reader.iter_messages(log_time_order=False):
            if channel.id not in channels:
                assert schema is not None
                schema_id = writer.register_schema(schema.name, schema.encoding, schema.data)
                channels[channel.id] = writer.register_channel(
                    channel.topic, channel.message_encoding, schema_id)
            writer.add_message(channels[channel.id], record.log_time,
                               message(channel.topic, record.data), record.publish_time)
        for metadata in reader.iter_metadata():
            values = dict(metadata.metadata)
            writer.add_metadata(metadata.name, {**values, **changes}
                                if metadata.name == "hubero" else values)
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


def _stamped(seconds: str, topics: tuple[str, ...] = ()) -> Rewrite:
    """A message rewrite giving every timestamp (of `topics`, or of all) `seconds`."""
    def rewrite(topic: str, data: bytes) -> bytes:
        if topics and topic not in topics:
            return data
        return re.sub(rb'"sec":\d+', b'"sec":' + seconds.encode(), data)
    return rewrite


FORGED = {
    "metadata nested 200 000 deep": ({"humans": "[" * 200_000 + "]" * 200_000}, _as_is),
    "parameters nested 200 000 deep": ({"params": '{"a":' * 200_000 + "1" + "}" * 200_000},
                                       _as_is),
    "a human listed as a robot": ({"robots": '["alice"]'}, _as_is),
    "a human listed twice": ({"humans": '["alice", "alice"]'}, _as_is),
    "names that are no names": ({"humans": '[1, 2]'}, _as_is),
    "a /log time of 1e400 s": ({}, _stamped("1e400", ("/log",))),
    "every time 10**400 s": ({}, _stamped("1" + "0" * 400)),
}


@pytest.mark.parametrize("forgery", FORGED.values(), ids=FORGED.keys())
def test_a_forged_log_is_refused(meeting: LoggedMeeting, tmp_path: Path,
                                 forgery: tuple[dict[str, str], Rewrite]) -> None:
    forged = _rewritten(meeting.log, tmp_path / "forged.mcap", *forgery)
    with pytest.raises(LogError, match="not a readable hubero run log"):
        load_run(forged)


@pytest.mark.parametrize("command", [("plot",), ("export", "--ros2", "{tmp}/bag"),
                                     ("diff", "{log}")])
def test_commands_refuse_a_forged_log_with_exit_2(meeting: LoggedMeeting, tmp_path: Path,
                                                  command: tuple[str, ...]) -> None:
    forged = _rewritten(meeting.log, tmp_path / "forged.mcap", {}, _stamped("1e400"))
    argv = [a.format(tmp=tmp_path, log=meeting.log) for a in command]
    outcome = hubero(argv[0], str(forged), *argv[1:])
    assert outcome.returncode == 2, outcome.stderr
    assert "not a readable hubero run log" in outcome.stderr
    assert "internal error" not in outcome.stderr


def _map_of(columns: int, rows: int) -> Rewrite:
    """A message rewrite giving the log's /map `columns` x `rows` free cells."""
    def rewrite(topic: str, data: bytes) -> bytes:
        if topic != "/map":
            return data
        grid = json.loads(data)
        grid["column_count"] = grid["row_stride"] = columns
        grid["data"] = base64.b64encode(bytes(columns * rows)).decode("ascii")
        return json.dumps(grid).encode()
    return rewrite


def test_a_logged_map_larger_than_a_map_may_be_is_refused(meeting: LoggedMeeting,
                                                          tmp_path: Path) -> None:
    forged = _rewritten(meeting.log, tmp_path / "huge_map.mcap", {}, _map_of(4001, 4000))
    with pytest.raises(LogError, match=r"/map: a grid of 16,004,000 cells \(4,001 a row\), "
                                       r"more than the 16,000,000 a map may have"):
        load_run(forged)


def test_a_logged_map_of_other_cells_reads_back(meeting: LoggedMeeting, tmp_path: Path) -> None:
    forged = _rewritten(meeting.log, tmp_path / "other_map.mcap", {}, _map_of(30, 20))
    assert load_run(forged).grid.shape == (20, 30)


MAGIC = b"\x89MCAP0\r\n"


def _record(opcode: int, body: bytes) -> bytes:
    return struct.pack("<BQ", opcode, len(body)) + body


def _string(text: str) -> bytes:
    return struct.pack("<I", len(text)) + text.encode()


def _zstd_zeros(size: int, declare: bool) -> bytes:
    """A zstd frame of `size` zero bytes, made a megabyte at a time; its header declares the
    size when `declare`."""
    packer = zstandard.ZstdCompressor(write_content_size=declare).compressobj(
        size=size if declare else -1)
    block = bytes(1 << 20)
    return b"".join([*(packer.compress(block) for _ in range(size >> 20)), packer.flush()])


def _chunk_bomb(path: Path, frame: bytes, declared: int) -> Path:
    """An MCAP file of one zstd chunk holding `frame`, the chunk declaring `declared` bytes
    unpacked (its CRC 0: unchecked), and no summary."""
    chunk = (struct.pack("<QQQI", 0, 0, declared, 0) + _string("zstd")
             + struct.pack("<Q", len(frame)) + frame)
    path.write_bytes(MAGIC + _record(0x01, _string("") + _string("forger"))
                     + _record(0x06, chunk) + _record(0x0F, struct.pack("<I", 0))
                     + _record(0x02, struct.pack("<QQI", 0, 0, 0)) + MAGIC)
    return path


SIZE_OF_THE_BOMB = 512 << 20


@pytest.mark.skipif(not Path("/proc/self/status").exists(), reason="reads Linux's /proc")
@pytest.mark.parametrize(("declare", "declared"), [(True, 1024), (False, SIZE_OF_THE_BOMB)],
                         ids=["the frame declares it", "the chunk declares it"])
def test_a_chunk_that_unpacks_to_half_a_gigabyte_is_refused_before_unpacking(
        tmp_path: Path, declare: bool, declared: int) -> None:
    bomb = _chunk_bomb(tmp_path / "bomb.mcap", _zstd_zeros(SIZE_OF_THE_BOMB, declare),
                       declared)
    assert bomb.stat().st_size < 100_000
    # the peak of this process's own memory (VmHWM: ru_maxrss would count its parent's too,
    # as Linux keeps it across the exec)
    probe = ("import re, sys\n"
             "from hubero_dsl.errors import LogError\n"
             "from hubero_dsl.log.reader import load_run\n"
             "try:\n    load_run(sys.argv[1])\n"
             "except LogError as error:\n    print(error)\n"
             "status = open('/proc/self/status').read()\n"
             "print(int(re.search(r'VmHWM:\\s+(\\d+) kB', status)[1]) // 1024)\n")
    done = subprocess.run([sys.executable, "-c", probe, str(bomb)], capture_output=True,
                          text=True, check=True)
    message, peak_mb = done.stdout.strip().splitlines()
    assert int(peak_mb) < 300, f"reading the bomb took {peak_mb} MB"
    assert "a chunk of it unpacks to more than 64 MB" in message


def test_commands_refuse_a_chunk_bomb_with_exit_2(tmp_path: Path) -> None:
    bomb = _chunk_bomb(tmp_path / "bomb.mcap", _zstd_zeros(128 << 20, True), 1024)
    outcome = hubero("plot", str(bomb), "-o", str(tmp_path / "bomb.png"))
    assert outcome.returncode == 2, outcome.stderr
    assert "unpacks to more than 64 MB" in outcome.stderr
    assert not (tmp_path / "bomb.png").exists()
