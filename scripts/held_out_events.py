"""The real-ball detector held out by event: each event of a grouping scored with the check
trained without it and, with no labelled frame, with the generic model fitted without it.

    python scripts/held_out_events.py ../shared/real/msl-images ../shared/real/msl-more \
        --groups train/msl-events.txt --checks train/checks [--out held-out.json] \
        [--off-field-weight 0]

For each event E of the grouping (``train/train.py --groups ... --held-out DIR`` makes
DIR/lovo-E.onnx and DIR/generic-E.json): ``dsp-eval --suite images ROOTS --group-by GROUPS
--only E --check-model DIR/lovo-E.onnx`` (fitted on E's first 10 labelled frames, scored on the
rest) and the same with ``--train-count 0 --ball DIR/generic-E.json`` (no frame fitted,
every image scored; and, to compare the two on the same images, on the images after the
first 10 alone). Prints one Markdown table, a row per event and the totals, with the
targets (precision >= 0.95, recall >= 0.90, centroid median <= 2 px with 10 frames on an
event of 30 or more test images; precision >= 0.90, recall >= 0.85 with none) marked.
Then what each event's detector gets wrong (false hits in empty images, over a ball,
balls unreported), and balls, false hits and misses on the field and beyond it
(:mod:`replay.evaluate.images`). ``--off-field-weight 0`` scores the detector without its
rule for candidates beyond the field (:mod:`estimator.detection.real.field`), to see what
the rule moved. Everything but the time is the same on every run.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from dsp.ball_file import read_ball_file, read_check_file
from dsp.cli import run_main
from dsp.errors import UsageError
from dsp.image_groups import read_grouping
from estimator.detection.real.field import OFF_FIELD
from replay.evaluate.images import ImageRow, images_csv, run_images_suite, summarise

TARGET_10 = (0.95, 0.90, 2.0)
TARGET_0 = (0.90, 0.85)
MIN_TEST = 30


def _mark(ok: bool) -> str:
    return "" if ok else " (no)"


def _cells(s: dict[str, Any], with_px: bool) -> list[str]:
    out = [f"{s['tp']} / {s['fp']} / {s['fn']}", str(s["precision"]), str(s["recall"])]
    return [*out, str(s["centroid_median_px"])] if with_px else out


def _misses(rows: Sequence[ImageRow]) -> tuple[int, int, int, int]:
    """(images without a ball, false hits in them, look-alikes reported over a ball, balls
    with nothing reported)."""
    return (sum(r.balls == 0 for r in rows),
            sum(r.balls == 0 and r.outcome == "fp" for r in rows),
            sum(r.balls > 0 and r.outcome == "fp" for r in rows),
            sum(r.balls > 0 and r.report is None for r in rows))


def _misses_table(per_event: dict[str, tuple[list[ImageRow], list[ImageRow]]]) -> str:
    """What each event's detector gets wrong, with ten frames (with none in brackets)."""
    lines = ["| event | empty images | false hits there | over a ball | unreported balls |",
             "|---" * 5 + "|"]
    for name, (rows10, rows0) in per_event.items():
        ten, none = _misses(rows10), _misses(rows0)
        cells = [f"{a}" if a == b else f"{a} ({b})" for a, b in zip(ten, none, strict=True)]
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _kinds(rows: Sequence[ImageRow]) -> tuple[int, ...]:
    """(balls on the field, beyond it; false hits on it, beyond; misses on it, beyond)."""
    on_ball = [r.balls_off_field for r in rows if r.balls > 0]
    fp = [r.report_off_field for r in rows if r.outcome == "fp"]
    fn = [r.balls_off_field for r in rows if r.balls > 0 and r.outcome != "tp"]
    return tuple(x for kinds in (on_ball, fp, fn) for x in (kinds.count(False), kinds.count(True)))


def _kinds_table(per_event: dict[str, tuple[list[ImageRow], list[ImageRow]]]) -> str:
    """Balls, false hits and misses on the field and beyond it, per event, with ten frames
    (with none in brackets)."""
    lines = ["| event | balls on the field | beyond | false hits on the field | beyond | "
             "misses on the field | beyond |", "|---" * 7 + "|"]
    totals = [[0] * 6, [0] * 6]
    for name, (rows10, rows0) in per_event.items():
        ten, none = _kinds(rows10), _kinds(rows0)
        for i in range(6):
            totals[0][i] += ten[i]
            totals[1][i] += none[i]
        cells = [f"{a}" if a == b else f"{a} ({b})" for a, b in zip(ten, none, strict=True)]
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    cells = [f"{a}" if a == b else f"{a} ({b})" for a, b in zip(*totals, strict=True)]
    lines.append("| total | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def _main(argv: Sequence[str] | None) -> int:
    ap = argparse.ArgumentParser(allow_abbrev=False, description=__doc__.splitlines()[0])
    ap.add_argument("roots", type=Path, nargs="+")
    ap.add_argument("--groups", required=True)
    ap.add_argument("--checks", type=Path, required=True,
                    help="folder of lovo-EVENT.onnx and generic-EVENT.json")
    ap.add_argument("--out", type=Path, help="also write the figures as JSON, and beside it "
                    "one row per image (OUT stem + -10.csv and -0.csv, as dsp-eval's images.csv)")
    ap.add_argument("--off-field-weight", type=float, default=OFF_FIELD.weight,
                    help="the weight of the detector's rule for a candidate beyond the field "
                    f"(default {OFF_FIELD.weight:g}, the shipped one; 0: the rule off)")
    args = ap.parse_args(argv)
    if not args.off_field_weight >= 0:
        raise UsageError(f"--off-field-weight {args.off_field_weight}: use 0 or more")
    grouping = read_grouping(args.groups)
    if grouping.kind != "file":
        raise UsageError(f"--groups {args.groups}: give a grouping file (one event a line)")
    names = [name for name, _ in grouping.lines]
    rule = dataclasses.replace(OFF_FIELD, weight=args.off_field_weight)
    doc: dict[str, Any] = {}
    same0: list[ImageRow] = []
    per_event: dict[str, tuple[list[ImageRow], list[ImageRow]]] = {}
    lines = ["| event | test images | 10 frames: tp / fp / fn | precision | recall | "
             "centroid median px | no frame (every image): tp / fp / fn | precision | recall | "
             "no frame, the same test images: precision | recall |",
             "|---" * 11 + "|"]
    for name in names:
        check = read_check_file(args.checks / f"lovo-{name}.onnx")
        generic = read_ball_file(args.checks / f"generic-{name}.json")
        common: dict[str, Any] = {"check": check, "grouping": grouping, "only": [name],
                                  "off_field": rule}
        d10, rows10 = run_images_suite(args.roots, train_count=10, **common)
        d0, rows0 = run_images_suite(args.roots, train_count=0, generic=generic, **common)
        tested = {(r.folder, r.image) for r in rows10}
        rows_same = [r for r in rows0 if (r.folder, r.image) in tested]
        s10, s0, ss = d10["total"], d0["total"], summarise(rows_same)
        per_event[name] = (rows10, rows0)
        same0 += rows_same
        doc[name] = {"fitted_10": s10, "no_frame": s0, "no_frame_same_images": ss}
        big = s10["test_images"] >= MIN_TEST
        ok10 = (not big or ((s10["precision"] or 0) >= TARGET_10[0]
                            and (s10["recall"] or 0) >= TARGET_10[1]
                            and (s10["centroid_median_px"] or 99) <= TARGET_10[2]))
        ok0 = ((s0["precision"] or 0) >= TARGET_0[0] and (s0["recall"] or 0) >= TARGET_0[1])
        lines.append(f"| {name}{_mark(ok10 and ok0)} | {s10['test_images']} | "
                     + " | ".join(_cells(s10, True) + _cells(s0, False)
                                  + [str(ss["precision"]), str(ss["recall"])]) + " |")
        print(f"{name} done", file=sys.stderr, flush=True)
    all10 = [r for rows10, _ in per_event.values() for r in rows10]
    all0 = [r for _, rows0 in per_event.values() for r in rows0]
    t10, t0, ts = summarise(all10), summarise(all0), summarise(same0)
    doc["total"] = {"fitted_10": t10, "no_frame": t0, "no_frame_same_images": ts}
    lines.append(f"| total | {t10['test_images']} | " + " | ".join(
        _cells(t10, True) + _cells(t0, False) + [str(ts["precision"]), str(ts["recall"])])
        + " |")
    print("\n".join(lines))
    print("\n" + _misses_table(per_event))
    print("\n" + _kinds_table(per_event))
    if args.out is not None:
        for part in doc.values():
            for s in part.values():
                s.pop("ms_per_image", None)
        args.out.write_text(json.dumps(doc, indent=1, sort_keys=True) + "\n", encoding="utf-8")
        for suffix, rows in (("-10.csv", all10), ("-0.csv", all0)):
            args.out.with_name(args.out.stem + suffix).write_text(images_csv(rows),
                                                                  encoding="utf-8")
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    return run_main("held_out_events.py", _main, argv)


if __name__ == "__main__":
    sys.exit(main())
