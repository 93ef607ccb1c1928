"""The shapes and labels the Rerun sink draws: covariance ellipses, rings, the fused label,
the predicted landing's mark, a pose correction's label."""

from __future__ import annotations

import math

import numpy as np

from estimator.constants import BALL_RADIUS_M, NS_PER_S
from estimator.estimates import Covariance
from replay.records import FrameResult, StepResult

__all__ = ["correction_label", "ellipse", "fused_label", "landing_mark", "ring", "truth_mark"]


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


def correction_label(result: FrameResult) -> str:
    """" lines 3.1 cm +0.50 deg": the frame's pose correction and where it comes from ("" when
    it has none)."""
    loc, believed = result.localisation, result.pose
    if loc is None:
        return ""
    label = f" {loc.source}"
    if believed is not None:
        shift = math.hypot(loc.pose.x_m - believed.x_m, loc.pose.y_m - believed.y_m)
        turn = math.degrees(math.remainder(loc.pose.yaw_rad - believed.yaw_rad, math.tau))
        label += f" {100 * shift:.1f} cm {turn:+.2f} deg"
    return label
