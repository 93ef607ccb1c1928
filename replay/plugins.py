"""Estimator parts from outside the package: detectors, fusions, calibration models.

A part is named on the command line (``dsp-replay --detector SPEC``, ``--fusion SPEC``,
``--calibration-model SPEC``) and in :class:`~replay.options.ReplayOptions` by one of:

- a built-in name: the fusions of :data:`estimator.fusion.FUSION_METHODS`, the detectors
  :data:`replay.real_ball.DETECTORS` (the paper's chain,
  :func:`estimator.detection.detect_ball`, and the real-ball detector of a ball model); the
  built-in calibration models have no such name: a calibration file (``--calibration``)
  names them with its parameters;
- an entry point's name in the group :data:`GROUPS` gives (``dual_sight.detectors``,
  ``dual_sight.fusions``, ``dual_sight.calibrations``), which an installed distribution
  declares in its pyproject::

      [project.entry-points."dual_sight.fusions"]
      median = "my_parts.fusion:MedianFusion"

- ``package.module:Class``, imported from ``sys.path``.

The class is called with no arguments. A fusion is an :class:`estimator.fusion.Fusion`
(``name``, ``fuse(estimates) -> FusedEstimate | None``), made afresh for each replay
(:func:`new_part`) so one that keeps state from step to step, a tracker, starts clean (a
tracker that needs the time also has ``fuse_at(stamp_ns, estimates)``, an
:class:`estimator.fusion.TimedFusion`: the replay then calls it at every step); a
detector a :class:`Detector` (``name``, ``detect(image_bgr) -> Detection | None``, called
from the decoding threads, so it must be thread-safe); a calibration model an
:class:`estimator.calibration.Calibration` (``name``, ``range_m(r_px) -> float``, raising
:class:`estimator.errors.OutOfRangeError` where it has no range, ``to_dict()``), used for
every robot in place of its camera's. Results name a part from outside, its distribution's
version and how it was found in their header (``parts``: :func:`parts_view`), so
``dsp-compare`` can say what differed; built-in parts are named by the options alone (files
stay as they were).
A spec that does not load is one line (:class:`~dsp.errors.UsageError`).
"""

from __future__ import annotations

import functools
import importlib
from dataclasses import dataclass
from importlib import metadata
from typing import Any, Protocol, runtime_checkable

import numpy as np

from dsp.errors import UsageError
from dsp.jsonio import Json
from estimator.calibration import Calibration
from estimator.detection import Detection
from estimator.fusion import FUSION_METHODS, Fusion
from replay.real_ball import DETECTORS

__all__ = ["GROUPS", "Detector", "Part", "load_part", "new_part", "parts_view"]

GROUPS = {"detector": "dual_sight.detectors", "fusion": "dual_sight.fusions",
          "calibration": "dual_sight.calibrations"}
BUILTIN: dict[str, tuple[str, ...]] = {"detector": DETECTORS, "fusion": FUSION_METHODS,
                                       "calibration": ()}
FLAGS = {"detector": "--detector", "fusion": "--fusion", "calibration": "--calibration-model"}


@runtime_checkable
class Detector(Protocol):
    """The ball in one BGR image (H x W x 3 uint8), or None."""

    @property
    def name(self) -> str: ...

    def detect(self, image_bgr: np.ndarray) -> Detection | None: ...


PROTOCOLS: dict[str, tuple[type, str]] = {
    "detector": (Detector, "name and detect(image)"),
    "fusion": (Fusion, "name and fuse(estimates)"),
    "calibration": (Calibration, "name, range_m(r_px) and to_dict()"),
}


@dataclass(frozen=True)
class Part:
    """A part from outside: what the results header says of it, and the part itself."""

    kind: str
    spec: str
    name: str
    version: str
    source: str
    """"entry point" (its group) or "module" (``package.module:Class``)."""
    obj: Any
    make: Any
    """What ``obj`` was made by (:func:`new_part` calls it again), or ``obj`` itself when
    the spec names an object rather than a class."""

    def view(self) -> dict[str, Json]:
        return {"spec": self.spec, "name": self.name, "version": self.version,
                "source": self.source}


def _version_of(module: str, ep: metadata.EntryPoint | None) -> str:
    if ep is not None and ep.dist is not None:
        return ep.dist.version
    top = module.partition(".")[0]
    dists = metadata.packages_distributions().get(top, [])
    for dist in dists:
        try:
            return metadata.version(dist)
        except metadata.PackageNotFoundError:
            continue
    mod = importlib.import_module(module)
    return str(getattr(mod, "__version__", "unknown"))


def _import(kind: str, spec: str) -> tuple[Any, str, metadata.EntryPoint | None]:
    flag = FLAGS[kind]
    if ":" in spec:
        module, _, attr = spec.partition(":")
        try:
            obj: Any = importlib.import_module(module)
            for name in attr.split("."):
                obj = getattr(obj, name)
        except (ImportError, AttributeError) as err:
            raise UsageError(f"{flag} {spec}: cannot load it ({type(err).__name__}: "
                             f"{str(err).splitlines()[0] if str(err) else err})") from None
        return obj, module, None
    found = [ep for ep in metadata.entry_points(group=GROUPS[kind]) if ep.name == spec]
    if not found:
        names = sorted({*BUILTIN[kind], *(ep.name for ep in
                                         metadata.entry_points(group=GROUPS[kind]))})
        what = f"a built-in {kind} nor " if BUILTIN[kind] else ""
        choose = f"choose one of {', '.join(names)} or " if names else ""
        raise UsageError(f"{flag} {spec!r}: not {what}an installed {GROUPS[kind]} entry "
                         f"point; {choose}give package.module:Class")
    ep = found[0]
    try:
        obj = ep.load()
    except Exception as err:  # a broken plug-in: one line, whatever it raised
        raise UsageError(f"{flag} {spec}: its entry point {ep.value} does not load "
                         f"({type(err).__name__}: {err})") from None
    return obj, ep.module, ep


@functools.lru_cache(maxsize=32)
def load_part(kind: str, spec: str) -> Part:
    """The part ``spec`` names (not a built-in one), made and checked; cached per process."""
    obj, module, ep = _import(kind, spec)
    make = obj if isinstance(obj, type) or callable(obj) else (lambda: obj)
    part = _make(kind, spec, make)
    protocol, wants = PROTOCOLS[kind]
    if not isinstance(part, protocol):
        raise UsageError(f"{FLAGS[kind]} {spec}: {type(part).__name__} is not a {kind} (it "
                         f"needs {wants})")
    named: Any = part
    return Part(kind, spec, str(named.name), _version_of(module, ep),
                f"entry point {GROUPS[kind]}" if ep is not None else "module", part, make)


def _make(kind: str, spec: str, make: Any) -> Any:
    try:
        return make()
    except Exception as err:
        raise UsageError(f"{FLAGS[kind]} {spec}: making it failed ({type(err).__name__}: "
                         f"{err})") from None


def new_part(kind: str, spec: str) -> Any:
    """A new instance of the part ``spec`` names (checked once, by :func:`load_part`): each
    replay's own, so a part that keeps state does not carry it from one replay to the next."""
    return _make(kind, spec, load_part(kind, spec).make)


def is_builtin(kind: str, spec: str | None) -> bool:
    return spec is None or spec in BUILTIN[kind]


def parts_view(specs: dict[str, str | None]) -> dict[str, Json]:
    """The header's ``parts``: each part from outside (kind -> its view), none built in."""
    return {kind: load_part(kind, spec).view() for kind, spec in sorted(specs.items())
            if spec is not None and not is_builtin(kind, spec)}
