"""Ball detection in an omnidirectional image, as the paper (Section II.F, eq. 1-2).

Pipeline: BGR -> HSV -> threshold on the ball colour -> morphological OPEN -> connected
blobs (external contours) -> centroid from image moments ``Cx = M10 / M00`` (eq. 1),
``Cy = M01 / M00`` (eq. 2) in OpenCV pixel coordinates (pixel index i has coordinate i).

Colour. The default range is for the simulator's orange ball (about RGB (255, 110, 0),
OpenCV hue 13 of 0-179): H 5-25, S >= 120, V >= 80. The hue window is +-8-12 around
the ball's hue, which shading (a darker V) does not move; S >= 120 rejects the white
lines, the green field (H about 60) and the grey/black robots; V >= 80 keeps the shaded
side of the ball but rejects the dark robot body. A range with ``hsv_lower[0] >
hsv_upper[0]`` wraps around hue 180 (for a red ball).

Centroid. The OPEN removes speckle but also nibbles a blob's outline, so the opened mask
only FINDS blobs; the moments are taken over the blob's threshold mask (holes filled, so a
specular highlight does not pull the centroid). With ``subpixel=True`` (default) the
pixels on the blob's edge are weighted by how much of them the ball covers, estimated
from their colour: an edge pixel p that is a blend of the ball's colour c_b (median of
the blob's interior) and the local background c_g (median of a ring around the blob) gets
weight ``w = <p - c_g, c_b - c_g> / |c_b - c_g|^2`` clipped to [0, 1]; if p is not on that
blend line (e.g. a white line touches the ball) its binary mask value is used. Interior
pixels weigh 1. On an anti-aliased disc these are the true area fractions, so the
centroid is accurate to a few hundredths of a pixel, where the binary mask alone is only
accurate to about 0.5 / sqrt(radius) px (digitisation noise). ``subpixel=False`` gives
the paper's plain binary moments.

Search. The chain runs only where the colour is: the threshold is first tested on every
``search_stride_px``-th row (after a cheaper test, a gap between two colour channels that
every pixel in the HSV range shows, picks the few pixels worth converting), and
thresholding, OPEN, outlines and moments run in boxes around the hits, grown until each
holds whole blobs with an empty margin (:mod:`estimator.detection.regions`). The numbers
are those of the whole image, for every blob with a pixel on a sampled row (any blob at
least ``search_stride_px`` rows tall, so any anti-aliased ball of radius >= 2 px at the
default 3); ``search_stride_px=1`` processes the whole image.

Plausibility (several blobs). A blob is plausible when ``min_area_px <= area <=
max_area_px``, its circularity ``4 pi A / P^2`` (contour area A and perimeter P) is at
least ``min_circularity`` and its fill ratio (pixels / bounding box area, pi/4 for a disc
and for a half disc) is within ``[min_fill_ratio, max_fill_ratio]``. Candidates are ranked
plausible first, then by the shape score ``min(circularity, 1) * (1 - |fill - pi/4| /
(pi/4))`` (most ball-like first), then by larger area, then top-to-bottom, left-to-right.
"""

from __future__ import annotations

import functools
import itertools
import math
from dataclasses import dataclass, field

import cv2
import numpy as np
import numpy.typing as npt

from estimator.detection.regions import ChannelGap, Region, search_regions
from estimator.errors import DetectionError

__all__ = ["Detection", "DetectionParams", "detect_ball", "detect_blobs"]

_PI_4 = math.pi / 4.0  # fill ratio of a disc (and a half disc) in its bounding box


@dataclass(frozen=True)
class DetectionParams:
    """Parameters of :func:`detect_ball` (OpenCV HSV units: H 0-179, S and V 0-255)."""

    hsv_lower: tuple[int, int, int] = (5, 120, 80)
    hsv_upper: tuple[int, int, int] = (25, 255, 255)
    open_kernel_px: int = 3
    """Side of the elliptical structuring element of the OPEN (1 or less: no OPEN)."""
    min_area_px: float = 12.0
    max_area_px: float = 200_000.0
    min_circularity: float = 0.5
    min_fill_ratio: float = 0.5
    max_fill_ratio: float = 0.95
    ignore_radius_px: float = 0.0
    """Pixels within this radius of ``ignore_centre_px`` are ignored (the robot's body)."""
    ignore_centre_px: tuple[float, float] | None = None
    """Centre of the ignored disc; None: the image centre ((w - 1) / 2, (h - 1) / 2)."""
    subpixel: bool = True
    """Weight edge pixels by their ball coverage (see the module docstring)."""
    search_stride_px: int = 3
    """Coarse-to-fine search: the colour is first tested on every ``search_stride_px``-th
    row, and the full chain runs only in boxes around the hits (see the module docstring);
    the results are the whole image's. 1: process the whole image."""

    def __post_init__(self) -> None:
        for name, lo, hi in (("H", 0, 179), ("S", 0, 255), ("V", 0, 255)):
            i = "HSV".index(name)
            for bound in (self.hsv_lower[i], self.hsv_upper[i]):
                if not lo <= bound <= hi:
                    raise DetectionError(
                        f"HSV bound {name} = {bound} is outside OpenCV's {lo}-{hi}; "
                        "use OpenCV units (hue is degrees / 2)"
                    )
        for i in (1, 2):
            if self.hsv_lower[i] > self.hsv_upper[i]:
                raise DetectionError(
                    f"hsv_lower {self.hsv_lower} exceeds hsv_upper {self.hsv_upper} in "
                    f"{'HSV'[i]}; swap them (only the hue may wrap)"
                )
        if not 0 <= self.min_area_px <= self.max_area_px:
            raise DetectionError(
                f"area limits [{self.min_area_px}, {self.max_area_px}] px are not "
                "0 <= min <= max; fix min_area_px / max_area_px"
            )
        if self.search_stride_px < 1:
            raise DetectionError(
                f"search_stride_px = {self.search_stride_px}; use 1 (whole image) or more"
            )
        if self.ignore_radius_px < 0:
            raise DetectionError(
                f"ignore_radius_px = {self.ignore_radius_px} is negative; use 0 to ignore nothing"
            )


@dataclass(frozen=True)
class Detection:
    """One ball candidate: centroid [px] (eq. 1-2), area, bounding box and shape."""

    cx_px: float
    cy_px: float
    area_px: float
    """M00: the (edge-weighted) pixel count of the blob."""
    bbox_px: tuple[int, int, int, int]
    """(x, y, w, h) of the blob's bounding box."""
    circularity: float
    """4 pi A / P^2 of the blob's outline: 1 for a circle, pi/4 for a square."""
    outline_px: npt.NDArray[np.int32] = field(compare=False, repr=False)
    """N x 2 (u, v) outline of the blob (not compared)."""


def _check_image(image_bgr: npt.NDArray[np.uint8]) -> None:
    if not isinstance(image_bgr, np.ndarray):
        raise DetectionError(
            f"image is a {type(image_bgr).__name__}; pass an H x W x 3 uint8 BGR numpy array"
        )
    if image_bgr.ndim != 3 or image_bgr.shape[2] != 3 or image_bgr.dtype != np.uint8:
        raise DetectionError(
            f"image has shape {image_bgr.shape} and dtype {image_bgr.dtype}; pass an "
            "H x W x 3 uint8 BGR array (decode PNG/JPEG with cv2.imdecode first)"
        )


@functools.lru_cache(maxsize=4)
def _keep_mask(height: int, width: int, centre_16: tuple[int, int], radius_16: int
               ) -> npt.NDArray[np.uint8]:
    """255 outside the ignored disc, 0 inside (centre and radius in 1/16 px), read-only."""
    keep = np.full((height, width), 255, np.uint8)
    cv2.circle(keep, centre_16, radius_16, 0, thickness=-1, shift=4)
    keep.setflags(write=False)
    return keep


@functools.lru_cache(maxsize=16)
def _hsv_bounds(lo: tuple[int, int, int], hi: tuple[int, int, int]
                ) -> tuple[tuple[npt.NDArray[np.uint8], npt.NDArray[np.uint8]], ...]:
    """inRange bounds of the HSV range: one pair, or two when the hue wraps around 180."""
    pairs = [(lo, hi)] if lo[0] <= hi[0] else [(lo, (179, hi[1], hi[2])),
                                               ((0, lo[1], lo[2]), hi)]
    out = []
    for pair in pairs:
        lower, upper = (np.array(b, np.uint8) for b in pair)
        lower.setflags(write=False)
        upper.setflags(write=False)
        out.append((lower, upper))
    return tuple(out)


@functools.lru_cache(maxsize=4)
def _open_kernel(size: int) -> npt.NDArray[np.uint8] | None:
    """The OPEN's elliptical structuring element (None: no OPEN), read-only."""
    if size <= 1:
        return None
    kernel = np.asarray(cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (size, size)), np.uint8)
    kernel.setflags(write=False)
    return kernel


def _threshold(pixels: npt.NDArray[np.uint8], params: DetectionParams,
               origin: tuple[int, int] | None, image_shape: tuple[int, ...]
               ) -> npt.NDArray[np.uint8]:
    """The colour mask of ``pixels``: the image, a ROI of it starting at ``origin``, or (origin
    None) a subsample, which is not masked by the ignored disc."""
    hsv = cv2.cvtColor(pixels, cv2.COLOR_BGR2HSV)
    bounds = _hsv_bounds(params.hsv_lower, params.hsv_upper)
    mask = cv2.inRange(hsv, *bounds[0])
    if len(bounds) > 1:  # hue range wraps around 180 (red)
        mask = cv2.bitwise_or(mask, cv2.inRange(hsv, *bounds[1]))
    if params.ignore_radius_px > 0 and origin is not None:
        h, w = image_shape[:2]
        cu, cv = params.ignore_centre_px or ((w - 1) / 2.0, (h - 1) / 2.0)
        keep = _keep_mask(h, w, (round(cu * 16), round(cv * 16)),
                          round(params.ignore_radius_px * 16))
        x0, y0 = origin
        mask = cv2.bitwise_and(mask, keep[y0:y0 + mask.shape[0], x0:x0 + mask.shape[1]])
    return np.asarray(mask, dtype=np.uint8)


def _hue_weight(channel: int, hue: float) -> float:
    """How much of max - min a channel (BGR index) holds at a hue (OpenCV units, 0-180):
    1 within 30 of its own hue (B 120, G 60, R 0), 0 beyond 60, linear between."""
    distance = abs((hue - (2 - channel) * 60.0 + 90.0) % 180.0 - 90.0)
    return min(1.0, max(0.0, 2.0 - distance / 30.0))


@functools.lru_cache(maxsize=16)
def _channel_gap(lower: tuple[int, int, int], upper: tuple[int, int, int]) -> ChannelGap | None:
    """The largest gap between two channels that every pixel in the HSV range shows (None:
    no pair of channels is ordered over the whole range, e.g. greys are in it).

    A pixel with maximum V, minimum m and hue h has channel k = m + (V - m) w_k(h)
    (:func:`_hue_weight`), so ``plus - minus = (V - m) (w_plus(h) - w_minus(h))``, and
    ``V - m = S V / 255 >= S_lo V_lo / 255``, and ``V - m >= 1`` when S >= 1. OpenCV rounds
    H and S to integers (to within 0.5 and a table error well under 0.2), so the true hue is
    taken over the range widened by 1 on each side and S_lo is taken 1 lower. The weights
    are linear between multiples of 30, so their difference is least at the range's ends
    or at such a multiple."""
    if lower[1] < 1:
        return None
    hue_lo, hue_hi = lower[0] - 1.0, upper[0] + 1.0 + (180.0 if lower[0] > upper[0] else 0.0)
    spread = max(1.0, (lower[1] - 1) * lower[2] / 255.0)
    hues = [hue_lo, hue_hi, *range(math.ceil(hue_lo / 30) * 30, math.floor(hue_hi), 30)]
    best: ChannelGap | None = None
    for plus, minus in itertools.permutations(range(3), 2):
        least = min(_hue_weight(plus, h) - _hue_weight(minus, h) for h in hues)
        if least <= 0.0:
            continue
        gap = ChannelGap(plus, minus, max(1, math.floor(spread * least)))  # integers
        if best is None or gap.min_gap > best.min_gap:
            best = gap
    return best


_CROSS3 = cv2.getStructuringElement(cv2.MORPH_CROSS, (3, 3))
_ELLIPSE5 = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (5, 5))
_ELLIPSE9 = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (9, 9))
_PAD = 6  # ROI margin around a blob's bounding box: room for the 9 x 9 ring


def _median_bgr(pixels: npt.NDArray[np.uint8]) -> npt.NDArray[np.float64]:
    """Per-channel median of N x 3 pixels (``np.median(pixels, axis=0)``, without its
    float copy: the middle value, or the mean of the two middle values)."""
    n = len(pixels)
    k = (n - 1) // 2
    if n % 2:
        return np.asarray(np.partition(pixels, k, axis=0)[k], np.float64)
    middle = np.partition(pixels, (k, k + 1), axis=0)[k:k + 2].astype(np.float64)
    return np.asarray((middle[0] + middle[1]) / 2.0, np.float64)


def _weights(
    image_roi: npt.NDArray[np.uint8],
    blob: npt.NDArray[np.uint8],
    subpixel: bool,
) -> npt.NDArray[np.float64]:
    """Per-pixel ball coverage in [0, 1] of one blob (binary, or edge-weighted). ``blob``
    holds 0 and 1, so it and the masks made from it read as booleans without a copy."""
    binary = blob.astype(np.float64)
    if not subpixel:
        return binary
    core = cv2.erode(blob, _CROSS3)  # pixels whose 4 neighbours are ball: weight 1
    region = cv2.dilate(blob, _ELLIPSE5)  # blob + 2 px: every partly covered pixel
    ring = cv2.dilate(blob, _ELLIPSE9)
    cv2.subtract(ring, region, dst=ring)  # the local background
    pixels = image_roi.reshape(-1, 3)
    background = pixels.compress(ring.reshape(-1).view(np.bool_), axis=0)
    if len(background) == 0:
        return binary
    interior = pixels.compress(core.reshape(-1).view(np.bool_), axis=0)
    has_core = len(interior) > 0
    if not has_core:
        interior = pixels.compress(blob.reshape(-1).view(np.bool_), axis=0)
    c_b = _median_bgr(interior)  # ball colour
    c_g = _median_bgr(background)  # background colour
    delta = c_b - c_g
    norm2 = float(np.dot(delta, delta))
    if norm2 < 30.0**2:  # ball and background too alike to unmix: binary moments
        return binary
    if has_core:
        cv2.subtract(region, core, dst=region)
    band = region.reshape(-1).view(np.bool_)
    p = pixels.compress(band, axis=0) - c_g
    w = p @ delta / norm2  # coverage: position on the blend line, clipped to [0, 1]
    np.minimum(np.maximum(w, 0.0, out=w), 1.0, out=w)
    r = p - w[:, None] * delta
    off_line = np.sqrt(np.einsum("ij,ij->i", r, r)) > 0.25 * math.sqrt(norm2)  # not a blend
    weights = binary.reshape(-1)  # a view; the core's pixels are already 1
    np.copyto(w, weights.compress(band), where=off_line)  # off the line: binary
    weights[band] = w
    return binary


def _regions(image_bgr: npt.NDArray[np.uint8], params: DetectionParams) -> list[Region]:
    """Where to run the full chain: boxes around the coarse hits, or the whole image."""
    shape = image_bgr.shape

    def threshold(pixels: npt.NDArray[np.uint8], origin: tuple[int, int] | None
                  ) -> npt.NDArray[np.uint8]:
        return _threshold(pixels, params, origin, shape)

    if params.search_stride_px > 1:
        band = max(_PAD, params.open_kernel_px // 2) + 1
        regions = search_regions(image_bgr, threshold, stride=params.search_stride_px,
                                 band=band, gap=_channel_gap(params.hsv_lower,
                                                             params.hsv_upper))
        if regions is not None:
            return regions
    height, width = shape[:2]
    return [Region(0, 0, width, height, threshold(image_bgr, (0, 0)))]


def _measure(contour: npt.NDArray[np.int32], image_bgr: npt.NDArray[np.uint8],
             region: Region, params: DetectionParams
             ) -> tuple[tuple[bool, float, float, float, float], Detection] | None:
    """One blob's detection and ranking key (None: it weighs nothing)."""
    height, width = image_bgr.shape[:2]
    x, y, w, h = cv2.boundingRect(contour)
    x0, y0 = max(x - _PAD, 0), max(y - _PAD, 0)
    x1, y1 = min(x + w + _PAD, width), min(y + h + _PAD, height)
    # The blob: its opened outline filled (holes closed), grown back by the OPEN's
    # kernel, intersected with the threshold mask plus the filled outline; 0 and 1.
    filled = np.zeros((y1 - y0, x1 - x0), np.uint8)
    cv2.drawContours(filled, [contour], 0, 1, thickness=-1, offset=(-x0, -y0))
    blob = np.asarray(cv2.dilate(filled, _CROSS3) if params.open_kernel_px > 1
                      else filled.copy(), np.uint8)
    mask = region.mask[y0 - region.y0:y1 - region.y0, x0 - region.x0:x1 - region.x0]
    cv2.bitwise_and(blob, mask, dst=blob)  # 0/1 and 0/255: 0/1
    cv2.bitwise_or(blob, filled, dst=blob)
    moments = cv2.moments(_weights(image_bgr[y0:y1, x0:x1], blob, params.subpixel))
    m00 = float(moments["m00"])
    if m00 <= 0.0:
        return None
    cx = x0 + float(moments["m10"]) / m00  # eq. 1: Cx = M10 / M00 (M10 about the ROI's x0)
    cy = y0 + float(moments["m01"]) / m00  # eq. 2: Cy = M01 / M00
    contour_area = float(cv2.contourArea(contour))
    perimeter = float(cv2.arcLength(contour, True))
    circularity = 4.0 * math.pi * contour_area / perimeter**2 if perimeter > 0 else 0.0
    fill = cv2.countNonZero(blob) / float(w * h)
    plausible = (
        params.min_area_px <= m00 <= params.max_area_px
        and circularity >= params.min_circularity
        and params.min_fill_ratio <= fill <= params.max_fill_ratio
    )
    score = min(circularity, 1.0) * max(0.0, 1.0 - abs(fill - _PI_4) / _PI_4)
    detection = Detection(
        cx_px=cx,
        cy_px=cy,
        area_px=m00,
        bbox_px=(int(x), int(y), int(w), int(h)),
        circularity=circularity,
        outline_px=contour.reshape(-1, 2),
    )
    return (not plausible, -score, -m00, cy, cx), detection


def _candidates(
    image_bgr: npt.NDArray[np.uint8], params: DetectionParams
) -> list[tuple[bool, Detection]]:
    """(plausible, detection) for every blob, best first."""
    _check_image(image_bgr)
    kernel = _open_kernel(params.open_kernel_px)
    blobs: list[tuple[npt.NDArray[np.int32], Region]] = []
    for region in _regions(image_bgr, params):
        opened = region.mask if kernel is None else cv2.morphologyEx(
            region.mask, cv2.MORPH_OPEN, kernel)
        contours, _ = cv2.findContours(opened, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE,
                                       offset=(region.x0, region.y0))
        blobs.extend((np.asarray(c, np.int32), region) for c in contours)
    # findContours' own order over the whole image (last-found first; a contour starts
    # at its blob's first pixel in raster order), so equal keys rank as they always did
    blobs.sort(key=lambda b: (int(b[0][0, 0, 1]), int(b[0][0, 0, 0])), reverse=True)
    ranked = [m for c, r in blobs if (m := _measure(c, image_bgr, r, params)) is not None]
    ranked.sort(key=lambda item: item[0])
    return [(not key[0], detection) for key, detection in ranked]


def detect_blobs(
    image_bgr: npt.NDArray[np.uint8], params: DetectionParams | None = None
) -> list[Detection]:
    """Every ball-coloured blob, best first (plausible ones first; see the module doc)."""
    return [d for _, d in _candidates(image_bgr, params or DetectionParams())]


def detect_ball(
    image_bgr: npt.NDArray[np.uint8], params: DetectionParams | None = None
) -> Detection | None:
    """The most plausible ball in the image, or None when no blob is plausible."""
    for plausible, detection in _candidates(image_bgr, params or DetectionParams()):
        return detection if plausible else None
    return None
