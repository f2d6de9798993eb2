"""The pieces of the live server that need no client: the pace, and the sinks' contract.

The server itself is tested with a real WebSocket client in tests/cli/test_cli_live.py."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader

from hubero_dsl.log.container import McapContainer, message_payloads
from hubero_dsl.log.live import parse_pace
from hubero_dsl.log.sinks import Fanout


@pytest.mark.parametrize(("text", "factor"), [("1x", 1.0), ("10x", 10.0), ("0.5x", 0.5),
                                              ("2.5x", 2.5), ("max", None)])
def test_a_pace_is_a_factor_of_real_time_or_max(text: str, factor: float | None) -> None:
    assert parse_pace(text) == factor


@pytest.mark.parametrize("text", ["1", "x", "0x", "-2x", "infx", "nanx", "MAX", "1 x", ""])
def test_anything_else_is_no_pace(text: str) -> None:
    with pytest.raises(ValueError, match="invalid pace"):
        parse_pace(text)


@pytest.mark.parametrize("text", ["0.0009x", "0.0000000000001x"])
def test_a_pace_too_slow_to_wait_for_is_refused(text: str) -> None:
    # a tick's wait overflowed time.sleep: an internal error
    with pytest.raises(ValueError, match=r"slower than 0\.001x"):
        parse_pace(text)
    assert parse_pace("0.001x") == 0.001


def test_a_fanout_gives_every_record_to_each_sink(tmp_path: Path) -> None:
    paths = [tmp_path / "a.mcap", tmp_path / "b.mcap"]
    streams = [path.open("wb") for path in paths]
    sinks = [McapContainer(stream, library="test") for stream in streams]
    both = Fanout(sinks)
    schema = both.add_schema("s", b"{}")
    first, second = both.add_channels(["/a", "/b"], schema)
    both.add_message(first, 5, b'{"n":1}')
    both.finish()
    for stream in streams:
        stream.close()
    assert paths[0].read_bytes() == paths[1].read_bytes()
    with paths[0].open("rb") as stream:
        [(_, channel, message)] = list(make_reader(stream).iter_messages())
    assert (channel.topic, message.log_time, message.data) == ("/a", 5, b'{"n":1}')
    assert second == first + 1


def test_sinks_that_number_differently_cannot_be_fanned_out(tmp_path: Path) -> None:
    with (tmp_path / "a.mcap").open("wb") as a, (tmp_path / "b.mcap").open("wb") as b:
        ahead = McapContainer(b, library="test")
        ahead.add_schema("other", b"{}")
        both = Fanout([McapContainer(a, library="test"), ahead])
        with pytest.raises(AssertionError, match="numbered a record differently"):
            both.add_schema("s", b"{}")


def test_message_payloads_reads_back_records_encoded_in_advance() -> None:
    import struct

    records, offsets = b"", []
    for channel, data in [(3, b"abc"), (4, b"{}"), (3, b"")]:
        offsets.append(len(records))
        records += struct.pack("<BQHIQQ", 0x05, 2 + 4 + 8 + 8 + len(data), channel, 0, 7, 7)
        records += data
    found = message_payloads(records, np.array(offsets, dtype=np.uint64))
    assert [(channel, bytes(data)) for channel, data in found] == [(3, b"abc"), (4, b"{}"),
                                                                  (3, b"")]
