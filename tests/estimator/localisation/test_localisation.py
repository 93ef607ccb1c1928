"""The field-line pose correction on synthetic omni images of a known carpet
(:mod:`field_images`): known lines give the known pose, the field's symmetry never flips a
pose, too little to see keeps the prior, the same bits whatever the thread count."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest
from field_images import field_lines, render_carpet

from dsp.field import FIELDS
from estimator.camera import CAMERA_MODELS, make_camera
from estimator.errors import LocalisationError
from estimator.geometry import RobotPose, wrap_angle
from estimator.localisation import (
    CorrectionHold,
    DistanceGrid,
    FitStatus,
    GroundGrid,
    LinePointParams,
    LinePoints,
    PoseCorrection,
    PoseFitParams,
    correct_pose,
    detect_line_points,
    pose_fit,
)

LINES = field_lines(FIELDS["18x12"])
GRID = DistanceGrid.build(LINES)
PRIOR_COV = np.diag([0.05**2, 0.05**2, math.radians(1.0) ** 2])
GROUND = {m: GroundGrid.build(make_camera(m)) for m in CAMERA_MODELS}


def _errors(pose: RobotPose, truth: RobotPose) -> tuple[float, float]:
    return (math.hypot(pose.x_m - truth.x_m, pose.y_m - truth.y_m),
            abs(math.degrees(wrap_angle(pose.yaw_rad - truth.yaw_rad))))


def _fit(model: str, truth: RobotPose, prior: RobotPose, *,
         image: np.ndarray | None = None) -> tuple[PoseCorrection, LinePoints]:
    img = render_carpet(make_camera(model), truth) if image is None else image
    pts = detect_line_points(img, GROUND[model])
    return correct_pose(prior, PRIOR_COV, pts, GRID, LINES), pts


def test_distance_is_exact_on_known_points() -> None:
    pts = np.array([[0.0, 0.0], [0.3, 1.0], [9.2, 0.0], [0.0, 2.5], [-6.0, 0.05]])
    d, n = LINES.distance(pts)
    # (0, 0): on the half-way line; (0.3, 1): 0.3 from it; (9.2, 0): 0.2 behind the goal
    # line; (0, 2.5): on the half-way line; (-6, 0.05): inside the penalty mark
    np.testing.assert_allclose(d, [0.0, 0.3, 0.2, 0.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(n[1], [1.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(n[2], [1.0, 0.0], atol=1e-12)


def test_distance_grid_matches_exact_near_lines() -> None:
    rng = np.random.default_rng(1)
    pts = rng.uniform([-9.5, -6.5], [9.5, 6.5], (20000, 2))
    exact, _ = LINES.distance(pts)
    grid, _ = GRID.distance(pts)
    near = exact < 0.15
    err = np.abs(exact - grid)[near]
    assert np.percentile(err, 99) < 1e-3  # exact near straight lines, bar corners
    assert err.max() < 0.05  # at a corner the nearest line changes within a cell
    far, _ = GRID.distance(np.array([[40.0, 0.0]]))
    assert far[0] == GRID.outside_m


def test_ground_grid_reads_the_pixel_of_its_ground_point() -> None:
    cam = make_camera("mirror")
    gg = GROUND["mirror"]
    i, j = np.nonzero(gg.valid)
    k = len(i) // 3
    ray = np.array([gg.x_m[i[k], j[k]], gg.y_m[i[k], j[k]], -cam.height_m])
    u, v = cam.ray_to_pixel(ray)
    img = np.zeros((cam.height_px, cam.width_px, 3), np.uint8)
    img[round(v), round(u)] = 255
    ground = cv2.remap(img, gg.map1, gg.map2, cv2.INTER_LINEAR)
    assert ground[i[k], j[k]].max() > 0
    assert not gg.valid[gg.valid.shape[0] // 2, gg.valid.shape[1] // 2]  # the robot's body


def test_line_points_lie_on_the_lines() -> None:
    """Seen from the true pose, the points found on the field are on the painted lines'
    centres (beyond the carpet's edge the hall's floor gives points too: off the field)."""
    truth = RobotPose(-6.2, 1.1, math.radians(20.0))
    pts = detect_line_points(render_carpet(make_camera("ideal"), truth), GROUND["ideal"])
    c, s = math.cos(truth.yaw_rad), math.sin(truth.yaw_rad)
    xy = pts.xy_m @ np.array([[c, s], [-s, c]]) + [truth.x_m, truth.y_m]
    xy = xy[LINES.inside(xy, PoseFitParams().field_margin_m)]
    assert len(xy) > 500
    d, _ = LINES.distance(xy)
    assert np.median(d) < 0.01
    assert np.percentile(d, 90) < 0.03


@pytest.mark.parametrize("model", CAMERA_MODELS)
@pytest.mark.parametrize("truth", [RobotPose(-4.3, 1.7, math.radians(35.0)),
                                   RobotPose(6.8, -2.4, math.radians(-90.0)),
                                   RobotPose(0.4, 0.3, math.radians(180.0))],
                         ids=["left-half", "penalty-area", "centre-circle"])
def test_known_lines_give_the_known_pose(model: str, truth: RobotPose) -> None:
    prior = RobotPose(truth.x_m + 0.08, truth.y_m - 0.06, truth.yaw_rad + math.radians(1.5))
    result, _ = _fit(model, truth, prior)
    assert result.status is FitStatus.OK
    pos, yaw = _errors(result.pose, truth)
    assert pos < 0.01 and yaw < 0.1
    before = _errors(prior, truth)
    assert pos < before[0] / 5 and yaw < before[1] / 5
    sd = np.sqrt(np.diag(result.covariance))
    assert np.all(sd < np.sqrt(np.diag(PRIOR_COV)))
    assert result.inliers >= PoseFitParams().min_inliers


def test_a_prior_on_the_wrong_line_is_not_followed() -> None:
    """A prior 0.75 m off (the goal area's depth: the next parallel line) that claims 5 cm:
    the fit may find the wrong line; its result contradicts the prior and is refused."""
    truth = RobotPose(-7.6, 0.4, 0.0)
    prior = RobotPose(truth.x_m + 0.75, truth.y_m, truth.yaw_rad)
    result, _ = _fit("ideal", truth, prior)
    assert not (result.ok and _errors(result.pose, truth)[0] < 0.1)
    if not result.ok:
        assert result.pose == prior


@pytest.mark.parametrize("model", ["fisheye", "mirror"])
def test_symmetric_field_never_flips(model: str) -> None:
    """The field looks the same from (x, y, yaw) and (-x, -y, yaw + pi): one image, two
    priors, and each result stays beside its own prior, even with a prior off by 0.1 m."""
    truth = RobotPose(5.0, -2.0, math.radians(-120.0))
    mirrored = RobotPose(-5.0, 2.0, wrap_angle(truth.yaw_rad + math.pi))
    img = render_carpet(make_camera(model), truth)
    for expected in (truth, mirrored):
        for dx, dy in ((0.0, 0.0), (0.07, -0.07)):
            prior = RobotPose(expected.x_m + dx, expected.y_m + dy, expected.yaw_rad)
            result, _ = _fit(model, truth, prior, image=img)
            assert result.ok
            assert _errors(result.pose, expected)[0] < 0.01


def test_a_pose_on_the_half_way_line_does_not_slide() -> None:
    """Beside the centre circle's symmetric lines a 2 deg yaw error and 0.1 m are undone,
    not traded for each other."""
    truth = RobotPose(0.0, 0.0, math.radians(90.0))
    prior = RobotPose(0.1, 0.0, truth.yaw_rad + math.radians(2.0))
    cov = np.diag([0.1**2, 0.1**2, math.radians(2.0) ** 2])
    pts = detect_line_points(render_carpet(make_camera("mirror"), truth), GROUND["mirror"])
    result = correct_pose(prior, cov, pts, GRID, LINES)
    assert result.ok
    pos, yaw = _errors(result.pose, truth)
    assert pos < 0.01 and yaw < 0.1


def test_too_few_points_keeps_the_prior() -> None:
    """Beyond the carpet, looking away from it: nothing on the field."""
    cam = make_camera("fisheye")
    truth = RobotPose(0.0, -7.4, math.radians(-90.0))
    prior = RobotPose(0.03, -7.42, truth.yaw_rad)
    img = render_carpet(cam, truth)
    img[cam.height_px // 2 - 60:] = 0  # the field side (behind the robot) hidden
    result, _ = _fit("fisheye", truth, prior, image=img)
    assert result.status is FitStatus.TOO_FEW_POINTS
    assert result.pose == prior
    assert result.points < PoseFitParams().min_points
    np.testing.assert_array_equal(result.covariance, PRIOR_COV)
    np.testing.assert_array_equal(result.line_information, np.zeros((3, 3)))


def test_a_dark_image_keeps_the_prior() -> None:
    prior = RobotPose(1.0, 2.0, 0.3)
    result, pts = _fit("mirror", prior, prior, image=np.zeros((1080, 1080, 3), np.uint8))
    assert len(pts) == 0
    assert result.status is FitStatus.TOO_FEW_POINTS and result.pose == prior


def test_what_is_seen_elsewhere_is_a_poor_fit() -> None:
    """Lines that fit nowhere near the prior (the image of another place)."""
    truth = RobotPose(-6.5, 2.5, math.radians(10.0))
    prior = RobotPose(2.3, -0.9, math.radians(70.0))
    result, _ = _fit("ideal", truth, prior)
    assert result.status in (FitStatus.POOR_FIT, FitStatus.JUMP)
    assert result.pose == prior


@pytest.mark.parametrize("threads", [1, 2, 4])
def test_bit_identical_whatever_the_thread_count(threads: int) -> None:
    truth = RobotPose(2.2, 3.1, math.radians(80.0))
    prior = RobotPose(2.25, 3.06, truth.yaw_rad - math.radians(0.8))
    img = render_carpet(make_camera("mirror"), truth)
    reference = _digest(img, prior, GROUND["mirror"])
    before = cv2.getNumThreads()
    try:
        cv2.setNumThreads(threads)
        again = _digest(img, prior, GroundGrid.build(make_camera("mirror")))
    finally:
        cv2.setNumThreads(before)
    assert again == reference


def _digest(img: np.ndarray, prior: RobotPose, grid: GroundGrid) -> bytes:
    pts = detect_line_points(img, grid)
    r = correct_pose(prior, PRIOR_COV, pts, GRID, LINES)
    return (pts.xy_m.tobytes() + pts.sigma_m.tobytes() + r.covariance.tobytes()
            + np.array([r.pose.x_m, r.pose.y_m, r.pose.yaw_rad]).tobytes())


def test_bad_inputs_are_refused() -> None:
    gg = GROUND["ideal"]
    with pytest.raises(LocalisationError, match="shape"):
        detect_line_points(np.zeros((100, 100, 3), np.uint8), gg)
    pts = LinePoints(np.zeros((0, 2)), np.zeros(0), np.zeros(0))
    prior = RobotPose(0.0, 0.0, 0.0)
    with pytest.raises(LocalisationError, match="positive definite"):
        correct_pose(prior, np.diag([1.0, -1.0, 1.0]), pts, GRID, LINES)
    with pytest.raises(LocalisationError, match="3 x 3"):
        correct_pose(prior, np.eye(2), pts, GRID, LINES)
    with pytest.raises(LocalisationError, match="finite"):
        correct_pose(RobotPose(math.nan, 0.0, 0.0), PRIOR_COV, pts, GRID, LINES)
    with pytest.raises(LocalisationError, match="parameters"):
        PoseFitParams(stages=())
    with pytest.raises(LocalisationError, match="parameters"):
        LinePointParams(cell_m=0.0)


def _correction(status: FitStatus, pose: RobotPose) -> PoseCorrection:
    cov = np.diag([1e-6, 1e-6, 1e-8])
    return PoseCorrection(pose, cov, status, 100, 100 if status is FitStatus.OK else 0,
                          np.zeros((3, 3)))


def test_the_hold_carries_a_correction_over_failed_frames() -> None:
    hold = CorrectionHold(max_age_ns=2_000_000_000)
    believed = RobotPose(1.05, 2.0, 0.01)
    good = hold.update("r1", 0, believed, PRIOR_COV,
                       _correction(FitStatus.OK, RobotPose(1.0, 2.0, 0.0)))
    assert good.source == "lines"
    later = RobotPose(1.55, 2.0, 0.01)  # the robot drove 0.5 m; the bias is the same
    held = hold.update("r1", 500_000_000, later, PRIOR_COV,
                       _correction(FitStatus.TOO_FEW_POINTS, later))
    assert held.source == "held"
    assert held.pose.x_m == pytest.approx(1.5) and held.pose.yaw_rad == pytest.approx(0.0)
    assert np.trace(held.covariance) > np.trace(good.covariance)  # it grew with the age
    other = hold.update("r2", 500_000_000, later, PRIOR_COV,
                        _correction(FitStatus.POOR_FIT, later))
    assert other.source == "prior" and other.pose == later  # no fit of its own yet
    stale = hold.update("r1", 3_000_000_000, later, PRIOR_COV,
                        _correction(FitStatus.JUMP, later))
    assert stale.source == "prior" and stale.pose == later


def test_the_lines_information_is_divided_by_its_scale() -> None:
    """Guards H_L / information_scale: halving the scale doubles the lines' information
    (the same points, the same pose), and the covariance is (P0^-1 + H_L / s)^-1 plus the
    floor; information multiplied by the scale would halve it instead."""
    model, truth = CAMERA_MODELS[0], RobotPose(-4.3, 1.7, math.radians(35.0))
    prior = RobotPose(truth.x_m + 0.08, truth.y_m - 0.06, truth.yaw_rad + math.radians(1.5))
    pts = detect_line_points(render_carpet(make_camera(model), truth), GROUND[model])
    fits = {s: correct_pose(prior, PRIOR_COV, pts, GRID, LINES,
                            PoseFitParams(information_scale=s)) for s in (0.5, 0.25)}
    assert all(f.status is FitStatus.OK for f in fits.values())
    assert fits[0.5].pose == fits[0.25].pose
    np.testing.assert_allclose(fits[0.25].line_information, 2.0 * fits[0.5].line_information,
                               rtol=1e-12)
    floor = np.diag(np.square(PoseFitParams().floor_sigma))
    for f in fits.values():
        expected = np.linalg.inv(np.linalg.inv(PRIOR_COV) + f.line_information) + floor
        np.testing.assert_allclose(f.covariance, expected, rtol=1e-9)
    assert np.all(np.diag(fits[0.25].covariance) < np.diag(fits[0.5].covariance))


# A fit that starts from the robot's last correction: the same pose in fewer steps.


def _counted(monkeypatch: pytest.MonkeyPatch) -> list[int]:
    calls = [0]
    inner = pose_fit._normal_equations

    def counting(*args: object) -> object:
        calls[0] += 1
        return inner(*args)  # type: ignore[arg-type]

    monkeypatch.setattr(pose_fit, "_normal_equations", counting)
    return calls


@pytest.mark.parametrize("model", CAMERA_MODELS)
def test_a_warm_start_finds_the_same_pose_in_fewer_steps(
        model: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """From a start 1 cm and 0.3 deg off the minimum (the last frame's correction carried
    over, with the belief's white noise of two moments), only the last stage runs: the
    pose is the cold fit's to a fraction of a millimetre, in fewer steps."""
    truth = RobotPose(-4.3, 1.7, math.radians(35.0))
    prior = RobotPose(truth.x_m + 0.06, truth.y_m - 0.04, truth.yaw_rad + math.radians(1.2))
    pts = detect_line_points(render_carpet(make_camera(model), truth),
                             GroundGrid.build(make_camera(model)))
    calls = _counted(monkeypatch)
    cold = correct_pose(prior, PRIOR_COV, pts, GRID, LINES)
    cold_steps = calls[0]
    c = cold.pose
    start = RobotPose(c.x_m + 0.01, c.y_m - 0.01, c.yaw_rad + math.radians(0.3))
    calls[0] = 0
    warm = correct_pose(prior, PRIOR_COV, pts, GRID, LINES, start=start)
    assert cold.status is FitStatus.OK and warm.status is FitStatus.OK
    assert math.hypot(warm.pose.x_m - c.x_m, warm.pose.y_m - c.y_m) < 5e-4
    assert abs(math.degrees(wrap_angle(warm.pose.yaw_rad - c.yaw_rad))) < 0.01
    assert calls[0] < cold_steps
    # the prior is still the belief: the covariance and the jump test are the cold fit's
    # (each taken where its last step began, under a millimetre from the minimum): the
    # sigmas within 5 %, the correlations within 0.02
    sw, sc = np.sqrt(np.diag(warm.covariance)), np.sqrt(np.diag(cold.covariance))
    np.testing.assert_allclose(sw, sc, rtol=0.05)
    np.testing.assert_allclose(warm.covariance / np.outer(sw, sw),
                               cold.covariance / np.outer(sc, sc), atol=0.02)


def test_a_warm_start_far_from_the_lines_still_fails_the_jump_test() -> None:
    """A start on the wrong line (0.75 m off) with a 5 cm prior: the minimum found there
    contradicts the prior and is refused, as from a cold start."""
    model, truth = CAMERA_MODELS[0], RobotPose(4.5, 1.0, math.radians(90.0))
    pts = detect_line_points(render_carpet(make_camera(model), truth),
                             GroundGrid.build(make_camera(model)))
    wrong = RobotPose(truth.x_m + 0.75, truth.y_m, truth.yaw_rad)
    result = correct_pose(truth, PRIOR_COV, pts, GRID, LINES, start=wrong)
    assert result.status is not FitStatus.OK or math.hypot(
        result.pose.x_m - truth.x_m, result.pose.y_m - truth.y_m) < 0.02


def test_the_warm_stages_are_checked() -> None:
    with pytest.raises(Exception, match="pose fit parameters"):
        PoseFitParams(warm_stages=0)
    with pytest.raises(Exception, match="pose fit parameters"):
        PoseFitParams(stages=(0.1, 0.05), warm_stages=3)


def test_the_hold_carries_the_last_correction_to_a_new_belief() -> None:
    hold = CorrectionHold()
    assert hold.carried("r1", 0, RobotPose(0.0, 0.0, 0.0), 10**9) is None  # none yet
    cov = np.diag([1e-6, 1e-6, 1e-8])
    hold.update("r1", 0, RobotPose(1.05, 2.0, 0.02), PRIOR_COV, PoseCorrection(
        RobotPose(1.0, 2.0, 0.0), cov, FitStatus.OK, 100, 100, np.zeros((3, 3))))
    moved = RobotPose(1.55, 2.5, 0.03)  # 0.5 s on: the same bias
    start = hold.carried("r1", 500_000_000, moved, 500_000_000)
    assert start is not None
    assert (start.x_m, start.y_m, start.yaw_rad) == pytest.approx((1.5, 2.5, 0.01))
    assert hold.carried("r1", 500_000_001, moved, 500_000_000) is None  # too old
    assert hold.carried("r1", -1, moved, 500_000_000) is None  # before it
    assert hold.carried("r2", 0, moved, 500_000_000) is None  # another robot's
