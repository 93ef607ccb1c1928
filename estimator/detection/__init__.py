"""Finding the ball in an omnidirectional image (the paper's Section II.F, eq. 1-2).

- :mod:`estimator.detection.chain`: the paper's chain (HSV threshold, OPEN, blobs, image
  moments), sub-pixel centroids and the ranking of several blobs;
- :mod:`estimator.detection.regions`: the coarse-to-fine search that runs the chain only in
  boxes around where the colour is;
- :mod:`estimator.detection.real`: the real-ball detector for real camera images (a venue's
  colour model fitted from a few labelled frames proposes candidates, a small learned check
  run through OpenCV's dnn decides). The paper's chain stays the default.
"""

from __future__ import annotations

from estimator.detection.chain import Detection, DetectionParams, detect_ball, detect_blobs

__all__ = ["Detection", "DetectionParams", "detect_ball", "detect_blobs"]
