"""Self-localisation from the field's white lines: a per-frame pose correction.

The omni image that sees the ball also sees the lines. :mod:`.line_points` finds their
pixels on the ground around the robot (through any camera model), :mod:`.pose_fit` fits
them to the field's markings (:mod:`.field_lines`) around the pose the robot believes,
with a covariance and a failure status (the prior is kept then). Pure numpy + OpenCV, no
I/O; the caller builds :class:`FieldLines` from its field description once, the grids
(:class:`DistanceGrid`, one :class:`GroundGrid` per camera model) once, then per image::

    points = detect_line_points(image_bgr, ground_grid)
    result = correct_pose(believed_pose, believed_covariance, points, distance_grid, lines)
    pose = result.pose            # the prior itself unless result.ok

and, across frames, :class:`CorrectionHold` (:mod:`.pose_hold`) carries a robot's last
accepted correction over the frames whose fit failed, and :class:`CorrectionSpread`
(:mod:`.spread`) learns from the corrections how far each robot's belief is off: the prior
of its next fits.
"""

from estimator.localisation.field_lines import DistanceGrid, FieldLines
from estimator.localisation.line_points import (
    GroundGrid,
    LinePointParams,
    LinePoints,
    detect_line_points,
)
from estimator.localisation.pose_fit import FitStatus, PoseCorrection, PoseFitParams, correct_pose
from estimator.localisation.pose_hold import CorrectionHold, HeldPose
from estimator.localisation.spread import CorrectionSpread, SpreadParams

__all__ = [
    "CorrectionHold",
    "CorrectionSpread",
    "DistanceGrid",
    "FieldLines",
    "FitStatus",
    "GroundGrid",
    "HeldPose",
    "LinePointParams",
    "LinePoints",
    "PoseCorrection",
    "PoseFitParams",
    "SpreadParams",
    "correct_pose",
    "detect_line_points",
]
