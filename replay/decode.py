"""Image messages to pixels: compressed (PNG, JPEG) through OpenCV, raw ``sensor_msgs/Image``
in the encodings replay understands (bgr8, rgb8, mono8)."""

from __future__ import annotations

import cv2
import numpy as np

from replay.reader import ImageMessage

__all__ = ["decode_image"]


def decode_image(msg: ImageMessage) -> np.ndarray | None:
    """BGR pixels of an image message, None when it does not decode."""
    if msg.fmt == "raw":
        enc = msg.encoding.lower()
        channels = {"bgr8": 3, "rgb8": 3, "mono8": 1}.get(enc)
        if channels is None or msg.width_px <= 0 or msg.height_px <= 0:
            return None
        step = msg.step or msg.width_px * channels
        if step < msg.width_px * channels or len(msg.data) < step * msg.height_px:
            return None
        buf = np.frombuffer(msg.data, np.uint8, count=step * msg.height_px)
        px = buf.reshape(msg.height_px, step)[:, : msg.width_px * channels]
        px = px.reshape(msg.height_px, msg.width_px, channels)
        if enc == "rgb8":
            return cv2.cvtColor(px, cv2.COLOR_RGB2BGR)
        if enc == "mono8":
            return cv2.cvtColor(px, cv2.COLOR_GRAY2BGR)
        return np.ascontiguousarray(px)
    img = cv2.imdecode(np.frombuffer(msg.data, np.uint8), cv2.IMREAD_COLOR)
    return img if img is not None and img.size else None
