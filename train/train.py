"""Train the real-ball detector's learned check (seeded, CPU, deterministic), export to ONNX.

    pip install -e '.[train]'
    python train/train.py ../shared/real/msl-images ../shared/real/msl-more \
        --groups train/msl-events.txt --epochs 8 --held-out train/checks \
        -o estimator/detection/real/ball_check.onnx     # the shipped check: all eight events
    python train/train.py ../shared/real/msl-images --split lovo:20220715 -o lovo-20220715.onnx

ROOT holds labelled folders (images with YOLO label files, class 0 the ball), each one
venue-day; a folder's venue is its first path part under ROOT. Splits (which samples of
``dataset.py`` a model may learn from):
  all             every image of every folder (with --groups: the shipped model)
  lovo:VENUE      every image of the other venues' folders (leave one venue out)
  infolder:F      every image except folder F's test images (those after its first 10)
  invenue:VENUE   every image except the test images of VENUE's folders (the other venues
                  whole, and the first 10 of each of VENUE's folders: what a team labels)
  venues:A+B      every image of the named venues only (how the check's reach grows
                  with the venues it learns from)

Determinism: one thread, ``torch.use_deterministic_algorithms``, the seed for torch and for
the NumPy generator that shuffles and augments: the same images, split and seed give the
same ONNX bytes on the same torch build. After export, OpenCV's dnn must give torch's
outputs on the exported bytes (the detector runs them through OpenCV only).

The images' licence (Apache-2.0) goes with the weights: keep estimator/detection/real/NOTICE
and LICENSE-images beside any model trained on them.
"""

from __future__ import annotations

import argparse
import hashlib
import io
import os
import sys
import time
from pathlib import Path

import cv2
import numpy as np
import torch
from torch import nn

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from dataset import TRAIN_COUNT, Samples, build_folder, build_items
from edge import NO_EDGE, EdgeSpec
from flying import flying
from generic import events, fit_generic, pick

from dsp.labelled import labelled_folders

EPOCHS = 32
SAMPLE_FIELDS = ("x", "y", "offset", "image", "label_crop", "ctx")
NEG_SHARE = 0.5
"""Share of the negatives drawn afresh for each epoch (all positives every epoch)."""
BATCH = 128
LR = 2e-3


class CheckNet(nn.Module):
    """5 x 24 x 24 crop and 3 context numbers -> (ball logit, dx, dy, log size). Three
    conv-ReLU-maxpool stages, a dense layer to 32 features, the context beside them, and
    a dense layer out."""

    def __init__(self) -> None:
        super().__init__()
        self.features = nn.Sequential(
            nn.Conv2d(5, 12, 3, padding=1), nn.ReLU(), nn.MaxPool2d(2),
            nn.Conv2d(12, 24, 3, padding=1), nn.ReLU(), nn.MaxPool2d(2),
            nn.Conv2d(24, 32, 3, padding=1), nn.ReLU(), nn.MaxPool2d(2),
        )
        self.embed = nn.Sequential(nn.Flatten(), nn.Linear(32 * 3 * 3, 32), nn.ReLU())
        self.head = nn.Linear(32 + 3, 4)

    def forward(self, x: torch.Tensor, ctx: torch.Tensor) -> torch.Tensor:
        return self.head(torch.cat([self.embed(self.features(x)), ctx], dim=1))


class Exported(nn.Module):
    """The net with its 32 features as a second output (for a venue's own ball/not head)."""

    def __init__(self, net: CheckNet) -> None:
        super().__init__()
        self.net = net

    def forward(self, x: torch.Tensor, ctx: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        feat = self.net.embed(self.net.features(x))
        return self.net.head(torch.cat([feat, ctx], dim=1)), feat


def venue_of(folder: str) -> str:
    """A folder's venue: its first path part (a venue-day: r2 and r4 of 20190606 are one)."""
    return folder.split("/")[0]


def select(root: Path, split: str, edge: EdgeSpec = NO_EDGE) -> tuple[np.ndarray, ...]:
    """x, y, offset, context of the samples of the folders under root the split allows."""
    kind, _, name = split.partition(":")
    if kind not in ("all", "lovo", "infolder", "invenue", "venues"):
        raise SystemExit(f"unknown split {split!r}: all, lovo:VENUE, infolder:FOLDER, "
                         "invenue:VENUE or venues:A+B")
    xs, ys, offs, ctxs = [], [], [], []
    for path in labelled_folders(root):
        folder = path.relative_to(root).as_posix()
        s = build_folder(path, edge=edge)
        if kind == "all":
            keep = np.ones(len(s.y), bool)
        elif kind == "lovo":
            keep = np.full(len(s.y), venue_of(folder) != name)
        elif kind == "venues":
            keep = np.full(len(s.y), venue_of(folder) in name.split("+"))
        elif kind == "invenue":
            keep = (np.ones(len(s.y), bool) if venue_of(folder) != name
                    else s.image < TRAIN_COUNT)
        else:
            keep = np.ones(len(s.y), bool) if folder != name else s.image < TRAIN_COUNT
        xs.append(s.x[keep])
        ys.append(s.y[keep])
        offs.append(s.offset[keep])
        ctxs.append(s.ctx[keep])
    if not any(len(y) for y in ys):
        raise SystemExit(f"split {split!r} selects no image under {root}")
    return (np.concatenate(xs), np.concatenate(ys), np.concatenate(offs),
            np.concatenate(ctxs))


def cached_samples(roots: list[Path], groups: str, cache: Path | None,
                   edge: EdgeSpec = NO_EDGE) -> dict[str, Samples]:
    """:func:`event_samples`, kept in ``cache`` (an .npz of plain arrays, read without
    pickle) so that several checks train from one build; a cache is the build's bytes, so
    a check trained from it is the check trained without it. A cache records its
    ``--edge-*`` options (:meth:`EdgeSpec.key`) and is refused for others."""
    if cache is not None and cache.is_file():
        with np.load(cache, allow_pickle=False) as z:
            made = tuple(float(v) for v in z["edge"]) if "edge" in z.files else (0, 0, 0)
            if made != edge.key():
                raise SystemExit(f"--cache {cache}: made with other --edge-* options "
                                 f"(count, sides, random: {made}, not {edge.key()})")
            names = [str(n) for n in z["events"]]
            return {n: Samples(*(z[f"{n}/{f}"] for f in SAMPLE_FIELDS)) for n in names}
    samples = event_samples(roots, groups, edge=edge)
    if cache is not None:
        arrays = {f"{n}/{f}": getattr(s, f) for n, s in samples.items() for f in SAMPLE_FIELDS}
        extra = {"edge": np.asarray(edge.key(), np.float64)} if edge.count else {}
        np.savez(cache, events=np.asarray(list(samples)), **extra, **arrays)
    return samples


def event_samples(roots: list[Path], groups: str, generic: bool = True,
                  edge: EdgeSpec = NO_EDGE) -> dict[str, Samples]:
    """Each event's samples (``--groups``): its venue model fitted on the event's first
    ``TRAIN_COUNT`` labelled images (by name, then folder, as ``dsp-eval --group-by``
    orders them); with ``generic``, also the candidates of the generic model fitted
    without the event (``generic.py --without EVENT``: what that event meets with no
    labelled frame); with ``edge.count``, up to that many negatives an image beyond the
    field's far edge, from the event's own images (``edge.py``)."""
    found = events(roots, groups)
    out = {}
    for name, items in found.items():
        gen = fit_generic({n: pick(v) for n, v in found.items() if n != name}
                          ) if generic else None
        out[name] = build_items(items, generic=gen, edge=edge)
        print(f"  {name}: {len(items)} images, {len(out[name].y)} samples "
              f"({int(out[name].y.sum())} balls)", flush=True)
    return out


def select_events(samples: dict[str, Samples], split: str) -> tuple[np.ndarray, ...]:
    """x, y, offset, context of the events the split allows: ``all`` or ``lovo:EVENT``
    (every event but EVENT, whole)."""
    kind, _, name = split.partition(":")
    if kind not in ("all", "lovo") or (kind == "lovo" and name not in samples):
        raise SystemExit(f"split {split!r}: with --groups, all or lovo:EVENT (one of "
                         f"{', '.join(samples)})")
    chosen = [s for n, s in samples.items() if kind == "all" or n != name]
    return tuple(np.concatenate([getattr(s, f) for s in chosen])
                 for f in ("x", "y", "offset", "ctx"))


def with_flying(s: Samples, share: float, rng: np.random.Generator) -> Samples:
    """An event's samples and its balls and look-alikes in the air (``flying.py``, on the
    event's own crops: a check held out from the event sees none of them)."""
    x, y, off, ctx = flying(s.x, s.y, s.offset, s.ctx, share, rng)
    return Samples(np.concatenate([s.x, x]), np.concatenate([s.y, y]),
                   np.concatenate([s.offset, off]),
                   np.concatenate([s.image, np.full(len(y), -1, s.image.dtype)]),
                   np.concatenate([s.label_crop, np.ones(len(y), bool)]),
                   np.concatenate([s.ctx, ctx]))


def _hue_turn(angle: float, sat: float) -> np.ndarray:
    """3 x 3 on (B, G, R): turn the colour about the grey axis by angle, scale its
    saturation by sat (grey stays grey)."""
    g = np.full((3, 3), 1.0 / 3.0)
    c, s = np.cos(angle), np.sin(angle)
    k = np.array([[0, -1, 1], [1, 0, -1], [-1, 1, 0]]) / np.sqrt(3.0)  # cross with grey axis
    rot = g + c * (np.eye(3) - g) + s * k
    return (g + sat * (rot - g)).astype(np.float32)


def augment(x: np.ndarray, off: np.ndarray, rng: np.random.Generator, hue: float = 0.0
            ) -> tuple[np.ndarray, np.ndarray]:
    """Mirror left-right; swap the colour channels or grey them (another ball colour the
    venue's model would call ball-like); with ``hue`` > 0 that share of the crops also
    turned to a random hue and saturation (``--hue``); small gain on the pixels."""
    x, off = x.copy(), off.copy()
    n = len(x)
    flip = rng.random(n) < 0.5
    x[flip] = x[flip, :, :, ::-1]
    off[flip, 0] *= -1
    perm = rng.random(n) < 0.3
    for i in np.flatnonzero(perm):
        x[i, :3] = x[i, rng.permutation(3)]
    grey = rng.random(n) < 0.1
    x[grey, :3] = x[grey, :3].mean(axis=1, keepdims=True)
    if hue > 0:
        turn = np.flatnonzero(rng.random(n) < hue)
        angle = rng.uniform(-np.pi, np.pi, len(turn))
        sat = rng.uniform(0.4, 1.2, len(turn))
        for k, i in enumerate(turn):
            x[i, :3] = np.tensordot(_hue_turn(angle[k], sat[k]), x[i, :3], axes=1)
    x[:, :3] *= rng.uniform(0.85, 1.15, (n, 1, 1, 1)).astype(np.float32)
    np.clip(x, 0.0, 1.0, out=x)
    return x, off


def train(root: Path, split: str, seed: int = 0, epochs: int = EPOCHS, hue: float = 0.0,
          data: tuple[np.ndarray, ...] | None = None, fly: float = 0.0,
          edge: EdgeSpec = NO_EDGE) -> CheckNet:
    torch.manual_seed(seed)
    torch.set_num_threads(1)
    torch.use_deterministic_algorithms(True)
    rng = np.random.default_rng(seed)
    x, y, off, ctx = select(root, split, edge) if data is None else data
    if fly > 0:
        # its own stream of the seed: the shuffles and augments draw as before
        extra = flying(x, y, off, ctx, fly, np.random.default_rng([seed, 1]))
        x, y, off, ctx = (np.concatenate([a, b])
                          for a, b in zip((x, y, off, ctx), extra, strict=True))
    net = CheckNet()
    opt = torch.optim.Adam(net.parameters(), lr=LR, weight_decay=1e-4)
    sched = torch.optim.lr_scheduler.CosineAnnealingLR(opt, epochs)
    pos_weight = torch.tensor(min(8.0, float((y == 0).sum()) / max(1.0, float(y.sum()))))
    bce = nn.BCEWithLogitsLoss(pos_weight=pos_weight)
    for epoch in range(epochs):
        neg = np.flatnonzero(y == 0)
        keep = np.concatenate([np.flatnonzero(y > 0),
                               rng.choice(neg, int(NEG_SHARE * len(neg)), replace=False)])
        order = keep[rng.permutation(len(keep))]
        total = 0.0
        for start in range(0, len(order), BATCH):
            idx = order[start:start + BATCH]
            xb, ob = augment(x[idx], off[idx], rng, hue)
            out = net(torch.from_numpy(xb), torch.from_numpy(ctx[idx]))
            yb = torch.from_numpy(y[idx])
            loss = bce(out[:, 0], yb)
            pos = yb > 0.5
            if bool(pos.any()):
                loss = loss + 4.0 * nn.functional.smooth_l1_loss(
                    out[pos, 1:], torch.from_numpy(ob)[pos], beta=0.05)
            opt.zero_grad()
            loss.backward()
            opt.step()
            total += float(loss) * len(idx)
        sched.step()
        print(f"  epoch {epoch + 1}/{epochs} loss {total / len(order):.4f}", flush=True)
    return net.eval()


def export(net: CheckNet, path: str) -> bytes:
    buf = io.BytesIO()
    torch.onnx.export(Exported(net), (torch.zeros(1, 5, 24, 24), torch.zeros(1, 3)), buf,
                      input_names=["crops", "context"], output_names=["out", "feat"],
                      dynamic_axes={"crops": {0: "n"}, "context": {0: "n"}, "out": {0: "n"},
                                    "feat": {0: "n"}},
                      opset_version=13, dynamo=False)
    data = buf.getvalue()
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    with open(path, "wb") as f:
        f.write(data)
    return data


def verify(net: CheckNet, data: bytes, x: np.ndarray, ctx: np.ndarray) -> float:
    """Largest difference between torch's outputs and OpenCV dnn's on the ONNX bytes, over
    up to 256 of the split's samples (raises when they disagree beyond float rounding)."""
    x, ctx = x[:256], ctx[:256]
    with torch.no_grad():
        ref_out, ref_feat = Exported(net)(torch.from_numpy(x), torch.from_numpy(ctx))
    cvnet = cv2.dnn.readNetFromONNX(np.frombuffer(data, np.uint8))
    cvnet.setInput(x, "crops")
    cvnet.setInput(ctx, "context")
    out, feat = cvnet.forward(["out", "feat"])
    diff = max(float(np.abs(out - ref_out.numpy()).max()),
               float(np.abs(feat - ref_feat.numpy()).max()))
    if diff > 1e-3:
        raise SystemExit(f"OpenCV dnn and torch differ by {diff} on the exported model")
    return diff


def main() -> None:
    ap = argparse.ArgumentParser(allow_abbrev=False, description=__doc__.splitlines()[0])
    ap.add_argument("roots", type=Path, nargs="+",
                    help="folder(s) of labelled folders (each venue-day one)")
    ap.add_argument("--groups", metavar="FILE",
                    help="train by event: the grouping file (train/msl-events.txt); the "
                    "splits are then all and lovo:EVENT, and the samples include the "
                    "generic model's candidates")
    ap.add_argument("--split", default="all")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--epochs", type=int, default=EPOCHS)
    ap.add_argument("--hue", type=float, default=0.0, metavar="SHARE",
                    help="share of the crops turned to a random hue and saturation (default "
                         "0: none; the shipped and held-out checks are made without)")
    ap.add_argument("--flying", type=float, default=0.0, metavar="SHARE",
                    help="balls in the air for this share of the positives, and as many "
                         "look-alikes made over alike (flying.py: shrunk, darkened, "
                         "motion-blurred, over a crop with little field; default 0: none; "
                         "not better held out by event, docs/notes/detection.md)")
    ap.add_argument("--edge-negatives", type=int, default=0, metavar="N",
                    help="up to N more negatives an image beyond the field's far edge, "
                    "cut while the samples are built (edge.py: the candidate finder's "
                    "blobs there, then random squares at the image's ball sizes; "
                    "default 0: none)")
    ap.add_argument("--edge-sides", type=float, default=1.0, metavar="S",
                    help="with --edge-negatives: how far beyond the edge, the blob's lowest "
                    "point over S times its size above it (default 1: the detector's rule "
                    "for a candidate beyond the field; 0: above the edge at all)")
    ap.add_argument("--edge-candidates-only", action="store_true",
                    help="with --edge-negatives: no random squares, only the candidate "
                    "finder's blobs beyond the edge")
    ap.add_argument("--held-out", type=Path, metavar="DIR",
                    help="with --groups: also one check per event trained without it "
                    "(DIR/lovo-EVENT.onnx) and the generic model without it "
                    "(DIR/generic-EVENT.json), from the same samples")
    ap.add_argument("--cache", type=Path, metavar="NPZ",
                    help="with --groups: keep the samples in this file (made when missing, "
                    "read when there) to train several checks from one build")
    ap.add_argument("-o", "--output", required=True)
    args = ap.parse_args()
    if args.edge_negatives < 0 or not args.edge_sides >= 0:
        raise SystemExit(f"--edge-negatives {args.edge_negatives} --edge-sides "
                         f"{args.edge_sides}: use 0 or more")
    edge = EdgeSpec(args.edge_negatives, args.edge_sides, not args.edge_candidates_only)
    t0 = time.perf_counter()
    if args.groups is None:
        if len(args.roots) != 1 or args.held_out is not None:
            raise SystemExit("several roots and --held-out go with --groups")
        net = train(args.roots[0], args.split, args.seed, args.epochs, args.hue,
                    fly=args.flying, edge=edge)
        data = export(net, args.output)
        x, _, _, ctx = select(args.roots[0], args.split, edge)
        _report(args.output, net, data, x, ctx, t0)
        return
    samples = cached_samples(args.roots, args.groups, args.cache, edge)
    if args.flying > 0:
        samples = {name: with_flying(s, args.flying, np.random.default_rng([args.seed, 1, k]))
                   for k, (name, s) in enumerate(samples.items())}
    runs = []
    if args.held_out is not None:
        from dsp.ball_file import ball_file_text
        found = events(args.roots, args.groups)
        args.held_out.mkdir(parents=True, exist_ok=True)
        for name in samples:
            runs.append((f"lovo:{name}", str(args.held_out / f"lovo-{name}.onnx")))
            model = fit_generic({n: pick(v) for n, v in found.items() if n != name})
            (args.held_out / f"generic-{name}.json").write_text(ball_file_text(model),
                                                                encoding="utf-8")
    runs.append((args.split, args.output))
    for split, output in runs:
        t0 = time.perf_counter()
        data_xy = select_events(samples, split)
        print(f"{output}: {split}, {len(data_xy[1])} samples", flush=True)
        net = train(Path(), split, args.seed, args.epochs, args.hue, data=data_xy)
        data = export(net, output)
        _report(output, net, data, data_xy[0], data_xy[3], t0)


def _report(output: str, net: CheckNet, data: bytes, x: np.ndarray, ctx: np.ndarray,
            t0: float) -> None:
    diff = verify(net, data, x, ctx)
    print(f"{output}: {len(data)} bytes, sha256 {hashlib.sha256(data).hexdigest()[:16]}, "
          f"OpenCV dnn vs torch max |diff| {diff:.2e}, {time.perf_counter() - t0:.0f} s",
          flush=True)


if __name__ == "__main__":
    main()
