"""Ball model files (``ball.json``): a venue's real-ball model, and the shipped learned check.

``dsp-calibrate --ball-from DIR`` writes one (:func:`ball_file_text`); ``dsp-replay --ball``
and ``dsp-eval --suite images`` read one (:func:`read_ball_file`): bounded, a regular file,
JSON through the standard library (no pickle, no eval), every field checked by
:func:`estimator.detection.real.model_from_dict`; a bad one is one line naming the file
and the field. The models are fitted on someone's labelled images: the file says which
(``fit``), and a model fitted on the robocup_ml images keeps their notice (Apache-2.0,
``estimator/detection/real/NOTICE``).

:func:`shipped_check` is the shared check's ONNX bytes, read from the installed package;
:func:`shipped_generic` the ball model that needs no frame of the venue.
"""

from __future__ import annotations

import json
from functools import cache
from importlib.resources import files
from pathlib import Path

from dsp import jsonio
from dsp.errors import InputError
from dsp.textfile import read_bytes_file, read_text_file
from estimator.detection.real import BallModel, model_from_dict, model_to_dict
from estimator.errors import BallModelError

__all__ = ["MAX_BALL_FILE_BYTES", "MAX_CHECK_BYTES", "ball_file_text", "read_ball_file",
           "read_check_file", "shipped_check", "shipped_generic"]

MAX_BALL_FILE_BYTES = 1 << 20
"""A fitted model is about 13 kB."""
GENERIC_NAME = "ball_generic.json"
MAX_CHECK_BYTES = 16 << 20
"""The shipped check is 81 kB."""


def read_ball_file(path: Path) -> BallModel:
    """The ball model of a ``ball.json``; :class:`InputError` naming the file and problem."""
    text = read_text_file(path, MAX_BALL_FILE_BYTES, what="a ball model file")
    try:
        data = jsonio.loads(text)
    except json.JSONDecodeError as err:
        raise InputError(f"{path}: not JSON ({err.msg} at line {err.lineno})") from err
    except ValueError as err:  # beyond the limits of a JSON input
        raise InputError(f"{path}: not a usable JSON file ({err})") from err
    try:
        return model_from_dict(data)
    except BallModelError as err:
        raise InputError(f"{path}: {err}") from err


def ball_file_text(model: BallModel) -> str:
    """The JSON text of a model (sorted keys, one item per line: the same model, the same
    bytes)."""
    return json.dumps(model_to_dict(model), indent=1, sort_keys=True) + "\n"


@cache
def shipped_generic() -> BallModel:
    """The shipped generic ball model (``estimator/detection/real/ball_generic.json``,
    made by ``train/generic.py``): what a team uses before it labels a frame of its venue."""
    text = files("estimator.detection.real").joinpath(GENERIC_NAME).read_text("utf-8")
    try:
        return model_from_dict(json.loads(text))
    except (json.JSONDecodeError, BallModelError) as err:  # pragma: no cover: packaging
        raise InputError(f"the shipped {GENERIC_NAME}: {err}") from err


@cache
def shipped_check() -> bytes:
    """The shared check's ONNX bytes (``estimator/detection/real/ball_check.onnx``)."""
    return files("estimator.detection.real").joinpath("ball_check.onnx").read_bytes()


def read_check_file(path: Path) -> bytes:
    """A learned check's ONNX bytes (``train/train.py`` makes one): a regular file, bounded;
    that it loads is checked where it is used."""
    return read_bytes_file(path, MAX_CHECK_BYTES, what="a ball check")
