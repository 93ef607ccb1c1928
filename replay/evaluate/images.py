"""``dsp-eval --suite images``: the ball detector scored on folders of labelled real images.

For each folder that holds labelled images (each venue-day apart), a venue's ball model is
fitted on its first ``train_count`` labelled images by file name (as a team would,
:func:`replay.calibrate.ball.fit_from_folder`; ``train_from`` k: the ``train_count`` from
the k-th on, to see how much the figures owe to which frames were labelled) and every
other labelled image is scored:

- per image the detector reports at most one ball; a hit (tp) is a reported centroid
  inside a labelled ball box grown by ``MARGIN_PX`` on each side; a report anywhere else is
  a false hit (fp); an image with a labelled ball and no hit is a miss (fn);
- precision = tp / (tp + fp); recall = tp / (images with a labelled ball); the centroid
  error of a hit is its distance to the centre of the box it hit (the nearest, when it lies
  in several), summarised by its median and 95th percentile;
- by kind: a false hit is off the field when the report's box's bottom centre lies above
  the field's far edge by more than its larger side (the detector's rule,
  :mod:`estimator.detection.real.field`, the field found with the scored model's field
  colour; the paper's chain: the generic model's), a ball (found or missed) when every
  labelled ball's box does; the labels
  say nothing of a ball in the air, so off the field stands for it (a ball in the air
  above the far side, or held up) as well as for the look-alikes among the spectators:
  ``with_ball_off_field``, ``fp_off_field`` and ``fn_off_field`` count them;
- ``ms_per_image``: the median wall time of the detector on one image (decoded already),
  the only figure that differs from run to run.

``threshold`` (None: the fitted model's) is the P(ball) from which the best candidate is
reported, to score a venue at another one.

``detector`` "paper" scores the paper's chain (default parameters, no fit) on the same
images, for comparison.

``grouping`` (:mod:`dsp.image_groups`; default: each folder apart) fits and scores by
group instead: a group's labelled images, by file name (then folder), are one venue's, its
first ``train_count`` the fit; so a day or an event of many small folders is one row.
``train_count`` 0 fits nothing: every image is scored with ``generic``, a ball model that
needs no frame of the venue (``dsp-calibrate --ball-generic``), as a team's first match.
"""

from __future__ import annotations

import csv
import io
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from dsp.ball_file import shipped_generic
from dsp.errors import InputError
from dsp.image_groups import BY_FOLDER, Grouping, group_folders
from dsp.jsonio import Json
from dsp.labelled import Labelled, find_labelled, labelled_folders
from estimator.detection import Detection, detect_ball
from estimator.detection.real import BallCheck, BallModel, RealBallDetector
from estimator.detection.real.colour import ColourTables
from estimator.detection.real.field import OFF_FIELD, OffField, beyond, find_field
from replay.calibrate.ball import fit_from_labelled

__all__ = ["KEYS", "MARGIN_PX", "ImageRow", "images_csv", "images_markdown", "judge",
           "run_images_suite", "summarise"]

MARGIN_PX = 2.0
KEYS = ("test_images", "with_ball", "tp", "fp", "fn", "precision", "recall",
        "centroid_median_px", "centroid_p95_px", "with_ball_off_field", "fp_off_field",
        "fn_off_field", "ms_per_image")
Box = tuple[float, float, float, float]
Report = tuple[float, float, float] | None
"""(cx, cy, P(ball)) of the reported ball, or None."""
Foot = tuple[float, float, float]
"""A ball's (or report's) box's bottom centre x, y and its larger side [px]."""
Scored = tuple[Report, Foot | None]
"""A report and its box's :data:`Foot` (None without a report)."""


@dataclass(frozen=True)
class ImageRow:
    """One scored test image."""

    folder: str
    image: str
    balls: int
    outcome: str
    """tp, fp, fn or tn (no ball labelled, none reported)."""
    report: Report
    error_px: float | None
    ms: float
    balls_off_field: bool = False
    """Every labelled ball lies beyond the field (see the module docstring); False
    without one."""
    report_off_field: bool = False
    """The report lies beyond the field; False without one."""


def judge(report: tuple[float, float] | None, balls: Sequence[Box]
          ) -> tuple[str, float | None]:
    """(outcome, centroid error) of one image's report by the scoring rule."""
    if report is None:
        return ("fn" if balls else "tn"), None
    cx, cy = report
    errors = [math.hypot(cx - (x0 + x1) / 2.0, cy - (y0 + y1) / 2.0)
              for x0, y0, x1, y1 in balls
              if x0 - MARGIN_PX <= cx <= x1 + MARGIN_PX and y0 - MARGIN_PX <= cy <= y1 + MARGIN_PX]
    return ("tp", min(errors)) if errors else ("fp", None)


def summarise(rows: Sequence[ImageRow]) -> dict[str, Json]:
    """The summary of scored images (:data:`KEYS`; None where a ratio has no denominator)."""
    tp = sum(r.outcome == "tp" for r in rows)
    fp = sum(r.outcome == "fp" for r in rows)
    with_ball = sum(r.balls > 0 for r in rows)
    errors = [r.error_px for r in rows if r.error_px is not None]
    ms = [r.ms for r in rows]
    return {
        "test_images": len(rows), "with_ball": with_ball, "tp": tp, "fp": fp,
        "fn": with_ball - tp,
        "precision": round(tp / (tp + fp), 4) if tp + fp else None,
        "recall": round(tp / with_ball, 4) if with_ball else None,
        "centroid_median_px": round(float(np.median(errors)), 3) if errors else None,
        "centroid_p95_px": round(float(np.percentile(errors, 95)), 3) if errors else None,
        "with_ball_off_field": sum(r.balls > 0 and r.balls_off_field for r in rows),
        "fp_off_field": sum(r.outcome == "fp" and r.report_off_field for r in rows),
        "fn_off_field": sum(r.balls > 0 and r.outcome != "tp" and r.balls_off_field
                            for r in rows),
        "ms_per_image": round(float(np.median(ms)), 3) if ms else None,
    }


def _paper(image: np.ndarray) -> Scored:
    det = detect_ball(image)
    return (None, None) if det is None else ((det.cx_px, det.cy_px, 1.0), _lowest(det))


def _lowest(det: Detection) -> Foot:
    x, y, w, h = det.bbox_px
    return x + w / 2.0, float(y + h), float(max(w, h))


def _scorer(source: str, labelled: Sequence[Labelled], *, detector: str, train_count: int,
            ball_class: int, check: bytes, head: bool, threshold: float | None = None,
            train_from: int = 0, generic: BallModel | None = None,
            off_field: OffField = OFF_FIELD
            ) -> tuple[Callable[[np.ndarray], Scored], ColourTables]:
    """The scoring function and the colour tables the field is found with."""
    if detector == "paper":
        return _paper, ColourTables.of(shipped_generic())
    if train_count == 0:
        if generic is None:
            raise InputError(f"{source}: --train-count 0 needs a generic ball model")
        model = generic
    else:
        model = fit_from_labelled(source, labelled, ball_class=ball_class,
                                  train_count=train_count, head=head, check=check,
                                  train_from=train_from)
    real = RealBallDetector(model, BallCheck(check), off_field=off_field)
    cut = model.threshold if threshold is None else threshold

    def score(image: np.ndarray) -> Scored:
        ranked = real.candidates(image)
        if ranked and ranked[0].check_score >= cut:
            d = ranked[0].detection
            return (d.cx_px, d.cy_px, ranked[0].check_score), _lowest(d)
        return None, None

    return score, real.tables


def _off_field(image: np.ndarray, tables: ColourTables, balls: Sequence[Box],
               lowest: Foot | None) -> tuple[bool, bool]:
    """Whether every labelled ball lies beyond the field by the detector's rule
    (:data:`field.OFF_FIELD`), and whether the report does."""
    feet = [((x0 + x1) / 2.0, y1, max(x1 - x0, y1 - y0)) for x0, y0, x1, y1 in balls]
    if lowest is not None:
        feet.append(lowest)
    if not feet:
        return False, False
    at = np.array(feet, np.float64)
    off = OFF_FIELD.is_off(beyond(find_field(image, tables), at[:, :2]), at[:, 2])
    return (bool(balls) and bool(off[:len(balls)].all()),
            lowest is not None and bool(off[-1]))


def _score_folder(keys: Sequence[str], tests: Sequence[Labelled],
                  scorer: tuple[Callable[[np.ndarray], Scored], ColourTables],
                  ball_class: int) -> list[ImageRow]:
    score, tables = scorer
    rows = []
    if tests:  # untimed: the first call sets the network up
        score(tests[0].read(ball_class)[0])
    for key, item in zip(keys, tests, strict=True):
        image, balls = item.read(ball_class)
        t0 = time.perf_counter()
        report, lowest = score(image)
        ms = (time.perf_counter() - t0) * 1000.0
        outcome, error = judge(None if report is None else report[:2], balls)
        rows.append(ImageRow(key, item.image.name, len(balls), outcome, report, error, ms,
                             *_off_field(image, tables, balls, lowest)))
    return rows


def _folders(roots: Sequence[Path]) -> list[tuple[str, str, Path]]:
    """(key, path under its root, path) of every folder of labelled images."""
    found = []
    for root in roots:
        for folder in labelled_folders(root):
            rel = folder.relative_to(root).as_posix()
            key = rel if len(roots) == 1 else f"{root.name}/{rel}".removesuffix("/.")
            found.append((key, rel, folder))
    if not found:
        raise InputError(f"{', '.join(map(str, roots))}: no folder of images with YOLO labels")
    return found


def _group_images(members: Sequence[tuple[str, Path]]) -> list[tuple[str, Labelled]]:
    """A group's labelled images with their folders' keys, by file name, then folder."""
    found = [(key, item) for key, folder in members for item in find_labelled(folder)]
    return sorted(found, key=lambda ki: (ki[1].image.name, ki[0]))


def run_images_suite(roots: Sequence[Path], *, train_count: int, detector: str = "real",
                     ball_class: int = 0, check: bytes, head: bool = True,
                     threshold: float | None = None,
                     on_folder: Callable[[str], None] | None = None, train_from: int = 0,
                     grouping: Grouping | None = None, generic: BallModel | None = None,
                     only: Sequence[str] = (), off_field: OffField = OFF_FIELD
                     ) -> tuple[dict[str, Json], list[ImageRow]]:
    """The summary document (per folder, or per group under "groups" with "group_by", and
    "total"; "train_from" only when not 0) and the per-image rows; ``only``: score these
    groups (or folders) alone; ``off_field``: the detector's rule for a candidate beyond
    the field (the shipped one; its ``weight`` 0: off; the kinds are judged by the shipped
    one's ``sides`` either way)."""
    grouping = grouping or Grouping(BY_FOLDER)
    groups: dict[str, Json] = {}
    every: list[ImageRow] = []
    end = train_from + train_count
    found_groups = group_folders(grouping, _folders(roots))
    unknown = [name for name in only if name not in found_groups]
    if unknown:
        unit = "folder" if grouping.kind == BY_FOLDER else "group"
        raise InputError(f"--only {unknown[0]}: no such {unit} under "
                         f"{', '.join(map(str, roots))} (there are "
                         f"{', '.join(list(found_groups)[:12])})")
    for name, members in found_groups.items():
        if only and name not in only:
            continue
        found = _group_images(members)
        labelled = [item for _, item in found]
        source = str(members[0][1]) if len(members) == 1 else f"{name} ({members[0][1]} ...)"
        if len(labelled) < end or len(labelled) == train_count:
            which = f"{train_count}" if not train_from else f"numbers {train_from + 1}-{end}"
            left = "needs more" if train_from and len(labelled) < end else "leaves none to score"
            raise InputError(f"{source}: {len(labelled)} labelled images; fitting on "
                             f"{which} {left}")
        scorer = _scorer(source, labelled, detector=detector, train_count=train_count,
                        ball_class=ball_class, check=check, head=head,
                        threshold=threshold, train_from=train_from, generic=generic,
                        off_field=off_field)
        tests = found[:train_from] + found[end:]
        rows = _score_folder([k for k, _ in tests], [it for _, it in tests], scorer,
                             ball_class)
        groups[name] = summarise(rows)
        every += rows
        if on_folder is not None:
            on_folder(name)
    doc: dict[str, Json] = {
        "format": "dsp-eval images", "version": 1, "detector": detector,
        "train_count": train_count, "ball_class": ball_class,
        "venue_head": head and train_count > 0 if detector == "real" else None,
        "margin_px": MARGIN_PX, "total": summarise(every)}
    if grouping.kind == BY_FOLDER:
        doc["folders"] = groups
    else:
        doc["groups"], doc["group_by"] = groups, grouping.label
    if train_from:
        doc["train_from"] = train_from
    return doc, every


def _cell(v: Json) -> str:
    return "-" if v is None else str(v)


def images_markdown(doc: dict[str, Json]) -> str:
    """The summary as a Markdown table, a row per folder (or group) and the total."""
    grouped = "groups" in doc
    folders = doc["groups" if grouped else "folders"]
    assert isinstance(folders, dict)
    start, count = doc.get("train_from", 0), doc["train_count"]
    assert isinstance(start, int) and isinstance(count, int)
    unit = f"group ({doc['group_by']})" if grouped else "folder"
    which = (f"first {count} labelled images" if not start
             else f"labelled images {start + 1}-{start + count} by name")
    fitted = (f"no frame fitted on (the generic ball model); every {unit}'s images scored"
              if count == 0 else f"fitted on each {unit}'s {which}, scored on the rest")
    lines = [f"Detector: {doc['detector']}; {fitted}.", "",
             f"| {'group' if grouped else 'folder'} | " + " | ".join(KEYS) + " |",
             "|---" * (len(KEYS) + 1) + "|"]
    for key, row in [*folders.items(), ("total", doc["total"])]:
        assert isinstance(row, dict)
        lines.append(f"| {key} | " + " | ".join(_cell(row[k]) for k in KEYS) + " |")
    return "\n".join(lines) + "\n"


def images_csv(rows: Sequence[ImageRow]) -> str:
    """One line per test image: folder, image, balls, outcome, cx, cy, p, error_px, ms,
    balls_off_field and report_off_field (1: beyond the field, else 0)."""
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(["folder", "image", "balls", "outcome", "cx_px", "cy_px", "p_ball",
                     "error_px", "ms", "balls_off_field", "report_off_field"])
    for r in rows:
        cx, cy, p = (("", "", "") if r.report is None
                     else (f"{r.report[0]:.3f}", f"{r.report[1]:.3f}", f"{r.report[2]:.4f}"))
        err = "" if r.error_px is None else f"{r.error_px:.3f}"
        writer.writerow([r.folder, r.image, r.balls, r.outcome, cx, cy, p, err, f"{r.ms:.2f}",
                         int(r.balls_off_field), int(r.report_off_field)])
    return buf.getvalue()
