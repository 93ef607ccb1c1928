"""Folders of labelled images: pictures with YOLO/darknet label files beside them.

A folder holds images (``.jpg``, ``.jpeg``, ``.png``) and, for each labelled one, a text
file of the same stem (``NAME.txt``): one ``class cx cy w h`` line per object, the four
numbers normalised to the image's width and height. The labelled images are taken in
order of their file names, so "the first N" is the same set on every machine.

Everything is read bounded and checked first: a label file of at most
``MAX_LABEL_BYTES``, an image file of at most ``MAX_IMAGE_BYTES`` that decodes to at most
``MAX_PIXELS``; a bad one is an :class:`dsp.errors.InputError` of one line naming the file.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
import numpy.typing as npt

from dsp.errors import InputError
from dsp.textfile import read_bytes_file, read_text_file

__all__ = ["IMAGE_SUFFIXES", "Labelled", "find_labelled", "labelled_folders", "read_boxes",
           "read_image"]

IMAGE_SUFFIXES = (".jpg", ".jpeg", ".png")
MAX_LABEL_BYTES = 1 << 20
MAX_IMAGE_BYTES = 64 << 20
MAX_PIXELS = 40_000_000

Box = tuple[float, float, float, float]


@dataclass(frozen=True)
class Labelled:
    """One labelled image: its path and its label file's path."""

    image: Path
    label: Path

    def read(self, ball_class: int) -> tuple[npt.NDArray[np.uint8], list[Box]]:
        """The BGR image and its boxes of ``ball_class`` (x0, y0, x1, y1 in pixels)."""
        img = read_image(self.image)
        return img, read_boxes(self.label, img.shape[1], img.shape[0], ball_class)


def _line_box(path: Path, number: int, line: str, width: int, height: int
              ) -> tuple[int, Box]:
    parts = line.split()
    try:
        cls = int(parts[0])
        cx, cy, w, h = (float(v) for v in parts[1:])
    except ValueError as err:
        raise InputError(f"{path}:{number}: not 'class cx cy w h': {line[:60]!r}") from err
    if not all(0.0 <= v <= 1.0 for v in (cx, cy, w, h)):
        raise InputError(f"{path}:{number}: cx cy w h must be numbers 0-1 (normalised "
                         f"to the image), not {line[:60]!r}")
    return cls, ((cx - w / 2) * width, (cy - h / 2) * height,
                 (cx + w / 2) * width, (cy + h / 2) * height)


def read_boxes(path: Path, width: int, height: int, ball_class: int) -> list[Box]:
    """The boxes of ``ball_class`` in a YOLO label file, in pixels of a width x height
    image (a box of zero width or height is left out)."""
    text = read_text_file(path, MAX_LABEL_BYTES, what="a label file")
    boxes = []
    for number, line in enumerate(text.splitlines(), 1):
        if not line.strip():
            continue
        if len(line.split()) != 5:
            raise InputError(f"{path}:{number}: not 'class cx cy w h': {line[:60]!r}")
        cls, box = _line_box(path, number, line, width, height)
        if cls == ball_class and box[2] > box[0] and box[3] > box[1]:
            boxes.append(box)
    return boxes


def read_image(path: Path) -> npt.NDArray[np.uint8]:
    """A BGR image from a JPEG or PNG file, bounded in bytes and pixels."""
    data = read_bytes_file(path, MAX_IMAGE_BYTES, what="an image file")
    buf = np.frombuffer(data, np.uint8)
    # the header first: a small file may still claim a huge image
    probe = cv2.imdecode(buf, cv2.IMREAD_REDUCED_GRAYSCALE_8) if buf.size else None
    if probe is None:
        raise InputError(f"{path}: not a readable JPEG or PNG image")
    if probe.shape[0] * probe.shape[1] * 64 > MAX_PIXELS:
        raise InputError(f"{path}: more than {MAX_PIXELS} pixels")
    image = cv2.imdecode(buf, cv2.IMREAD_COLOR)
    if image is None or image.ndim != 3:
        raise InputError(f"{path}: not a readable JPEG or PNG image")
    return np.asarray(image, np.uint8)


def _check_folder(folder: Path) -> None:
    """A missing folder and a file given as one are two different mistakes: say which."""
    if not folder.exists():
        raise InputError(f"{folder}: no such folder")
    if not folder.is_dir():
        raise InputError(f"{folder}: not a folder")


def find_labelled(folder: Path) -> list[Labelled]:
    """The images of ``folder`` with a label file beside them, by file name."""
    _check_folder(folder)
    found = []
    for name in sorted(os.listdir(folder)):
        path = folder / name
        label = path.with_suffix(".txt")
        if path.suffix.lower() in IMAGE_SUFFIXES and label.is_file() and path.is_file():
            found.append(Labelled(path, label))
    return found


def labelled_folders(root: Path) -> list[Path]:
    """``root`` and every folder under it that holds labelled images, by path (symbolic
    links are not followed)."""
    _check_folder(root)
    found = []
    for here, dirs, _ in os.walk(root):
        dirs.sort()
        if find_labelled(Path(here)):
            found.append(Path(here))
    return sorted(found)
