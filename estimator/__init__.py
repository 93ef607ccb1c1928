"""The Dual-Sight Perspective ball estimator: pure numpy + OpenCV, no I/O.

Four rooms: detection (:mod:`estimator.detection`), calibrations (:mod:`estimator.calibration`:
models, fitting, JSON form), the ball tracker (:mod:`estimator.tracking`) and a robot's pose
from the field's white lines (:mod:`estimator.localisation`). Beside them:
paper mode (:mod:`estimator.paper`), the corrected estimator (:mod:`estimator.corrected`),
the estimates that flow between the parts (:mod:`estimator.estimates`), their noise models
(:mod:`estimator.noise`), fusion of several robots (:mod:`estimator.fusion`), geometry,
errors and the numbers defined once (:mod:`estimator.constants`). Camera models live in
:mod:`estimator.camera` (imported on demand, not re-exported here, as is
:mod:`estimator.localisation`). Imports run one way:
fusion -> tracking -> noise -> estimates; the estimator imports nothing else of the project.
"""

from estimator.calibration import (
    PAPER_CALIBRATION,
    Calibration,
    CameraCalibration,
    FitResult,
    LinearCalibration,
    LookupCalibration,
    MirrorCalibration,
    calibration_from_dict,
    calibration_from_json,
    calibration_to_json,
    fit_all,
    fit_linear,
    fit_lookup,
    fit_mirror,
)
from estimator.constants import (
    BALL_RADIUS_M,
    NS_PER_S,
    PAPER_B_M,
    PAPER_CENTRE_PX,
    PAPER_IMAGE_SIZE_PX,
    PAPER_K_M_PER_PX,
    PAPER_R2,
)
from estimator.corrected import ball_visibility, estimate_ball
from estimator.detection import Detection, DetectionParams, detect_ball, detect_blobs
from estimator.errors import (
    CalibrationError,
    CalibrationFormatError,
    DetectionError,
    EstimatorError,
    FitError,
    FusionError,
    GeometryError,
    LocalisationError,
    OutOfRangeError,
    UnknownFusionError,
)
from estimator.estimates import BallEstimate, FusedEstimate
from estimator.fusion import (
    FUSION_METHODS,
    Fusion,
    MeanFusion,
    NearestFusion,
    RobustFusion,
    WeightedFusion,
    get_fusion,
)
from estimator.geometry import (
    RobotPose,
    normalise_quaternion,
    quaternion_from_yaw,
    slerp,
    wrap_angle,
    yaw_from_quaternion,
)
from estimator.noise import (
    RANGE_SIGMA_COEFFICIENTS,
    CalibratedNoise,
    Noise,
    NoiseModel,
    range_sigma_m,
)
from estimator.paper import locate_ball, rpy_from_quaternion
from estimator.tracking import BallTracker, Measurement, TrackerParams, TrackFusion, TrackState

__all__ = [
    "BALL_RADIUS_M",
    "FUSION_METHODS",
    "NS_PER_S",
    "PAPER_B_M",
    "PAPER_CALIBRATION",
    "PAPER_CENTRE_PX",
    "PAPER_IMAGE_SIZE_PX",
    "PAPER_K_M_PER_PX",
    "PAPER_R2",
    "RANGE_SIGMA_COEFFICIENTS",
    "BallEstimate",
    "BallTracker",
    "CalibratedNoise",
    "Calibration",
    "CalibrationError",
    "CalibrationFormatError",
    "CameraCalibration",
    "Detection",
    "DetectionError",
    "DetectionParams",
    "EstimatorError",
    "FitError",
    "FitResult",
    "FusedEstimate",
    "Fusion",
    "FusionError",
    "GeometryError",
    "LinearCalibration",
    "LocalisationError",
    "LookupCalibration",
    "MeanFusion",
    "Measurement",
    "MirrorCalibration",
    "NearestFusion",
    "Noise",
    "NoiseModel",
    "OutOfRangeError",
    "RobotPose",
    "RobustFusion",
    "TrackFusion",
    "TrackState",
    "TrackerParams",
    "UnknownFusionError",
    "WeightedFusion",
    "ball_visibility",
    "calibration_from_dict",
    "calibration_from_json",
    "calibration_to_json",
    "detect_ball",
    "detect_blobs",
    "estimate_ball",
    "fit_all",
    "fit_linear",
    "fit_lookup",
    "fit_mirror",
    "get_fusion",
    "locate_ball",
    "normalise_quaternion",
    "quaternion_from_yaw",
    "range_sigma_m",
    "rpy_from_quaternion",
    "slerp",
    "wrap_angle",
    "yaw_from_quaternion",
]
