"""The real-ball detector: a venue's colour model proposes, a learned check decides.

For real camera images (real light, a ball of any colour, shirts, robot covers and crowds
of the ball's colour), fitted per venue from a few labelled frames:

- :mod:`estimator.detection.real.model`: a venue's :class:`BallModel` (colour table over
  YCrCb, field mask, size range and size line, the venue's head) and its JSON form;
- :mod:`estimator.detection.real.fit`: :func:`fit_ball_model`, the colour, field and size
  fit from (image, ball boxes) samples; :mod:`estimator.detection.real.adapt`:
  :func:`adapt`, the venue's head on the shared check;
- :mod:`estimator.detection.real.candidates`: ball-coloured blobs at several levels;
- :mod:`estimator.detection.real.field`: where the field is (its far edge), and the rule
  for a candidate beyond it;
- :mod:`estimator.detection.real.check`: :class:`BallCheck`, the shared small CNN, from the
  ONNX bytes the caller read (the shipped ones: ``ball_check.onnx`` beside this file, with
  its NOTICE), run through OpenCV's ``dnn``;
- :mod:`estimator.detection.real.detector`: :class:`RealBallDetector`.

Pure: arrays and bytes in, records out; nothing here reads or writes a file.
"""

from __future__ import annotations

from estimator.detection.real.adapt import adapt
from estimator.detection.real.check import BallCheck, CheckSpec
from estimator.detection.real.detector import Candidate, RealBallDetector, Search, search_for
from estimator.detection.real.fit import Box, fit_ball_model
from estimator.detection.real.model import BallModel, model_from_dict, model_to_dict

__all__ = ["BallCheck", "BallModel", "Box", "Candidate", "CheckSpec", "RealBallDetector",
           "Search", "adapt", "fit_ball_model", "model_from_dict", "model_to_dict",
           "search_for"]
