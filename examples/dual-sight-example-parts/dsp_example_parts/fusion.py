"""A window fusion: the robots' estimates' median, axis by axis.

The contract (``estimator.fusion.Fusion``): a class made with no arguments, with a ``name``
and ``fuse(estimates) -> FusedEstimate | None`` (None for no estimates).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from estimator.estimates import BallEstimate, FusedEstimate

SIGMA_M = 0.05
"""The fused estimate's standard deviation per axis [m], a fixed guess."""


class MedianFusion:
    name = "example-median"

    def fuse(self, estimates: Sequence[BallEstimate]) -> FusedEstimate | None:
        if not estimates:
            return None
        x = float(np.median([e.x_m for e in estimates]))
        y = float(np.median([e.y_m for e in estimates]))
        v = SIGMA_M**2
        return FusedEstimate(x_m=x, y_m=y, covariance=((v, 0.0), (0.0, v)),
                             robots=tuple(e.robot for e in estimates))
