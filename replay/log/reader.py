"""Stream a log's images, poses and ground truth in log-time order.

:class:`LogReader` opens an MCAP file, checks it, and yields frozen records
(:class:`ImageMessage`, :class:`PoseMessage`, :class:`TruthMessage`) one at a time, so memory
stays flat however long the log is.

Checks (:mod:`replay.log.catalogue`): the data section is scanned record by record with every
length bounded (:class:`~replay.log.mcap_records.Limits`); chunk, data and summary CRCs are
verified; the summary must agree with the data (chunk and metadata index entries, channels,
statistics). Any valid MCAP layout reads the same: chunked or not, any compression, with or
without indexes, statistics, summary offsets or repeated channels and schemas; metadata is
found by the scan, not only through its index.

Order: ascending ``log_time``; equal ``log_time`` keeps file order (chunk offset, then
position in the chunk). Only the topics replay needs are decoded. A message that does not
decode, or decodes to a pose with a non-finite value or a zero quaternion or an empty image,
is skipped and counted (:attr:`LogReader.bad_messages`).

Strict (default): damage raises a :class:`~replay.errors.ReplayError` naming the file and
byte. ``recover=True`` reads every intact chunk and the complete messages of an unchunked
tail; :attr:`LogReader.loss` says exactly what was lost (chunks, messages, sim-time ranges).
"""

from __future__ import annotations

import heapq
import os
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any

from mcap.records import Channel, Message
from mcap_ros2.decoder import DecoderFactory

from dsp import contract
from dsp import metadata as meta
from dsp.text import printable
from estimator.constants import NS_PER_S
from replay.errors import (
    CorruptLogError,
    MissingPosesError,
    NoFramesError,
    NoImageTopicsError,
    NoPoseTopicError,
    SchemaError,
)
from replay.log.catalogue import (
    Catalogue,
    build_catalogue,
    check_definition,
    check_mcap_file,
    load_block,
    nothing_recovered,
    read_all_blocks,
)
from replay.log.mcap_records import Limits, Malformed
from replay.log.mcap_scan import Block
from replay.log.messages import BadMessage, ImageMessage, PoseMessage, TruthMessage, convert
from replay.log.recovery import RecoveryLoss
from replay.log.schemas import definition_mismatch
from replay.log.stamps import FAR_NS, StampGate

__all__ = ["LogInfo", "LogReader"]

GT_ODOMETRY = contract.GT_BALL_ODOMETRY_TOPIC
Record = ImageMessage | PoseMessage | TruthMessage


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


class LogReader:
    """Context manager reading one log, with keyword-only options.

    For example::

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
        limits: Limits | None = None,
    ) -> None:
        self.path = Path(path)
        self._image_pattern = image_topic
        self._pose_pattern = pose_topic
        self._truth_topic = truth_topic
        self._robots_wanted = tuple(robots) if robots else None
        self.recover = recover
        self._validate = validate_crcs
        self.limits = limits or Limits()
        self._file: IO[bytes] | None = None
        self._decoders = DecoderFactory()
        self._wanted: dict[int, tuple[str, str, Callable[[bytes], Any]]] = {}
        self.catalogue: Catalogue
        self.loss = RecoveryLoss()
        self.bad_messages: dict[str, int] = {}
        """Skipped messages by reason ("undecodable", "bad pose: zero quaternion", ...)."""
        self.info: LogInfo

    @property
    def undecodable(self) -> int:
        """Messages skipped (every reason)."""
        return sum(self.bad_messages.values())

    # --- opening ---------------------------------------------------------------------------
    def __enter__(self) -> LogReader:
        size = check_mcap_file(self.path)
        self._file = self.path.open("rb")
        try:
            self.catalogue = build_catalogue(self._file, self.path, size, self.limits,
                                             recover=self.recover,
                                             validate_crcs=self._validate)
            cat = self.catalogue
            if self.recover:
                blocks = cat.blocks
                self.loss = RecoveryLoss.from_damage(
                    size, cat.damage, cat.problems,
                    max((b.end_ns for b in blocks), default=None), cat.salvaged)
                if not blocks and cat.damage:
                    raise NoFramesError(self.path, "nothing is recoverable: "
                                        + nothing_recovered(cat))
            try:
                self.info = self._make_info()
            except (NoImageTopicsError, MissingPosesError) as err:
                if self.recover and cat.damage:  # the damage says it better
                    raise NoFramesError(self.path, f"{err} in the readable part; the rest "
                                        f"is lost ({cat.damage[0].reason})") from err
                if not cat.chunks_checked:  # a damaged summary would say it better
                    read_all_blocks(self._file, cat, self.limits, recover=False,
                                    validate_crcs=self._validate)
                raise
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

    def _make_info(self) -> LogInfo:
        cat = self.catalogue
        topics = {ch.topic for ch in cat.channels.values()}
        matched = contract.robot_names_in(topics, self._image_pattern)
        image_robots = matched
        if self._robots_wanted is not None:
            image_robots = [r for r in image_robots if r in self._robots_wanted]
        if not image_robots:
            raise NoImageTopicsError(
                self.path, self._image_pattern, list(self._robots_wanted or []), topics=topics,
                given=self._image_pattern != contract.IMAGE_TOPIC, matched=matched)
        pose_robots = set(contract.robot_names_in(topics, self._pose_pattern))
        missing = [r for r in image_robots if r not in pose_robots]
        if missing and self.recover and cat.damage and len(missing) < len(image_robots):
            # what the damage left of a robot: its images without a pose topic to pair with
            image_robots = [r for r in image_robots if r in pose_robots]
            self.loss.problems.append(
                f"no pose topic {printable(self._pose_pattern, limit=120)!r} in the readable "
                f"part for {', '.join(printable(r, limit=60) for r in missing)}: their "
                "images are left out")
        elif missing:
            raise NoPoseTopicError(self.path, self._pose_pattern, missing, topics=topics,
                                   given=self._pose_pattern != contract.POSE_TOPIC)
        image_topics = {r: contract.topic_for(self._image_pattern, r) for r in image_robots}
        pose_topics = {r: contract.topic_for(self._pose_pattern, r) for r in image_robots}
        kinds: dict[str, tuple[str, str]] = {t: ("image", r) for r, t in image_topics.items()}
        kinds.update({t: ("pose", r) for r, t in pose_topics.items()})
        if self._truth_topic == contract.GT_BALL_TOPIC and GT_ODOMETRY in topics:
            self._truth_topic = GT_ODOMETRY  # the same truth with the ball's velocity
        has_truth = self._truth_topic in topics
        if has_truth:
            kinds[self._truth_topic] = ("truth", "")
        for cid, channel in sorted(cat.channels.items()):
            if channel.topic in kinds:
                kind, robot = kinds[channel.topic]
                self._wanted[cid] = (kind, robot, self._decoder(channel))
        count = None
        if cat.counts is not None:
            count = sum(n for cid, n in cat.counts.items() if cid in self._wanted)
        blocks = cat.blocks
        scenario, cameras, recorder = self._parse_metadata()
        self._check_cameras(image_robots, cameras, recorder)
        return LogInfo(
            path=self.path,
            robots=tuple(image_robots),
            image_topics=image_topics,
            pose_topics=pose_topics,
            has_truth=has_truth,
            message_count=count,
            metadata=dict(cat.metadata),
            start_ns=min((b.start_ns for b in blocks), default=None),
            end_ns=max((b.end_ns for b in blocks), default=None),
            scenario=scenario,
            cameras=cameras,
            recorder=recorder,
        )

    def _decoder(self, channel: Channel) -> Callable[[bytes], Any]:
        schema = self.catalogue.schemas.get(channel.schema_id)
        what = f"topic {printable(channel.topic, limit=120)}"
        if schema is None:
            raise SchemaError(self.path, what, f"schema {channel.schema_id} is not in the log")
        if schema.encoding == "ros2msg":
            mismatch = definition_mismatch(schema.name, schema.data.decode("utf-8", "replace"))
            if mismatch is not None:
                raise SchemaError(self.path, what, f"{schema.name}: {mismatch}")
        try:
            decoder = self._decoders.decoder_for(channel.message_encoding, schema)
        except Exception as err:  # the ROS 2 message parser raises many kinds on bad text
            raise SchemaError(self.path, what, f"{type(err).__name__}: {err}") from err
        if decoder is None:
            raise SchemaError(self.path, what, "no decoder for message encoding "
                              f"{printable(channel.message_encoding, limit=120)!r}")
        return decoder

    def _parse_metadata(self) -> tuple[meta.ScenarioMetadata | None,
                                       meta.CamerasMetadata, meta.RecorderMetadata | None]:
        """The dsp.* metadata records, typed (parse at the boundary): one that is there but
        unreadable raises :class:`dsp.metadata.MetadataError` naming the log."""
        records = self.catalogue.metadata
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

    def _check_cameras(self, robots: list[str], cameras: meta.CamerasMetadata,
                       recorder: object) -> None:
        """A log written by dsp-record names every robot's camera: one it lacks is damaged
        metadata, an error. Another writer's log may name none (a robot's own log): the
        replay then needs a camera description from its options (replay.cameras), and says
        so rather than guessing one."""
        have = cameras.by_robot()
        missing = [printable(r, limit=120) for r in robots if r not in have]
        if missing and recorder is not None:
            raise meta.MetadataError(
                f"{self.path}: metadata {contract.CAMERAS_METADATA} has no camera for "
                f"{', '.join(missing)} although the log was written by dsp-record "
                "(damaged metadata?)")

    # --- streaming -------------------------------------------------------------------------
    def messages(
        self, *, start_ns: int | None = None
    ) -> Iterator[ImageMessage | PoseMessage | TruthMessage]:
        """Decoded records in log-time order (from ``start_ns`` on, when given). A message
        that does not decode, holds bad values or is stamped absurdly far from the rest of
        the log (:mod:`replay.log.stamps`) is counted in :attr:`bad_messages`."""
        gate: StampGate[Record] = StampGate(self._absurd)
        return gate.filter(self._decoded(start_ns))

    def _decoded(self, start_ns: int | None) -> Iterator[tuple[str, int, Record]]:
        """(stream, stamp, record) of every message that decodes to a usable record."""
        for message in self._merged(start_ns):
            kind, robot, decoder = self._wanted[message.channel_id]
            try:
                record = convert(kind, robot, decoder(message.data), message)
            except BadMessage as bad:
                self._count(f"bad {kind}: {bad.reason}")
                continue
            except Exception:
                self._count(f"undecodable {kind}")
                continue
            yield f"{kind} {robot}", record.stamp_ns, record

    def _absurd(self, record: Record) -> None:
        kind = "image" if isinstance(record, ImageMessage) else (
            "pose" if isinstance(record, PoseMessage) else "truth")
        self._count(f"bad {kind}: stamp over {FAR_NS // NS_PER_S} s away from the rest of the log")

    def _count(self, reason: str) -> None:
        self.bad_messages[reason] = self.bad_messages.get(reason, 0) + 1

    def _merged(self, start_ns: int | None) -> Iterator[Message]:
        """Wanted messages of every block, merged by (log time, block offset, position)."""
        blocks = sorted((b for b in self.catalogue.blocks
                         if start_ns is None or b.end_ns >= start_ns),
                        key=lambda b: (b.start_ns, b.offset))
        heap: list[tuple[int, int, int, list[Message]]] = []
        held: dict[int, int] = {}  # open block offset -> bytes of its messages
        budget = 2 * self.limits.max_chunk_bytes
        i = 0
        while i < len(blocks) or heap:
            # open every block that could hold the next message: (start, offset) before it
            while i < len(blocks) and (
                    not heap or (blocks[i].start_ns, blocks[i].offset) < heap[0][:2]):
                msgs = self._load(blocks[i], start_ns)
                if msgs:
                    heapq.heappush(heap, (msgs[0].log_time, blocks[i].offset, 0, msgs))
                    held[blocks[i].offset] = sum(len(m.data) for m in msgs)
                    if sum(held.values()) > budget:
                        raise CorruptLogError(self.path, f"{len(held)} chunks overlap in "
                                              "time by more than the memory limit allows "
                                              "(raise --max-chunk-mib)")
                i += 1
            if not heap:
                continue
            _t, offset, j, msgs = heapq.heappop(heap)
            yield msgs[j]
            if j + 1 < len(msgs):
                heapq.heappush(heap, (msgs[j + 1].log_time, offset, j + 1, msgs))
            else:
                held.pop(offset, None)

    def _load(self, block: Block, start_ns: int | None) -> list[Message]:
        """The wanted messages of one block, sorted stably by log time."""
        assert self._file is not None
        try:
            records = load_block(self._file, block, self.limits, validate_crcs=self._validate)
            out: list[Message] = []
            for rec in records:
                if isinstance(rec, Message):
                    if rec.channel_id in self._wanted and (
                            start_ns is None or rec.log_time >= start_ns):
                        out.append(rec)
                elif not self.catalogue.chunks_checked:
                    check_definition(self.catalogue, rec, block)
        except Malformed as err:
            # the catalogue checked (recover: dropped) every block already when it read them
            raise CorruptLogError(self.path, f"block at byte {block.offset}: {err}") from err
        out.sort(key=lambda m: m.log_time)
        return out
