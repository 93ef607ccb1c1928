"""A ball detector: the centroid of every orange pixel (no opening, no blob choice).

The contract (dual-sight's ``replay.plugins.Detector``): a class made with no arguments,
with a ``name`` and ``detect(image_bgr) -> estimator.detection.Detection | None``, safe to
call from several threads at once (it keeps no state).
"""

from __future__ import annotations

import cv2
import numpy as np

from estimator.detection import Detection

HSV_LOWER = (5, 120, 80)
HSV_UPPER = (25, 255, 255)
MIN_PIXELS = 4


class CentroidDetector:
    name = "example-centroid"

    def detect(self, image_bgr: np.ndarray) -> Detection | None:
        hsv = cv2.cvtColor(image_bgr, cv2.COLOR_BGR2HSV)
        mask = cv2.inRange(hsv, np.array(HSV_LOWER, np.uint8), np.array(HSV_UPPER, np.uint8))
        rows, cols = np.nonzero(mask)
        if len(rows) < MIN_PIXELS:
            return None
        x, y, w, h = cv2.boundingRect(mask)
        return Detection(cx_px=float(cols.mean()), cy_px=float(rows.mean()),
                         area_px=float(len(rows)), bbox_px=(x, y, w, h), circularity=1.0,
                         outline_px=np.zeros((0, 2), np.int32))
