"""The replay's ball finder: the paper's chain, or the real-ball detector of a ball model.

:class:`BallFinder` is what :func:`replay.estimation.detect` calls. The real detector
holds an OpenCV dnn network, which is not safe to share between threads, so each thread
gets its own (made from the same bytes: the same results, bit for bit, whatever the
thread count).

The real detector is fitted and trained on labelled boxes, whose convention (YOLO's) has
pixel i span [i, i + 1): its centroids are half a pixel right of and below the replay's,
where pixel i is at i (docs/api.md, as the paper's chain and the camera models have it). The
finder moves them back (:data:`LABEL_OFFSET_PX`), so a ball is located from where it is.
"""

from __future__ import annotations

import dataclasses
import threading
from dataclasses import dataclass, field

import numpy as np

from estimator.detection import Detection
from estimator.detection.real import BallCheck, BallModel, Candidate, RealBallDetector

__all__ = ["DETECTORS", "LABEL_OFFSET_PX", "BallFinder", "Found"]

DETECTORS = ("paper", "real")
LABEL_OFFSET_PX = 0.5
"""The real detector's centroids less this (in u and v) are in the replay's convention."""


def _to_replay(candidate: Candidate) -> Candidate:
    det = candidate.detection
    return dataclasses.replace(candidate, detection=dataclasses.replace(
        det, cx_px=det.cx_px - LABEL_OFFSET_PX, cy_px=det.cy_px - LABEL_OFFSET_PX))


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
        ranked = [_to_replay(c) for c in self._detector().candidates(image)]
        best = ranked[0] if ranked and ranked[0].check_score >= self.model.threshold else None
        return Found(None if best is None else best.detection, tuple(ranked))
