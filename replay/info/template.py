"""``dsp-info --cameras-template``: a starting camera file for a log.

From the log's ``dsp.cameras`` metadata when it has some (the entries as written: the same
schema, :mod:`dsp.cameras`), else from the size of each robot's first image: a ``lookup``
camera centred in the image, not turned, with poses in the field frame, and its calibration
left empty, to fill in (``dsp-calibrate --from-measurements`` or ``--from-log`` writes one):
a replay refuses an empty calibration rather than guess one.

The field goes at the top (``field:``) when the log's ``dsp.scenario`` names it; for a log
that names none, a commented ``# field: 18x12`` says where to name it, so that the default
pipeline corrects the poses from the field lines (:mod:`replay.profiles`).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from dsp import contract
from dsp import metadata as meta
from dsp.camera_file import camera_file_text
from dsp.cameras import DEFAULT_ENTRY
from dsp.errors import InputError
from dsp.field import DEFAULT_FIELD
from dsp.text import printable
from dsp.topics import infer_patterns
from replay.log import (
    ImageMessage,
    Limits,
    LogReader,
    build_catalogue,
    check_mcap_file,
    image_size,
)

__all__ = ["FIELD_HINT", "FIELD_NAMED", "TEMPLATE_COMMENTS", "camera_template"]

FIELD_HINT = (f"field: {DEFAULT_FIELD}   # name your field to let the default correct poses "
              "from the field lines")
"""The comment line of a template for a log that names no field."""
FIELD_NAMED = "the field the log's dsp.scenario names: the default fits its lines"
"""The comment after the ``field`` key of a template for a log that names its field."""

TEMPLATE_COMMENTS = {
    "model": "lookup: the range comes from the calibration; add height_m (the camera's "
             "height [m]) for the line fit and the 3-D track",
    "cu_px": "the image's middle; the mirror's centre goes here (dsp-calibrate fits it)",
    "usable_radius_px": "a ball seen farther from the centre is out of range",
    "mount_yaw_deg": "the robot-frame direction image up shows (0 forward, 90 left)",
    "map_to_field": "the poses' frame in the field (AMCL's map: where its origin lies)",
    "calibration": "REQUIRED: pixel radius -> range; dsp-calibrate --from-measurements or "
                   "--from-log writes it",
    "ball": "the ball model, see dsp-calibrate --ball-from",
}


def _from_metadata(path: Path) -> tuple[dict[str, Mapping[str, Any]] | None, str | None]:
    """The log's camera entries (None: it has no camera metadata) and the name of the field
    a replay of it localises on (its dsp.scenario's; None: it has no scenario metadata)."""
    size = check_mcap_file(path)
    with path.open("rb") as f:
        cat = build_catalogue(f, path, size, Limits(), recover=False)
    record = cat.metadata.get(contract.CAMERAS_METADATA)
    scenario = cat.metadata.get(contract.SCENARIO_METADATA)
    try:
        field = (None if scenario is None
                 else meta.ScenarioMetadata.from_metadata(scenario).field.name)
        if not record:
            return None, field
        cameras = meta.CamerasMetadata.from_metadata(record)
    except meta.MetadataError as err:
        raise meta.MetadataError(f"{path}: metadata {err}") from err
    return {c.robot: dict(c.model) for c in cameras.cameras}, field


def _image_sizes(path: Path, image_topic: str | None, pose_topic: str | None
                 ) -> tuple[dict[str, tuple[int, int]], str, str]:
    """Each robot's first image size (width, height), and the topic patterns used."""
    size = check_mcap_file(path)
    with path.open("rb") as f:
        cat = build_catalogue(f, path, size, Limits(), recover=False)
    types = {ch.topic: (cat.schemas[ch.schema_id].name if ch.schema_id in cat.schemas else "")
             for ch in cat.channels.values()}
    found = infer_patterns(types)
    image_topic = image_topic or (found.image_topic if found else None)
    pose_topic = pose_topic or (found.pose_topic if found else None)
    if image_topic is None or pose_topic is None:
        raise InputError(f"{path}: cannot tell its robots' image and pose topics; give "
                         "--image-topic and --pose-topic (patterns with {robot})")
    sizes: dict[str, tuple[int, int]] = {}
    with LogReader(path, image_topic=image_topic, pose_topic=pose_topic) as reader:
        robots = reader.info.robots
        for msg in reader.messages():
            if isinstance(msg, ImageMessage) and msg.robot not in sizes:
                header = (("raw", msg.width_px, msg.height_px) if msg.fmt == "raw"
                          else image_size(msg.data))
                if header is not None and header[1] > 0 and header[2] > 0:
                    sizes[msg.robot] = (header[1], header[2])
                if len(sizes) == len(robots):
                    break
    if not sizes:
        raise InputError(f"{path}: no image of {image_topic} has a readable size")
    return sizes, image_topic, pose_topic


def _entry(width: int, height: int) -> dict[str, Any]:
    return {"model": "lookup", "width_px": width, "height_px": height,
            "cu_px": (width - 1) / 2.0, "cv_px": (height - 1) / 2.0,
            "usable_radius_px": min(width, height) / 2.0, "mount_yaw_deg": 0.0,
            "map_to_field": {"x_m": 0.0, "y_m": 0.0, "yaw_deg": 0.0}, "calibration": None}


def camera_template(path: Path, suffix: str = ".yaml", *, image_topic: str | None = None,
                    pose_topic: str | None = None) -> str:
    """The text of a starting camera file for the log at ``path`` (YAML or JSON)."""
    name = printable(path.name)  # a name is a line of the file's header, and terminal-safe
    entries, field = _from_metadata(path)
    field_comment = FIELD_HINT if field is None else FIELD_NAMED
    if entries is not None:
        header = (f"The cameras of {name}, from its dsp.cameras metadata (dsp-info "
                  "--cameras-template).\nEdit them and give the file to dsp-replay --cameras; "
                  "the keys: docs/cameras.md.")
        return camera_file_text(entries, suffix, header=header, field=field,
                                field_comment=field_comment)
    sizes, image_topic, pose_topic = _image_sizes(path, image_topic, pose_topic)
    if len(set(sizes.values())) == 1:
        width, height = next(iter(sizes.values()))
        entries = {DEFAULT_ENTRY: _entry(width, height)}
        seen = f"its images are {width} x {height} px"
    else:
        entries = {r: _entry(*wh) for r, wh in sizes.items()}
        seen = "its robots' images differ in size"
    header = (f"A starting camera description for {name} ({seen}; it has no camera "
              "metadata),\nwritten by dsp-info --cameras-template. Fill in the calibration "
              "(and what differs), then:\n  dsp-replay "
              f"{name} --cameras THIS_FILE --image-topic '{printable(image_topic)}' "
              f"--pose-topic '{printable(pose_topic)}'\nThe keys: docs/cameras.md.")
    return camera_file_text(entries, suffix, comments=TEMPLATE_COMMENTS, header=header,
                            field=field, field_comment=field_comment)
