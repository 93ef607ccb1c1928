"""The viewer's labels read as words and sit beside what they name: a robot's label (on
hovering) says how its pose was corrected and from what, its name is written below its
footprint, and the detection's label lies off the ball in the camera image."""

from __future__ import annotations

import math

import numpy as np
import pytest

from estimator.detection.chain import Detection
from estimator.geometry import RobotPose
from replay.records import FrameResult, FrameStatus, Localisation
from replay.sinks.rerun.shapes import (
    CHAR_PX,
    NAME_BOX_M,
    NamePlacer,
    beside_ball,
    detection_label,
    label_box,
    name_position,
    pose_label,
)
from replay.sinks.style import ROBOT_FOOTPRINT_M

BELIEVED = RobotPose(1.0, 2.0, 0.3)
CORRECTED = RobotPose(1.0 + 0.031, 2.0, 0.3 + math.radians(0.5))
I3 = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))


def _frame(source: str | None, believed: RobotPose | None = BELIEVED) -> FrameResult:
    loc = None if source is None else Localisation(
        BELIEVED if source == "prior" else CORRECTED, I3, "ok", source, 0, 0)
    return FrameResult(0, "robot1", 0, FrameStatus.OK, pose=believed, localisation=loc)


@pytest.mark.parametrize(("source", "want"), [
    (None, "robot1"),
    ("lines", "robot1 (pose corrected 3.1 cm, +0.50° from the field lines)"),
    ("held", "robot1 (pose corrected 3.1 cm, +0.50° by its last field-line fit, carried over)"),
    ("ball", "robot1 (pose corrected 3.1 cm, +0.50° by its bias learnt from the ball)"),
    ("prior", "robot1 (believed pose kept: the field lines gave no fit)"),
])
def test_a_robot_s_label_says_in_words_how_its_pose_was_corrected(
        source: str | None, want: str) -> None:
    assert pose_label(_frame(source)) == want


def test_a_correction_without_a_believed_pose_names_its_source_alone() -> None:
    assert pose_label(_frame("lines", believed=None)) == "robot1 (pose from the field lines)"


def _footprint_lowest(pose: RobotPose) -> float:
    """The footprint's lowest corner's y, whatever the heading."""
    h = ROBOT_FOOTPRINT_M / 2
    return min(pose.y_m + h * (sx * math.sin(pose.yaw_rad) + sy * math.cos(pose.yaw_rad))
               for sx in (-1, 1) for sy in (-1, 1))


@pytest.mark.parametrize("yaw", [0.0, math.pi / 4, 1.0, -2.5])
def test_a_robot_s_name_is_written_below_its_footprint(yaw: float) -> None:
    pose = RobotPose(-3.0, 1.0, yaw)
    x, y, _ = name_position("robot1", {"robot1": pose, "robot2": RobotPose(3.0, 1.0, 0.0)})
    assert x == pose.x_m and y < _footprint_lowest(pose)  # its label hanging further down


def _name_box(robot: str, top: tuple[float, float, float]) -> tuple[float, float, float, float]:
    half_w = 0.5 * (NAME_BOX_M[0] + NAME_BOX_M[1] * len(robot))
    return top[0] - half_w, top[1] - NAME_BOX_M[2], top[0] + half_w, top[1]


@pytest.mark.parametrize(("dx", "dy"), [(0.0, -0.6), (0.0, 0.6), (0.6, 0.0), (0.3, -0.5)])
def test_a_robot_s_name_covers_no_other_robot_close_by(dx: float, dy: float) -> None:
    me, other = RobotPose(0.0, 0.0, 0.4), RobotPose(dx, dy, 1.0)
    box = _name_box("r2", name_position("r2", {"r2": me, "r3": other}))
    for pose in (me, other):  # clear of both footprints (within their half diagonals)
        assert _clear_of(box, (pose.x_m, pose.y_m), math.sqrt(2) * ROBOT_FOOTPRINT_M / 2)


def _box(top: tuple[float, float], text: str) -> tuple[float, float, float, float]:
    """The label's box as Rerun draws it: hanging below its position, centred across it."""
    half_w = 0.5 * CHAR_PX[0] * len(text)
    return top[0] - half_w, top[1], top[0] + half_w, top[1] + CHAR_PX[1]


def _clear_of(box: tuple[float, float, float, float], c: tuple[float, float],
              r: float) -> bool:
    nx, ny = min(max(c[0], box[0]), box[2]), min(max(c[1], box[1]), box[3])
    return math.hypot(nx - c[0], ny - c[1]) > r


@pytest.mark.parametrize("angle", np.linspace(0.0, 2 * math.pi, 13)[:-1].tolist())
def test_the_detection_s_label_lies_off_the_ball(angle: float) -> None:
    centre, text, r = (540.0, 540.0), "(100.0, 200.0) px, r = 250.0 px", 30.0
    ball = (centre[0] + 250 * math.cos(angle), centre[1] + 250 * math.sin(angle))
    at = beside_ball(centre, ball, r, text, (1080, 1080))
    box = _box(at, text)
    assert _clear_of(box, ball, r)
    assert 0 <= box[0] and box[2] <= 1080 and 0 <= box[1] and box[3] <= 1080


def test_near_the_image_s_edge_the_label_goes_inward() -> None:
    centre, ball, text = (540.0, 540.0), (1040.0, 540.0), "(1040.0, 540.0) px, r = 500.0 px"
    at = beside_ball(centre, ball, 10.0, text, (1080, 1080))
    assert centre[0] < at[0] < ball[0] and _clear_of(_box(at, text), ball, 10.0)
    # with no image size known it goes outward, past the ball
    assert beside_ball(centre, ball, 10.0, text)[0] > ball[0]


def test_a_frame_s_detection_label_gives_the_centroid_and_r() -> None:
    det = Detection(700.0, 540.0, 300.0, (690, 530, 20, 21), 0.9,
                    np.zeros((0, 2), dtype=np.int32))
    frame = FrameResult(0, "robot1", 0, FrameStatus.OK, detection=det, r_px=160.0,
                        centre_px=(540.0, 540.0))
    at, text = detection_label(frame, np.zeros((1080, 1080, 3), dtype=np.uint8))
    assert text == "(700.0, 540.0) px, r = 160.0 px"
    assert at[0] - 0.5 * CHAR_PX[0] * len(text) > 700.0 + 10.5  # right of the ball


def test_a_robot_s_name_keeps_off_the_fused_ball_s_label() -> None:
    """A robot with the ball at its feet: the fused label hangs below the ball, so the name
    goes elsewhere than below."""
    me = RobotPose(0.0, 0.0, 0.0)
    fused = label_box(0.2, 0.0, "fused (0.20, 0.00), 1.00 m/s")
    placer = NamePlacer()
    placer.ball(0.2, 0.0, "fused (0.20, 0.00), 1.00 m/s")
    at = placer.place("robot3", me)
    assert at == name_position("robot3", {"robot3": me}, (fused,))
    box = _name_box("robot3", at)
    assert not (box[0] < fused[2] and fused[0] < box[2] and box[1] < fused[3]
                and fused[1] < box[3])
    assert at[1] > me.y_m  # above it


def test_two_robots_side_by_side_keep_their_names_apart() -> None:
    placer = NamePlacer()
    a, b = RobotPose(0.0, 0.0, 0.0), RobotPose(0.9, 0.0, 0.0)
    placer.place("robot1", a)
    placer.place("robot2", b)
    one, two = placer.names["robot1"], placer.names["robot2"]
    assert not (one[0] < two[2] and two[0] < one[2] and one[1] < two[3] and two[1] < one[3])
