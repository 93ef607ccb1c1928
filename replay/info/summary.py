"""What a log holds, like ``ros2 bag info`` / ``mcap info``, and whether it is intact.

:func:`log_info` reads the catalogue (:mod:`replay.log.catalogue`) of any MCAP file, whatever its
topics, and returns a :class:`LogSummary`: duration, start and end, topics with their types,
counts and rates, the robots (named by the topics: a foreign log's too, with the
``--image-topic`` / ``--pose-topic`` patterns that replay it, :mod:`dsp.topics`), scenario,
each camera's description and renderer from the metadata, chunks and compression.
What the log allows of the default pipeline (the line fit, the 3-D track) and what the rest
needs is said by the rules the replay decides with (:func:`replay.profiles.allowances`).
``check=True`` reads every chunk too: chunk and data CRCs, the summary's CRC and whether it
agrees with the data; the problems found are listed (none: the log is intact).
"""

from __future__ import annotations

import json
from collections import Counter
from dataclasses import asdict, dataclass, field
from pathlib import Path

from dsp import contract, jsonio
from dsp import metadata as meta
from dsp.jsonio import Json
from dsp.text import format_bytes, printable
from dsp.topics import infer_patterns
from estimator.constants import NS_PER_S
from replay.log import Catalogue, Limits, build_catalogue, check_mcap_file, read_all_blocks
from replay.log.catalogue import nothing_recovered
from replay.profiles import allowances

__all__ = ["LogSummary", "TopicInfo", "format_info", "log_info"]


def _shown(text: object, limit: int = 120) -> str:
    """A name from the log for a terminal: escaped, cut to ``limit`` characters."""
    return printable(text, limit=limit)

@dataclass(frozen=True)
class TopicInfo:
    topic: str
    type: str
    messages: int | None
    rate_hz: float | None


@dataclass
class LogSummary:
    """A log at a glance (sim time in seconds from the log's own clock)."""

    path: str
    bytes: int
    profile: str | None
    start_s: float | None
    end_s: float | None
    duration_s: float | None
    messages: int | None
    topics: list[TopicInfo]
    robots: list[str]
    scenario: dict[str, Json] | None
    cameras: dict[str, str]
    """robot -> camera model name"""
    renderer: str | None
    chunks: int
    compression: dict[str, int]
    """compression ("none" for uncompressed) -> chunks"""
    chunk_bytes: int
    uncompressed_bytes: int
    metadata: list[str]
    summary: str
    """"indexed" (a summary with chunk indexes), "summary", or "none"."""
    checked: bool = False
    problems: list[str] = field(default_factory=list)
    salvaged: list[str] = field(default_factory=list)
    """``check``: what was kept of each cut or damaged chunk (what ``--recover`` replays)."""
    recoverable: str | None = None
    """``check`` of a damaged log: what ``--recover`` keeps, or why it keeps nothing, in
    terms of the log."""
    image_topic: str | None = None
    """The image topic pattern the robots were found by (:mod:`dsp.topics`)."""
    pose_topic: str | None = None
    """The pose topic pattern that names the same robots, when one does."""
    camera_descriptions: dict[str, str] = field(default_factory=dict)
    """robot -> its camera description in one line (:meth:`dsp.cameras.CameraSpec.describe`)"""
    default_pipeline: list[str] = field(default_factory=list)
    """What the log allows of the default pipeline, one line per part, by the rules the
    replay decides with (:func:`replay.profiles.allowances`), and whether it states its
    poses' covariance; empty when it has no robots."""

    def to_json(self) -> str:
        return json.dumps(asdict(self), indent=1, sort_keys=True, allow_nan=False) + "\n"


def log_info(path: Path | str, *, check: bool = False, limits: Limits | None = None
             ) -> LogSummary:
    """Summarise the log at ``path``; ``check``: read and check everything, list problems
    instead of raising. Raises :class:`~replay.errors.ReplayError` for a file that is not
    MCAP, and (without ``check``) for a damaged one."""
    path = Path(path)
    size = check_mcap_file(path)
    limits = limits or Limits()
    with path.open("rb") as f:
        cat = build_catalogue(f, path, size, limits, recover=check, read_chunks=check)
        if cat.counts is None:
            read_all_blocks(f, cat, limits, recover=False, validate_crcs=True)
    return _summarise(cat, check)


def _recoverable(cat: Catalogue) -> str:
    """A damaged log's verdict: the messages ``--recover`` keeps, or why there are none."""
    kept = sum((cat.counts or {}).values())
    if not kept:
        return _shown(f"nothing is recoverable: {nothing_recovered(cat)}", limit=400)
    blocks = cat.blocks
    span = (f", sim time {min(b.start_ns for b in blocks) / NS_PER_S:.3f}.."
            f"{max(b.end_ns for b in blocks) / NS_PER_S:.3f} s" if blocks else "")
    return f"--recover keeps {kept} message(s){span}"


def _summarise(cat: Catalogue, check: bool) -> LogSummary:
    blocks = cat.blocks
    start = min((b.start_ns for b in blocks), default=None)
    end = max((b.end_ns for b in blocks), default=None)
    duration = None if start is None or end is None else (end - start) / NS_PER_S
    counts = cat.counts or {}
    topics = []
    for cid, ch in sorted(cat.channels.items(), key=lambda kv: kv[1].topic):
        schema = cat.schemas.get(ch.schema_id)
        n = counts.get(cid) if cat.counts is not None else None
        rate = n / duration if n is not None and duration else None
        topics.append(TopicInfo(_shown(ch.topic), _shown(schema.name) if schema else "",
                                n, None if rate is None else round(rate, 3)))
    types = {ch.topic: (cat.schemas[ch.schema_id].name if ch.schema_id in cat.schemas else "")
             for ch in cat.channels.values()}
    patterns = infer_patterns(types)
    robots = [] if patterns is None else [_shown(r) for r in patterns.robots]
    scenario, cameras, renderer = _metadata(cat)
    descriptions, camera_robots = _descriptions(cat)
    chunks = cat.scan.chunks
    summary = "none" if cat.summary is None else (
        "indexed" if cat.summary.chunk_indexes else "summary")
    problems = [*cat.problems, *(d.reason for d in cat.damage)] if check else []
    return LogSummary(
        path=str(cat.path), bytes=cat.size, profile=cat.scan.profile,
        start_s=None if start is None else start / NS_PER_S,
        end_s=None if end is None else end / NS_PER_S, duration_s=duration,
        messages=sum(counts.values()) if cat.counts is not None else None,
        topics=topics, robots=robots, scenario=scenario, cameras=cameras, renderer=renderer,
        chunks=len(chunks),
        compression=dict(Counter(c.compression or "none" for c in chunks)),
        chunk_bytes=sum(c.data_length for c in chunks),
        uncompressed_bytes=sum(c.uncompressed_size for c in chunks),
        metadata=sorted(_shown(n) for n in cat.metadata), summary=summary, checked=check,
        problems=[_shown(p, limit=300) for p in problems],
        salvaged=[_shown(s.describe().strip(), limit=400) for s in cat.salvaged] if check
        else [],
        recoverable=_recoverable(cat) if problems else None,
        image_topic=None if patterns is None else _shown(patterns.image_topic),
        pose_topic=None if patterns is None or patterns.pose_topic is None
        else _shown(patterns.pose_topic),
        camera_descriptions=descriptions,
        default_pipeline=[] if patterns is None else _default_pipeline(
            cat, robots, camera_robots, types, patterns.pose_topic),
    )


def _default_pipeline(cat: Catalogue, robots: list[str], camera_robots: list[str],
                      types: dict[str, str], pose_topic: str | None) -> list[str]:
    """The parts of the default pipeline the log allows, and what the rest needs."""
    scenario = cat.metadata.get(contract.SCENARIO_METADATA)
    field_name = None
    if scenario is not None:
        try:
            field_name = meta.ScenarioMetadata.from_metadata(scenario).field.name
        except meta.MetadataError:
            pass  # reported in the scenario line
    line_fit, track = allowances(field=field_name, robots=robots, camera_robots=camera_robots)
    lines = [line_fit.describe(), track.describe()]
    if not line_fit.allowed:
        lines.append("poses: each robot's bias corrected from the ball (how it disagrees with "
                     "the other robots')" if len(robots) >= 2 else
                     "poses: the believed ones (one robot: no other ball to compare with)")
    pose_types = set() if pose_topic is None else {
        types.get(contract.topic_for(pose_topic, r), "") for r in robots}
    if pose_types == {contract.POSE_WITH_COVARIANCE_STAMPED}:
        lines.append("pose covariance: in the pose messages (PoseWithCovarianceStamped; all "
                     "zero means unknown: learnt from the log then)")
    else:
        lines.append("pose covariance: not in the log (learnt from it as it replays, from how "
                     "each robot's ball disagrees with the others')")
    no_model = [r for r in robots if r not in camera_robots]
    if no_model:  # replay.aloft: their rays cannot cross, their blobs' widths can tell
        lines.append(f"balls in the air: placed by the blob's width for {', '.join(no_model)} "
                     "(no camera model), once their blobs agree with the calibration")
    return lines


def _descriptions(cat: Catalogue) -> tuple[dict[str, str], list[str]]:
    """robot -> its camera in one line (an entry that does not parse: its error), and the
    robots whose entry is a projection model (what the line fit needs)."""
    out: dict[str, str] = {}
    models: list[str] = []
    for robot, text in cat.metadata.get(contract.CAMERAS_METADATA, {}).items():
        try:
            spec = meta.CameraMetadata(robot, jsonio.loads(text)).spec
            out[_shown(robot)] = spec.describe()
            if spec.camera is not None:
                models.append(_shown(robot))
        except (ValueError, TypeError, AttributeError) as err:
            out[_shown(robot)] = _shown(f"unusable: {err}", limit=200)
    return out, models


def _metadata(cat: Catalogue) -> tuple[dict[str, Json] | None, dict[str, str], str | None]:
    """Scenario (name, seed, field), cameras (robot -> model) and renderer; a record that
    does not parse is reported by name rather than failing the summary."""
    records = cat.metadata
    scenario: dict[str, Json] | None = None
    if contract.SCENARIO_METADATA in records:
        try:
            s = meta.ScenarioMetadata.from_metadata(records[contract.SCENARIO_METADATA])
            scenario = {"name": _shown(s.name), "seed": s.seed, "field": s.field_name}
        except meta.MetadataError as err:
            scenario = {"error": _shown(str(err), limit=200)}
    cameras: dict[str, str] = {}
    try:
        cams = meta.CamerasMetadata.from_metadata(records.get(contract.CAMERAS_METADATA, {}))
        cameras = {_shown(c.robot): _shown(str(c.model.get("model", "?"))) for c in cams.cameras}
    except meta.MetadataError as err:
        cameras = {"error": _shown(str(err), limit=200)}
    renderer = None
    if contract.RECORDER_METADATA in records:
        renderer = _shown(records[contract.RECORDER_METADATA].get("renderer", "?"))
    return scenario, cameras, renderer


def format_info(s: LogSummary) -> str:
    """The summary as aligned text."""
    def secs(v: float | None) -> str:
        return "-" if v is None else f"{v:.3f} s"

    lines = [f"file:        {printable(s.path)} ({format_bytes(s.bytes)}, profile "
             f"{s.profile or '-'})",
             f"duration:    {secs(s.duration_s)}  (start {secs(s.start_s)}, end "
             f"{secs(s.end_s)})",
             f"messages:    {'-' if s.messages is None else s.messages}"]
    comp = ", ".join(f"{k} {v}" for k, v in sorted(s.compression.items())) or "-"
    sizes = f"{format_bytes(s.uncompressed_bytes)} uncompressed"
    if set(s.compression) - {"none"}:
        sizes = f"{format_bytes(s.chunk_bytes)} compressed, {sizes}"
    lines.append(f"chunks:      {s.chunks} ({comp}; {sizes}), summary: {s.summary}")
    lines.append(f"robots:      {', '.join(s.robots) or '-'}")
    if s.robots and s.image_topic is not None and s.image_topic != contract.IMAGE_TOPIC:
        pose = s.pose_topic or "(none found: give --pose-topic)"
        lines.append(f"  from topics {s.image_topic} and {pose}: replay with --image-topic "
                     f"'{s.image_topic}'" + (f" --pose-topic '{s.pose_topic}'"
                                             if s.pose_topic else ""))
    if s.scenario is not None:
        lines.append("scenario:    " + ", ".join(f"{k} {v}" for k, v in s.scenario.items()))
    if s.cameras:
        lines.append("cameras:     " + ", ".join(f"{k} {v}" for k, v in s.cameras.items()))
        width = max(len(k) for k in s.camera_descriptions) if s.camera_descriptions else 0
        lines.extend(f"  {k:<{width}}  {v}" for k, v in s.camera_descriptions.items())
    elif s.robots:
        lines.append("cameras:     - (no camera description: dsp-replay needs --cameras; "
                     "dsp-info --cameras-template LOG -o cameras.yaml writes one to start from)")
    if s.default_pipeline:
        lines.append("default pipeline:")
        lines.extend(f"  {line}" for line in s.default_pipeline)
    lines.append(f"renderer:    {s.renderer or '-'}")
    lines.append(f"metadata:    {', '.join(s.metadata) or '-'}")
    width = max((len(t.topic) for t in s.topics), default=5)
    lines.append(f"topics:      {len(s.topics)}")
    for t in s.topics:
        n = "-" if t.messages is None else str(t.messages)
        rate = "-" if t.rate_hz is None else f"{t.rate_hz:.2f} Hz"
        lines.append(f"  {t.topic:<{width}}  {n:>7} msgs  {rate:>10}  {t.type}")
    if s.checked:
        if s.problems:
            lines.append(f"check:       {len(s.problems)} problem(s)")
            lines.extend(f"  {p}" for p in s.problems)
            lines.extend(f"  {k}" for k in s.salvaged)
            if s.recoverable:
                lines.append(f"recover:     {s.recoverable}")
        else:
            lines.append("check:       intact (every CRC the log carries matches; the "
                         "summary agrees with the data)")
    return "\n".join(lines)
