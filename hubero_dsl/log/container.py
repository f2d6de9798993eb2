"""The MCAP container: a chunked, indexed, CRC-checked MCAP file written fast and reproducibly.

`McapContainer` writes what the MCAP specification calls a fully indexed file: the magic, a
header, schema and channel records, then chunks of messages (each followed by its message
indexes), attachments and metadata between chunks, the data end record with the CRC of the data
section, and a summary (schemas, channels, statistics, chunk, attachment and metadata indexes,
summary offsets) whose CRC is in the footer.

Why not `mcap.writer.Writer`: it spends about 4 µs of Python per message, and a log of 1000
humans writes 2000 messages per frame. Here a frame's messages are written in one batch: their
record headers are one numpy structured array, and the message indexes are built with numpy when
a chunk closes. The records other than messages are serialised by `mcap.records`, so their layout
is the library's. Nothing depends on the clock or on hash order: the same calls give the same
bytes. zstd (one thread, fixed level) is deterministic for a given zstd library.

With `background=True` everything that touches the file (closing and compressing chunks, CRCs,
indexes, the summary) runs on one worker thread, in the order it was asked for, so the bytes are
the same as without it; the caller's thread only buffers messages. An error on the worker (a
full disk) is raised by the next call, or by `finish()`.
"""

from __future__ import annotations

import struct
import zlib
from collections import deque
from collections.abc import Callable, Sequence
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass
from typing import Any, BinaryIO

import numpy as np
import numpy.typing as npt
import zstandard
from mcap.data_stream import RecordBuilder
from mcap.opcode import Opcode
from mcap.records import (
    Attachment,
    AttachmentIndex,
    Channel,
    Chunk,
    DataEnd,
    Footer,
    Header,
    McapRecord,
    Metadata,
    MetadataIndex,
    Schema,
    Statistics,
    SummaryOffset,
)

from hubero_dsl.files import MCAP_MAGIC

COMPRESSIONS = ("zstd", "")  # zstd or none
ZSTD_LEVEL = 1  # 3 compresses 2% better and takes 40% longer

# A message record: opcode, record length, channel id, then MESSAGE_FIELDS (sequence, log and
# publish time) and the data. The record length counts everything after itself
# (RECORD_PREFIX bytes: opcode and length are not counted).
MESSAGE_FIELDS = struct.Struct("<IQQ")
RECORD_PREFIX = 9
_MESSAGE_HEADER = struct.Struct("<BQH" + MESSAGE_FIELDS.format.lstrip("<"))
_MESSAGE_OVERHEAD = _MESSAGE_HEADER.size - RECORD_PREFIX
# opcode, record length, channel id, byte length of the (log time, offset) entries
_INDEX_HEADER_DTYPE = np.dtype([("opcode", "u1"), ("length", "<u8"), ("channel", "<u2"),
                                ("size", "<u4")])
_OFFSET_PAIR = np.dtype([("channel", "<u2"), ("offset", "<u8")])  # packed: 10 bytes


class McapContainer:
    """Writes one MCAP file to `stream`; call `finish()` once at the end."""

    def __init__(self, stream: BinaryIO, *, library: str, profile: str = "",
                 compression: str = "zstd", chunk_size: int = 4 << 20,
                 background: bool = False) -> None:
        if compression not in COMPRESSIONS:
            raise ValueError(f"unknown compression {compression!r}")
        self._stream = stream
        self._compression = compression
        self._chunk_size = chunk_size
        self._pool = ThreadPoolExecutor(1, "mcap-writer") if background else None
        self._pending: deque[Future[None]] = deque()
        # written by the worker only
        self._offset = 0
        self._data_crc = 0
        self._chunk_indexes: list[_ChunkIndex] = []
        self._attachment_indexes: list[AttachmentIndex] = []
        self._metadata_indexes: list[MetadataIndex] = []
        self._channel_records: list[bytes] = []
        self._channel_counts: npt.NDArray[np.int64] = np.zeros(1, dtype=np.int64)
        # kept by the caller's thread
        self._schemas: list[Schema] = []
        self._channels: list[Channel] = []
        self._message_count = 0
        self._start_time: int | None = None
        self._end_time = 0
        self._chunk = _OpenChunk()
        self._run(self._write, MCAP_MAGIC)
        self._run(self._write_record, Header(profile=profile, library=library))

    # ---- definitions ------------------------------------------------------------------------

    def add_schema(self, name: str, data: bytes, encoding: str = "jsonschema") -> int:
        schema = Schema(id=len(self._schemas) + 1, name=name, encoding=encoding, data=data)
        self._schemas.append(schema)
        self._run(self._write_record, schema)
        return schema.id

    def add_channel(self, topic: str, schema_id: int, message_encoding: str = "json") -> int:
        return self.add_channels([topic], schema_id, message_encoding)[0]

    def add_channels(self, topics: Sequence[str], schema_id: int,
                     message_encoding: str = "json") -> list[int]:
        """Channels of one schema, written as one task (a log has two per human)."""
        first = len(self._channels) + 1
        channels = [Channel(id=first + i, topic=topic, schema_id=schema_id,
                            message_encoding=message_encoding, metadata={})
                    for i, topic in enumerate(topics)]
        self._channels.extend(channels)
        self._run(self._write_channels, channels)
        return [channel.id for channel in channels]

    def add_attachment(self, name: str, media_type: str, data: bytes, log_time: int = 0) -> None:
        self._run(self._write_attachment, Attachment(
            log_time=log_time, create_time=0, name=name, media_type=media_type, data=data))

    def add_metadata(self, name: str, values: dict[str, str]) -> None:
        self._run(self._write_metadata,
                  Metadata(name=name, metadata=dict(sorted(values.items()))))

    # ---- messages ---------------------------------------------------------------------------

    def add_message(self, channel: int, log_time: int, data: bytes, sequence: int = 0) -> None:
        """One message (publish time = log time); a task event or a frame's /tf."""
        chunk = self._chunk
        chunk.add_one(channel, chunk.size, log_time)
        chunk.records += _MESSAGE_HEADER.pack(Opcode.MESSAGE, len(data) + _MESSAGE_OVERHEAD,
                                              channel, sequence, log_time, log_time)
        chunk.records += data
        chunk.size += _MESSAGE_HEADER.size + len(data)
        self._count_messages(1, log_time)
        if chunk.size >= self._chunk_size:
            self._close_chunk()

    def add_messages(self, channels: Sequence[int] | npt.NDArray[np.uint16], log_time: int,
                     payloads: Sequence[bytes], sequence: int = 0) -> None:
        """Messages of several channels at one time (publish time = log time)."""
        for channel, data in zip(np.asarray(channels).tolist(), payloads, strict=True):
            self.add_message(channel, log_time, data, sequence)

    def add_block(self, data: bytes | memoryview, channels: npt.NDArray[np.uint16],
                  offsets: npt.NDArray[np.uint64], log_time: int) -> None:
        """Message records encoded by the caller, all at `log_time`; `offsets` locate each
        record in `data` (for the message indexes). `data` is copied before this returns."""
        if not len(channels):
            return
        chunk = self._chunk
        chunk.add_index(channels, offsets + np.uint64(chunk.size), log_time)
        chunk.records += data
        chunk.size += len(data)
        self._count_messages(len(channels), log_time)
        if chunk.size >= self._chunk_size:
            self._close_chunk()

    def _count_messages(self, count: int, log_time: int) -> None:
        self._message_count += count
        if self._start_time is None:
            self._start_time = log_time
        self._end_time = max(self._end_time, log_time)

    # ---- the end ----------------------------------------------------------------------------

    def finish(self) -> None:
        """Close the last chunk, write the data end, the summary and the footer; wait for it."""
        self._close_chunk()
        self._run(self._write_summary)
        if self._pool is not None:
            pending, self._pending = self._pending, deque()
            self._pool.shutdown(wait=True)
            for future in pending:
                future.result()

    def abandon(self) -> None:
        """Stop the worker without finishing the file (it is being thrown away)."""
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)

    # ---- on the worker ----------------------------------------------------------------------

    def _run(self, task: Callable[..., Any], *args: Any) -> None:
        """Do `task` now, or queue it for the worker; raise what an earlier task raised."""
        if self._pool is None:
            task(*args)
            return
        # one worker thread finishes tasks in order: only the front of the queue can be done,
        # so this stays O(1) however far the worker lags behind
        while self._pending and self._pending[0].done():
            self._pending.popleft().result()
        self._pending.append(self._pool.submit(task, *args))

    def _write_summary(self) -> None:
        self._write_record(DataEnd(data_section_crc=self._data_crc))
        summary_start = self._offset
        builder = RecordBuilder()
        offsets: list[SummaryOffset] = []
        totals = np.zeros(len(self._channels) + 1, dtype=np.int64)
        totals[:len(self._channel_counts)] = self._channel_counts
        # channels with messages only: a flow's members who never came have none
        counts = {channel.id: int(totals[channel.id]) for channel in self._channels
                  if totals[channel.id]}
        statistics = Statistics(
            message_count=self._message_count, schema_count=len(self._schemas),
            channel_count=len(self._channels),
            attachment_count=len(self._attachment_indexes),
            metadata_count=len(self._metadata_indexes), chunk_count=len(self._chunk_indexes),
            message_start_time=self._start_time or 0, message_end_time=self._end_time,
            channel_message_counts=counts)
        groups: list[tuple[Opcode, Sequence[McapRecord]]] = [
            (Opcode.SCHEMA, self._schemas), (Opcode.CHANNEL, self._channels),
            (Opcode.STATISTICS, [statistics]), (Opcode.CHUNK_INDEX, self._chunk_indexes),
            (Opcode.ATTACHMENT_INDEX, self._attachment_indexes),
            (Opcode.METADATA_INDEX, self._metadata_indexes)]
        for opcode, records in groups:
            if not records:
                continue
            group_start = builder.count
            if opcode == Opcode.CHANNEL:
                builder.write(b"".join(self._channel_records))
            else:
                for record in records:
                    record.write(builder)
            offsets.append(SummaryOffset(group_opcode=opcode,
                                         group_start=summary_start + group_start,
                                         group_length=builder.count - group_start))
        summary_offset_start = summary_start + builder.count
        for offset in offsets:
            offset.write(builder)
        summary = builder.end()
        footer_fields = struct.pack("<BQQQ", Opcode.FOOTER, 20, summary_start,
                                    summary_offset_start)
        summary_crc = zlib.crc32(footer_fields, zlib.crc32(summary))
        self._write(summary)
        self._write_record(Footer(summary_start=summary_start,
                                  summary_offset_start=summary_offset_start,
                                  summary_crc=summary_crc))
        self._write(MCAP_MAGIC)

    # ---- internals --------------------------------------------------------------------------

    def _write(self, data: bytes) -> None:
        self._stream.write(data)
        self._data_crc = zlib.crc32(data, self._data_crc)
        self._offset += len(data)

    def _write_record(self, record: McapRecord) -> int:
        builder = RecordBuilder()
        record.write(builder)
        data = builder.end()
        self._write(data)
        return len(data)

    def _write_channels(self, channels: Sequence[Channel]) -> None:
        """Channel records, kept as bytes: the summary repeats them as they are."""
        builder = RecordBuilder()
        for channel in channels:
            channel.write(builder)
        data = builder.end()
        self._channel_records.append(data)
        self._write(data)

    def _write_attachment(self, record: Attachment) -> None:
        offset = self._offset
        length = self._write_record(record)
        self._attachment_indexes.append(AttachmentIndex(
            offset=offset, length=length, log_time=record.log_time, create_time=0,
            data_size=len(record.data), name=record.name, media_type=record.media_type))

    def _write_metadata(self, record: Metadata) -> None:
        offset = self._offset
        length = self._write_record(record)
        self._metadata_indexes.append(MetadataIndex(offset=offset, length=length,
                                                    name=record.name))

    def _close_chunk(self) -> None:
        chunk, self._chunk = self._chunk, _OpenChunk()
        if chunk.size:
            self._run(self._write_chunk, chunk)

    def _write_chunk(self, chunk: _OpenChunk) -> None:
        records = chunk.records
        channels, times, offsets = chunk.index()
        compressed = _compress(records, self._compression)
        start, first_time, last_time = self._offset, int(times.min()), int(times.max())
        length = self._write_record(Chunk(
            message_start_time=first_time, message_end_time=last_time,
            uncompressed_size=len(records), uncompressed_crc=zlib.crc32(records),
            compression=self._compression, data=compressed))
        ids, indexes, starts = _message_indexes(channels, times, offsets)
        record_offsets = np.uint64(self._offset) + starts
        self._write(indexes)
        self._chunk_indexes.append(_ChunkIndex(
            message_start_time=first_time, message_end_time=last_time,
            chunk_start_offset=start, chunk_length=length, channel_ids=ids,
            record_offsets=record_offsets,
            message_index_length=self._offset - int(record_offsets[0]),
            compression=self._compression, compressed_size=len(compressed),
            uncompressed_size=len(records)))
        counts = np.bincount(channels)
        if len(counts) > len(self._channel_counts):
            counts[:len(self._channel_counts)] += self._channel_counts
            self._channel_counts = counts
        else:
            self._channel_counts[:len(counts)] += counts


def message_payloads(data: bytes | memoryview, offsets: npt.NDArray[np.uint64]
                     ) -> list[tuple[int, memoryview]]:
    """(channel id, message data) of each message record in `data` at `offsets` (as
    `add_block` takes them): how a sink other than the file reads records encoded in advance."""
    view = memoryview(data)
    found = []
    for offset in offsets.tolist():
        _, length, channel = struct.unpack_from("<BQH", view, offset)
        found.append((channel, view[offset + _MESSAGE_HEADER.size:offset + RECORD_PREFIX + length]))
    return found


def _message_indexes(channels: npt.NDArray[np.uint16], times: npt.NDArray[np.uint64],
                     offsets: npt.NDArray[np.uint64]
                     ) -> tuple[npt.NDArray[np.uint16], bytes, npt.NDArray[np.uint64]]:
    """One message index record per channel (ascending ids), its entries in file order.

    Returns the channel ids, the records (one after another) and where each record starts.
    Built with numpy: a chunk of a large crowd holds thousands of channels."""
    order = np.lexsort((offsets, channels))
    ids, firsts, counts = np.unique(channels[order], return_index=True, return_counts=True)
    sizes = _INDEX_HEADER_DTYPE.itemsize + 16 * counts
    starts = np.concatenate([[0], np.cumsum(sizes)[:-1]]).astype(np.int64)
    records = np.empty(int(sizes.sum()), dtype=np.uint8)
    headers = np.empty(len(ids), dtype=_INDEX_HEADER_DTYPE)
    headers["opcode"] = Opcode.MESSAGE_INDEX
    headers["length"] = 2 + 4 + 16 * counts
    headers["channel"] = ids
    headers["size"] = 16 * counts
    _scatter(records, starts, headers.view(np.uint8).reshape(len(ids), -1))
    entries = np.column_stack([times[order], offsets[order]]).astype("<u8")
    rank = np.arange(len(order)) - np.repeat(firsts, counts)  # position within its record
    _scatter(records, np.repeat(starts + _INDEX_HEADER_DTYPE.itemsize, counts) + 16 * rank,
             entries.view(np.uint8).reshape(len(order), 16))
    return ids.astype(np.uint16), records.tobytes(), starts.astype(np.uint64)


def _scatter(target: npt.NDArray[np.uint8], starts: npt.NDArray[np.int64],
             rows: npt.NDArray[np.uint8]) -> None:
    """Write each row of bytes into `target` at its start."""
    target[starts[:, None] + np.arange(rows.shape[1])] = rows


@dataclass
class _ChunkIndex(McapRecord):
    """A chunk index record whose map of message index offsets is packed with numpy.

    `mcap.records.ChunkIndex.write` makes Python calls per channel; with thousands of channels
    per chunk that was most of the cost of closing one. The layout is the same.
    """

    message_start_time: int
    message_end_time: int
    chunk_start_offset: int
    chunk_length: int
    channel_ids: npt.NDArray[np.uint16]
    record_offsets: npt.NDArray[np.uint64]
    message_index_length: int
    compression: str
    compressed_size: int
    uncompressed_size: int

    def write(self, stream: RecordBuilder) -> None:
        pairs = np.empty(len(self.channel_ids), dtype=_OFFSET_PAIR)
        pairs["channel"], pairs["offset"] = self.channel_ids, self.record_offsets
        offsets_map = pairs.tobytes()
        compression = self.compression.encode()
        stream.start_record(Opcode.CHUNK_INDEX)
        stream.write(struct.pack("<QQQQI", self.message_start_time, self.message_end_time,
                                 self.chunk_start_offset, self.chunk_length, len(offsets_map)))
        stream.write(offsets_map)
        stream.write(struct.pack("<QI", self.message_index_length, len(compression)))
        stream.write(compression)
        stream.write(struct.pack("<QQ", self.compressed_size, self.uncompressed_size))
        stream.finish_record()


class _OpenChunk:
    """The records of the chunk being filled, and what its message indexes need."""

    def __init__(self) -> None:
        self.records = bytearray()  # copied in as they come: one copy, no join at the end
        self.size = 0
        self._channels: list[npt.NDArray[np.uint16]] = []
        self._offsets: list[npt.NDArray[np.uint64]] = []
        self._times: list[npt.NDArray[np.uint64]] = []
        self._single: list[tuple[int, int, int]] = []  # (channel, offset, time) of lone messages

    def add_one(self, channel: int, offset: int, log_time: int) -> None:
        """A lone message: kept as numbers (arrays per message would cost more than it)."""
        self._single.append((channel, offset, log_time))

    def add_index(self, channels: npt.NDArray[np.uint16], offsets: npt.NDArray[np.uint64],
                  log_time: int) -> None:
        self._channels.append(channels)
        self._offsets.append(offsets)
        self._times.append(np.full(len(channels), log_time, dtype=np.uint64))

    def index(self) -> tuple[npt.NDArray[np.uint16], npt.NDArray[np.uint64],
                             npt.NDArray[np.uint64]]:
        single = np.array(self._single, dtype=np.uint64).reshape(-1, 3)
        return (np.concatenate([*self._channels, single[:, 0].astype(np.uint16)]),
                np.concatenate([*self._times, single[:, 2]]),
                np.concatenate([*self._offsets, single[:, 1]]))


def _compress(data: bytes | bytearray, compression: str) -> bytes:
    if compression == "zstd":
        return zstandard.ZstdCompressor(level=ZSTD_LEVEL, threads=0).compress(data)
    return bytes(data)
