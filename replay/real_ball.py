"""The replay's ball finder: the paper's chain, or the real-ball detector of a ball model.

:class:`BallFinder` is what :func:`replay.estimation.detect` calls. The real detector
holds an OpenCV dnn network, which is not safe to share between threads, so each thread
gets its own (made from the same bytes: the same results, bit for bit, whatever the
thread count).
"""

from __future__ import annotations

import threading
from dataclasses import dataclass, field

import numpy as np

from estimator.detection import Detection
from estimator.detection.real import BallCheck, BallModel, Candidate, RealBallDetector

__all__ = ["DETECTORS", "BallFinder", "Found"]

DETECTORS = ("paper", "real")


@dataclass(frozen=True)
class Found:
    """The ball (None: none reported) and every candidate the detector checked."""

    detection: Detection | None
    candidates: tuple[Candidate, ...] = ()


@dataclass
class BallFinder:
    """The real-ball detector of one ball model and the shared check's ONNX bytes."""

    model: BallModel
    onnx: bytes
    _local: threading.local = field(default_factory=threading.local, repr=False)

    def _detector(self) -> RealBallDetector:
        det: RealBallDetector | None = getattr(self._local, "detector", None)
        if det is None:
            det = RealBallDetector(self.model, BallCheck(self.onnx))
            self._local.detector = det
        return det

    def __call__(self, image: np.ndarray) -> Found:
        ranked = self._detector().candidates(image)
        best = ranked[0] if ranked and ranked[0].check_score >= self.model.threshold else None
        return Found(None if best is None else best.detection, tuple(ranked))
