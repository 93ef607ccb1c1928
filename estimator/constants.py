"""Numbers the estimator takes from the paper and from the RoboCup MSL world, defined once.

The paper ("Object Position Estimation based on Dual Sight Perspective Configuration")
calibrates the pixel radius r of the ball's centroid to its range,
``d = PAPER_K_M_PER_PX * r + PAPER_B_M`` (eq. 4, R^2 = PAPER_R2), in a square omni image of
``PAPER_IMAGE_SIZE_PX`` pixels whose centre, the robot's centre, is ``PAPER_CENTRE_PX``.
The ball is the MSL (and simatch) ball of radius ``BALL_RADIUS_M``. Time between stages is an
integer count of nanoseconds; ``NS_PER_S`` converts it, for the whole project (the estimator
imports nothing of ours, so everything else can import this).
"""

from __future__ import annotations

__all__ = [
    "BALL_RADIUS_M",
    "NS_PER_S",
    "PAPER_B_M",
    "PAPER_CENTRE_PX",
    "PAPER_IMAGE_SIZE_PX",
    "PAPER_K_M_PER_PX",
    "PAPER_R2",
]

PAPER_K_M_PER_PX = 0.0163
"""Slope of the paper's calibration d = 0.0163 r + 0.2786 (eq. 4) [m/px]."""
PAPER_B_M = 0.2786
"""Offset of the paper's calibration (eq. 4) [m]."""
PAPER_R2 = 0.9932
"""Coefficient of determination the paper reports for its eq. 4 fit."""
PAPER_IMAGE_SIZE_PX = 1080
"""Width and height of the paper's omni image [px]."""
PAPER_CENTRE_PX = (539.0, 539.0)
"""The paper's image centre = robot centre in the 1080 x 1080 image [px] (eq. 3, 6)."""
BALL_RADIUS_M = 0.11
"""Radius of the MSL ball [m]."""
NS_PER_S = 1_000_000_000
"""Nanoseconds per second: stamps are integer nanoseconds (``*_ns``), seconds only at the
edges."""
