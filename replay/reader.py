"""Stream a log's images, poses and ground truth in log-time order.

:class:`LogReader` opens an MCAP file, checks it (magic, summary, topics), and yields frozen
records (:class:`ImageMessage`, :class:`PoseMessage`, :class:`TruthMessage`) one at a time,
so memory stays flat however long the log is.

Order: ascending ``log_time``; messages with equal ``log_time`` keep their file order (mcap's
indexed reader breaks ties by chunk offset, then position in the chunk; the recovery reader
sorts each chunk stably). Only the topics replay needs are decoded.

``recover=True`` reads the file front to back with mcap's :class:`~mcap.stream_reader.StreamReader`
and stops at the first incomplete record, so a truncated log replays every complete chunk;
damaged chunks are skipped and counted. :attr:`LogReader.loss` says what was lost.
"""

from __future__ import annotations

import os
import struct
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any

from mcap.exceptions import McapError
from mcap.reader import SeekingReader
from mcap.records import Channel, Chunk, Message, Metadata, Schema
from mcap.stream_reader import MAGIC_SIZE, StreamReader, breakup_chunk
from mcap_ros2.decoder import DecoderFactory

from dsp import contract
from dsp import metadata as meta
from replay.errors import (
    CorruptLogError,
    InputNotFoundError,
    MissingPosesError,
    NoImageTopicsError,
    NotMcapError,
    TruncatedLogError,
)

__all__ = ["ImageMessage", "LogInfo", "LogReader", "PoseMessage", "RecoveryLoss",
           "TruthMessage"]

_MCAP_MAGIC = b"\x89MCAP0\r\n"
GT_ODOMETRY = contract.GT_BALL_ODOMETRY_TOPIC

# Errors mcap (and its decompressors) raise on damaged bytes. lz4 raises RuntimeError.
_READ_ERRORS: tuple[type[BaseException], ...] = (
    McapError,
    ValueError,
    struct.error,
    EOFError,
    RuntimeError,
)
try:  # zstandard is optional in mcap
    import zstandard as _zstd

    _READ_ERRORS = (*_READ_ERRORS, _zstd.ZstdError)
except ImportError:  # pragma: no cover
    pass

# ... and what a message that decodes to an unexpected shape raises in _convert.
_DECODE_ERRORS: tuple[type[BaseException], ...] = (*_READ_ERRORS, AttributeError, TypeError,
                                                   IndexError, KeyError)


@dataclass(frozen=True)
class ImageMessage:
    """One camera image. ``data`` is the compressed bytes (``fmt`` "png"/"jpeg"/...) or the
    raw pixel buffer (``fmt`` "raw", with ``encoding``, ``width_px``, ``height_px``, ``step``)."""

    robot: str
    stamp_ns: int
    log_time_ns: int
    fmt: str
    data: bytes
    encoding: str = ""
    width_px: int = 0
    height_px: int = 0
    step: int = 0


@dataclass(frozen=True)
class PoseMessage:
    """A robot's pose in the field frame: position in metres, quaternion (x, y, z, w)."""

    robot: str
    stamp_ns: int
    x_m: float
    y_m: float
    qx: float
    qy: float
    qz: float
    qw: float


@dataclass(frozen=True)
class TruthMessage:
    """The ball's true position [m], velocity [m/s] from Odometry, field frame (evaluation)."""

    stamp_ns: int
    x_m: float
    y_m: float
    vx_m_s: float | None = None
    vy_m_s: float | None = None


@dataclass(frozen=True)
class LogInfo:
    """What the log holds, known before streaming."""

    path: Path
    robots: tuple[str, ...]
    image_topics: dict[str, str]
    pose_topics: dict[str, str]
    has_truth: bool
    message_count: int | None
    """Messages on the topics replay reads (from the summary), None when unknown."""
    metadata: dict[str, dict[str, str]]
    """Every metadata record as written: name -> {key: value}."""
    start_ns: int | None
    end_ns: int | None
    scenario: meta.ScenarioMetadata | None = None
    """The ``dsp.scenario`` record, parsed; None when the log has none (e.g. a robot's log)."""
    cameras: meta.CamerasMetadata = field(default_factory=meta.CamerasMetadata)
    """The ``dsp.cameras`` record, parsed; no cameras when the log has none."""
    recorder: meta.RecorderMetadata | None = None
    """The ``dsp.recorder`` record, parsed; None when the log has none."""


@dataclass
class RecoveryLoss:
    """What ``recover=True`` could not read."""

    file_bytes: int = 0
    read_bytes: int = 0
    bad_chunks: int = 0
    truncated: bool = False
    detail: str = ""

    @property
    def lost_bytes(self) -> int:
        return self.file_bytes - self.read_bytes


@dataclass
class _Catalogue:
    schemas: dict[int, Schema] = field(default_factory=dict)
    channels: dict[int, Channel] = field(default_factory=dict)
    metadata: dict[str, dict[str, str]] = field(default_factory=dict)
    counts: dict[int, int] | None = None
    start_ns: int | None = None
    end_ns: int | None = None


def _check_file(path: Path) -> None:
    if not path.is_file():
        raise InputNotFoundError(path)
    with path.open("rb") as f:
        head = f.read(MAGIC_SIZE)
    if head != _MCAP_MAGIC:
        raise NotMcapError(path)


class LogReader:
    """Context manager reading one log. Keyword-only options::

        with LogReader(path, robots=["robot1"]) as log:
            print(log.info.robots)
            for msg in log.messages():
                ...
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        *,
        image_topic: str = contract.IMAGE_TOPIC,
        pose_topic: str = contract.POSE_TOPIC,
        truth_topic: str = contract.GT_BALL_TOPIC,
        robots: list[str] | tuple[str, ...] | None = None,
        recover: bool = False,
        validate_crcs: bool = True,
    ) -> None:
        self.path = Path(path)
        self._image_pattern = image_topic
        self._pose_pattern = pose_topic
        self._truth_topic = truth_topic
        self._robots_wanted = tuple(robots) if robots else None
        self._recover = self.recover = recover
        self._validate = validate_crcs
        self._file: IO[bytes] | None = None
        self._cat = _Catalogue()
        self._decoders = DecoderFactory()
        self.loss = RecoveryLoss()
        self.undecodable: int = 0
        self.info: LogInfo

    # --- opening ---------------------------------------------------------------------------
    def __enter__(self) -> LogReader:
        _check_file(self.path)
        self._file = self.path.open("rb")
        try:
            if self._recover:
                self._catalogue_by_streaming()
            else:
                self._catalogue_from_summary()
            self.info = self._make_info()
        except BaseException:
            self.close()
            raise
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        if self._file is not None:
            self._file.close()
            self._file = None

    def _catalogue_from_summary(self) -> None:
        assert self._file is not None
        try:
            reader = SeekingReader(self._file, validate_crcs=self._validate)
            summary = reader.get_summary()
        except _READ_ERRORS as err:
            raise TruncatedLogError(self.path, "no readable footer or summary") from err
        if summary is None:
            # A valid but unindexed log: catalogue it by streaming (no loss is tolerated).
            self._catalogue_by_streaming(strict=True)
            return
        self._reader = reader
        self._cat.schemas = dict(summary.schemas)
        self._cat.channels = dict(summary.channels)
        if summary.statistics is not None:
            self._cat.counts = dict(summary.statistics.channel_message_counts)
            if summary.statistics.message_count:
                self._cat.start_ns = summary.statistics.message_start_time
                self._cat.end_ns = summary.statistics.message_end_time
        try:
            for record in reader.iter_metadata():
                self._cat.metadata[record.name] = dict(record.metadata)
        except _READ_ERRORS as err:
            raise CorruptLogError(self.path, f"metadata: {_short(err)}") from err

    def _catalogue_by_streaming(self, *, strict: bool = False) -> None:
        """One pass over the file collecting schemas, channels, metadata and message counts,
        stopping at the first incomplete record (and noting the loss)."""
        assert self._file is not None
        self.loss.file_bytes = self.path.stat().st_size
        counts: dict[int, int] = {}
        for item in self._stream_records(strict=strict, catalogue_only=True):
            if isinstance(item, Message):
                counts[item.channel_id] = counts.get(item.channel_id, 0) + 1
        self._cat.counts = counts

    def _stream_records(self, *, strict: bool, catalogue_only: bool) -> Iterator[Any]:
        """Records of the file in file order; the messages of each chunk sorted stably by
        log time. Schemas, channels and metadata go to the catalogue as they pass."""
        assert self._file is not None
        self._file.seek(0)
        stream = StreamReader(self._file, emit_chunks=True, validate_crcs=False)
        records = stream.records
        cat = self._cat
        while True:
            try:
                record = next(records)
            except StopIteration:
                return
            except _READ_ERRORS as err:
                if strict:
                    raise TruncatedLogError(self.path, _short(err)) from err
                self.loss.truncated = True
                self.loss.detail = _short(err)
                return
            self.loss.read_bytes = self._file.tell()
            if isinstance(record, Schema):
                cat.schemas[record.id] = record
            elif isinstance(record, Channel):
                cat.channels[record.id] = record
            elif isinstance(record, Metadata):
                cat.metadata[record.name] = dict(record.metadata)
            elif isinstance(record, Message):
                yield record
            elif isinstance(record, Chunk):
                try:
                    inner = breakup_chunk(record, validate_crc=self._validate)
                except _READ_ERRORS as err:
                    if strict:
                        raise CorruptLogError(self.path, _short(err)) from err
                    if catalogue_only:
                        self.loss.bad_chunks += 1
                    continue
                messages: list[Message] = []
                for rec in inner:
                    if isinstance(rec, Schema):
                        cat.schemas[rec.id] = rec
                    elif isinstance(rec, Channel):
                        cat.channels[rec.id] = rec
                    elif isinstance(rec, Message):
                        messages.append(rec)
                messages.sort(key=lambda m: m.log_time)  # stable: equal times keep file order
                yield from messages

    def _make_info(self) -> LogInfo:
        topics = {ch.topic for ch in self._cat.channels.values()}
        image_robots = contract.robot_names_in(topics, self._image_pattern)
        if self._robots_wanted is not None:
            image_robots = [r for r in image_robots if r in self._robots_wanted]
        if not image_robots:
            raise NoImageTopicsError(
                self.path, self._image_pattern, list(self._robots_wanted or [])
            )
        pose_robots = set(contract.robot_names_in(topics, self._pose_pattern))
        missing = [r for r in image_robots if r not in pose_robots]
        if missing:
            raise MissingPosesError(
                self.path,
                f"no pose topic {self._pose_pattern!r} for {', '.join(missing)}",
            )
        image_topics = {r: contract.topic_for(self._image_pattern, r) for r in image_robots}
        pose_topics = {r: contract.topic_for(self._pose_pattern, r) for r in image_robots}
        self._topic_kind: dict[str, tuple[str, str]] = {}
        for r, t in image_topics.items():
            self._topic_kind[t] = ("image", r)
        for r, t in pose_topics.items():
            self._topic_kind[t] = ("pose", r)
        if self._truth_topic == contract.GT_BALL_TOPIC and GT_ODOMETRY in topics:
            self._truth_topic = GT_ODOMETRY  # the same truth with the ball's velocity
        has_truth = self._truth_topic in topics
        if has_truth:
            self._topic_kind[self._truth_topic] = ("truth", "")
        count = None
        if self._cat.counts is not None:
            count = sum(
                n
                for cid, n in self._cat.counts.items()
                if cid in self._cat.channels and self._cat.channels[cid].topic in self._topic_kind
            )
        scenario, cameras, recorder = self._parse_metadata()
        return LogInfo(
            path=self.path,
            robots=tuple(image_robots),
            image_topics=image_topics,
            pose_topics=pose_topics,
            has_truth=has_truth,
            message_count=count,
            metadata=dict(self._cat.metadata),
            start_ns=self._cat.start_ns,
            end_ns=self._cat.end_ns,
            scenario=scenario,
            cameras=cameras,
            recorder=recorder,
        )

    def _parse_metadata(self) -> tuple[meta.ScenarioMetadata | None,
                                       meta.CamerasMetadata, meta.RecorderMetadata | None]:
        """The dsp.* metadata records, typed (parse at the boundary): one that is there but
        unreadable raises :class:`dsp.metadata.MetadataError` naming the log."""
        records = self._cat.metadata
        scenario, recorder = (records.get(contract.SCENARIO_METADATA),
                              records.get(contract.RECORDER_METADATA))
        try:
            return (
                None if scenario is None else meta.ScenarioMetadata.from_metadata(scenario),
                meta.CamerasMetadata.from_metadata(records.get(contract.CAMERAS_METADATA, {})),
                None if recorder is None else meta.RecorderMetadata.from_metadata(recorder),
            )
        except meta.MetadataError as err:
            raise meta.MetadataError(f"{self.path}: metadata {err}") from err

    # --- streaming -------------------------------------------------------------------------
    def messages(
        self, *, start_ns: int | None = None
    ) -> Iterator[ImageMessage | PoseMessage | TruthMessage]:
        """Decoded records in log-time order (from ``start_ns`` on, when given). A message
        that does not decode is counted in :attr:`undecodable` and skipped."""
        topics = list(self._topic_kind)
        if self._recover or not hasattr(self, "_reader"):
            raw: Iterator[tuple[Channel, Message]] = (
                (self._cat.channels[m.channel_id], m)
                for m in self._stream_records(strict=not self._recover, catalogue_only=False)
                if m.channel_id in self._cat.channels
                and self._cat.channels[m.channel_id].topic in self._topic_kind
                and (start_ns is None or m.log_time >= start_ns)
            )
        else:
            raw = self._indexed(topics, start_ns)
        for channel, message in raw:
            kind, robot = self._topic_kind[channel.topic]
            try:
                record = _convert(kind, robot, self._decode(channel, message), message)
            except _DECODE_ERRORS:
                self.undecodable += 1
                continue
            yield record

    def _indexed(
        self, topics: list[str], start_ns: int | None
    ) -> Iterator[tuple[Channel, Message]]:
        it = self._reader.iter_messages(topics, log_time_order=True, starting_at=start_ns)
        while True:
            try:
                _schema, channel, message = next(it)
            except StopIteration:
                return
            except _READ_ERRORS as err:
                raise CorruptLogError(self.path, _short(err)) from err
            yield channel, message

    def _decode(self, channel: Channel, message: Message) -> Any:
        schema = self._cat.schemas.get(channel.schema_id)
        decoder = self._decoders.decoder_for(channel.message_encoding, schema)
        if decoder is None:
            raise McapError(f"no decoder for {channel.topic} ({channel.message_encoding})")
        return decoder(message.data)


def _convert(
    kind: str, robot: str, msg: Any, record: Message
) -> ImageMessage | PoseMessage | TruthMessage:
    stamp = contract.stamp_to_ns(msg.header.stamp)
    if kind == "pose":
        pose = msg.pose
        if hasattr(pose, "pose"):  # PoseWithCovarianceStamped (AMCL), nav_msgs/Odometry
            pose = pose.pose
        p, q = pose.position, pose.orientation
        return PoseMessage(robot, stamp, float(p.x), float(p.y), float(q.x), float(q.y),
                           float(q.z), float(q.w))
    if kind == "truth":
        if hasattr(msg, "twist"):  # nav_msgs/Odometry: the true position and velocity
            p, v = msg.pose.pose.position, msg.twist.twist.linear
            return TruthMessage(stamp, float(p.x), float(p.y), float(v.x), float(v.y))
        p = msg.pose.position if hasattr(msg, "pose") else msg.point
        return TruthMessage(stamp, float(p.x), float(p.y))
    if hasattr(msg, "format"):  # sensor_msgs/CompressedImage
        fmt = str(msg.format).lower()
        fmt = "jpeg" if ("jpeg" in fmt or "jpg" in fmt) else ("png" if "png" in fmt else fmt)
        return ImageMessage(robot, stamp, record.log_time, fmt, bytes(msg.data))
    return ImageMessage(  # sensor_msgs/Image
        robot, stamp, record.log_time, "raw", bytes(msg.data), encoding=str(msg.encoding),
        width_px=int(msg.width), height_px=int(msg.height), step=int(msg.step),
    )


def _short(err: BaseException) -> str:
    text = str(err).strip().splitlines()[0] if str(err).strip() else ""
    return f"{type(err).__name__}: {text}" if text else type(err).__name__
