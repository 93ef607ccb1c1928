"""The shapes and labels the Rerun sink draws: covariance ellipses, rings, the fused label,
the predicted landing's mark, a robot's label and where its name goes, the detection's
label and where it goes (beside what it names, never on it)."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np

from estimator.constants import BALL_RADIUS_M, NS_PER_S
from estimator.estimates import Covariance
from estimator.geometry import RobotPose
from replay.records import FrameResult, StepResult

__all__ = ["SOURCE_WORDS", "NamePlacer", "beside_ball", "detection_label", "detection_text",
           "ellipse", "fused_label", "label_box", "landing_mark", "name_position", "pose_label",
           "ring", "truth_mark"]


def ellipse(x: float, y: float, cov: Covariance, k: float = 2.0, n: int = 48) -> np.ndarray:
    """The k-sigma ellipse of a 2x2 covariance around (x, y), just above the ground."""
    c = np.asarray(cov, dtype=np.float64)
    vals, vecs = np.linalg.eigh(0.5 * (c + c.T))
    vals = np.sqrt(np.clip(vals, 0.0, None)) * k
    a = np.linspace(0.0, 2 * math.pi, n + 1)
    circle = np.stack([np.cos(a) * vals[0], np.sin(a) * vals[1]])
    pts = (vecs @ circle).T + np.array([x, y])
    return np.column_stack([pts, np.full(len(pts), 0.01)])


def ring(x: float, y: float, r: float, n: int = 32, *, z: float | None = None) -> np.ndarray:
    """A ring of radius r around (x, y) at height z (default 2 r: atop a ball on the ground)."""
    a = np.linspace(0.0, 2 * math.pi, n + 1)
    return np.column_stack([x + r * np.cos(a), y + r * np.sin(a),
                            np.full(n + 1, 2 * r if z is None else z)])


def truth_mark(x: float, y: float, z: float) -> list[np.ndarray]:
    """The true ball with its centre at height z: a ring of its radius atop it and, while it
    is off the ground, a line from the ground up to it (seen obliquely, a ring alone floats
    off the spot it is over)."""
    r = BALL_RADIUS_M
    strips = [ring(x, y, r, z=z + r)]
    if z > 2 * r:  # its underside more than a radius up
        strips.append(np.array([(x, y, 0.0), (x, y, z - r)]))
    return strips


def fused_label(result: StepResult) -> str:
    """The fused position's one label, with the tracker's speed when it has one (a label of
    its own at the arrow would sit on this one, and neither could be read)."""
    fused = result.fused
    assert fused is not None
    label = (f"fused ({fused.x_m:.2f}, {fused.y_m:.2f})" if fused.z_m is None
             else f"fused ({fused.x_m:.2f}, {fused.y_m:.2f}, {fused.z_m:.2f})")
    if result.velocity_m_s is not None:
        label += f", {math.hypot(*result.velocity_m_s):.2f} m/s"
    return label


def landing_mark(result: StepResult) -> tuple[list[np.ndarray], str]:
    """The predicted landing (``result.landing``, not None): a ring of the ball's radius on
    the ground with a cross in it, and its label, the time to it."""
    landing = result.landing
    assert landing is not None
    x, y, r = landing.x_m, landing.y_m, BALL_RADIUS_M
    cross = [np.array([(x - r, y - r, 0.01), (x + r, y + r, 0.01)]),
             np.array([(x - r, y + r, 0.01), (x + r, y - r, 0.01)])]
    ahead_s = (landing.stamp_ns - result.stamp_ns) / NS_PER_S
    return [ring(x, y, r, z=0.01), *cross], f"lands in {ahead_s:.2f} s"


def pose_share_cm(result: FrameResult) -> float | None:
    """The pose's share of the frame's ball [cm], sqrt(s_x s_y + s_t^2 rho^2) of the pose
    covariance its estimate was weighed with (the line fit's, the bias filter's, the log's
    or the one learnt from the log): what the replay believed of the pose; None without one."""
    est = None if result.estimate is None else result.estimate
    if est is None or est.pose_covariance is None:
        return None
    cov = est.pose_covariance
    rho2 = (est.x_m - est.robot_x_m) ** 2 + (est.y_m - est.robot_y_m) ** 2
    return 100.0 * math.sqrt(max(0.0, math.sqrt(max(0.0, cov[0][0] * cov[1][1]))
                                 + cov[2][2] * rho2))


SOURCE_WORDS = {
    "lines": "from the field lines",
    "held": "by its last field-line fit, carried over",
    "ball": "by its bias learnt from the ball",
}
"""How a corrected pose's source (:attr:`replay.records.Localisation.source`) reads in a
robot's label; "prior" (the believed pose kept) has a sentence of its own."""


def pose_label(result: FrameResult) -> str:
    """The robot's footprint's label, shown on hovering: its name and, with a pose
    correction, how far the pose was moved and from what, "robot1 (pose corrected 3.1 cm,
    +0.50° from the field lines)"; the name alone without one."""
    loc, believed, robot = result.localisation, result.pose, result.robot
    if loc is None:
        return robot
    if loc.source == "prior":
        return f"{robot} (believed pose kept: the field lines gave no fit)"
    words = SOURCE_WORDS.get(loc.source, f"({loc.source})")
    if believed is None:
        return f"{robot} (pose {words})"
    shift = math.hypot(loc.pose.x_m - believed.x_m, loc.pose.y_m - believed.y_m)
    turn = math.degrees(math.remainder(loc.pose.yaw_rad - believed.yaw_rad, math.tau))
    return f"{robot} (pose corrected {100 * shift:.1f} cm, {turn:+.2f}\N{DEGREE SIGN} {words})"


NAME_GAP_M = 0.4
"""How far from a robot's centre its name's box begins [m]: past the footprint's half
diagonal (0.35 m), so the name covers none of it whatever the robot's heading."""
NAME_BOX_M = (0.2, 0.18, 0.5)
"""A robot name's box in the field view at its usual zoom [m]: width 0.2 + 0.18 a
character, height 0.5."""


Box = tuple[float, float, float, float]
"""(x0, y0, x1, y1) of a label's box on the field [m]."""


def label_box(top_x: float, top_y: float, text: str) -> Box:
    """The box of a label of ``text`` whose position is (top_x, top_y) in the field view
    from above: Rerun hangs a label below its position, centred across it."""
    half_w = 0.5 * (NAME_BOX_M[0] + NAME_BOX_M[1] * len(text))
    return (top_x - half_w, top_y - NAME_BOX_M[2], top_x + half_w, top_y)


def _overlaps(a: Box, b: Box) -> bool:
    return a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]


def name_position(robot: str, poses: Mapping[str, RobotPose],
                  avoid: Sequence[Box] = ()) -> tuple[float, float, float]:
    """Where ``robot``'s always-shown name goes in the field view: beside its footprint (one
    at the robot would cover it), below it, or above, right or left where below would
    cover more of the other robots' footprints (``poses``: every robot's latest, its own
    included) and the boxes to ``avoid`` (their names, the fused ball's label); below when
    all do alike.
    The position returned is the label's (the top centre of its box, :func:`label_box`)."""
    pose = poses[robot]
    x, y, gap = pose.x_m, pose.y_m, NAME_GAP_M
    half_w, h = 0.5 * (NAME_BOX_M[0] + NAME_BOX_M[1] * len(robot)), NAME_BOX_M[2]
    tops = [(x, y - gap), (x, y + gap + h), (x + gap + half_w, y + 0.5 * h),
            (x - gap - half_w, y + 0.5 * h)]  # below, above, right, left
    obstacles = [(p.x_m - gap, p.y_m - gap, p.x_m + gap, p.y_m + gap)
                 for name, p in poses.items() if name != robot] + list(avoid)
    best = min(tops, key=lambda t: sum(_overlaps(label_box(t[0], t[1], robot), o)
                                       for o in obstacles))  # the first of equals
    return (best[0], best[1], 0.05)


class NamePlacer:
    """Keeps what the robots' names must not cover (each robot's latest pose and name, the
    fused ball's label) and places each name (:func:`name_position`) as its robot's frame
    comes."""

    def __init__(self) -> None:
        self.poses: dict[str, RobotPose] = {}
        self.names: dict[str, Box] = {}
        self.ball_label: Box | None = None

    def place(self, robot: str, pose: RobotPose) -> tuple[float, float, float]:
        self.poses[robot] = pose
        avoid = [box for name, box in self.names.items() if name != robot]
        at = name_position(robot, self.poses, avoid + ([] if self.ball_label is None
                                                       else [self.ball_label]))
        self.names[robot] = label_box(at[0], at[1], robot)
        return at

    def ball(self, x: float, y: float, text: str) -> str:
        """Notes the fused ball's label, ``text`` at (x, y), and returns it."""
        self.ball_label = label_box(x, y, text)
        return text


CHAR_PX = (11.0, 26.0)
"""A label's character's width and the label's height in image pixels, for a 1080-pixel
omni image shown about 550 pixels tall (the viewer's usual camera view); an image of
another height is shown as tall, so its labels span pixels in proportion."""
GAP_PX = 12.0
"""The gap between the ball's edge and the nearest edge of its label [image px]."""


def detection_text(cx: float, cy: float, r_px: float | None) -> str:
    """The detection's label in the camera view: its centroid and pixel radius r."""
    text = f"({cx:.1f}, {cy:.1f}) px"
    return text if r_px is None else f"{text}, r = {r_px:.1f} px"


def beside_ball(centre: tuple[float, float], centroid: tuple[float, float], ball_r_px: float,
                text: str, size: tuple[int, int] | None = None) -> tuple[float, float]:
    """Where the detection's label goes: its box (its size guessed from the text) outward
    from the image centre along the radius, beyond the ball, so far that it does not reach
    the ball's circle: the ball stays visible. Inward instead (towards the robot, on the
    radius line) where outward the box would leave an image of ``size`` (width, height).
    The position returned is the box's top centre: Rerun hangs a label below its position."""
    dx, dy = centroid[0] - centre[0], centroid[1] - centre[1]
    norm = math.hypot(dx, dy)
    ux, uy = (dx / norm, dy / norm) if norm > 1e-6 else (0.0, 1.0)
    scale = 1.0 if size is None else size[1] / 1080
    half_w, half_h = 0.5 * scale * CHAR_PX[0] * len(text), 0.5 * scale * CHAR_PX[1]
    reach = abs(ux) * half_w + abs(uy) * half_h  # the box's extent along (ux, uy)
    d = ball_r_px + scale * GAP_PX + reach
    x, y = centroid[0] + d * ux, centroid[1] + d * uy
    if size is not None and not (half_w <= x <= size[0] - half_w
                                 and half_h <= y <= size[1] - half_h):
        x, y = centroid[0] - d * ux, centroid[1] - d * uy
    return (x, y - half_h)


def detection_label(result: FrameResult, image: np.ndarray | None
                    ) -> tuple[tuple[float, float], str]:
    """The frame's detection's (not None) label and where it goes (:func:`beside_ball`,
    the ball's radius half its box's larger side), in ``image`` if there is one."""
    det = result.detection
    assert det is not None
    cx, cy = float(det.cx_px), float(det.cy_px)
    text = detection_text(cx, cy, result.r_px)
    ball_r_px = 0.5 * max(det.bbox_px[2], det.bbox_px[3])
    size = None if image is None else (image.shape[1], image.shape[0])
    return beside_ball(result.centre_px, (cx, cy), ball_r_px, text, size), text
