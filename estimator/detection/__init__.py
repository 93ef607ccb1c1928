"""Finding the ball in an omnidirectional image (the paper's Section II.F, eq. 1-2).

- :mod:`estimator.detection.chain`: the paper's chain (HSV threshold, OPEN, blobs, image
  moments), sub-pixel centroids and the ranking of several blobs;
- :mod:`estimator.detection.regions`: the coarse-to-fine search that runs the chain only in
  boxes around where the colour is.
"""

from __future__ import annotations

from estimator.detection.chain import Detection, DetectionParams, detect_ball, detect_blobs

__all__ = ["Detection", "DetectionParams", "detect_ball", "detect_blobs"]
