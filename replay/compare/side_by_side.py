"""``dsp-compare A B --rerun LOG``: both runs of one log in one Rerun recording.

Rerun shows one recording at a time, so the two runs go into one recording under two entity
prefixes, ``/A`` and ``/B`` (each the entity tree of docs/viewer.md), and a blueprint puts
A's cameras beside B's, A's field view beside B's, and the error plots of both in one panel
(the series named "A fused", "B robot1", ...; B's fused error in the track colour). The
images, the same in both runs, are logged once (under ``/A``); B's camera views show them
under B's detections. Each run
is replayed again from the log with the options its results file names (calibration and
camera files by name: looked for beside the log, then in the working folder), so the log
must be the one the results are of (its sha256).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from pathlib import Path
from typing import Any, cast

import rerun as rr
import rerun.blueprint as rrb

from dsp import contract
from dsp.atomic import AtomicFile
from dsp.errors import InputError, OutputError
from dsp.field import DEFAULT_FIELD, FIELDS, FieldSpec
from dsp.jsonio import Json
from replay.cameras import cameras_for
from replay.compare.load import ResultsRun
from replay.log import LogInfo, LogReader
from replay.options import ReplayOptions, RerunTarget
from replay.runner import file_digest, replay
from replay.sinks.rerun.blueprint import cameras_view, field_view, learnt_view
from replay.sinks.rerun.live import check_display
from replay.sinks.rerun.sink import APPLICATION_ID, RerunSink
from replay.sinks.rerun.streams import check_room, commit, flush, recording_id, write_failure
from replay.sinks.style import FUSED_COLOUR, TRACK_COLOUR

__all__ = ["PREFIXES", "replay_options", "side_by_side", "side_by_side_blueprint"]

PREFIXES = ("/A", "/B")
_OPTION_KEYS = ("method", "fusion", "detector", "image_topic", "pose_topic", "truth_topic",
                "start_s", "end_s", "start_absolute", "end_absolute", "pose_tolerance_s",
                "window_s", "recover", "noise", "smooth", "clock_hz", "hops", "width_range",
                "localise", "pose_uncertainty", "pose_sigma_m", "pose_sigma_deg")


def replay_options(run: ResultsRun, log: Path) -> ReplayOptions:
    """The options a results file was made with, to replay ``log`` the same way."""
    o: Mapping[str, Any] = run.options
    kw: dict[str, Any] = {k: o[k] for k in _OPTION_KEYS if o.get(k) is not None}
    if o.get("robots") is not None:
        kw["robots"] = tuple(o["robots"])
    for key in ("calibration", "cameras"):
        name = o.get(key)
        if name is None or name == "paper":
            kw[key] = name
            continue
        found = [p for p in (log.parent / str(name), Path(str(name))) if p.is_file()]
        if not found:
            raise InputError(f"{run.path}: made with --{key} {name}, which is neither beside "
                             f"{log} nor in the working folder")
        kw[key] = found[0]
    return ReplayOptions(**kw, progress=False, quiet=True)


class _Prefixed:
    """A recording stream's logging, every entity path under ``prefix``."""

    def __init__(self, rec: rr.RecordingStream, prefix: str, *, images: bool) -> None:
        self._rec, self._prefix, self._images = rec, prefix, images

    def log(self, path: str, *args: Any, **kwargs: Any) -> None:
        if self._images or not path.endswith("/camera/image"):
            self._rec.log(f"{self._prefix}{path}", *args, **kwargs)

    def set_time(self, *args: Any, **kwargs: Any) -> None:
        self._rec.set_time(*args, **kwargs)

    def reset_time(self) -> None:
        self._rec.reset_time()


class _PrefixedSink(RerunSink):
    """The replay's Rerun sink, logging into a shared recording under a prefix."""

    def __init__(self, rec: rr.RecordingStream, prefix: str, **kwargs: Any) -> None:
        self._shared, self._prefix = rec, prefix
        super().__init__(RerunTarget("save"), **kwargs)

    def _open(self, *, force: bool) -> None:
        # the images are the same in both runs: logged once, under A
        self.rec = cast(rr.RecordingStream, _Prefixed(self._shared, self._prefix,
                                                      images=self._prefix == PREFIXES[0]))
        self._static()
        label = self._prefix.strip("/")
        for name in (*self.info.robots, "fused"):
            colour = (TRACK_COLOUR if label == "B" else FUSED_COLOUR) if name == "fused" \
                else self.colours[name]
            self.rec.log(f"/plots/error/{name}", rr.SeriesLines(
                colors=[colour], names=[f"{label} {name}"],
                widths=[3.0 if name == "fused" else 1.5]), static=True)

    def close(self, ok: bool) -> None:  # the shared recording is closed by its owner
        pass


def side_by_side_blueprint(robots: tuple[str, ...], field: FieldSpec) -> rrb.Blueprint:
    """A's cameras beside B's (each run's last tab what it learnt), A's field beside B's,
    both runs' errors in one plot."""
    a, b = PREFIXES
    errors = rrb.TimeSeriesView(origin="/", contents=[f"{a}/plots/error/**",
                                                      f"{b}/plots/error/**"],
                                name="error vs ground truth [m], A and B",
                                plot_legend=rrb.PlotLegend(rrb.Corner2D.RightTop))
    return rrb.Blueprint(
        rrb.Vertical(rrb.Horizontal(cameras_view(robots, a, extra=[learnt_view(a)]),
                                    cameras_view(robots, b, images_from=a,
                                                 extra=[learnt_view(b)])),
                     rrb.Horizontal(field_view(field, a), field_view(field, b)),
                     errors, row_shares=[3.0, 2.4, 1.6]),
        rrb.BlueprintPanel(state="collapsed"), rrb.SelectionPanel(state="collapsed"),
        rrb.TimePanel(state="collapsed", timeline="sim_time", play_state="following"))


def _log_info(log: Path) -> tuple[LogInfo, dict[str, tuple[float, float]]]:
    with LogReader(log) as reader:
        info = reader.info
    cams = cameras_for(info.robots, log=str(log), metadata=info.cameras.camera_set(
        f"{log}: metadata {contract.CAMERAS_METADATA}"))
    return info, dict(cams.centres)


def side_by_side(log: Path, a: ResultsRun, b: ResultsRun, *, save: Path | None,
                 force: bool = False) -> None:
    """Replay ``log`` as ``a`` and ``b`` were made into one recording: saved to ``save``
    (.rrd), or shown in a spawned viewer."""
    digest = file_digest(log)
    for run in (a, b):
        if run.sha256 != digest:
            raise InputError(f"{log}: not the log {run.path} is the results of "
                             f"({run.log_file}, sha256 {run.sha256[:12]}...)")
    options = [replay_options(run, log) for run in (a, b)]
    info, centres = _log_info(log)
    field = info.scenario.field if info.scenario is not None else FIELDS[DEFAULT_FIELD]
    views: dict[str, Json] = {"a": a.options, "b": b.options}
    rec = rr.RecordingStream(f"{APPLICATION_ID}_compare",
                             recording_id=recording_id(digest, views))
    rec.set_log_time_enabled(False)
    bp = side_by_side_blueprint(info.robots, field)
    out = AtomicFile(save, force=force) if save is not None else None
    try:
        if out is not None:
            check_room(out.path)  # a nearly full disk can block Rerun's writer
            try:
                rec.save(out.tmp, default_blueprint=bp)
            except RuntimeError as err:
                raise write_failure(out.path, err, rec) from err
        else:
            check_display()
            rec.spawn(default_blueprint=bp)
        for prefix, opts in zip(PREFIXES, options, strict=True):
            sink = _PrefixedSink(rec, prefix, info=info, digest=digest, centres=centres,
                                 options=dataclasses.replace(opts))
            sink.log_learnt(replay(log, opts, sinks=[sink]).beliefs)  # under the prefix
        try:
            flush(rec, None if out is None else out.tmp)
        except RuntimeError as err:  # the file writer stopped, or the viewer went away
            if out is not None:
                raise write_failure(out.path, err, rec) from err
            raise OutputError("the Rerun viewer", str(err)) from err
        if out is not None:
            commit(rec, out)  # when whole: a writer stopped mid-way may say nothing
        else:
            rec.disconnect()
    finally:
        if out is not None:
            out.discard()
