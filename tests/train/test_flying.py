"""train/flying.py (``train.py --flying SHARE``): balls in the air made from positive crops are
the same crops again from the same generator, smeared along one direction by the motion
blur, shrunk with their targets, and pasted over a background with no field. NumPy and
OpenCV only (no torch)."""

from __future__ import annotations

import importlib.util
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]


def _module() -> ModuleType:
    spec = importlib.util.spec_from_file_location("train_flying", ROOT / "train" / "flying.py")
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


fly = _module()


@pytest.fixture(autouse=True)
def _one_background(monkeypatch: pytest.MonkeyPatch) -> None:
    """Two negatives here: backgrounds only where there is no field."""
    monkeypatch.setattr(fly, "MIN_BACKGROUNDS", 1)


def _samples() -> tuple[np.ndarray, ...]:
    """Two positives (a bright disc of diameter 12, framed as the check frames a ball)
    and two negatives: a field-green one and one with no field (a value of 0.2)."""
    yy, xx = np.mgrid[0:24, 0:24] + 0.5
    disc = (np.hypot(xx - 12, yy - 12) < 6).astype(np.float32)
    x = np.zeros((4, 5, 24, 24), np.float32)
    for i in (0, 1):
        x[i, :3] = 0.3 + 0.6 * disc
        x[i, 3] = disc
        x[i, 4] = 1 - disc
    x[2, :3], x[2, 4] = 0.5, 1.0
    x[3, :3], x[3, 4] = 0.2, 0.0
    y = np.array([1, 1, 0, 0], np.float32)
    off = np.array([[0, 0, 0], [0.05, -0.05, 0.1], [0, 0, 0], [0, 0, 0]], np.float32)
    ctx = np.array([[0.1, 0.01, 0.8], [-0.2, 0.04, 0.8], [0, 0, 1.0], [0, 0, 0.0]],
                   np.float32)
    return x, y, off, ctx


def test_the_same_generator_gives_the_same_bytes() -> None:
    a = fly.flying(*_samples(), 1.5, np.random.default_rng(7))
    b = fly.flying(*_samples(), 1.5, np.random.default_rng(7))
    c = fly.flying(*_samples(), 1.5, np.random.default_rng(8))
    assert a[1].tolist() == [1.0] * 3 + [0.0] * 3
    assert all(p.tobytes() == q.tobytes() for p, q in zip(a, b, strict=True))
    assert a[0].tobytes() != c[0].tobytes()


def test_the_background_is_a_negative_with_no_field() -> None:
    x, _, _, ctx = fly.flying(*_samples(), 2.0, np.random.default_rng(0))
    assert len(x) == 8
    corner = x[:, :, :3, :3]
    assert np.allclose(corner[:, :3], 0.2) and np.all(corner[:, 4] == 0)
    assert np.all(ctx[:, 2] == 0)


def _spread(crop: np.ndarray) -> np.ndarray:
    """Eigenvalues of the second moments of the crop's difference from its background."""
    w = np.abs(crop[0] - 0.2)
    yy, xx = np.mgrid[0:24, 0:24]
    m = w.sum()
    mx, my = (w * xx).sum() / m, (w * yy).sum() / m
    cov = np.array([[(w * (xx - mx) ** 2).sum(), (w * (xx - mx) * (yy - my)).sum()],
                    [(w * (xx - mx) * (yy - my)).sum(), (w * (yy - my) ** 2).sum()]]) / m
    return np.linalg.eigvalsh(cov)


def test_the_motion_blur_smears_along_one_direction(monkeypatch: pytest.MonkeyPatch) -> None:
    x, y, off, ctx = _samples()
    monkeypatch.setattr(fly, "SHRINK", (1.0, 1.0))
    monkeypatch.setattr(fly, "DARK", (1.0, 1.0))
    monkeypatch.setattr(fly, "BLUR_PX", (0.0, 0.0))
    sharp = fly.flying(x[[0, 2, 3]], y[[0, 2, 3]], off[[0, 2, 3]], ctx[[0, 2, 3]], 4,
                       np.random.default_rng(1))[0]
    monkeypatch.setattr(fly, "BLUR_PX", (8.0, 8.0))
    blurred = fly.flying(x[[0, 2, 3]], y[[0, 2, 3]], off[[0, 2, 3]], ctx[[0, 2, 3]], 4,
                         np.random.default_rng(1))[0]
    for s, b in zip(sharp, blurred, strict=True):
        (s_lo, s_hi), (b_lo, b_hi) = _spread(s), _spread(b)
        assert b_hi - s_hi > 3.0  # a line of 8 px adds 8^2 / 12 along it
        assert abs(b_lo - s_lo) < 0.5  # and nothing across it
        assert np.abs(np.diff(b[0], axis=1)).sum() < np.abs(np.diff(s[0], axis=1)).sum()


def test_a_shrunk_ball_carries_its_targets(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(fly, "SHRINK", (0.5, 0.5))
    monkeypatch.setattr(fly, "BLUR_PX", (0.0, 0.0))
    x, y, off, ctx = fly.flying(*_samples(), 1.0, np.random.default_rng(2))
    assert y.tolist() == [1, 1, 0, 0]
    first = int(np.argmax(off[:2, 2]))  # the positive with log size 0.1
    assert np.allclose(off[first], [0.025, -0.025, 0.1 - np.log(2)], atol=1e-6)
    assert np.allclose(sorted(ctx[:2, 0]), [-0.2 - np.log(2), 0.1 - np.log(2)], atol=1e-6)
    lit = x[1 - first, 3] > 0.25  # the ball channel: a disc of diameter 6 (from 12) in the middle
    ys, xs = np.nonzero(lit)
    assert 20 <= lit.sum() <= 36 and abs(xs.mean() - 11.5) < 0.6 and abs(ys.mean() - 11.5) < 0.6


def test_a_kernel_is_a_normalised_line() -> None:
    k = fly.motion_kernel(6.0, 0.0)
    assert abs(float(k.sum()) - 1.0) < 1e-6
    rows = np.flatnonzero(k.sum(axis=1) > 1e-6)
    cols = np.flatnonzero(k.sum(axis=0) > 1e-6)
    assert len(rows) <= 2 and 6 <= len(cols) <= 8


def test_a_ball_the_crop_does_not_frame_is_not_pasted() -> None:
    x, y, off, ctx = _samples()
    off[1] = [-0.4, -1.5, 2.5]  # a candidate on a ball's edge: the ball's centre far outside
    _, yf, offf, _ = fly.flying(x, y, off, ctx, 3.0, np.random.default_rng(4))
    assert yf.tolist() == [1.0] * 3 + [0.0] * 3
    assert np.all(offf[:3, 2] <= 0.0) and np.all(np.abs(offf[:3, :2]) < 1e-6)


def test_the_look_alikes_weigh_as_the_balls() -> None:
    x, y, off, ctx = _samples()
    more = np.concatenate([y, np.zeros(4, np.float32)])  # six negatives for two balls
    xs, offs, ctxs = (np.concatenate([a, a[[2, 3, 2, 3]]]) for a in (x, off, ctx))
    _, yf, _, _ = fly.flying(xs, more, offs, ctxs, 1.0, np.random.default_rng(5))
    assert yf.tolist() == [1.0] * 2 + [0.0] * 6
    _, yf, _, _ = fly.flying(xs, more, offs, ctxs, 1.0, np.random.default_rng(5), per_ball=1.0)
    assert yf.tolist() == [1.0] * 2 + [0.0] * 2
