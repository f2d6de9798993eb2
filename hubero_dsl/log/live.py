"""Watching a run live: a Foxglove WebSocket server fed by the log's encoder.

    with LiveServer(port=8765, pace=1.0, wait=True) as live:    # ws://127.0.0.1:8765
        result = simulate(program, log="run.mcap", live=live)
        live.serve_until_clients_leave()          # optional: keep the end on screen

`LiveServer` is a `MessageSink` (`sinks.py`): the encoder that writes the MCAP log hands it the
same schemas, channels and message bytes, and it publishes them with the `foxglove-sdk`
package's server (the `live` extra), so a Foxglove client sees the log's topics and schemas as
the run makes them. Messages carry the simulation time as their log time, as in the file.

Pace: the messages of simulation time t go out no earlier than t / pace seconds of wall clock
after the first one (1.0 is real time; None, `max`, waits for nothing). The wait happens here,
in the encoder's calls, outside the simulation: the run computes the same ticks and the log
gets the same bytes whatever the pace, only later.

`on_ready(server)` is called once every channel is advertised, before the first message: a
client that connects from then on is told of all of them at once (one that connects while they
are being added may subscribe to a channel the SDK has advertised but not yet registered). With
`wait`, the first message then waits until a client has subscribed: the run starts when
someone watches.

The map and the scene are state rather than events (`/map` is sent once, `/scene` when it
changes): a client that subscribes to them after they went out gets the last one again.
"""

from __future__ import annotations

import math
import re
import threading
import time
from collections.abc import Callable, Sequence
from types import TracebackType
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from hubero_dsl.errors import InputError
from hubero_dsl.log import schemas as s
from hubero_dsl.log.container import message_payloads

if TYPE_CHECKING:
    import numpy.typing as npt
    from foxglove.websocket import ServerListener

DEFAULT_HOST = "127.0.0.1"
DEFAULT_PORT = 8765
DEFAULT_PACE = "1x"
LATCHED = (s.MAP_TOPIC, s.SCENE_TOPIC)  # state: sent again to a client that subscribes late
SETTLE = 0.5  # s after a client's first subscription for the rest of its subscriptions to land
POLL = 0.05  # s between looks at the clients while waiting (short: Ctrl-C is seen between)
# Messages buffered per client before the oldest is dropped (the SDK's default is 1024):
# at `max` pace a frame of a crowd is two messages per human, and a client must not lose any.
BACKLOG = 1 << 16
INSTALL_HINT = "install it with: pip install 'hubero[live]'"


MIN_PACE = 1e-3  # of real time: slower, a tick's wait outgrows what a sleep can take


def parse_pace(text: str) -> float | None:
    """`1x`, `10x`, `0.5x` -> the factor; `max` -> None (no waiting). ValueError otherwise."""
    if text == "max":
        return None
    written = re.fullmatch(r"(\d+(?:\.\d*)?|\.\d+)x", text)
    factor = float(written[1]) if written else 0.0
    if not (math.isfinite(factor) and factor > 0):
        raise ValueError(f"invalid pace '{text}': give a factor of real time such as 1x, 10x "
                         "or 0.5x, or max")
    if factor < MIN_PACE:
        raise ValueError(f"pace '{text}' is slower than {MIN_PACE:g}x (a second of the run "
                         f"in {1 / MIN_PACE:g} s): give a factor of at least {MIN_PACE:g}x")
    return factor


class LiveServer:
    """A Foxglove WebSocket server that publishes a run's log as it is written."""

    def __init__(self, *, host: str = DEFAULT_HOST, port: int = DEFAULT_PORT,
                 pace: float | None = 1.0, wait: bool = False, name: str = "hubero",
                 on_ready: Callable[[LiveServer], None] | None = None) -> None:
        try:
            import foxglove
            from foxglove.websocket import Capability
        except ImportError:
            raise InputError("watching a run live needs the foxglove-sdk package",
                             hint=INSTALL_HINT) from None
        self._foxglove = foxglove
        self._context = foxglove.Context()  # channels of this server only
        self._clients = _Clients()
        self._pace = pace
        self._wait = wait
        self._on_ready = on_ready
        self._origin: float | None = None
        self._last_time = -1
        self._schemas: list[Any] = []
        self._channels: list[Any] = []        # foxglove.Channel, by our channel id - 1
        self._by_sdk_id: dict[int, int] = {}  # the SDK's channel id -> ours
        self._latched: dict[int, bytes] = {}  # our channel id -> its last message
        self._latched_channels: set[int] = set()
        self._watched_sdk_ids: frozenset[int] = frozenset()
        self._watched_ids: frozenset[int] = frozenset()
        self._watched_array = np.zeros(0, dtype=np.uint16)
        try:
            self._server = foxglove.start_server(
                name=name, host=host, port=port, context=self._context,
                server_listener=cast("ServerListener", self._clients),
                capabilities=[Capability.Time], message_backlog_size=BACKLOG)
        except RuntimeError as exc:  # the SDK's errors: binding the address
            raise InputError(_bind_failure(host, port, str(exc))) from None
        self.host = host
        self.port = self._server.port

    @property
    def address(self) -> str:
        """The address a Foxglove client connects to."""
        host = f"[{self.host}]" if ":" in self.host else self.host
        return f"ws://{host}:{self.port}"

    # ---- the server's life ------------------------------------------------------------------

    def __enter__(self) -> LiveServer:
        return self

    def __exit__(self, kind: type[BaseException] | None, error: BaseException | None,
                 trace: TracebackType | None) -> None:
        self.stop()

    def stop(self) -> None:
        """Close every connection and stop listening."""
        self._server.stop()

    def _wait_for_client(self) -> None:
        """Block until a client subscribes to a channel, then give its other subscriptions a
        moment to land. Ctrl-C stops the wait."""
        while not self._clients.any():
            time.sleep(POLL)
        time.sleep(SETTLE)

    def serve_until_clients_leave(self) -> None:
        """Keep serving (the last map and scene to late subscribers) until no client is
        subscribed to anything: they have seen the end. Ctrl-C stops it too."""
        while self._clients.any():
            self._resend_latched()
            time.sleep(POLL)

    # ---- the sink ---------------------------------------------------------------------------

    def add_schema(self, name: str, data: bytes, encoding: str = "jsonschema") -> int:
        self._schemas.append(self._foxglove.Schema(name=name, encoding=encoding, data=data))
        return len(self._schemas)

    def add_channels(self, topics: Sequence[str], schema_id: int,
                     message_encoding: str = "json") -> list[int]:
        ids = []
        for topic in topics:
            channel = self._foxglove.Channel(topic, schema=self._schemas[schema_id - 1],
                                             message_encoding=message_encoding,
                                             context=self._context)
            self._channels.append(channel)
            ids.append(len(self._channels))
            self._by_sdk_id[channel.id()] = ids[-1]
            if topic in LATCHED:
                self._latched_channels.add(ids[-1])
        return ids

    def add_metadata(self, name: str, values: dict[str, str]) -> None:
        pass  # the protocol has no metadata: the run's provenance is in the log file

    def add_attachment(self, name: str, media_type: str, data: bytes, log_time: int = 0) -> None:
        pass  # nor attachments

    def add_message(self, channel: int, log_time: int, data: bytes, sequence: int = 0) -> None:
        self._advance(log_time)
        if channel in self._watched() or channel in self._latched_channels:
            self._publish(channel, log_time, bytes(data))

    def add_block(self, data: bytes | memoryview, channels: npt.NDArray[np.uint16],
                  offsets: npt.NDArray[np.uint64], log_time: int) -> None:
        self._advance(log_time)
        if not self._watched():  # a frame is two messages per human: skip what nobody reads
            return
        chosen = offsets[np.isin(channels, self._watched_array)]
        for channel, payload in message_payloads(data, chosen):
            self._publish(channel, log_time, bytes(payload))

    def finish(self) -> None:
        pass  # the server outlives the run: its owner stops it

    def abandon(self) -> None:
        pass

    # ---- publishing -------------------------------------------------------------------------

    def _watched(self) -> frozenset[int]:
        """Our ids of the channels some client is subscribed to, updated as that changes."""
        sdk_ids = self._clients.channels
        if sdk_ids is not self._watched_sdk_ids:
            self._watched_sdk_ids = sdk_ids
            self._watched_ids = frozenset(self._by_sdk_id[i] for i in sdk_ids
                                          if i in self._by_sdk_id)
            self._watched_array = np.fromiter(self._watched_ids, dtype=np.uint16)
        return self._watched_ids

    def _publish(self, channel: int, log_time: int, data: bytes) -> None:
        if channel in self._latched_channels:
            self._latched[channel] = data
        self._channels[channel - 1].log(data, log_time=log_time)

    def _advance(self, log_time: int) -> None:
        """Wait for the wall clock to reach `log_time` at the pace; tell clients the time."""
        if log_time <= self._last_time:
            return
        on_ready, self._on_ready = self._on_ready, None
        if on_ready is not None:
            on_ready(self)
        if self._wait:
            self._wait = False
            self._wait_for_client()
        self._resend_latched()
        if self._pace is not None:
            now = time.monotonic()
            if self._origin is None:
                self._origin = now - log_time / 1e9 / self._pace
            delay = self._origin + log_time / 1e9 / self._pace - now
            if delay > 0:
                time.sleep(delay)
        self._last_time = log_time
        self._server.broadcast_time(log_time)

    def _resend_latched(self) -> None:
        for sdk_id in self._clients.new_subscriptions():
            channel = self._by_sdk_id.get(sdk_id)
            if channel in self._latched:
                self._channels[channel - 1].log(self._latched[channel],
                                                log_time=max(self._last_time, 0))


class _Clients:
    """The SDK's server listener (the callbacks it needs of `ServerListener`): who is
    subscribed to what. Called on the server's threads."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._subscribed: dict[int, set[int]] = {}  # client id -> SDK channel ids
        self._new: list[int] = []
        # the SDK channel ids anyone is subscribed to: a new set on each change, so that the
        # publishing thread reads it without the lock
        self.channels: frozenset[int] = frozenset()

    def on_subscribe(self, client: Any, channel: Any) -> None:
        with self._lock:
            self._subscribed.setdefault(client.id, set()).add(channel.id)
            self._new.append(channel.id)
            self.channels = frozenset().union(*self._subscribed.values())

    def on_unsubscribe(self, client: Any, channel: Any) -> None:  # also when a client leaves
        with self._lock:
            channels = self._subscribed.get(client.id, set())
            channels.discard(channel.id)
            if not channels:
                self._subscribed.pop(client.id, None)
            self.channels = frozenset().union(*self._subscribed.values())

    def any(self) -> bool:
        with self._lock:
            return bool(self._subscribed)

    def new_subscriptions(self) -> list[int]:
        with self._lock:
            new, self._new = self._new, []
        return new


def _bind_failure(host: str, port: int, reason: str) -> str:
    where = f"{host}:{port}"
    if "in use" in reason:
        return f"cannot serve the run live on {where}: the port is in use (choose another " \
               "with --port, or --port 0 for any free one)"
    reason = reason.removeprefix("FoxgloveError: ").removeprefix("Failed to bind port: ")
    return f"cannot serve the run live on {where}: {reason}"
