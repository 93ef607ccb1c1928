"""A lookup camera with its height: the calibration's ranges make a projection model."""

from __future__ import annotations

import math

import numpy as np
import pytest

from estimator.calibration import CameraCalibration, MirrorCalibration
from estimator.calibration.models import LookupCalibration
from estimator.camera import make_camera
from estimator.table_camera import TableCamera, table_camera

MIRROR = make_camera("mirror", width_px=1080, height_px=1080, cu_px=539.0, cv_px=539.0,
                     max_radius_px=539.0)


def _sampled(camera: object, radii: np.ndarray) -> LookupCalibration:
    cal = CameraCalibration(camera)  # type: ignore[arg-type]
    return LookupCalibration(tuple(radii), tuple(cal.range_m(float(r)) for r in radii))


def test_a_table_of_the_mirrors_ball_ranges_gives_the_mirrors_rays() -> None:
    """The ball ranges a mirror camera gives at 40..530 px, every 10 px, as a lookup table,
    with the mirror's height: a ground point 0.5-7 m away is seen within half a pixel of
    where the mirror model puts it, and each pixel's ray is the mirror's."""
    table = table_camera(_sampled(MIRROR, np.arange(40.0, 531.0, 10.0)),
                         height_m=MIRROR.height_m, width_px=1080, height_px=1080,
                         centre_px=(539.0, 539.0), max_radius_px=530.0)
    rng = np.random.default_rng(3)
    dist, bearing = rng.uniform(0.5, 7.0, 200), rng.uniform(-math.pi, math.pi, 200)
    rays = np.column_stack([dist * np.cos(bearing), dist * np.sin(bearing),
                            np.full(200, -MIRROR.height_m)])
    uv_t, uv_m = table.ray_to_pixel(rays), MIRROR.ray_to_pixel(rays)
    assert np.max(np.hypot(*(uv_t - uv_m).T)) < 0.5
    back = table.pixel_to_ray(uv_t[:, 0], uv_t[:, 1])
    np.testing.assert_allclose(back, rays / np.linalg.norm(rays, axis=1)[:, None], atol=1e-6)


def test_no_ray_outside_the_sampled_radii() -> None:
    table = table_camera(_sampled(MIRROR, np.arange(40.0, 531.0, 10.0)),
                         height_m=MIRROR.height_m, width_px=1080, height_px=1080,
                         centre_px=(539.0, 539.0), max_radius_px=500.0)
    assert table.r_px[0] == 40.0 and table.max_radius_px == 500.0
    assert np.isnan(table.nadir_angle_rad([39.0, 500.5])).all()
    assert np.isfinite(table.nadir_angle_rad([40.0, 500.0])).all()
    assert np.isnan(table.radius_px([0.0, math.radians(89.9)])).all()


def test_a_mirror_law_ends_at_its_horizon() -> None:
    """d = a tan(b r) has no range from r = pi / (2 b) on: the table stops before it."""
    law = MirrorCalibration(a_m=1.2, b_rad_per_px=math.pi / 1000.0)  # horizon at 500 px
    table = table_camera(law, height_m=0.85, width_px=1080, height_px=1080,
                         centre_px=(539.0, 539.0), max_radius_px=539.0)
    assert table.r_px[0] == 0.0 and 499.0 <= table.max_radius_px < 500.0
    assert np.all(np.diff(table.nadir_rad) > 0)


def test_a_level_stretch_leaves_its_samples_out() -> None:
    flat = LookupCalibration((40.0, 100.0, 200.0, 300.0), (0.5, 1.5, 1.5, 4.0))
    table = table_camera(flat, height_m=0.85, width_px=640, height_px=640,
                         centre_px=(319.5, 319.5), max_radius_px=300.0)
    assert np.all(np.diff(table.nadir_rad) > 0) and np.all(np.diff(table.r_px) > 0)
    assert not any(100.0 < r < 200.0 for r in table.r_px)  # the level stretch


def test_bad_tables_are_refused() -> None:
    law = LookupCalibration((40.0, 300.0), (0.5, 4.0))
    with pytest.raises(ValueError, match="above the ball's centre"):
        table_camera(law, height_m=0.05, width_px=640, height_px=640,
                     centre_px=(319.5, 319.5), max_radius_px=300.0)
    with pytest.raises(ValueError, match="no range"):
        table_camera(LookupCalibration((40.0, 300.0), (-4.0, -0.5)), height_m=0.85,
                     width_px=640, height_px=640, centre_px=(319.5, 319.5),
                     max_radius_px=300.0)
    with pytest.raises(ValueError, match="increasing"):
        TableCamera(r_px=(1.0, 2.0), nadir_rad=(0.2, 0.1))
