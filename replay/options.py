"""What a replay depends on: :class:`ReplayOptions`, validated when it is made.

Seconds at this edge (the CLI's units); the runner turns them into integer nanoseconds once
(:meth:`ReplayOptions.timing`). Every value is checked when the options are made: times
finite and in range (:data:`MAX_WINDOW_S`, :data:`~dsp.checks.MAX_TIME_S`), topic patterns
holding ``{robot}``, no two outputs on one file (the CLI checks their extensions). Output
paths are checked against the file system (and the input log) only when a replay starts
(:meth:`ReplayOptions.check_outputs`), since files come and go.
"""

from __future__ import annotations

import os
from dataclasses import asdict, dataclass
from pathlib import Path

from dsp import contract
from dsp.atomic import check_distinct, check_output_path
from dsp.checks import (
    MAX_THREADS,
    MAX_TIME_S,
    MIN_RATE_HZ,
    check_int,
    check_number,
    check_topic_pattern,
)
from dsp.errors import UsageError
from dsp.jsonio import Json
from estimator.calibration import Calibration
from estimator.constants import NS_PER_S
from estimator.fusion import FUSION_METHODS
from replay import plugins
from replay.log import DEFAULT_MAX_MESSAGE_BYTES, Limits
from replay.real_ball import DETECTORS

__all__ = ["DEFAULT_FUSION", "DEFAULT_POSE_SIGMA", "FIT_LEAD_S", "LOCALISE_MODES",
           "MAX_WINDOW_S", "METHODS", "ReplayOptions", "RerunTarget", "Timing"]

METHODS = ("paper", "corrected")
DEFAULT_FUSION = {"paper": "mean", "corrected": "track"}
"""Paper mode fuses as the paper does (eq. 20-21); the corrected estimator tracks the ball
(:mod:`estimator.tracking.tracker`): a position and velocity at every image stamp."""
NOISE_MODELS = ("cambada", "calibrated")  # the window fusions' --noise (the tracker's: calibrated)
MAX_WINDOW_S = 60.0  # the largest --pose-tolerance and --window [s] (images wait that long)
MAX_CLOCK_HZ = 10_000.0  # the fastest --clock [Hz]
RERUN_MODES = ("spawn", "save", "connect", "serve")
LOCALISE_MODES = ("none", "lines", "ball", "auto")
"""``--localise``: the believed poses, or corrected from each image's field lines
(:mod:`replay.localise`) or by each robot's bias the tracker's residuals show
(:mod:`estimator.tracking.bias`); "auto": :func:`replay.profiles.decide`."""
DEFAULT_POSE_SIGMA = (0.05, 1.0)
"""What :attr:`ReplayOptions.pose_sigma` gives where ``--pose-sigma`` is not: no replay uses
it then (the line fit's prior, the bias's spread and the pose's covariance are learnt from
the log: :mod:`estimator.localisation.spread`, :mod:`estimator.tracking.pose_noise`); the
fallback of a :class:`~replay.localise.Localiser` asked to fit without a prior."""
FIT_LEAD_S = 0.1
"""With ``--localise lines`` a frame settles (its fit runs) this much later [s] in log time
than its pose: which earlier fits its prior and start have seen, the same every run."""


@dataclass(frozen=True)
class RerunTarget:
    """Where Rerun data goes: ``mode`` one of spawn, save, connect, serve."""

    mode: str
    target: str | None = None

    def __post_init__(self) -> None:
        if self.mode not in RERUN_MODES:
            raise UsageError(f"Rerun mode {self.mode!r}; choose one of {', '.join(RERUN_MODES)}")


@dataclass(frozen=True)
class Timing:
    """The options' times in integer nanoseconds, as the runner uses them."""

    tolerance_ns: int
    window_ns: int
    start_ns: int | None
    end_ns: int | None
    clock_ns: int | None = None
    """The clock's period, when steps are also made at its ticks."""
    lead_ns: int = 0
    """How long a frame waits after its poses are known, for work done meanwhile (the
    line fit); 0 when there is none."""

    @property
    def lookahead_ns(self) -> int:
        """How far the log must run past an image before its poses and step are complete."""
        return self.tolerance_ns + self.window_ns

    @property
    def read_from_ns(self) -> int | None:
        """Where reading starts: early enough before ``start`` to have the poses and truth
        that the first images after it are paired with."""
        return None if self.start_ns is None else max(0, self.start_ns - 2 * self.lookahead_ns)


@dataclass(frozen=True)
class ReplayOptions:
    """Everything a replay depends on (keyword arguments of the CLI, in seconds at the edge).

    Raises :class:`~replay.errors.UsageError` when made with a value out of range."""

    method: str = "corrected"
    profile: str | None = None
    """The profile these options were made from (:func:`replay.profiles.options_for`),
    recorded in the results; None: options made one by one."""
    detector: str | None = None
    """How the ball is found in an image: "paper" (the paper's chain), "real" (the
    real-ball detector of ``ball``) or a detector from outside (:mod:`replay.plugins`: an
    entry point's name or ``package.module:Class``); None: "real" with a ball model, else
    "paper"."""
    ball: Path | None = None
    """A ball model file (``dsp-calibrate --ball-from``) for the real detector."""
    fusion: str | None = None
    """None: the method's own (:data:`DEFAULT_FUSION`); a built-in name, an entry point's
    or ``package.module:Class`` (:mod:`replay.plugins`)."""
    calibration: Path | str | None = None
    """A calibration file for every robot, or "paper" (the paper's eq. 4 and, for a robot
    the log describes no camera of, its image centre too)."""
    calibration_model: str | None = None
    """A calibration model from outside for every robot, in place of its camera's: an entry
    point's name (``dual_sight.calibrations``) or ``package.module:Class``
    (:mod:`replay.plugins`); not with ``calibration``."""
    cameras: Path | str | None = None
    """A camera file (:mod:`dsp.camera_file`), or "paper" (the paper's camera for every
    robot); None: the log's ``dsp.cameras`` metadata (:mod:`replay.cameras`)."""
    image_topic: str = contract.IMAGE_TOPIC
    pose_topic: str = contract.POSE_TOPIC
    truth_topic: str | None = None
    """The ball's true position (PoseStamped, PointStamped or Odometry), for scoring; None:
    the contract's (/ground_truth/ball, or its odometry)."""
    robots: tuple[str, ...] | None = None
    start_s: float | None = None
    """Seconds from the log's start (see :meth:`timing`), or an absolute stamp with
    ``start_absolute``."""
    end_s: float | None = None
    start_absolute: bool = False
    """``start_s`` is a stamp (seconds since the epoch of the log's clock), not an offset."""
    end_absolute: bool = False
    pose_tolerance_s: float = 0.1
    window_s: float = 0.05
    recover: bool = False
    noise: str = "cambada"
    """The window fusions' per-estimate covariance: "cambada" (the fixed range law,
    :class:`~estimator.noise.NoiseModel`) or "calibrated" (from the calibration,
    :class:`~estimator.noise.CalibratedNoise`, as the tracker and ``triangulate`` always
    use)."""
    smooth: bool = False
    """Offline: the tracker's fixed-interval (RTS) smoother instead of its causal estimate
    (``track`` fusion only); steps reach the sinks once the log is read."""
    hops: bool = False
    """The tracker's position from a 3-D track beside it while the ball hops
    (:mod:`estimator.hops`; ``track`` fusion only, not with ``smooth``)."""
    width_range: bool | None = None
    """Each blob's range also from its width across the bearing, which a ball in the air
    does not change (:mod:`estimator.width`; the corrected method only): True every robot's,
    None those of robots whose camera has no model, False none (:mod:`replay.aloft`)."""
    clock_hz: float | None = None
    """Also a step at every tick k / clock_hz s of a clock (no image in it): the fused
    estimate the fusion gives then (the tracker's prediction from the estimates so far; none
    from a window fusion), scored against the truth at the tick, only near images
    (:mod:`replay.clock`). None: steps at images."""
    out: Path | None = None
    out_mcap: Path | None = None
    out_csv: Path | None = None
    """The estimates as CSV (:mod:`replay.sinks.csv_export`)."""
    plot: Path | None = None
    """A figure of the replay, .png or .svg (:mod:`replay.sinks.figure`)."""
    force: bool = False
    rerun: RerunTarget | None = None
    rerun_save: Path | None = None
    """An .rrd file the Rerun recording is saved to as well, while it is viewed live
    (``--rerun --save FILE``, as Rerun's own examples allow)."""
    threads: int | None = None
    """Threads decoding and detecting images ahead (:mod:`replay.ahead`); None: the
    machine's cores, 1: none (serial). The outputs are the same bytes whatever the count."""
    progress: bool | None = None
    """Show progress: True a bar, False none, None a bar when stderr is a terminal and
    plain lines every few seconds when it is not (:func:`dsp.progress.progress_bar`)."""
    quiet: bool = False
    """Print no summary and no progress (the CLI's ``-q``); warnings are still printed: they
    are what a replay that went wrong quietly would otherwise hide."""
    strict: bool = False
    """Warnings are errors (:mod:`replay.diagnosis`): a replay that would warn fails, and
    writes nothing."""
    max_chunk_mib: float = 128.0
    """Refuse a chunk (compressed or declared uncompressed) or summary larger than this."""
    max_image_mpx: float = 40.0
    """Refuse to decode an image whose header declares more megapixels than this."""
    localise: str = "none"
    """"lines": each frame's pose corrected from the field lines in its image before the
    ball is located (:mod:`replay.localise`); "ball": corrected by its robot's bias, which
    the tracker's residuals estimate (:mod:`estimator.tracking.bias`; ``--fusion track``
    only); "none": the believed poses."""
    pose_sigma_m: float | None = None
    pose_sigma_deg: float | None = None
    """``--pose-sigma`` (position [m], yaw [deg]): the line fit's weight of the believed
    pose; the pose's covariance where neither the line fit nor the log gives one; the bias's
    spread. None: each learnt from the log as it replays."""
    pose_uncertainty: bool = False
    """Each robot's estimate carries the covariance of the pose it was located from, and
    the fusion adds the ball's share of it (:func:`estimator.noise.localisation_covariance`:
    the position's, and the yaw's across the bearing, growing with range): the line fit's
    (``--localise lines``), else the log pose's own (PoseWithCovarianceStamped, Odometry),
    else ``--pose-sigma``'s."""

    def __post_init__(self) -> None:
        if self.method not in METHODS:
            raise UsageError(f"--method {self.method!r}; choose one of {', '.join(METHODS)}")
        if self.detector_name != "real" and self.ball is not None:
            raise UsageError(f"--ball goes with the real detector, not --detector "
                             f"{self.detector_name}")
        if self.fusion_method not in FUSION_METHODS:
            plugins.load_part("fusion", self.fusion_method)  # a fusion from outside, or one line
        if not plugins.is_builtin("detector", self.detector):
            plugins.load_part("detector", str(self.detector))
        if self.calibration_model is not None:
            if self.calibration is not None:
                raise UsageError("--calibration-model and --calibration both replace every "
                                 "robot's calibration; give one of the two")
            plugins.load_part("calibration", self.calibration_model)
        if self.threads is not None and (isinstance(self.threads, bool) or self.threads < 1):
            raise UsageError(f"--threads {self.threads}; must be >= 1")
        check_int("--threads", self.threads, low=1, high=MAX_THREADS)
        check_number("--pose-tolerance", self.pose_tolerance_s, low=0, high=MAX_WINDOW_S,
                     unit="s")
        check_number("--window", self.window_s, low=0, high=MAX_WINDOW_S, low_open=True,
                     unit="s")
        for flag, value in (("--start", self.start_s), ("--end", self.end_s)):
            check_number(flag, value, low=-MAX_TIME_S, high=MAX_TIME_S, unit="s")
        check_number("--clock", self.clock_hz, low=MIN_RATE_HZ, high=MAX_CLOCK_HZ, unit="Hz")
        # under 1 MiB a log's own records (not its chunks) hit the limit: "corrupt" would mislead
        check_number("--max-chunk-mib", self.max_chunk_mib, low=1, high=1 << 20, unit="MiB")
        check_number("--max-image-mpx", self.max_image_mpx, low=0.01, high=1 << 20, unit="Mpx")
        if (self.start_s is not None and self.end_s is not None
                and self.start_absolute == self.end_absolute and self.end_s < self.start_s):
            raise UsageError(f"--end {self.end_s} is before --start {self.start_s}")
        if self.noise not in NOISE_MODELS:
            raise UsageError(f"--noise {self.noise!r}; choose one of {', '.join(NOISE_MODELS)}")
        if self.smooth and self.fusion_method != "track":
            raise UsageError(f"--smooth smooths the tracker; it needs --fusion track, not "
                             f"{self.fusion_method!r}")
        if self.hops and self.fusion_method != "track":
            raise UsageError("--hops follows the tracker's ball in 3-D; it needs --fusion "
                             f"track, not {self.fusion_method!r}")
        if self.hops and self.smooth:
            raise UsageError("--hops gives the causal track's position; it does not go "
                             "with --smooth")
        if self.width_range and self.method == "paper":
            raise UsageError("--width-range ranges each blob by its width as well, beside "
                             "the corrected estimator's calibration; the paper's equations "
                             "(--method paper) have none")
        if self.localise not in LOCALISE_MODES:
            raise UsageError(f"--localise {self.localise!r}; choose one of "
                             f"{', '.join(LOCALISE_MODES)}")
        if self.localise == "ball" and self.fusion_method != "track":
            raise UsageError(f"--localise ball learns the biases from the tracker's residuals; "
                             f"it needs --fusion track, not {self.fusion_method!r}")
        if (self.pose_sigma_m is None) != (self.pose_sigma_deg is None):
            raise UsageError("--pose-sigma needs both standard deviations, M,DEG")
        check_number("--pose-sigma", self.pose_sigma_m, low=0, high=10, low_open=True,
                     unit="m")
        check_number("--pose-sigma", self.pose_sigma_deg, low=0, high=90, low_open=True,
                     unit="deg")
        check_topic_pattern("--image-topic", self.image_topic)
        check_topic_pattern("--pose-topic", self.pose_topic)
        if self.truth_topic is not None and not (
                self.truth_topic.startswith("/") and self.truth_topic.isprintable()):
            raise UsageError(f"--truth-topic {self.truth_topic!r}: give a topic name such as "
                             "/mocap/ball")
        if self.robots is not None and not all(r and r.isprintable() for r in self.robots):
            raise UsageError(f"--robots {','.join(self.robots)!r}: give robot names")
        check_distinct(self.output_flags())

    @property
    def fusion_method(self) -> str:
        """The fusion in use: the one asked for, else the method's default."""
        return self.fusion or DEFAULT_FUSION[self.method]

    @property
    def save_path(self) -> Path | None:  # the .rrd file --save writes, if any
        if self.rerun is not None and self.rerun.mode == "save" and self.rerun.target:
            return Path(self.rerun.target)
        return self.rerun_save

    def output_flags(self) -> tuple[tuple[str, Path | None], ...]:
        """Every file output with the flag that names it."""
        return (("--out", self.out), ("--out-mcap", self.out_mcap), ("--out-csv", self.out_csv),
                ("--plot", self.plot), ("--save", self.save_path))

    def timing(self, origin_ns: int = 0) -> Timing:
        """The times in nanoseconds; ``--start`` / ``--end`` that are not absolute count from
        ``origin_ns``, the log's start (:func:`replay.selection.log_origin_ns`)."""
        def stamp(seconds: float | None, absolute: bool) -> int | None:
            if seconds is None:
                return None
            return round(seconds * NS_PER_S) + (0 if absolute else origin_ns)

        return Timing(
            tolerance_ns=round(self.pose_tolerance_s * NS_PER_S),
            window_ns=max(1, round(self.window_s * NS_PER_S)),
            start_ns=stamp(self.start_s, self.start_absolute),
            end_ns=stamp(self.end_s, self.end_absolute),
            clock_ns=None if self.clock_hz is None else max(1, round(NS_PER_S / self.clock_hz)),
            lead_ns=round(FIT_LEAD_S * NS_PER_S) if self.localise == "lines" else 0,
        )

    @property
    def pose_sigma_given(self) -> bool:  # else the pose's covariance is learnt
        return self.pose_sigma_m is not None

    @property
    def pose_sigma_used(self) -> bool:  # given, and something to weigh with it
        return self.pose_sigma_given and (self.localising or self.pose_uncertainty)

    @property
    def pose_sigma(self) -> tuple[float, float]:  # (m, deg): given, else the default
        if self.pose_sigma_m is None or self.pose_sigma_deg is None:
            return DEFAULT_POSE_SIGMA
        return self.pose_sigma_m, self.pose_sigma_deg

    @property
    def localising(self) -> bool:  # the poses are corrected (lines or ball)
        return self.localise != "none"

    def limits(self) -> Limits:
        """The reader's size limits in bytes."""
        chunk = int(self.max_chunk_mib * 1024 * 1024)
        return Limits(max_message_bytes=min(DEFAULT_MAX_MESSAGE_BYTES, chunk),
                      max_chunk_bytes=chunk)

    @property
    def max_image_pixels(self) -> int:
        return int(self.max_image_mpx * 1_000_000)

    def input_flags(self) -> list[tuple[str, Path]]:
        """Every file the options name for reading (the log aside), labelled."""
        return [(f"the {flag} file", Path(given))
                for flag, given in (("--ball", self.ball), ("--calibration", self.calibration),
                                    ("--cameras", self.cameras))
                if given is not None and given != "paper"]

    def check_outputs(self, log: Path | str | None = None) -> None:
        """Refuse, before any work: an output that exists already (unless ``force``), is a
        folder or has no folder; an output that is the input ``log`` or a file of
        :meth:`input_flags`, or that another output names too (symlinks and hard links included)."""
        check_distinct(self.output_flags(), [("the input log", log), *self.input_flags()])
        for flag, out in self.output_flags():
            if out is not None:
                check_output_path(out, force=self.force, label=flag)

    @property
    def detector_name(self) -> str:
        """The detector in use: the one asked for, else "real" with a ball model."""
        return self.detector or ("real" if self.ball is not None else "paper")

    def results_view(self) -> dict[str, Json]:
        """The options that shape the results (no output paths, no display switches)."""
        return {
            "method": self.method,
            "fusion": self.fusion_method,
            "calibration": None if self.calibration is None else Path(self.calibration).name,
            **({"calibration_model": self.calibration_model}
               if self.calibration_model is not None else {}),
            **({"cameras": Path(self.cameras).name} if self.cameras is not None else {}),
            "image_topic": self.image_topic,
            "pose_topic": self.pose_topic,
            "robots": None if self.robots is None else list(self.robots),
            "start_s": self.start_s,
            "end_s": self.end_s,
            "pose_tolerance_s": self.pose_tolerance_s,
            "window_s": self.window_s,
            "recover": self.recover,
            # new options appear only when set: files made without them stay as they were
            **({"noise": self.noise} if self.noise != "cambada" else {}),
            **({"detector": self.detector}
               if self.detector is not None and self.detector not in DETECTORS else {}),
            **({"smooth": True} if self.smooth else {}),
            **({"hops": True} if self.hops else {}),
            **({"width_range": self.width_range} if self.width_range is not None else {}),
            **({"clock_hz": self.clock_hz} if self.clock_hz is not None else {}),
            **({"truth_topic": self.truth_topic} if self.truth_topic is not None else {}),
            **({"start_absolute": True} if self.start_absolute else {}),
            **({"end_absolute": True} if self.end_absolute else {}),
            **({"detector": "real", "ball": self.ball.name}
               if self.detector_name == "real" and self.ball is not None else {}),
            **({"localise": self.localise} if self.localising else {}),
            **({"pose_uncertainty": True} if self.pose_uncertainty else {}),
            **(dict(zip(("pose_sigma_m", "pose_sigma_deg"), self.pose_sigma, strict=True))
               if self.pose_sigma_used else {}),
        }

    @property
    def thread_count(self) -> int:
        """The threads in use: the ones asked for, else the cores this process may use."""
        if self.threads is not None:
            return self.threads
        try:
            return max(1, len(os.sched_getaffinity(0)))
        except AttributeError:  # not on Linux
            return max(1, os.cpu_count() or 1)

    def detector_part(self) -> plugins.Detector | None:
        """The detector from outside, None for the paper's chain."""
        if plugins.is_builtin("detector", self.detector):
            return None
        part: plugins.Detector = plugins.load_part("detector", str(self.detector)).obj
        return part

    def calibration_part(self) -> Calibration | None:
        """The calibration model from outside, None when the cameras' or a file's is used."""
        if self.calibration_model is None:
            return None
        part: Calibration = plugins.load_part("calibration", self.calibration_model).obj
        return part

    def parts_view(self) -> dict[str, Json]:
        """The parts from outside the package (:func:`replay.plugins.parts_view`)."""
        return plugins.parts_view({"detector": self.detector, "fusion": self.fusion_method,
                                   "calibration": self.calibration_model})

    def as_dict(self) -> dict[str, object]:
        """All options as plain values (for hashing into a Rerun recording id); not the
        thread count, which changes nothing in the outputs."""
        d = asdict(self)
        d.pop("threads")
        if self.rerun_save is None:
            d.pop("rerun_save")
        if not self.localising:  # as before the option existed: the same recording ids
            d.pop("localise")
        if not self.pose_uncertainty:
            d.pop("pose_uncertainty")
        if not self.hops:
            d.pop("hops")
        if self.width_range is None:
            d.pop("width_range")
        if self.pose_sigma_used:
            d["pose_sigma_m"], d["pose_sigma_deg"] = self.pose_sigma
        else:
            d.pop("pose_sigma_m")
            d.pop("pose_sigma_deg")
        if self.calibration_model is None:
            d.pop("calibration_model")
        if self.profile is None:
            d.pop("profile")
        d["fusion"] = self.fusion_method
        return {k: (str(v) if isinstance(v, Path) else v) for k, v in d.items()}
