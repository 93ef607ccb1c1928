"""RecordOptions: checked when made; the metadata a recording writes comes from them."""

from __future__ import annotations

import dataclasses
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
    ({"jpeg_quality": 0}, "1..100"),
    ({"pose_noise_m": -0.1}, "noise must be >= 0"),
    ({"face_px": 128}, ">= 256"),
    ({"field": "30x20"}, "unknown field"),
    ({"renderer": "vulkan"}, "unknown renderer"),
    ({"frames": 2, "duration_s": 1.0}, "not both"),
    ({"frames": 0}, ">= 1"),
    ({"duration_s": 0.0}, "> 0 s"),
    ({"rate_hz": 2000.0}, r"\(0, 1000\]"),
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
