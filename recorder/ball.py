"""How the ball looks: its colour, its panels and the meshes it is drawn with.

Real MSL balls are FIFA size-5 balls whose colour the tournament announces (orange, yellow,
white), printed with panels or bands in a second, darker tone of the same colour; seen by a
robot they are one colour with a faint pattern that turns as the ball rolls. The simulator
draws:

- ``plain``: one colour, no texture: the ball every log before this option had (the same
  mesh and colour, so the same bytes);
- ``panels``: a truncated icosahedron (12 pentagons, 20 hexagons, the classic football)
  projected onto the sphere: the pentagons and 4 mm seams between the panels in the second
  tone, the hexagons in the first;
- ``bands``: three 24 mm bands around three perpendicular axes in the second tone.

A pattern is an equirectangular texture in the ball's body frame, on a UV sphere; pybullet
turns the body (and so the texture) with the ball's physics. TinyRenderer samples a texture
without filtering, so no feature of the pattern is narrower than several texels.

Pure numpy + OpenCV: no pybullet here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = [
    "BALL_COLOURS",
    "BALL_PATTERNS",
    "BallLook",
    "ball_look",
    "ball_texture",
    "sphere_obj",
    "sphere_obj_uv",
]

BALL_COLOURS: dict[str, tuple[tuple[int, int, int], tuple[int, int, int]]] = {
    "orange": ((255, 110, 0), (190, 70, 0)),
    "yellow": ((250, 220, 30), (200, 160, 10)),
    "white": ((235, 232, 224), (165, 160, 150)),
}
"""Colour name -> (first tone, second tone) as RGB. Orange's first tone is the ball of
every earlier log; the second tones are the first darkened by about 0.7, hue kept."""
BALL_PATTERNS = ("plain", "panels", "bands")
TEXTURE_SIZE_PX = (1024, 512)
"""(width, height) of the equirectangular texture: 0.7 mm per texel around the equator."""
SEAM_M = 0.004
"""Width of the seams between panels."""
BAND_HALF_WIDTH_M = 0.012
_HEX_OVER_PENT = 2.2672 / 2.3274
"""Distance from the centre to a hexagon's plane over that to a pentagon's (a truncated
icosahedron of unit edge: 2.2672 and 2.3274)."""


@dataclass(frozen=True)
class BallLook:
    """The ball's colour name, pattern and its two tones (RGB 0-255)."""

    colour: str
    pattern: str
    rgb: tuple[int, int, int]
    second_rgb: tuple[int, int, int]

    @property
    def textured(self) -> bool:
        return self.pattern != "plain"


def ball_look(colour: str = "orange", pattern: str = "plain") -> BallLook:
    """The look of a ball of ``colour`` (one of BALL_COLOURS) with ``pattern``; ValueError
    names a bad one."""
    if colour not in BALL_COLOURS:
        raise ValueError(f"unknown ball colour {colour!r}; choose one of "
                         f"{', '.join(BALL_COLOURS)}")
    if pattern not in BALL_PATTERNS:
        raise ValueError(f"unknown ball pattern {pattern!r}; choose one of "
                         f"{', '.join(BALL_PATTERNS)}")
    first, second = BALL_COLOURS[colour]
    return BallLook(colour, pattern, first, second)


def _texel_directions(width: int, height: int) -> np.ndarray:
    """Unit vectors (height, width, 3) in the ball's frame of each texel's centre: column c
    at longitude 2 pi (c + 0.5) / width, row k at polar angle pi (k + 0.5) / height (row 0
    at +z), as :func:`sphere_obj_uv` maps them."""
    theta = math.pi * (np.arange(height) + 0.5) / height
    phi = 2.0 * math.pi * (np.arange(width) + 0.5) / width
    st = np.sin(theta)[:, None]
    return np.stack([st * np.cos(phi)[None, :], st * np.sin(phi)[None, :],
                     np.broadcast_to(np.cos(theta)[:, None], (height, width))], axis=-1)


def _football_faces() -> tuple[np.ndarray, np.ndarray]:
    """Unit normals of a truncated icosahedron's 12 pentagons (the icosahedron's vertices)
    and 20 hexagons (its face centres)."""
    g = (1.0 + math.sqrt(5.0)) / 2.0
    verts = []
    for a in (-1.0, 1.0):
        for b in (-g, g):
            verts += [(0.0, a, b), (a, b, 0.0), (b, 0.0, a)]
    v = np.array(verts) / math.hypot(1.0, g)
    edge = float(np.min([np.linalg.norm(v[0] - w) for w in v[1:]]))
    faces = []
    for i in range(12):
        for j in range(i + 1, 12):
            for k in range(j + 1, 12):
                tri = (v[i], v[j], v[k])
                if all(abs(np.linalg.norm(p - q) - edge) < 1e-9
                       for p, q in ((tri[0], tri[1]), (tri[1], tri[2]), (tri[0], tri[2]))):
                    c = v[i] + v[j] + v[k]
                    faces.append(c / np.linalg.norm(c))
    return v, np.array(faces)


def _panels_mask(d: np.ndarray, radius_m: float) -> np.ndarray:
    """True where a direction shows the second tone: a pentagon or a seam. A direction lies
    on the face whose plane its ray meets first (largest ``d . n / h``); it is on a seam
    when it is within ``SEAM_M / 2`` of the edge with the next face: there the two scores
    differ by about ``2 sin(a / 2)`` times the angular distance to the edge, ``a`` (37-42
    deg) the angle between neighbouring faces' normals."""
    pent, hexa = _football_faces()
    scores = np.concatenate([d @ pent.T, (d @ hexa.T) / _HEX_OVER_PENT], axis=-1)
    top2 = np.partition(scores, -2, axis=-1)
    gap = 2.0 * math.sin(math.radians(20.0)) * SEAM_M / 2 / radius_m
    seam = top2[..., -1] - top2[..., -2] < gap
    return np.asarray((np.argmax(scores, axis=-1) < len(pent)) | seam, dtype=bool)


def _bands_mask(d: np.ndarray, radius_m: float) -> np.ndarray:
    """True within ``BAND_HALF_WIDTH_M`` of one of three perpendicular great circles (the
    axes turned off the texture's own, so no band runs along the poles' rows)."""
    c, s = math.cos(0.5), math.sin(0.5)
    axes = np.array([[c, s, 0.0], [-s * c, c * c, s], [s * s, -c * s, c]])
    half = math.sin(BAND_HALF_WIDTH_M / radius_m)
    return np.asarray(np.any(np.abs(d @ axes.T) < half, axis=-1), dtype=bool)


def ball_texture(look: BallLook, radius_m: float) -> np.ndarray:
    """The look's equirectangular texture, BGR uint8 (TEXTURE_SIZE_PX), row 0 at the
    ball's +z pole; the plain look is a flat image of its colour."""
    width, height = TEXTURE_SIZE_PX
    img = np.empty((height, width, 3), np.uint8)
    img[:] = look.rgb[::-1]
    if look.pattern == "plain":
        return img
    d = _texel_directions(width, height)
    mask = _panels_mask(d, radius_m) if look.pattern == "panels" else _bands_mask(d, radius_m)
    img[mask] = look.second_rgb[::-1]
    return img


def sphere_obj(radius_m: float, n_lat: int, n_lon: int) -> str:
    """A UV sphere as OBJ text with smooth vertex normals (no texture coordinates)."""
    lines = []
    for i in range(n_lat + 1):
        th = math.pi * i / n_lat
        for j in range(n_lon):
            ph = 2 * math.pi * j / n_lon
            n = (math.sin(th) * math.cos(ph), math.sin(th) * math.sin(ph), math.cos(th))
            lines.append(f"v {radius_m * n[0]:.6f} {radius_m * n[1]:.6f} {radius_m * n[2]:.6f}")
            lines.append(f"vn {n[0]:.6f} {n[1]:.6f} {n[2]:.6f}")
    for i in range(n_lat):
        for j in range(n_lon):
            a = i * n_lon + j + 1
            b = i * n_lon + (j + 1) % n_lon + 1
            c, d = a + n_lon, b + n_lon
            lines.append(f"f {a}//{a} {c}//{c} {d}//{d}")
            lines.append(f"f {a}//{a} {d}//{d} {b}//{b}")
    return "\n".join(lines) + "\n"


def sphere_obj_uv(radius_m: float, n_lat: int, n_lon: int) -> str:
    """The same sphere with texture coordinates: u = longitude / 2 pi, v = 1 - polar angle
    / pi (the seam's column of vertices doubled, so u runs 0..1 without wrapping)."""
    lines = []
    for i in range(n_lat + 1):
        th = math.pi * i / n_lat
        for j in range(n_lon + 1):
            ph = 2 * math.pi * j / n_lon
            n = (math.sin(th) * math.cos(ph), math.sin(th) * math.sin(ph), math.cos(th))
            lines.append(f"v {radius_m * n[0]:.6f} {radius_m * n[1]:.6f} {radius_m * n[2]:.6f}")
            lines.append(f"vn {n[0]:.6f} {n[1]:.6f} {n[2]:.6f}")
            lines.append(f"vt {j / n_lon:.6f} {1 - i / n_lat:.6f}")
    row = n_lon + 1
    for i in range(n_lat):
        for j in range(n_lon):
            a = i * row + j + 1
            b, c = a + 1, a + row
            d = c + 1
            lines.append(f"f {a}/{a}/{a} {c}/{c}/{c} {d}/{d}/{d}")
            lines.append(f"f {a}/{a}/{a} {d}/{d}/{d} {b}/{b}/{b}")
    return "\n".join(lines) + "\n"
