"""Profiles: named sets of a replay's choices, and the pipeline decided from what a log holds.

A replay runs one pipeline: detect -> locate (with the pose as corrected) -> fuse and track.
A **profile** names a set of choices for it; a switch (``--fusion``, ``--localise``, ...)
overrides one choice, and choices that cannot go with an explicit switch fall away (``--fusion
mean`` drops the tracker's hop handling). Code branches on the choices, never on a profile's
name.

- ``best`` (the default): the corrected estimator; each frame's pose corrected from the
  field lines in its image where the log (or the camera file) names its field and describes
  a camera (the believed pose where a frame's lines are not seen), else by each robot's
  drifting bias, learnt from how its ball disagrees with the others'
  (:mod:`estimator.tracking.bias`, its spread learnt from the log:
  :mod:`estimator.tracking.pose_noise`); each estimate weighed by its pose's uncertainty
  (the line fit's or the bias filter's, else the log pose's own covariance, else the one
  learnt from the log); the tracker with its 3-D track beside it (hops and balls in the
  air).
- ``fast``: the same without the line fit (believed poses): no per-frame fit, for logs
  whose poses are good already or when speed matters more.
- ``paper``: the paper exactly: eq. 3-14, the paper's colour chain, the mean fusion
  (eq. 20-21); no pose correction, no uncertainty, no tracker.

What the log decides (:func:`decide`, by the rules of :func:`allowances`, which ``dsp-info``
reports too): the line fit needs the field's geometry (the log's ``dsp.scenario`` metadata,
else the camera file's ``field``) and a camera model of at least one robot; the 3-D track
needs two or more robots. Where a part cannot apply the :class:`Pipeline` says why and how
to give what it needs, once, and the results header records the pipeline that ran
(:meth:`Pipeline.to_dict`).
"""

from __future__ import annotations

import dataclasses
import re
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from dsp.errors import UsageError
from dsp.field import DEFAULT_FIELD
from dsp.jsonio import Json

if TYPE_CHECKING:
    from replay.options import ReplayOptions

__all__ = ["DEFAULT_PROFILE", "PROFILES", "PROFILE_CHOICES", "Allowance", "Pipeline", "Profile",
           "allowances", "decide", "options_for", "without_reason"]


@dataclass(frozen=True)
class Profile:
    """A named set of choices (values of :class:`~replay.options.ReplayOptions` fields)."""

    name: str
    summary: str
    """One line for ``--help``."""
    method: str
    fusion: str
    localise: str
    """"auto": the field lines where the log allows them, else the ball (:func:`decide`)."""
    hops: bool
    pose_uncertainty: bool


PROFILES: dict[str, Profile] = {p.name: p for p in (
    Profile("best", "the most accurate pipeline measured: poses corrected from the field "
            "lines where the log allows it, pose uncertainty, the tracker with hops and "
            "balls in the air (default)",
            method="corrected", fusion="track", localise="auto", hops=True,
            pose_uncertainty=True),
    Profile("fast", "best without the line fit (the believed poses): for logs whose poses "
            "are good already, or when speed matters more",
            method="corrected", fusion="track", localise="none", hops=True,
            pose_uncertainty=True),
    Profile("paper", "the paper exactly: eq. 3-14, its colour detector and the mean fusion",
            method="paper", fusion="mean", localise="none", hops=False,
            pose_uncertainty=False),
)}
DEFAULT_PROFILE = "best"
PROFILE_CHOICES = tuple(PROFILES)

_CHOICES = ("method", "fusion", "localise", "hops", "pose_uncertainty")
"""The options a profile sets."""


def options_for(profile: str = DEFAULT_PROFILE, **given: Any) -> ReplayOptions:
    """The :class:`~replay.options.ReplayOptions` of ``profile`` with the options ``given``
    (keyword arguments of ReplayOptions; a profile's choice given as None is the profile's).
    A profile's choice that an explicit option rules out falls away: the hops and the line
    fit's ``auto`` need what they need, an explicit value never does (it is refused by the
    options' own checks when it cannot be)."""
    from replay.options import ReplayOptions

    if profile not in PROFILES:
        raise UsageError(f"--profile {profile!r}; choose one of {', '.join(PROFILES)}")
    p = PROFILES[profile]
    explicit = {k: v for k, v in given.items() if not (k in _CHOICES and v is None)}
    chosen: dict[str, Any] = {k: getattr(p, k) for k in _CHOICES if k not in explicit}
    method = str(explicit.get("method", chosen.get("method")))
    if "fusion" in chosen and "method" in explicit and explicit["method"] != p.method:
        del chosen["fusion"]  # the method's own fusion (mean for the paper's)
    fusion = explicit.get("fusion", chosen.get("fusion"))
    if fusion is None:
        from replay.options import DEFAULT_FUSION
        fusion = DEFAULT_FUSION[method]
    if "hops" in chosen and (fusion != "track" or explicit.get("smooth")):
        chosen["hops"] = False
    if "pose_uncertainty" in chosen and method == "paper":
        chosen["pose_uncertainty"] = False
    if "localise" in chosen and method == "paper" and p.method != "paper":
        chosen["localise"] = "none"
    return ReplayOptions(profile=profile, **explicit, **chosen)


@dataclass(frozen=True)
class Pipeline:
    """What a replay runs, part by part, as decided from its options and its log."""

    profile: str | None
    detector: str
    method: str
    poses: str
    """"lines" (corrected from the field lines), "ball" (by the tracker's residuals) or
    "believed" (the log's)."""
    pose_uncertainty: bool
    fusion: str
    hops: bool
    notes: tuple[str, ...] = ()
    """Each part the profile wanted that the log did not allow, and why."""
    detector_choice: str | None = None
    """Why the log's images, camera file or metadata chose the detector
    (:mod:`replay.detector_choice`); None: the options gave it."""
    detector_choice_recorded: bool = True
    """Whether the header records ``detector_choice`` (not for a dsp-record log's orange
    ball, whose results stay as they were)."""
    width: tuple[str, ...] = ()
    """The robots whose blobs the width places in the air (:mod:`replay.aloft`)."""

    def to_dict(self) -> dict[str, Json]:
        d: dict[str, Json] = {k: v for k, v in dataclasses.asdict(self).items()
                              if k not in ("notes", "detector_choice",
                                           "detector_choice_recorded", "width")}
        d["notes"] = list(self.notes)
        if self.width:  # recorded where it applies: other results stay as they were
            d["width"] = list(self.width)
        if self.detector_choice is not None and self.detector_choice_recorded:
            d["detector_choice"] = self.detector_choice
        return d

    def describe(self) -> str:
        """One line: the pipeline, and what did not apply."""
        poses = {"lines": "poses corrected from the field lines",
                 "ball": "poses corrected by each robot's bias",
                 "believed": "the believed poses"}[self.poses]
        chosen = "" if self.detector_choice is None else f" (chosen: {self.detector_choice})"
        parts = [f"{self.detector} detector{chosen}", f"{self.method} ranges", poses]
        if self.width:
            parts.insert(2, "balls in the air by their blob's width (" + ", ".join(
                self.width) + ")")
        if self.pose_uncertainty:
            parts.append("pose uncertainty")
        parts.append(f"{self.fusion} fusion" + (" with hops and flight" if self.hops else ""))
        head = "pipeline" + (f" ({self.profile})" if self.profile else "")
        return f"{head}: " + ", ".join(parts) + "".join(f"; {n}" for n in self.notes)


_REASON = re.compile(r" \(chosen: (?:[^()]|\([^()]*\))*\)")


def without_reason(line: str) -> str:
    """A pipeline line (:meth:`Pipeline.describe`) without why its detector was chosen,
    which differs from log to log where the images chose it."""
    return _REASON.sub("", line, count=1)


@dataclass(frozen=True)
class Allowance:
    """Whether what a log holds (and the camera file adds) allows one part of the default
    pipeline: the one rule both :func:`decide` and ``dsp-info`` go by."""

    part: str
    """"line fit" or "3-D track"."""
    allowed: bool
    detail: str
    """Allowed: what the part rests on; else what is missing, and how to give it."""

    def describe(self) -> str:
        return f"{self.part}: " + (f"yes ({self.detail})" if self.allowed
                                   else f"no: {self.detail}")


def allowances(*, field: str | None, robots: Sequence[str], camera_robots: Sequence[str]
               ) -> tuple[Allowance, Allowance]:
    """The line fit and the 3-D track: which a log allows. ``field``: the field's name (the
    log's scenario metadata or the camera file's ``field``), None when neither names one;
    ``camera_robots``: the robots with a camera model (the line fit projects the image with
    it); ``robots``: every robot replayed."""
    missing = []
    if field is None:
        missing.append("the log names no field (dsp.scenario metadata); name it in the "
                       f"camera file: field: {DEFAULT_FIELD}")
    if not camera_robots:
        missing.append("no robot's camera model is known (a camera file's mirror, fisheye "
                       "or ideal entry, or a lookup entry with height_m: --cameras FILE)")
    n = len(camera_robots)
    line_fit = Allowance("line fit", not missing, " and ".join(missing) if missing else
                         f"field {field}, camera models of {n} robot{'s' * (n != 1)}")
    track = Allowance("3-D track", len(robots) >= 2,
                      f"{len(robots)} robots" if len(robots) >= 2
                      else "one robot, no rays to cross")
    return line_fit, track


def decide(options: ReplayOptions, *, field: str | None, robots: Sequence[str],
           camera_robots: Sequence[str], notes: Sequence[str] = ()
           ) -> tuple[ReplayOptions, Pipeline]:
    """The options with every ``auto`` choice settled from what the log holds
    (:func:`allowances`), and the pipeline they run. ``field``: the field's name, None when
    neither the log nor the camera file names one; ``camera_robots``: the robots with a
    camera model; ``notes``: the caller's, first (where the field came from)."""
    line_fit, track = allowances(field=field, robots=robots, camera_robots=camera_robots)
    said = list(notes)
    localise = options.localise
    if localise == "auto":
        # where the lines cannot correct the poses, the ball can, relative to each other
        # (estimator.tracking.bias): with the tracker and a second robot to compare with;
        # the biases' spread is the one the log states, else the one learnt from it
        ball = options.fusion_method == "track" and len(robots) >= 2
        localise = "lines" if line_fit.allowed else "ball" if ball else "none"
        if not line_fit.allowed:
            said.append(f"no {line_fit.part}: {line_fit.detail}")
    hops = options.hops
    if hops and not track.allowed and options.profile is not None:
        hops = False
        said.append(f"no {track.part}: {track.detail}")
    settled = dataclasses.replace(options, localise=localise, hops=hops)
    poses = {"lines": "lines", "ball": "ball"}.get(localise, "believed")
    return settled, Pipeline(
        profile=options.profile, detector=options.detector_name, method=options.method,
        poses=poses, pose_uncertainty=options.pose_uncertainty,
        fusion=options.fusion_method, hops=hops, notes=tuple(said))
