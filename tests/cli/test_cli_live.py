"""`hubero run --live`: the run served over Foxglove's WebSocket protocol, read by a real client.

The client is the `websockets` package speaking Foxglove's WebSocket protocol as the Foxglove app
does: serverInfo, advertise, subscribe, then binary message data (opcode 0x01: subscription id
u32, timestamp u64, payload). It offers the subprotocols the app offers; the foxglove-sdk server
takes `foxglove.sdk.v1` (the protocol `foxglove.websocket.v1` under the SDK's name) and refuses
a client that offers only the old name. What the client receives is compared with what the MCAP
log holds.
"""

from __future__ import annotations

import json
import os
import signal
import socket
import struct
import subprocess
import sys
import time
from collections import defaultdict
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
from mcap.reader import make_reader
from websockets.sync.client import ClientConnection, connect
from websockets.typing import Subprotocol

from tests.cli.conftest import REPO_ROOT, Outcome

LIVING_ROOM = str(REPO_ROOT / "scenarios" / "living_room.hub")
RUN_SECONDS = 19.25  # how long living_room.hub runs in simulated time
PROTOCOL = Subprotocol("foxglove.sdk.v1")
PROTOCOLS = [PROTOCOL, Subprotocol("foxglove.websocket.v1")]
MESSAGE_DATA, TIME = 0x01, 0x02
TIMEOUT = 60.0  # s: a bound for every wait, never reached when things work
END_SILENCE = 1.0  # s without a message after the run's end: all of it has arrived

Run = Callable[..., Outcome]


def _start(*argv: str, cwd: Path) -> subprocess.Popen[str]:
    environment = {k: v for k, v in os.environ.items() if k not in ("FORCE_COLOR",)}
    return subprocess.Popen([sys.executable, "-m", "hubero_dsl", "run", *argv], cwd=cwd,
                            env=environment, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)


def _address(process: subprocess.Popen[str]) -> str:
    """The ws:// address the run prints to stderr before it starts."""
    assert process.stderr is not None
    deadline = time.monotonic() + TIMEOUT
    while time.monotonic() < deadline:
        line = process.stderr.readline()
        if not line:
            break
        if "serving the run live on " in line:
            return line.split("serving the run live on ")[1].split()[0]
    process.kill()
    raise AssertionError(f"no address printed; exit {process.wait()}")


@pytest.fixture
def started(tmp_path: Path) -> Iterator[Callable[..., subprocess.Popen[str]]]:
    processes: list[subprocess.Popen[str]] = []

    def start(*argv: str) -> subprocess.Popen[str]:
        processes.append(_start(*argv, cwd=tmp_path))
        return processes[-1]

    yield start
    for process in processes:  # a failed test leaves no server behind
        if process.poll() is None:
            process.kill()
        process.wait(TIMEOUT)
        for stream in (process.stdout, process.stderr):
            if stream is not None:
                stream.close()


LIVING_ROOM_TOPICS = frozenset({"/log", "/humans/actor1/pose", "/humans/actor1/state",
                                "/humans/actor2/pose", "/humans/actor2/state"})


STATION_TOPICS = frozenset({"/map", "/scene", "/tf", "/tasks", "/log", "/humans/guard/pose",
                            "/humans/guard/state", "/crowds/alighting/poses",
                            "/crowds/alighting/state", "/crowds/boarding/poses",
                            "/crowds/boarding/state"})


def _channels(ws: ClientConnection, topics: frozenset[str] = LIVING_ROOM_TOPICS
              ) -> dict[int, dict[str, Any]]:
    """serverInfo, then the advertised channels by id, once `topics` are among them."""
    info = json.loads(ws.recv(timeout=TIMEOUT))
    assert info["op"] == "serverInfo"
    assert "time" in info["capabilities"]
    channels: dict[int, dict[str, Any]] = {}
    while True:
        advertise = json.loads(ws.recv(timeout=TIMEOUT))
        assert advertise["op"] == "advertise"
        channels.update({c["id"]: c for c in advertise["channels"]})
        if topics <= {c["topic"] for c in channels.values()}:
            return channels


def _watch(address: str, topics: frozenset[str] = LIVING_ROOM_TOPICS
           ) -> tuple[dict[int, dict[str, Any]], dict[str, list[tuple[int, bytes]]],
                      list[float]]:
    """Subscribe to every channel; receive until the run has reported its end on /log."""
    received: dict[str, list[tuple[int, bytes]]] = defaultdict(list)
    arrivals: list[float] = []
    with connect(address, subprotocols=PROTOCOLS, open_timeout=TIMEOUT) as ws:
        assert ws.subprotocol == PROTOCOL
        channels = _channels(ws, topics)
        topic_of = {}
        subscriptions = []
        for number, channel in enumerate(sorted(channels), start=1):
            topic_of[number] = channels[channel]["topic"]
            subscriptions.append({"id": number, "channelId": channel})
        ws.send(json.dumps({"op": "subscribe", "subscriptions": subscriptions}))
        ended = False
        while True:
            try:  # the end's messages go out together: then the held server is silent
                frame = ws.recv(timeout=END_SILENCE if ended else TIMEOUT)
            except TimeoutError:
                assert ended
                return channels, received, arrivals
            assert isinstance(frame, bytes), frame
            if frame[0] == TIME:
                continue
            assert frame[0] == MESSAGE_DATA
            subscription, stamp = struct.unpack_from("<IQ", frame, 1)
            topic = topic_of[subscription]
            received[topic].append((stamp, frame[13:]))
            arrivals.append(time.monotonic())
            ended = ended or (topic == "/log" and b"run completed" in frame[13:])


def _logged(path: Path) -> dict[str, list[tuple[int, bytes]]]:
    messages: dict[str, list[tuple[int, bytes]]] = defaultdict(list)
    with path.open("rb") as stream:
        for _, channel, message in make_reader(stream).iter_messages(log_time_order=False):
            messages[channel.topic].append((message.log_time, message.data))
    return messages


@pytest.mark.slow  # a whole run in a subprocess
def test_a_live_run_streams_what_the_log_holds(started: Callable[..., subprocess.Popen[str]],
                                                tmp_path: Path, cli: Run) -> None:
    process = started(LIVING_ROOM, "--live", "--live-wait", "--port", "0", "--pace", "10x",
                      "-o", "live.mcap")
    channels, received, arrivals = _watch(_address(process))
    # the client has gone: the run stops serving and ends as the run did
    assert process.wait(TIMEOUT) == 0
    assert process.stdout is not None and "log written to" in process.stdout.read()
    logged = _logged(tmp_path / "live.mcap")
    assert set(received) == set(logged)
    for topic, messages in logged.items():
        assert received[topic] == messages, topic
    state = json.loads(received["/humans/actor1/state"][-1][1])
    assert state["status"] == "SUCCEEDED"
    # the same schemas as the log's
    with (tmp_path / "live.mcap").open("rb") as stream:
        summary = make_reader(stream).get_summary()
    assert summary is not None
    schemas = {c.topic: summary.schemas[c.schema_id] for c in summary.channels.values()}
    for channel in channels.values():
        schema = schemas[channel["topic"]]
        assert (channel["encoding"], channel["schemaName"], channel["schemaEncoding"]) == \
            ("json", schema.name, schema.encoding)
        assert channel["schema"] == schema.data.decode()
    # 10x: 19.25 s of simulated time take at least 1.9 s of wall clock
    assert arrivals[-1] - arrivals[0] >= RUN_SECONDS / 10 * 0.95
    # and the log is the one a run without --live writes, byte for byte
    assert cli("run", LIVING_ROOM, "--quiet", "-o", str(tmp_path / "plain.mcap")).status == 0
    assert (tmp_path / "live.mcap").read_bytes() == (tmp_path / "plain.mcap").read_bytes()


@pytest.mark.slow  # a whole run in a subprocess
def test_a_live_run_streams_the_crowd_topics_the_log_holds(
        started: Callable[..., subprocess.Popen[str]], tmp_path: Path) -> None:
    process = started(str(REPO_ROOT / "scenarios" / "station.hub"), "--live", "--live-wait",
                      "--port", "0", "--pace", "20x", "-o", "live.mcap")
    _, received, _ = _watch(_address(process), STATION_TOPICS)
    assert process.wait(TIMEOUT) == 0
    logged = _logged(tmp_path / "live.mcap")
    crowds = {topic for topic in logged if topic.startswith("/crowds/")}
    assert crowds == {"/crowds/alighting/poses", "/crowds/alighting/state",
                      "/crowds/boarding/poses", "/crowds/boarding/state"}
    for topic in crowds:
        assert received[topic] == logged[topic], topic
    assert max(len(json.loads(data)["names"]) for _, data in received["/crowds/alighting/state"]
               ) > 5


@pytest.mark.slow  # a whole run in a subprocess
def test_a_late_client_gets_the_map_and_the_scene(started: Callable[..., subprocess.Popen[str]],
                                                  tmp_path: Path) -> None:
    process = started(LIVING_ROOM, "--live", "--port", "0", "--pace", "2x", "--no-log",
                      "--quiet")
    # --quiet prints no address: find the port from the process (the run is paced, so it is
    # still going when the client subscribes)
    address = _listening_address(process.pid)
    with connect(address, subprotocols=PROTOCOLS, open_timeout=TIMEOUT) as ws:
        channels = _channels(ws)
        wanted = {c["topic"]: c["id"] for c in channels.values()}
        ws.send(json.dumps({"op": "subscribe", "subscriptions": [
            {"id": 1, "channelId": wanted["/map"]}, {"id": 2, "channelId": wanted["/scene"]}]}))
        got: set[int] = set()
        while got != {1, 2}:
            frame = ws.recv(timeout=TIMEOUT)
            if isinstance(frame, bytes) and frame[0] == MESSAGE_DATA:
                got.add(struct.unpack_from("<I", frame, 1)[0])
                if struct.unpack_from("<I", frame, 1)[0] == 1:
                    grid = json.loads(frame[13:])
                    assert grid["frame_id"] == "map"
    process.send_signal(signal.SIGINT)
    assert process.wait(TIMEOUT) == 130
    assert process.stderr is not None
    assert process.stderr.read() == "hubero: interrupted\n"


@pytest.mark.slow  # a whole run in a subprocess
@pytest.mark.parametrize("sent", [signal.SIGINT, signal.SIGTERM])
def test_after_the_end_ctrl_c_stops_serving_and_the_run_status_stands(
        started: Callable[..., subprocess.Popen[str]], sent: signal.Signals) -> None:
    process = started(LIVING_ROOM, "--live", "--live-wait", "--port", "0", "--pace", "max",
                      "--no-log")
    address = _address(process)
    assert process.stderr is not None
    # (an unbounded queue: the client reads nothing more, and must still see the server go)
    with connect(address, subprotocols=PROTOCOLS, open_timeout=TIMEOUT, max_queue=None) as ws:
        channels = _channels(ws)
        ws.send(json.dumps({"op": "subscribe", "subscriptions": [
            {"id": 1, "channelId": next(iter(channels))}]}))
        subscribed = time.monotonic()
        while "the run has ended" not in process.stderr.readline():
            assert process.poll() is None
        # at max pace nothing waits: far sooner than the 19.25 s real time would take
        assert time.monotonic() - subscribed < RUN_SECONDS * 0.75
        time.sleep(0.2)
        assert process.poll() is None  # held while the client is there
        process.send_signal(sent)
        assert process.wait(TIMEOUT) == 0
    assert process.stdout is not None and "completed" in process.stdout.read()


@pytest.mark.parametrize("command", [["sweep", "--out-dir", "out"], ["test"]])
def test_commands_of_many_runs_refuse_live(cli: Run, command: list[str]) -> None:
    outcome = cli(command[0], LIVING_ROOM, *command[1:], "--live")
    assert outcome.status == 2
    assert "--live watches one run as it runs" in outcome.err
    assert "hubero run FILE --live" in outcome.err


def _listening_address(pid: int) -> str:
    """The TCP port the process listens on (from /proc), polled until it listens."""
    deadline = time.monotonic() + TIMEOUT
    while time.monotonic() < deadline:
        inodes = set()
        for fd in Path(f"/proc/{pid}/fd").iterdir():
            target = os.readlink(fd) if fd.is_symlink() else ""
            if target.startswith("socket:["):
                inodes.add(target[8:-1])
        for line in Path("/proc/net/tcp").read_text().splitlines()[1:]:
            fields = line.split()
            if fields[3] == "0A" and fields[9] in inodes:  # LISTEN
                return f"ws://127.0.0.1:{int(fields[1].split(':')[1], 16)}"
        time.sleep(0.05)
    raise AssertionError("the run never listened")


@pytest.mark.slow  # a whole run in a subprocess
@pytest.mark.parametrize(("sent", "status", "said"), [
    (signal.SIGINT, 130, "interrupted"), (signal.SIGTERM, 143, "terminated")])
def test_ctrl_c_and_sigterm_stop_a_live_run_cleanly(
        started: Callable[..., subprocess.Popen[str]], tmp_path: Path,
        sent: signal.Signals, status: int, said: str) -> None:
    process = started(LIVING_ROOM, "--live", "--port", "0", "--pace", "1x", "-o", "run.mcap")
    address = _address(process)
    with connect(address, subprotocols=PROTOCOLS, open_timeout=TIMEOUT) as ws:
        _channels(ws)
        process.send_signal(sent)
        assert process.wait(TIMEOUT) == status
    assert process.stderr is not None and said in process.stderr.read()
    assert list(tmp_path.iterdir()) == []  # no log, no temporary file


@pytest.mark.slow  # a whole run in a subprocess
def test_ctrl_c_while_waiting_for_a_client_leaves_nothing(
        started: Callable[..., subprocess.Popen[str]], tmp_path: Path) -> None:
    process = started(LIVING_ROOM, "--live", "--live-wait", "--port", "0", "-o", "run.mcap")
    _address(process)
    assert process.stderr is not None
    assert "starts when a client subscribes" in process.stderr.readline()
    process.send_signal(signal.SIGINT)
    assert process.wait(TIMEOUT) == 130
    assert list(tmp_path.iterdir()) == []


def test_a_port_in_use_is_a_clear_error(cli: Run) -> None:
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        outcome = cli("run", LIVING_ROOM, "--live", "--port", str(port), "--no-log")
    assert outcome.status == 2
    assert f"cannot serve the run live on 127.0.0.1:{port}: the port is in use" in outcome.err


def test_an_address_that_cannot_be_listened_on_is_a_clear_error(cli: Run) -> None:
    outcome = cli("run", LIVING_ROOM, "--live", "--host", "nowhere.invalid", "--no-log")
    assert outcome.status == 2
    assert "cannot serve the run live on nowhere.invalid:8765: " in outcome.err


@pytest.mark.parametrize("pace", ["fast", "0x", "-1x", "nanx", "infx", "10", "x", ""])
def test_a_bad_pace_is_a_usage_error(cli: Run, pace: str) -> None:
    outcome = cli("run", LIVING_ROOM, "--live", f"--pace={pace}")
    assert outcome.status == 2
    assert f"invalid pace '{pace}'" in outcome.err


@pytest.mark.parametrize("port", ["http", "-1", "65536"])
def test_a_bad_port_is_a_usage_error(cli: Run, port: str) -> None:
    outcome = cli("run", LIVING_ROOM, "--live", f"--port={port}")
    assert outcome.status == 2
    assert f"invalid port '{port}'" in outcome.err


@pytest.mark.parametrize("option", [["--pace", "2x"], ["--port", "9000"], ["--host", "::1"],
                                    ["--live-wait"]])
def test_live_options_need_live(cli: Run, option: list[str]) -> None:
    outcome = cli("run", LIVING_ROOM, *option)
    assert outcome.status == 2
    assert f"{option[0]} is an option of --live" in outcome.err


def test_live_options_are_checked_before_the_file_is_read(cli: Run) -> None:
    outcome = cli("run", "missing.hub", "--pace", "2x")
    assert outcome.status == 2
    assert "--pace is an option of --live" in outcome.err


def test_live_serves_one_run(cli: Run) -> None:
    outcome = cli("run", LIVING_ROOM, "--live", "--all-variants")
    assert outcome.status == 2
    assert "--live serves one run" in outcome.err


def test_without_the_sdk_live_says_what_to_install(cli: Run,
                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "foxglove", None)  # import foxglove now fails
    outcome = cli("run", LIVING_ROOM, "--live", "--no-log")
    assert outcome.status == 2
    assert "needs the foxglove-sdk package" in outcome.err
    assert "pip install 'hubero[live]'" in outcome.err
