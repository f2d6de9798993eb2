"""Where a log's records go: the MCAP file, a live server, or both.

The encoder (`encoder.py`) turns a run into schemas, channels and messages once and hands them
to a `MessageSink`: `McapContainer` (`container.py`) writes them into the log file,
`LiveServer` (`live.py`) publishes them over Foxglove's WebSocket protocol, and `Fanout` gives
every record to several sinks. Each sink gets the same bytes from the same calls, so the live
stream and the log cannot drift apart.

Ids: every sink numbers schemas and channels from 1 in the order they are added; message
records encoded in advance (`add_block`) carry these channel ids inside them.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol, TypeVar

import numpy as np
import numpy.typing as npt

T = TypeVar("T")


class MessageSink(Protocol):
    """What the encoder writes to (`McapContainer` is the reference)."""

    def add_schema(self, name: str, data: bytes, encoding: str = "jsonschema") -> int: ...

    def add_channels(self, topics: Sequence[str], schema_id: int,
                     message_encoding: str = "json") -> list[int]: ...

    def add_metadata(self, name: str, values: dict[str, str]) -> None: ...

    def add_attachment(self, name: str, media_type: str, data: bytes,
                       log_time: int = 0) -> None: ...

    def add_message(self, channel: int, log_time: int, data: bytes, sequence: int = 0) -> None:
        ...

    def add_block(self, data: bytes | memoryview, channels: npt.NDArray[np.uint16],
                  offsets: npt.NDArray[np.uint64], log_time: int) -> None: ...

    def finish(self) -> None: ...

    def abandon(self) -> None: ...


class Fanout:
    """One sink that writes every record to each of `sinks`, in their order."""

    def __init__(self, sinks: Sequence[MessageSink]) -> None:
        self._sinks = tuple(sinks)

    def add_schema(self, name: str, data: bytes, encoding: str = "jsonschema") -> int:
        return _same([sink.add_schema(name, data, encoding) for sink in self._sinks])

    def add_channels(self, topics: Sequence[str], schema_id: int,
                     message_encoding: str = "json") -> list[int]:
        return _same([sink.add_channels(topics, schema_id, message_encoding)
                      for sink in self._sinks])

    def add_metadata(self, name: str, values: dict[str, str]) -> None:
        for sink in self._sinks:
            sink.add_metadata(name, values)

    def add_attachment(self, name: str, media_type: str, data: bytes, log_time: int = 0) -> None:
        for sink in self._sinks:
            sink.add_attachment(name, media_type, data, log_time)

    def add_message(self, channel: int, log_time: int, data: bytes, sequence: int = 0) -> None:
        for sink in self._sinks:
            sink.add_message(channel, log_time, data, sequence)

    def add_block(self, data: bytes | memoryview, channels: npt.NDArray[np.uint16],
                  offsets: npt.NDArray[np.uint64], log_time: int) -> None:
        for sink in self._sinks:
            sink.add_block(data, channels, offsets, log_time)

    def finish(self) -> None:
        for sink in self._sinks:
            sink.finish()

    def abandon(self) -> None:
        for sink in self._sinks:
            sink.abandon()


def _same(ids: list[T]) -> T:
    """The id every sink gave; they number alike, and records encoded in advance rely on it."""
    if any(other != ids[0] for other in ids[1:]):
        raise AssertionError(f"log sinks numbered a record differently: {ids}")
    return ids[0]
