"""Reading a run log back: `load_run(path)` gives the trajectories, the map, the provenance
and the task events of a run, as numpy arrays and hubero's own types, for analysis.

    run = load_run("run.mcap")
    track = run.humans["actor1"]
    track.time, track.position, track.heading, track.status   # (T,), (T, 2), (T,), (T,)
    run.metadata.seed, run.metadata.params["actor1"]["speed"], run.grid, run.events

Anything that is not a complete hubero log (not MCAP, truncated, empty, a directory, another
tool's MCAP without hubero's metadata, a log of a newer format) raises `LogError` saying so.
CRCs of chunks are checked while reading, and no chunk is unpacked that would take more than
MAX_CHUNK_BYTES.
"""

from __future__ import annotations

import hashlib
import io
import json
import struct
import zlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import lz4.frame
import numpy as np
import numpy.typing as npt
import zstandard
from mcap.exceptions import InvalidMagic, McapError
from mcap.reader import make_reader
from mcap.records import Chunk, Footer
from mcap.stream_reader import StreamReader

from hubero_dsl.diagnostics import Span
from hubero_dsl.errors import InputError, LogError
from hubero_dsl.files import MCAP_MAGIC, refuse_other_kind
from hubero_dsl.log import schemas as s
from hubero_dsl.log.crowds import crowd_state_topic
from hubero_dsl.model.program import ParamValue
from hubero_dsl.sim.status import Posture, TaskEvent, TaskStatus
from hubero_dsl.world.grid import OccupancyGrid

FloatArray = npt.NDArray[np.float64]
# hubero writes chunks of 4 MB, or of one map message (4 bytes a cell at most, encoded): a
# chunk that unpacks to more is forged, its few kilobytes made to take gigabytes of memory
MAX_CHUNK_BYTES = 64 << 20
_CRC_BYTES = 4          # the footer's summary CRC, last before the closing magic
_FOOTER_FIELDS = 25     # the footer's opcode, length and two offsets, which its CRC covers
POSTURE_VALUE = {posture.name: posture.value for posture in Posture}  # as the log names them


@dataclass(frozen=True)
class RunMetadata:
    """What made the run: the provenance record written when the log was opened."""

    format_version: int
    hubero_version: str
    title: str
    source_path: str
    source_sha256: str
    source: str                    # the scenario's text (from its attachment)
    map_path: str
    seed: int
    variant: str | None
    variants: tuple[str, ...]
    params: dict[str, dict[str, ParamValue]]  # per human, resolved and drawn
    step: float
    time_limit: float
    log_rate_hz: float
    humans: tuple[str, ...]
    robots: tuple[str, ...]
    # crowds, flows and groups: name -> (kind, members); empty in a run without them
    sets: dict[str, tuple[str, tuple[str, ...]]] = field(default_factory=dict)
    # per robot, its resolved parameters (radius, goal, goal_tolerance, limits, controller);
    # empty in logs written before robots' parameters were recorded
    robot_params: dict[str, dict[str, Any]] = field(default_factory=dict)
    # the SHA-256 of the files the run was made from (scenario, map YAML, map image): what
    # no output made from the log may be written over, wherever they lie now
    input_sha256: frozenset[str] = frozenset()

    def robot_goal(self, robot: str) -> tuple[tuple[float, float] | None, float]:
        """The robot's declared goal (None without one) and how near counts as reaching it."""
        params = self.robot_params.get(robot, {})
        return params.get("goal"), params.get("goal_tolerance", 0.2)

    def members(self, name: str) -> tuple[str, ...]:
        """The humans a name stands for: a crowd's, flow's or group's members, or the human."""
        return self.sets[name][1] if name in self.sets else (name,)

    def set_of(self, human: str) -> str | None:
        """The crowd or flow a human belongs to (groups are of named humans), if any."""
        return next((name for name, (kind, members) in self.sets.items()
                     if kind != "group" and human in members), None)


@dataclass(frozen=True)
class HumanTrack:
    """One human, frame by frame (row t of every array is the same instant)."""

    name: str
    time: FloatArray                # (T,) seconds
    position: FloatArray            # (T, 2) metres, map frame
    velocity: FloatArray            # (T, 2) m/s
    heading: FloatArray             # (T,) radians
    posture: npt.NDArray[np.int8]   # (T,) Posture values
    status: npt.NDArray[np.str_]    # (T,) current or last task's status, IDLE before any
    fsm_state: npt.NDArray[np.str_]  # (T,) behaviour state: walking, talking, idle, ...
    task_id: npt.NDArray[np.int64]  # (T,) current task, 0 when none


@dataclass(frozen=True)
class RobotTrack:
    name: str
    time: FloatArray
    position: FloatArray
    heading: FloatArray
    radius: float = 0.0  # m, from its body in /scene


@dataclass(frozen=True)
class LogLine:
    """One /log message: a scenario event."""

    time: float
    level: int
    message: str
    file: str
    line: int


@dataclass(frozen=True)
class RunOutcome:
    """How the run ended (absent when the log was closed without a result)."""

    state: str
    reason: str
    time: float
    ticks: int
    succeeded: bool
    expectations: list[dict[str, Any]]
    humans: list[dict[str, Any]]


@dataclass(frozen=True)
class LoggedRun:
    """Everything `load_run` reads from one log."""

    path: Path
    metadata: RunMetadata
    grid: OccupancyGrid
    humans: dict[str, HumanTrack]
    robots: dict[str, RobotTrack]
    events: list[TaskEvent]
    log: list[LogLine]
    result: RunOutcome | None
    attachments: dict[str, bytes] = field(repr=False)
    # every frame's time (ns): a frame may hold nobody (a flow's people not yet come)
    frames: npt.NDArray[np.int64] = field(default_factory=lambda: np.zeros(0, np.int64),
                                          repr=False)


def refuse_unless_run_log(path: Path, advice: str) -> None:
    """Refuse (InputError) to write over a regular file at `path` that is not a hubero run
    log: a run's log is written over, a user's file never, another tool's MCAP (a ROS 2 bag)
    neither."""
    refuse_other_kind(path, MCAP_MAGIC, "an MCAP log", advice)
    if not path.is_file():
        return
    try:
        with path.open("rb") as stream:
            records = {record.name: dict(record.metadata)
                       for record in make_reader(stream).iter_metadata()}
        ours = records.get(s.METADATA_NAME, {}).get("format") == s.FORMAT
    except Exception:  # whatever it is, it cannot be shown to be a run's log
        ours = False
    if not ours:
        raise InputError(f"{path} is an MCAP file but not a hubero run log: not writing over "
                         f"it ({advice})")


def load_run(path: str | Path) -> LoggedRun:
    """Read a log written by `RunLog`; LogError for anything else."""
    path = Path(path)
    if path.is_dir():
        raise LogError(f"cannot read log {path}: it is a directory")
    try:
        size = path.stat().st_size
    except OSError as exc:
        raise LogError(f"cannot read log {path}: {exc.strerror or exc}") from None
    if size == 0:
        raise LogError(f"cannot read log {path}: the file is empty")
    try:
        with path.open("rb") as stream:
            return _read(path, stream)
    except LogError:
        raise
    except OSError as exc:
        raise LogError(f"cannot read log {path}: {exc.strerror or exc}") from None
    except InvalidMagic:  # its message would quote the file's first bytes: say no more
        raise LogError(f"{path} is not a readable hubero run log: it is not an MCAP file"
                       ) from None
    except (McapError, zstandard.ZstdError, struct.error, ValueError, KeyError, TypeError,
            IndexError, AttributeError, OverflowError) as exc:
        # Whatever a damaged file makes the MCAP library or the JSON decoder trip on; an
        # OverflowError is a number too large for a float or an integer (a forged timestamp).
        said = str(exc) or type(exc).__name__  # some say nothing: name what they are
        raise LogError(f"{path} is not a readable hubero run log (truncated or corrupt?): "
                       f"{said}") from None


def _read(path: Path, stream: Any) -> LoggedRun:
    _refuse_chunk_bombs(path, stream)
    stream.seek(0)
    reader = make_reader(stream, validate_crcs=True)
    records = {record.name: dict(record.metadata) for record in reader.iter_metadata()}
    provenance = records.get(s.METADATA_NAME)
    if provenance is None or provenance.get("format") != s.FORMAT:
        raise LogError(f"{path} is an MCAP file but not a hubero run log "
                       f"(it has no '{s.METADATA_NAME}' metadata)")
    version = int(provenance["format_version"])
    if version > s.FORMAT_VERSION:
        raise LogError(f"{path} was written in log format {version} by hubero "
                       f"{provenance.get('hubero_version')}; this hubero reads format "
                       f"{s.FORMAT_VERSION} and older")
    attachments = {a.name: a.data for a in reader.iter_attachments()}
    _check_attachments(path, provenance, attachments)
    crowds = [name for name, entry in _json(provenance.get("sets", "{}")).items()
              if entry["kind"] != "group"]
    humans, robots = _json(provenance["humans"]), _json(provenance["robots"])
    _check_names(humans, robots)
    collector = _Collector(humans, robots, crowds)
    for _, channel, message in reader.iter_messages(log_time_order=False):
        collector.add(channel.topic, message.data, message.log_time)
    if collector.grid_message is None:
        raise LogError(f"{path} has no /map message: the log is incomplete")
    metadata = _metadata(provenance, attachments)
    result = records.get(s.RESULT_METADATA_NAME)
    return LoggedRun(
        path=path, metadata=metadata,
        grid=s.grid_from_message(collector.grid_message, f"{path} /map"),
        humans=collector.human_tracks(), robots=collector.robot_tracks(),
        events=collector.events, log=collector.log,
        result=_outcome(result) if result is not None else None, attachments=attachments,
        frames=np.unique(np.asarray(collector.frames, dtype=np.int64)))


# the files a log attaches, each with its checksum (`KEY_sha256`) in the provenance record
ATTACHED = ("source", "map", "map_image")


def _check_names(humans: object, robots: object) -> None:
    """Humans and robots each a list of distinct names, none both (ValueError else: a log
    hubero did not write so would make every reader of its tracks trip)."""
    names = [*humans, *robots] if isinstance(humans, list) and isinstance(robots, list) \
        else None
    if names is None or not all(isinstance(name, str) for name in names):
        raise ValueError("its humans and robots are not lists of names")
    if len(set(names)) != len(names):
        raise ValueError("a name is listed twice among its humans and robots")


def _check_attachments(path: Path, provenance: dict[str, str],
                       attachments: dict[str, bytes]) -> None:
    """LogError for an attached scenario or map whose bytes are not those the provenance
    record's checksum names (the MCAP library checks the chunks' CRCs, not attachments')."""
    names = _json(provenance.get("attachments", "{}"))
    for key in ATTACHED:
        name, expected = names.get(key), provenance.get(f"{key}_sha256")
        if name in attachments and expected is not None \
                and hashlib.sha256(attachments[name]).hexdigest() != expected:
            raise LogError(f"{path} is not a readable hubero run log (truncated or corrupt?): "
                           f"its attachment {name} is not what it was when written")


def _refuse_chunk_bombs(path: Path, stream: Any) -> None:
    """LogError for a chunk that would unpack to more than MAX_CHUNK_BYTES, found before
    anything unpacks it: the MCAP library trusts the sizes a chunk and its frame declare.
    The data section's and the summary's CRCs are checked on the way (the library's reader
    checks only the chunks' it unpacks: a damaged schema went unseen)."""
    for record in StreamReader(stream, emit_chunks=True, validate_crcs=True).records:
        if isinstance(record, Chunk) and _unpacked_size(record) > MAX_CHUNK_BYTES:
            raise LogError(f"{path} is not a readable hubero run log: a chunk of it unpacks to "
                           f"more than {MAX_CHUNK_BYTES >> 20} MB (hubero writes 4 MB chunks)")
        if isinstance(record, Footer):
            _check_summary(path, stream, record)


def _check_summary(path: Path, stream: Any, footer: Footer) -> None:
    """LogError when the summary (and the footer's fields before its CRC) do not match the
    footer's summary CRC (0: not computed)."""
    if not footer.summary_crc:
        return
    here = stream.tell()   # where the reader goes on, to the closing magic
    end = stream.seek(0, io.SEEK_END) - len(MCAP_MAGIC) - _CRC_BYTES
    start = footer.summary_start or end - _FOOTER_FIELDS
    stream.seek(start)
    summary = stream.read(max(end - start, 0))
    stream.seek(here)
    if zlib.crc32(summary) != footer.summary_crc:
        raise LogError(f"{path} is not a readable hubero run log (truncated or corrupt?): "
                       "its summary does not match its checksum")


def _unpacked_size(chunk: Chunk) -> int:
    """The most that unpacking `chunk` allocates: the larger of the size the chunk declares
    and the size its zstd frame declares (which zstandard allocates, whatever it is told); an
    lz4 frame, which need not declare one, is unpacked up to the limit to learn it."""
    if chunk.compression == "zstd":
        return max(chunk.uncompressed_size, zstandard.frame_content_size(chunk.data))
    if chunk.compression == "lz4":
        unpacked = lz4.frame.LZ4FrameDecompressor().decompress(
            chunk.data, max_length=MAX_CHUNK_BYTES + 1)
        return max(chunk.uncompressed_size, len(unpacked))
    return int(chunk.uncompressed_size)


def _metadata(values: dict[str, str], attachments: dict[str, bytes]) -> RunMetadata:
    names = _json(values["attachments"])
    source = attachments.get(names["source"], b"").decode("utf-8")
    params: dict[str, dict[str, ParamValue]] = {
        human: {key: s.shape_from_json(v) if isinstance(v, dict) else v
                for key, v in entries.items()}
        for human, entries in _json(values["params"]).items()}
    return RunMetadata(
        format_version=int(values["format_version"]), hubero_version=values["hubero_version"],
        title=values["title"], source_path=values["source_path"],
        source_sha256=values["source_sha256"], source=source, map_path=values["map_path"],
        input_sha256=frozenset(values[f"{key}_sha256"] for key in ATTACHED
                               if f"{key}_sha256" in values),
        seed=int(values["seed"]), variant=values["variant"] or None,
        variants=tuple(_json(values["variants"])), params=params,
        step=float(values["step"]), time_limit=float(values["time_limit"]),
        log_rate_hz=float(values["log_rate_hz"]), humans=tuple(_json(values["humans"])),
        robots=tuple(_json(values["robots"])),
        sets={name: (entry["kind"], tuple(entry["members"]))
              for name, entry in _json(values.get("sets", "{}")).items()},
        robot_params=_robot_params(values.get("robot_params", "{}")))


def _robot_params(text: str) -> dict[str, dict[str, Any]]:
    """Each robot's logged parameters, its goal as a point and its tolerance as a number
    (ValueError, TypeError or AttributeError for a log that says otherwise)."""
    params: dict[str, dict[str, Any]] = _json(text)
    for entry in params.values():
        goal = entry.get("goal")
        if goal is not None:
            x, y = goal
            entry["goal"] = (float(x), float(y))
        entry["goal_tolerance"] = float(entry.get("goal_tolerance", 0.2))
    return params


def _outcome(values: dict[str, str]) -> RunOutcome:
    return RunOutcome(state=values["state"], reason=values["reason"],
                      time=float(values["time"]), ticks=int(values["ticks"]),
                      succeeded=values["succeeded"] == "true",
                      expectations=_json(values["expectations"]),
                      humans=_json(values["humans"]))


def _json(text: str | bytes) -> Any:
    """A JSON value of the log; ValueError for one nested too deeply to decode, which only a
    forged or damaged log holds (the decoder recurses once per level)."""
    try:
        return json.loads(text)
    except RecursionError:
        raise ValueError("its JSON is nested too deeply") from None


def _seconds(stamp: dict[str, int]) -> float:
    return int(stamp["sec"]) + int(stamp["nsec"]) * 1e-9


class _Collector:
    """Sorts a log's messages by topic into rows for the arrays of `LoggedRun`."""

    def __init__(self, humans: list[str], robots: list[str], crowds: list[str]) -> None:
        self.grid_message: dict[str, Any] | None = None
        self.events: list[TaskEvent] = []
        self.log: list[LogLine] = []
        self._states: dict[str, list[dict[str, Any]]] = {name: [] for name in humans}
        self._state_topics = {s.human_state_topic(name): name for name in humans}
        # crowds' and flows' states, one message for all their members (format 2 and later)
        self._crowd_states: list[dict[str, Any]] = []
        self._crowd_topics = {crowd_state_topic(name) for name in crowds}
        self._robot_frames = {s.robot_frame(name): name for name in robots}
        self._robots: dict[str, list[tuple[float, float, float, float]]] = {
            name: [] for name in robots}
        self._radius: dict[str, float] = {}
        self.frames: list[int] = []

    def add(self, topic: str, data: bytes, log_time: int) -> None:
        human = self._state_topics.get(topic)
        if human is not None:
            self._states[human].append(_json(data))
        elif topic in self._crowd_topics:
            self._crowd_states.append(_json(data))
        elif topic == s.TF_TOPIC:
            self.frames.append(log_time)  # one a frame, whoever is there
            if self._robot_frames:
                self._add_transforms(_json(data))
        elif topic == s.TASKS_TOPIC:
            self.events.append(_task_event(_json(data)))
        elif topic == s.LOG_TOPIC:
            value = _json(data)
            self.log.append(LogLine(_seconds(value["timestamp"]), int(value["level"]),
                                    value["message"], value["file"], int(value["line"])))
        elif topic == s.MAP_TOPIC and self.grid_message is None:
            self.grid_message = _json(data)
        elif topic == s.SCENE_TOPIC and self._robot_frames and not self._radius:
            for entity in _json(data)["entities"]:
                robot = self._robot_frames.get(entity["id"])
                if robot is not None and entity["cylinders"]:
                    self._radius[robot] = float(entity["cylinders"][0]["size"]["x"]) / 2

    def _add_transforms(self, message: dict[str, Any]) -> None:
        for transform in message["transforms"]:
            robot = self._robot_frames.get(transform["child_frame_id"])
            if robot is not None:
                rotation, translation = transform["rotation"], transform["translation"]
                heading = 2.0 * np.arctan2(rotation["z"], rotation["w"])
                self._robots[robot].append((_seconds(transform["timestamp"]),
                                            translation["x"], translation["y"], heading))

    def human_tracks(self) -> dict[str, HumanTrack]:
        tracks = {name: _human_track(name, rows) for name, rows in self._states.items()}
        tracks.update(_crowd_tracks(self._crowd_states))
        return tracks

    def robot_tracks(self) -> dict[str, RobotTrack]:
        tracks = {}
        for name, rows in self._robots.items():
            table = np.array(rows, dtype=np.float64).reshape(-1, 4)
            tracks[name] = RobotTrack(name, table[:, 0], table[:, 1:3], table[:, 3],
                                      self._radius.get(name, 0.0))
        return tracks


def _human_track(name: str, rows: list[dict[str, Any]]) -> HumanTrack:
    numbers = np.array([(_seconds(r["timestamp"]), r["position"]["x"], r["position"]["y"],
                         r["velocity"]["x"], r["velocity"]["y"], r["heading"]) for r in rows],
                       dtype=np.float64).reshape(-1, 6)
    return HumanTrack(
        name=name, time=numbers[:, 0], position=numbers[:, 1:3], velocity=numbers[:, 3:5],
        heading=numbers[:, 5],
        posture=np.array([POSTURE_VALUE[r["posture"]] for r in rows], dtype=np.int8),
        status=np.array([r["status"] for r in rows], dtype=np.str_),
        fsm_state=np.array([r["fsm_state"] for r in rows], dtype=np.str_),
        task_id=np.array([r["task"]["id"] if r["task"] else 0 for r in rows], dtype=np.int64))


def _crowd_tracks(messages: list[dict[str, Any]]) -> dict[str, HumanTrack]:
    """Each member's track from crowd state messages (parallel arrays, one per frame)."""
    names = np.array([name for m in messages for name in m["names"]], dtype=np.str_)
    if not len(names):
        return {}
    time = np.repeat([_seconds(m["timestamp"]) for m in messages],
                     [len(m["names"]) for m in messages])
    numbers = np.array([[value for m in messages for value in m[key]]
                        for key in ("x", "y", "vx", "vy", "heading")], dtype=np.float64).T
    posture = np.array([POSTURE_VALUE[p] for m in messages for p in m["posture"]],
                       dtype=np.int8)
    status = np.array([v for m in messages for v in m["status"]], dtype=np.str_)
    fsm_state = np.array([v for m in messages for v in m["fsm_state"]], dtype=np.str_)
    task_id = np.array([v for m in messages for v in m["task_id"]], dtype=np.int64)
    order = np.argsort(names, kind="stable")  # each member's rows together, in time order
    ordered = names[order]
    starts = np.flatnonzero(np.r_[True, ordered[1:] != ordered[:-1]])
    tracks = {}
    for rows in np.split(order, starts[1:]):
        name = str(names[rows[0]])
        tracks[name] = HumanTrack(
            name=name, time=time[rows], position=numbers[rows, 0:2],
            velocity=numbers[rows, 2:4], heading=numbers[rows, 4], posture=posture[rows],
            status=status[rows], fsm_state=fsm_state[rows], task_id=task_id[rows])
    return tracks


def _task_event(value: dict[str, Any]) -> TaskEvent:
    span = None
    if value["line"] > 0:
        span = Span(value["file"], value["line"], value["column"], value["end_line"],
                    value["end_column"])
    return TaskEvent(tick=int(value["tick"]), time=_seconds(value["timestamp"]),
                     task_id=int(value["task_id"]), human=value["human"], kind=value["kind"],
                     status=TaskStatus(value["status"]), reason=value["reason"], span=span)
