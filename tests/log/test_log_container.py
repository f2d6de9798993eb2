"""The MCAP container: what MCAP readers and validators make of it."""

from __future__ import annotations

import io
import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from mcap.reader import make_reader
from mcap.records import Chunk, DataEnd, Message, MessageIndex
from mcap.stream_reader import StreamReader

from hubero_dsl.log.container import McapContainer
from tests.log.conftest import LoggedMeeting


def write_sample(*, background: bool, compression: str = "zstd") -> bytes:
    stream = io.BytesIO()
    mcap = McapContainer(stream, library="test", compression=compression, chunk_size=2000,
                         background=background)
    schema = mcap.add_schema("test.Thing", b'{"type":"object"}')
    channels = [mcap.add_channel(f"/thing/{i}", schema) for i in range(5)]
    mcap.add_metadata("about", {"b": "2", "a": "1"})
    mcap.add_attachment("notes.txt", "text/plain", b"hello")
    for frame in range(40):
        payloads = [json.dumps({"frame": frame, "thing": i}).encode() for i in range(5)]
        mcap.add_messages(channels, frame * 1000, payloads, frame)
        mcap.add_message(channels[0], frame * 1000, b'{"extra":true}')
    mcap.finish()
    return stream.getvalue()


def test_readers_see_every_record_and_index() -> None:
    data = write_sample(background=False)
    reader = make_reader(io.BytesIO(data), validate_crcs=True)
    summary = reader.get_summary()
    assert summary is not None and summary.statistics is not None
    assert summary.statistics.message_count == 240
    assert summary.statistics.channel_message_counts == {1: 80, 2: 40, 3: 40, 4: 40, 5: 40}
    assert len(summary.chunk_indexes) == summary.statistics.chunk_count > 1
    assert [m.metadata for m in reader.iter_metadata()] == [{"a": "1", "b": "2"}]
    assert [a.data for a in reader.iter_attachments()] == [b"hello"]
    messages = list(reader.iter_messages(topics=["/thing/3"]))
    assert [json.loads(m.data)["frame"] for _, _, m in messages] == list(range(40))
    # the stream reader checks every chunk's CRC as it expands it, and the data section's
    records = list(StreamReader(io.BytesIO(data), validate_crcs=True).records)
    assert sum(isinstance(r, Message) for r in records) == 240
    assert any(isinstance(r, MessageIndex) for r in records)
    chunks = list(StreamReader(io.BytesIO(data), emit_chunks=True).records)
    assert sum(isinstance(r, Chunk) for r in chunks) == summary.statistics.chunk_count
    (data_end,) = [r for r in records if isinstance(r, DataEnd)]
    assert data_end.data_section_crc != 0


def test_background_writing_gives_the_same_bytes() -> None:
    assert write_sample(background=True) == write_sample(background=False)
    assert write_sample(background=True, compression="") == \
        write_sample(background=False, compression="")


def doctor() -> list[str] | None:
    """pymcap-cli's `doctor` (the MCAP structure validator), if it is installed."""
    beside = Path(sys.executable).parent / "pymcap-cli"
    found = str(beside) if beside.exists() else shutil.which("pymcap-cli")
    return [found, "doctor"] if found else None


@pytest.mark.skipif(doctor() is None, reason="pymcap-cli is not installed")
def test_mcap_doctor_finds_nothing_wrong(meeting: LoggedMeeting, tmp_path: Path) -> None:
    sample = tmp_path / "sample.mcap"
    sample.write_bytes(write_sample(background=True))
    for path in (meeting.log, sample):
        command = doctor()
        assert command is not None
        done = subprocess.run([*command, "--format", "jsonl", "--strict-message-order",
                               str(path)], capture_output=True, text=True, timeout=60,
                              check=False)
        assert done.returncode == 0, done.stdout + done.stderr
        summary = [json.loads(line) for line in done.stdout.splitlines()
                   if line.startswith("{")][-1]
        assert summary["type"] == "summary" and summary["complete"] is True
        assert summary["errors"] == summary["warnings"] == 0, done.stdout
