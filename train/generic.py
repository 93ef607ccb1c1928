"""Fit the generic ball model: the ball of many venues, for a venue with no labelled frame.

    python train/generic.py ../shared/real/msl-images ../shared/real/msl-more \
        --groups train/msl-events.txt -o estimator/detection/real/ball_generic.json
    python train/generic.py IMAGES MORE --groups train/msl-events.txt --without bangkok-2022 \
        -o train/checks/generic-bangkok-2022.json      # held out: no image of that event

The venue fit (``estimator.detection.real.fit_ball_model``) on a pool of every event's
images: up to ``PER_EVENT`` of each event (labelled images by file name, then folder, taken
evenly spaced), so a 290-image event weighs about as much as a 40-image one. Each ball
counts alike and each image's background alike, as in a venue's fit: the colour table says
what is ball-coloured at any of the venues, the size line is the cameras' (every image of
the shared set is from the same robots' 608 x 800 cameras; another camera wants its own
frames). No venue head (it reads the venue's look-alikes). The ball is reported from
P(ball) 0.731 (the logit 1, as a venue with a head), not 0.5: held out by event (each
event's generic model fitted without it, scored with the check trained without it), the
threshold of the best F1 on the seven other events, among the logits -0.5 to 2 in steps of
0.5, was 1 for each of the eight (docs/notes/detection.md). No randomness: the same folders
and grouping give the same bytes.
"""

from __future__ import annotations

import argparse
import hashlib
import sys
from collections.abc import Iterator, Sequence
from pathlib import Path

import numpy as np

from dsp.ball_file import ball_file_text
from dsp.image_groups import group_folders, read_grouping
from dsp.labelled import Labelled, find_labelled, labelled_folders
from estimator.detection.real import BallModel, fit_ball_model
from estimator.detection.real.head import HEAD_THRESHOLD

PER_EVENT = 40


def events(roots: Sequence[Path], groups: str) -> dict[str, list[Labelled]]:
    """Each group's labelled images, by file name then folder (as dsp-eval orders them)."""
    folders = [(f"{root.name}/{p.relative_to(root).as_posix()}", p.relative_to(root).as_posix(),
                p) for root in roots for p in labelled_folders(root)]
    out = {}
    for name, members in group_folders(read_grouping(groups), folders).items():
        found = [(key, item) for key, folder in members for item in find_labelled(folder)]
        out[name] = [item for _, item in sorted(found, key=lambda ki: (ki[1].image.name,
                                                                         ki[0]))]
    return out


def pick(items: Sequence[Labelled], count: int = PER_EVENT) -> list[Labelled]:
    """Up to ``count`` of ``items``, evenly spaced (all of them when fewer)."""
    if len(items) <= count:
        return list(items)
    return [items[int(i)] for i in np.unique(np.linspace(0, len(items) - 1, count).round())]


def fit_generic(chosen: dict[str, list[Labelled]], ball_class: int = 0) -> BallModel:
    def samples() -> Iterator[tuple[np.ndarray, list[tuple[float, float, float, float]]]]:
        for items in chosen.values():
            for item in items:
                yield item.read(ball_class)

    info = {"generic": True, "images": sum(map(len, chosen.values())),
            "events": {name: len(items) for name, items in chosen.items()}}
    return fit_ball_model(samples(), info=info, threshold=HEAD_THRESHOLD)


def main() -> None:
    ap = argparse.ArgumentParser(allow_abbrev=False, description=__doc__.splitlines()[0])
    ap.add_argument("roots", type=Path, nargs="+", help="folders of labelled folders")
    ap.add_argument("--groups", required=True, help="the grouping file (events)")
    ap.add_argument("--without", default="", metavar="EVENT[+EVENT]",
                    help="leave these events out (to score them held out)")
    ap.add_argument("--per-event", type=int, default=PER_EVENT)
    ap.add_argument("-o", "--output", required=True, type=Path)
    args = ap.parse_args()
    found = events(args.roots, args.groups)
    left = [e for e in args.without.split("+") if e]
    unknown = sorted(set(left) - set(found))
    if unknown:
        sys.exit(f"--without {args.without}: no event {unknown[0]!r} in {args.groups}")
    chosen = {name: pick(items, args.per_event) for name, items in found.items()
              if name not in left}
    text = ball_file_text(fit_generic(chosen))
    args.output.write_text(text, encoding="utf-8")
    print(f"{args.output}: {sum(map(len, chosen.values()))} images of {len(chosen)} events, "
          f"sha256 {hashlib.sha256(text.encode()).hexdigest()[:16]}")


if __name__ == "__main__":
    main()
