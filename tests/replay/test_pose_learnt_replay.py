"""What a log does not state is learnt from it: on logs another renderer drew (no dsp
metadata, PoseStamped), the default learns each robot's pose spread and corrects its
bias from the ball; a stated covariance is the biases' spread instead, and is checked
against the balls; what was learnt is in the summary and the results, with how far each
robot's estimates sat from the others' (the velocity filter's offsets)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from replay import replay
from replay.cli import format_summary
from replay.evaluate.foreign import (
    IMAGE_TOPIC,
    TRUTH_TOPIC,
    ForeignOptions,
    pose_topic,
    write_camera_file,
    write_foreign_log,
)
from replay.profiles import options_for

BASE = dict(robots=3, rate_hz=15.0, duration_s=6.0, size_px=640, camera="mirror")


def _log(folder: Path, name: str, options: ForeignOptions) -> tuple[Path, Path]:
    log, cams = folder / f"{name}.mcap", folder / f"{name}.yaml"
    write_foreign_log(log, options)
    write_camera_file(cams, options)
    return log, cams


def _replay(folder: Path, name: str, options: ForeignOptions) -> tuple[dict, str]:
    log, cams = _log(folder, name, options)
    out = folder / f"{name}.json"
    summary = replay(log, options_for(cameras=cams, image_topic=IMAGE_TOPIC,
                                      pose_topic=pose_topic(options), truth_topic=TRUTH_TOPIC,
                                      out=out, progress=False, quiet=True, threads=1))
    return json.loads(out.read_text()), format_summary(summary)


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, tuple[dict, str]]:
    folder = tmp_path_factory.mktemp("learnt")
    return {name: _replay(folder, name, ForeignOptions(seed=31, **BASE, **extra))
            for name, extra in (("exact", {}),
                                ("drift", {"poses": "drift", "drift": (0.10, 2.0)}),
                                ("stated", {"poses": "drift", "drift": (0.10, 2.0),
                                            "covariance": "honest",
                                            "covariance_scale": 0.2}))}


def test_exact_poses_are_learnt_exact_and_drifting_ones_not(runs: dict) -> None:
    exact, _ = runs["exact"]
    drift, text = runs["drift"]
    assert exact["pipeline"]["poses"] == drift["pipeline"]["poses"] == "ball"
    learnt = {r: b["pose_sigma_m"] ** 2 + (b["pose_sigma_deg"] / 20) ** 2  # 1 deg ~ 5 cm
              for r, b in exact["summary"]["learnt"].items()}
    drifting = {r: b["pose_sigma_m"] ** 2 + (b["pose_sigma_deg"] / 20) ** 2
                for r, b in drift["summary"]["learnt"].items()}
    assert set(learnt) == set(drifting) == {"r1", "r2", "r3"}
    assert max(learnt.values()) < 0.03**2  # well under the weak start's 3 cm / 0.5 deg
    assert sum(drifting.values()) > 4 * sum(learnt.values())
    assert all(b["residuals"] > 20 for b in drift["summary"]["learnt"].values())
    assert all("bias_x_m" in b for b in drift["summary"]["learnt"].values())
    assert "learnt r1: pose off by" in text and "corrected by" in text


def test_a_stated_covariance_is_used_and_checked_against_the_balls(runs: dict) -> None:
    """A localiser that states a fifth of its true error: its covariance is the spread of
    the biases corrected, and the summary sets what the balls show beside it."""
    stated, text = runs["stated"]
    assert stated["pipeline"]["poses"] == "ball" and stated["pipeline"]["pose_uncertainty"]
    for b in stated["summary"]["learnt"].values():
        assert b["stated_sigma_m"] == pytest.approx(0.02, abs=0.002)
        assert "bias_x_m" in b
    shown = sum(b["pose_sigma_m"] ** 2 + (b["pose_sigma_deg"] / 20) ** 2
                for b in stated["summary"]["learnt"].values())
    told = sum(b["stated_sigma_m"] ** 2 + (b["stated_sigma_deg"] / 20) ** 2
               for b in stated["summary"]["learnt"].values())
    assert shown > 2 * told  # the balls show the localiser overconfident
    assert "the log states 2.0 cm" in text


def test_each_robots_offset_from_the_others_is_in_the_summary(runs: dict) -> None:
    """Whatever corrects the poses, the offsets the track's velocity filter held at the end
    are in the results and the printed summary, a few centimetres each (the robots' own
    errors here are 2-20 cm)."""
    for name in ("exact", "drift", "stated"):
        doc, text = runs[name]
        learnt = doc["summary"]["learnt"]
        assert set(learnt) == {"r1", "r2", "r3"}
        offsets = [math.hypot(b["offset_x_m"], b["offset_y_m"]) for b in learnt.values()]
        assert 0.0 < max(offsets) < 0.15
        line = next(x for x in text.splitlines() if x.startswith("learnt r1:"))
        b = learnt["r1"]
        assert line.endswith(f"its ball ({100 * b['offset_x_m']:+.1f}, "
                             f"{100 * b['offset_y_m']:+.1f}) cm from the others' at the end")
