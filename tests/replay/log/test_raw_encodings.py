"""Every colour and grey ``sensor_msgs/Image`` encoding ROS 2 defines decodes: each test image
is made from one BGR frame by OpenCV's conversions (the Bayer mosaics, which OpenCV cannot
make, by sampling the frame as the pattern's name says), decoded, and compared with the frame:
exactly where the encoding is lossless, and through the ball's centroid where it is not."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from estimator.detection import detect_ball
from replay.log import ImageMessage, decode_image, image_problem
from replay.log.raw_image import RAW_ENCODINGS

W, H = 160, 120
BALL = (70.3, 52.6)


def _frame() -> np.ndarray:
    img = np.empty((H, W, 3), np.uint8)
    img[:] = (30, 90, 20)
    img[::7, :] = (40, 120, 35)  # some texture: lines of a lighter green
    shift = 4
    centre = (round(BALL[0] * 16), round(BALL[1] * 16))
    cv2.circle(img, centre, 12 << shift, (0, 110, 255), -1, cv2.LINE_8, shift)
    return img


FRAME = _frame()
_CHANNEL = {"b": 0, "g": 1, "r": 2}


def _bayer(img: np.ndarray, pattern: str) -> np.ndarray:
    """The mosaic a sensor with this pattern (its first two rows: rggb = R G / G B) records."""
    out = np.empty(img.shape[:2], img.dtype)
    for k, colour in enumerate(pattern):
        dy, dx = divmod(k, 2)
        out[dy::2, dx::2] = img[dy::2, dx::2, _CHANNEL[colour]]
    return out


def _nv21(img: np.ndarray) -> np.ndarray:
    yv12 = cv2.cvtColor(img, cv2.COLOR_BGR2YUV_YV12)  # Y, then the V plane, then U
    y, rest = yv12[:H], yv12[H:].reshape(-1)
    v, u = rest[: rest.size // 2], rest[rest.size // 2:]
    vu = np.stack([v, u], axis=-1).reshape(H // 2, W)
    return np.concatenate([y, vu])


def _nv24(img: np.ndarray) -> np.ndarray:
    """NV24 with each chroma sample of OpenCV's UYVY repeated for both pixels of its pair."""
    uyvy = cv2.cvtColor(img, cv2.COLOR_BGR2YUV_UYVY).reshape(H, W // 2, 4)
    y = np.stack([uyvy[..., 1], uyvy[..., 3]], axis=-1).reshape(H, W)
    uv = np.stack([uyvy[..., 0], uyvy[..., 2]], axis=-1)  # (H, W/2, 2)
    uv = np.repeat(uv[:, :, None, :], 2, axis=2).reshape(2 * H, W)  # rows of 2 W, halved
    return np.concatenate([y, uv])


def _sixteen(px: np.ndarray, big_endian: bool) -> np.ndarray:
    # the high byte is the 8-bit value (so /256 gives it back), the low byte differs from
    # it, so bytes read in the wrong order give another image
    wide = px.astype(np.uint16) * 256 + (255 - px)
    return wide.astype(">u2" if big_endian else "<u2")


def _encode(encoding: str, big_endian: bool = False) -> np.ndarray:
    base = encoding[:-2] + "8" if encoding.endswith("16") else encoding
    if base.startswith("bayer_"):
        px = _bayer(FRAME, base[len("bayer_"):-1])
    else:
        px = {
            "bgr8": lambda: FRAME, "rgb8": lambda: cv2.cvtColor(FRAME, cv2.COLOR_BGR2RGB),
            "bgra8": lambda: cv2.cvtColor(FRAME, cv2.COLOR_BGR2BGRA),
            "rgba8": lambda: cv2.cvtColor(FRAME, cv2.COLOR_BGR2RGBA),
            "mono8": lambda: cv2.cvtColor(FRAME, cv2.COLOR_BGR2GRAY),
            "yuv422": lambda: cv2.cvtColor(FRAME, cv2.COLOR_BGR2YUV_UYVY),
            "uyvy": lambda: cv2.cvtColor(FRAME, cv2.COLOR_BGR2YUV_UYVY),
            "yuv422_yuy2": lambda: cv2.cvtColor(FRAME, cv2.COLOR_BGR2YUV_YUYV),
            "yuyv": lambda: cv2.cvtColor(FRAME, cv2.COLOR_BGR2YUV_YUYV),
            "nv21": lambda: _nv21(FRAME), "nv24": lambda: _nv24(FRAME),
        }[base]()
    return _sixteen(px, big_endian) if encoding.endswith("16") else px


def _message(encoding: str, px: np.ndarray, *, pad: int = 0,
             big_endian: bool = False) -> ImageMessage:
    rows = px.reshape(px.shape[0], -1).view(np.uint8)
    if pad:
        rows = np.concatenate([rows, np.full((rows.shape[0], pad), 7, np.uint8)], axis=1)
        if encoding == "nv24":  # a chroma row is two steps long, its padding at its end
            y, uv = rows[:H], rows[H:, :W].reshape(H, 2 * W)
            uv = np.concatenate([uv, np.full((H, 2 * pad), 7, np.uint8)], axis=1)
            rows = np.concatenate([y, uv.reshape(2 * H, W + pad)])
    return ImageMessage("robot1", 0, 0, "raw", rows.tobytes(), encoding=encoding,
                        width_px=W, height_px=H, step=rows.shape[1], big_endian=big_endian)


LOSSLESS = {"bgr8": FRAME, "rgb8": FRAME, "bgra8": FRAME, "rgba8": FRAME,
            "mono8": cv2.cvtColor(cv2.cvtColor(FRAME, cv2.COLOR_BGR2GRAY), cv2.COLOR_GRAY2BGR)}


def test_every_encoding_ros_2_defines_for_colour_and_grey_is_read() -> None:
    ros2 = {"rgb8", "rgba8", "rgb16", "rgba16", "bgr8", "bgra8", "bgr16", "bgra16", "mono8",
            "mono16", "yuv422", "yuv422_yuy2", "nv21", "nv24",
            *(f"bayer_{p}{b}" for p in ("rggb", "bggr", "gbrg", "grbg") for b in (8, 16))}
    assert ros2 <= set(RAW_ENCODINGS)


@pytest.mark.parametrize("encoding", sorted(RAW_ENCODINGS))
@pytest.mark.parametrize("pad", [0, 6])
def test_each_encoding_decodes_to_the_frame(encoding: str, pad: int) -> None:
    out = decode_image(_message(encoding, _encode(encoding), pad=pad))
    assert out is not None and out.shape == (H, W, 3) and out.dtype == np.uint8
    base = encoding.replace("16", "8")
    if base in LOSSLESS:
        assert np.array_equal(out, LOSSLESS[base])
        return
    det, ref = detect_ball(out), detect_ball(FRAME)
    assert det is not None and ref is not None
    # 4:2:0 chroma covers 2 x 2 pixels and OpenCV repeats it: the colour moves by half one
    tolerance = 0.75 if encoding == "nv21" else 0.3
    assert abs(det.cx_px - ref.cx_px) < tolerance and abs(det.cy_px - ref.cy_px) < tolerance
    assert float(np.mean(np.abs(out.astype(int) - FRAME.astype(int)))) < 6.0


@pytest.mark.parametrize("encoding", ["bgr16", "mono16", "bayer_grbg16"])
def test_big_endian_samples_are_read_as_big_endian(encoding: str) -> None:
    little = decode_image(_message(encoding, _encode(encoding)))
    big = decode_image(_message(encoding, _encode(encoding, big_endian=True), big_endian=True))
    assert little is not None and big is not None and np.array_equal(little, big)
    swapped = decode_image(_message(encoding, _encode(encoding, big_endian=True)))
    assert swapped is not None and not np.array_equal(swapped, little)


def test_a_bayer_pattern_read_as_another_is_not_the_frame() -> None:
    """The four patterns are told apart: rggb data read as bggr swaps red and blue."""
    px = _encode("bayer_rggb8")
    right = decode_image(_message("bayer_rggb8", px))
    wrong = decode_image(_message("bayer_bggr8", px))
    assert right is not None and wrong is not None
    centre = (round(BALL[1]), round(BALL[0]))
    assert right[centre][2] > 200 and wrong[centre][0] > 200  # orange: red high; swapped: blue


@pytest.mark.parametrize(("encoding", "width", "height", "step", "size", "expected"), [
    ("nv12", W, H, W, W * H * 2, "encoding 'nv12' is not one replay reads"),
    ("32FC1", W, H, 4 * W, 4 * W * H, "encoding '32FC1' is not one replay reads"),
    ("bgr8", W, H, W, 3 * W * H, "row step 160 is less than 160 px x 3 bytes"),
    ("bgr8", W, H, 3 * W, 3 * W * H - 1, "data of 57599 bytes is less than the 57600"),
    ("yuv422", W + 1, H, 2 * W + 2, (2 * W + 2) * H, "must be even"),
    ("nv21", W, H, W, W * H, "less than the 28800"),
    ("mono8", 10_000, 10_000, 10_000, 10, "over 40 Mpx"),
])
def test_what_does_not_decode_says_why(encoding: str, width: int, height: int, step: int,
                                       size: int, expected: str) -> None:
    msg = ImageMessage("robot1", 0, 0, "raw", bytes(size), encoding=encoding,
                       width_px=width, height_px=height, step=step)
    assert decode_image(msg) is None
    assert expected in image_problem(msg)


def test_an_unreadable_compressed_image_says_so() -> None:
    msg = ImageMessage("robot1", 0, 0, "png", b"\x89PNG garbage" + bytes(40))
    assert decode_image(msg) is None
    assert "not an intact PNG, JPEG or BMP" in image_problem(msg)
