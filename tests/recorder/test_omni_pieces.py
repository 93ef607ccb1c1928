"""OmniRenderer renders only what the lens sees, at the size the omni image needs.

A stand-in world draws one bright spot about a 3-D point with the very view and projection
matrices the renderer hands it (the OpenGL convention: NDC -> pixel i covering
[i - 0.5, i + 0.5]), so the crops, the off-centre frustums, the tiling and the pieces' sizes
are checked against the camera model to a small fraction of a pixel, without pybullet.
The spot is a Gaussian in the angle from the point, as a real object looks the same
whichever view draws it, at whatever resolution.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import recorder.omni as omni_module
import recorder.omni_layout as omni_layout
from estimator.camera import CAMERA_MODELS, make_camera
from recorder.omni import OmniRenderer
from recorder.world import ROBOT_RGB

SPOT_RAD = 1.2 / 512
"""The spot's sigma: 1.2 px at a cube face's centre (1024 px faces)."""


class PointWorld:
    """Renders a Gaussian spot (sigma SPOT_RAD) about the direction of a 3-D point."""

    renderer = "egl"

    def __init__(self, point: np.ndarray) -> None:
        self.point = np.asarray(point, float)
        self.calls: list[tuple[int, int]] = []

    def render_into(self, out: np.ndarray, view: list[float], proj: list[float]) -> None:
        out[...] = self.render(out.shape[1], out.shape[0], view, proj)

    def render(self, width: int, height: int, view: list[float],
               proj: list[float]) -> np.ndarray:
        self.calls.append((width, height))
        vm = np.array(view).reshape(4, 4).T
        inv = np.linalg.inv(np.array(proj).reshape(4, 4).T @ vm)
        v, u = np.mgrid[0:height, 0:width]
        x = (u + 0.5) / width * 2 - 1  # each pixel's centre in NDC
        y = 1 - (v + 0.5) / height * 2
        ends = []
        for z in (-1.0, 1.0):  # the pixel's ray from the near to the far plane
            p = np.stack([x, y, np.full_like(x, z), np.ones_like(x)], axis=-1) @ inv.T
            ends.append(p[..., :3] / p[..., 3:])
        ray = ends[1] - ends[0]
        eye = np.linalg.inv(vm)[:3, 3]
        to_point = (self.point - eye) / np.linalg.norm(self.point - eye)
        cos = (ray @ to_point) / np.linalg.norm(ray, axis=-1)
        angle = np.arccos(np.clip(cos, -1.0, 1.0))
        spot = 250.0 * np.exp(-(angle**2) / (2 * SPOT_RAD**2))
        return np.repeat(np.rint(spot)[..., None], 3, axis=-1).astype(np.uint8)


def _spot(img: np.ndarray, background: np.ndarray) -> tuple[float, float]:
    w = img[..., 0].astype(np.float64) - background[..., 0]
    w[w < 8] = 0  # the spot, not the remap's faint tails
    v, u = np.mgrid[0:img.shape[0], 0:img.shape[1]]
    return float((w * u).sum() / w.sum()), float((w * v).sum() / w.sum())


@pytest.mark.parametrize("name", ["fisheye", "mirror"])
def test_five_views_one_render_each_and_fewer_pixels(name: str) -> None:
    omni = OmniRenderer(make_camera(name))
    assert omni.face_names == ("down", "front", "left", "back", "right")
    for piece in omni._pieces[1:]:  # the side views look down a little, and see no sky
        f = piece.view.forward
        assert f[2] < 0
        horizon_row = piece.tile[1] / 2 - 0.5 + f[2] / math.hypot(f[0], f[1]) * (
            piece.size[1] / 2 / piece.half_tan)
        assert horizon_row - 4 <= piece.rows[0] <= horizon_row + 16
    world = PointWorld(np.array([1.0, 0.0, 0.0]))
    omni.render_atlas(world, 0.0, 0.0, 0.0)  # type: ignore[arg-type]
    assert len(world.calls) == 5  # was 9: four side faces in two bands each, and the down face
    assert all(w <= 1024 and h <= 768 for w, h in world.calls)
    # was 2.03 (fisheye) and 1.69 Mpx (mirror) in square-pixel bands of cube faces
    assert omni.rendered_px < 1.65e6


def test_the_ideal_camera_still_renders_one_whole_face() -> None:
    omni = OmniRenderer(make_camera("ideal"))
    assert omni.face_names == ("down",)
    assert omni.pieces == (("down", omni.face_px + 2, omni.face_px + 2),)
    assert omni._pieces[0].whole
    world = PointWorld(np.array([0.0, 0.0, -1.0]))
    omni.render_atlas(world, 0.0, 0.0, 0.0)  # type: ignore[arg-type]
    assert world.calls == [(513, 513)] * 4  # 1026 px square, in EGL's 1024 x 768 window


def _cube_bar(cam: object, face_px: int) -> float:
    """Face pixels per omni pixel at the coarsest pixel of a cube of face_px faces."""
    rays, _, valid = omni_layout._rays(cam)  # type: ignore[arg-type]
    cube = omni_layout._cube()
    best = omni_layout._nearest(rays, cube, 1.0)
    smin = []
    for k, face in enumerate(cube):
        sel = valid & (best == k)
        if sel.any():
            a, b = omni_layout._plane(rays, face, sel)
            smin.append(omni_layout._smin(omni_layout._jacobian(a, b, sel, 1), 1.0))
    return face_px / 2.0 * min(smin)


@pytest.mark.parametrize("face_px", [1024, 256])
@pytest.mark.parametrize("name", ["fisheye", "mirror"])
def test_the_pieces_cover_every_ray_at_the_sampling_of_a_cube(name: str, face_px: int) -> None:
    """Every omni pixel reads its own ray from a rendered pixel of its piece (and the 2 x 2
    neighbourhood bilinear reads, with either renderer's offset), and one omni pixel spans
    at least as many atlas pixels, every way, as on a cube of face_px faces (within the
    1 % a piece may be shrunk by to fit one render)."""
    cam = make_camera(name)
    omni = OmniRenderer(cam, face_px=face_px)
    drawn = ~omni._black
    v, u = np.nonzero(drawn)
    mx, my = omni._map_x[drawn].astype(np.float64), omni._map_y[drawn].astype(np.float64)
    want = cam.pixel_to_ray(u.astype(np.float64), v.astype(np.float64))
    seen = np.zeros(len(u), bool)
    for piece in omni._pieces:
        cols = piece.shape[0]
        mine = (mx >= piece.x0) & (mx < piece.x0 + cols)
        # atlas -> the piece's window -> its tangent plane -> a ray
        x, y = mx[mine] - piece.x0 + piece.cols[0], my[mine] + piece.rows[0]
        assert x.min() - 0.5 >= piece.cols[0] and x.max() + 1.5 <= piece.cols[1]
        assert y.min() - 0.5 >= piece.rows[0] and y.max() + 1.5 <= piece.rows[1]
        nx, ny = piece.tile
        a = (x - (nx / 2.0 - 0.5)) * 2 * piece.half_tan / piece.size[0]
        b = ((ny / 2.0 - 0.5) - y) * 2 * piece.half_tan / piece.size[1]
        ray = piece.view.forward + a[:, None] * piece.view.right + b[:, None] * piece.view.up
        ray /= np.linalg.norm(ray, axis=1, keepdims=True)
        err_px = np.degrees(np.arccos(np.clip((ray * want[mine]).sum(1), -1, 1)))
        assert err_px.max() < 0.01  # degrees: float32 tables, ~1/100 of an omni pixel
        seen |= mine
    assert seen.all()
    # sampling: smallest singular value of d(atlas) / d(omni) inside each piece's region
    bar = _cube_bar(cam, face_px)
    for piece in omni._pieces:
        cols, _ = piece.shape
        sel = drawn & (omni._map_x >= piece.x0) & (omni._map_x < piece.x0 + cols)
        jac = omni_layout._jacobian(omni._map_x.astype(np.float64),
                                    omni._map_y.astype(np.float64), sel, 1)
        assert omni_layout._smin(jac, 1.0) >= bar / omni_layout.FIT_SLACK - 1e-6, piece.view.name


@pytest.mark.parametrize("renderer", ["egl", "tiny"])
@pytest.mark.parametrize("name", CAMERA_MODELS)
def test_the_remap_draws_the_body_and_blacks_the_rest(name: str, renderer: str) -> None:
    omni = OmniRenderer(make_camera(name))
    atlas = omni._new_atlas()
    rng = np.random.default_rng(0)
    atlas[:, :-omni_module._PATCH_PX] = rng.integers(30, 256, atlas[:, :-4].shape, np.uint8)
    out = omni.remap(atlas, renderer)
    assert omni._body.sum() > 500 and omni._black.sum() > 1000
    assert (out[omni._black] == 0).all()
    assert (out[omni._body] == ROBOT_RGB[::-1]).all()
    assert (out[~omni._black & ~omni._body].max(axis=-1) >= 30).all()  # the scene elsewhere


@pytest.mark.parametrize("limit", [None, 300])
@pytest.mark.parametrize("name", CAMERA_MODELS)
def test_a_point_lands_where_the_model_puts_it(name: str, limit: int | None,
                                                monkeypatch: pytest.MonkeyPatch) -> None:
    if limit is not None:  # tile every piece in sub-renders of at most 300 px
        monkeypatch.setitem(omni_module.MAX_RENDER_PX, "egl", (limit, limit))
    cam = make_camera(name)
    omni = OmniRenderer(cam)
    eye = np.array([0.0, 0.0, cam.height_m])
    nothing = PointWorld(np.array([0.0, 0.0, 1e4]))  # above: on no face (the spot: not the body)
    background = omni.render(nothing, None, 0.0, 0.0, 0.0)  # type: ignore[arg-type]
    worst = 0.0
    for nadir_deg, azimuth_deg in ((25, 10), (30, 100), (44, 200), (46, 45), (60, 300),
                                   (75, 135), (84, 260)):
        n, a = math.radians(nadir_deg), math.radians(azimuth_deg)
        ray = np.array([math.sin(n) * math.cos(a), math.sin(n) * math.sin(a), -math.cos(n)])
        u0, v0 = cam.ray_to_pixel(ray)
        if not math.hypot(u0 - cam.cu_px, v0 - cam.cv_px) < cam.max_radius_px - 10:
            continue  # outside this lens's image circle
        world = PointWorld(eye + 5.0 * ray)
        u, v = _spot(omni.render(world, None, 0.0, 0.0, 0.0),  # type: ignore[arg-type]
                     background)
        worst = max(worst, math.hypot(u - u0, v - v0))
        if limit is not None:
            assert max(max(c) for c in world.calls) <= limit
    assert worst < 0.1, worst  # 0.06 px at most (the fisheye at 75 deg, on a seam)
