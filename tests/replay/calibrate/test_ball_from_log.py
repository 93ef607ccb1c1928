"""dsp-calibrate --ball-from LOG.mcap: a simulated log's truth draws the ball's boxes, the
folder's fit makes the model, and the replay's real detector finds the ball where the
camera model puts the true ball; a box the ball does not show is left out; a log without
ground truth is one line naming it."""

from __future__ import annotations

import contextlib
import io
import json
import math
from pathlib import Path

import numpy as np
import pytest
from synthetic import write_log

from dsp.ball_file import read_ball_file, shipped_check
from replay.calibrate.ball_log import _histogram, frames_from_log, visible
from replay.calibrate.cli import main
from replay.real_ball import BallFinder

MATCH = Path(__file__).resolve().parents[3] / "logs" / "golden" / "match.mcap"


@pytest.fixture(scope="module")
def fitted(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, str]:
    out = tmp_path_factory.mktemp("ball") / "ball.json"
    with contextlib.redirect_stdout(io.StringIO()) as said:
        assert main(["--ball-from", str(MATCH), "-o", str(out)]) == 0
    return out, said.getvalue()


def test_the_model_fitted_from_a_log_finds_the_ball_where_the_truth_is(
        fitted: tuple[Path, str]) -> None:
    path, said = fitted
    fit = json.loads(path.read_text())["fit"]
    assert fit["log"] == "match.mcap" and fit["images"] + fit["left_out"] == 12
    assert fit["balls"] >= 6 and f"ball model from {fit['images']} images (robot" in said
    frames, _ = frames_from_log(MATCH, None)
    finder = BallFinder(read_ball_file(path), shipped_check())
    errors = []
    for image, boxes in frames:
        if boxes:
            x0, y0, x1, y1 = boxes[0]
            found = finder(image).detection
            assert found is not None
            # the boxes are drawn as a labeller would (pixel i spans [i, i + 1)); the
            # replay's centroid has pixel i at i, as the camera model does
            errors.append(math.hypot(found.cx_px - ((x0 + x1) / 2 - 0.5),
                                     found.cy_px - ((y0 + y1) / 2 - 0.5)))
    assert len(errors) == fit["balls"] and float(np.median(errors)) < 1.0, errors


def test_the_first_n_images_by_stamp() -> None:
    frames, info = frames_from_log(MATCH, 5)
    again, _ = frames_from_log(MATCH, 5)
    stamps = [m.stamp_ns for m in frames.images]
    assert stamps == sorted(stamps) and len(frames) + int(str(info["left_out"])) == 5
    assert stamps[-1] < max(m.stamp_ns for m in frames_from_log(MATCH, None)[0].images)
    assert frames.boxes == again.boxes and frames.images == again.images


def test_a_box_the_ball_does_not_show_is_left_out() -> None:
    frames, _ = frames_from_log(MATCH, None)
    shown = [(image, boxes[0]) for image, boxes in frames if boxes]
    hists = [_histogram(image, box) for image, box in shown]
    assert all(visible(hists))
    image, box = shown[0]
    covered = image.copy()  # a black robot over the ball
    covered[math.floor(box[1]):math.ceil(box[3]), math.floor(box[0]):math.ceil(box[2])] = 20
    assert visible([*hists, _histogram(covered, box)]) == [True] * len(hists) + [False]


def test_a_log_without_ground_truth_is_one_line(tmp_path: Path,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "ball.json"
    for truth in (False, True):  # the ball's truth, but never a robot's true pose
        log = write_log(tmp_path / f"robot-{truth}.mcap", duration_s=0.2, with_truth=truth,
                        with_cameras=True).path
        assert main(["--ball-from", str(log), "-o", str(out)]) != 0
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and f"{log}: no ground truth" in err[0] and not out.exists()
