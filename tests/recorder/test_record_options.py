"""RecordOptions: checked when made; the metadata a recording writes comes from them."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Any

import pytest

from dsp import metadata
from estimator.camera import make_camera
from recorder.errors import UsageError
from recorder.record import RecordOptions, log_metadata
from recorder.scenarios import make_scenario


def test_options_are_frozen() -> None:
    with pytest.raises(dataclasses.FrozenInstanceError):
        RecordOptions().seed = 1  # type: ignore[misc]


@pytest.mark.parametrize(("kwargs", "match"), [
    ({"camera": "pinhole"}, "unknown camera"),
    ({"image_format": "gif"}, "png or jpeg"),
    ({"jpeg_quality": 0}, r"--jpeg-quality 0: give a whole number in \[1, 100\]"),
    ({"pose_noise_m": -0.1}, r"--pose-noise -0.1: give a finite number in \[0, 100\] m"),
    ({"pose_noise_m": math.nan}, "--pose-noise nan"),
    ({"yaw_noise_deg": math.inf}, "--yaw-noise inf"),
    ({"face_px": 128}, r"--face-px 128: give a whole number in \[256, 4096\]"),
    ({"face_px": 10**6}, "--face-px 1000000"),
    ({"field": "30x20"}, "unknown field"),
    ({"renderer": "vulkan"}, "unknown renderer"),
    ({"frames": 2, "duration_s": 1.0}, "not both"),
    ({"frames": 0}, r"--frames 0: give a whole number in \[1, "),
    ({"duration_s": 0.0}, r"--duration 0.0: give a finite number in \(0, 3600\] s"),
    ({"duration_s": math.inf}, "--duration inf"),
    ({"duration_s": math.nan}, "--duration nan"),
    ({"rate_hz": 2000.0}, r"\[0.1, 1000\]"),
    ({"rate_hz": 1e-9}, r"--rate 1e-09: give a finite number in \[0.1, 1000\] Hz"),
    ({"rate_hz": math.nan}, "--rate nan"),
    ({"seed": -1}, "--seed -1"),
    ({"robots": 0}, "--robot-count 0"),
])
def test_bad_options_are_refused_when_made(kwargs: dict[str, Any], match: str) -> None:
    with pytest.raises(UsageError, match=match):
        RecordOptions(**kwargs)


def test_log_metadata_round_trips_and_says_how_it_was_recorded() -> None:
    options = RecordOptions(scenario="rolling", seed=2, field="22x14", pose_noise_m=0.05)
    sc = make_scenario("rolling", 2, field="22x14")
    records = log_metadata(sc, options, rate_hz=4.0, frames=3, renderer="tiny",
                           camera=make_camera("ideal"))
    scenario, cameras, recorder = records
    assert scenario.field.name == "22x14" and scenario.seed == 2
    assert scenario.recording is not None
    assert (scenario.recording.rate_hz, scenario.pose_rate_hz) == (4.0, 8.0)
    assert scenario.recording.pose_noise_m == 0.05
    assert [cam.robot for cam in cameras.cameras] == [tr.name for tr in sc.robots]
    assert recorder.renderer == "tiny" and "pybullet" in recorder.versions
    for record, cls in zip(records, (metadata.ScenarioMetadata, metadata.CamerasMetadata,
                                     metadata.RecorderMetadata),
                           strict=True):
        assert cls.from_metadata(record.to_metadata()) == record  # type: ignore[attr-defined]


@pytest.mark.parametrize("given", [{"frames": 72_000}, {"duration_s": 3600.0}])
def test_the_documented_72000_frames_are_recorded_and_one_more_is_not(
        tmp_path: Path, given: dict[str, Any]) -> None:
    """--frames' bound (an hour at a match's 20 Hz) is inclusive, given as frames or as a
    duration; the plan is made without recording anything."""
    from recorder.record import MAX_FRAMES, _plan

    assert MAX_FRAMES == 72_000
    plan = _plan(tmp_path / "long.mcap", RecordOptions(scenario="rolling", rate_hz=20.0,
                                                       **given))
    assert plan.frames == MAX_FRAMES and not (tmp_path / "long.mcap").exists()
    with pytest.raises(UsageError, match=r"--frames 72001: give a whole number in \[1, 72000\]"):
        RecordOptions(frames=MAX_FRAMES + 1)
    with pytest.raises(UsageError, match="is 72160 frames; record at most 72000"):
        _plan(tmp_path / "long.mcap", RecordOptions(scenario="rolling", rate_hz=20.05,
                                                    duration_s=3599.0))
