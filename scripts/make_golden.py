"""Regenerate the golden logs and their expected replay outputs in ``logs/golden/``.

Regenerating is a deliberate act: the goldens pin what the recorder and the estimator do
today, so a change to them must be explained in the commit that regenerates them::

    python scripts/make_golden.py                          # refuses: the goldens exist
    python scripts/make_golden.py --force                  # re-record, replay, rewrite all
    python scripts/make_golden.py --force --expected-only  # replay the pinned logs again
    python scripts/make_golden.py --force --images         # the image suite's scores only
    python scripts/make_golden.py --force --scene lobs     # add or refresh one scene alone

For each scene in :data:`SCENES` it records a small MCAP log with the EGL renderer
(:data:`RENDERER`), replays it once per configuration in :data:`CONFIGS` and keeps the
results file exactly as replay writes it (every field, floats as replay rounds them, the
same bytes) as ``<scene>.<method>-<fusion>.json``; a scene in :data:`EXTRA_CONFIGS` is
replayed with its own configurations too (the lob's 3-D fusions). The manifest
``manifest.json`` pins each log's SHA-256, size, topics and message counts, the record
options, the renderer and the package versions the logs were made with.
``--expected-only`` leaves the logs alone (they must still match the manifest) and rewrites
only the expected files and the manifest.
``--scene NAME`` records (or with ``--expected-only`` replays) that one scene and rewrites
its files and its manifest entry alone: every other log, expected file and manifest entry
is left as it is (a log re-recorded on another machine may differ in the last bit of a
pixel, so adding a scene must not re-record the others).

``tests/replay/test_golden.py`` imports this module by path for its constants (GOLDEN_DIR,
SCENES, CONFIGS, TOLERANCES, replay_results, ...). Importing it is cheap: the recorder
(pybullet) and replay are imported only inside the functions that need them.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import shutil
import sys
import tempfile
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
GOLDEN_DIR = ROOT / "logs" / "golden"
MANIFEST = "manifest.json"
MANIFEST_FORMAT = "dsp-golden"
MANIFEST_VERSION = 2
"""2: the expected files are the whole results files (1: a rounded subset of them)."""
RENDERER = "egl"
"""The goldens are recorded with EGL (hardware OpenGL path; Mesa EGL offscreen)."""

SCENES: dict[str, dict[str, Any]] = {
    # the paper's four static scenes: 3 robots, ball still; 3 frames at the default 5 Hz
    # (the first frame differs a little from the next: the ball settles onto the carpet)
    "scenario1": {"scenario": "scenario1", "seed": 0, "frames": 3, "camera": "ideal"},
    "scenario2": {"scenario": "scenario2", "seed": 0, "frames": 3, "camera": "ideal"},
    "scenario3": {"scenario": "scenario3", "seed": 0, "frames": 3, "camera": "ideal"},
    "scenario4": {"scenario": "scenario4", "seed": 0, "frames": 3, "camera": "ideal"},
    # a rolling ball and driving robots: 4 frames at 2 Hz (1.5 s, the ball moves ~4 m);
    # robot1 (the goalkeeper) never sees it, so "no_detection" frames are pinned too
    "rolling": {"scenario": "rolling", "seed": 0, "frames": 4, "rate_hz": 2.0,
                "camera": "ideal"},
    # match play: the ball kicked at t = 0, robots driving, each camera at its own phase (no
    # two images share a stamp), poses and truth (with the ball's velocity, nav_msgs/Odometry)
    # at 240 Hz; 4 frames per robot at 5 Hz (0.8 s), two distractors beside the field
    "match": {"scenario": "match", "seed": 0, "frames": 4, "rate_hz": 5.0,
              "camera": "ideal", "distractors": 2},
    # a lob: kicked into the air at t = 0; cameras in sync (rays of one instant), 4 frames at
    # 5 Hz (0.6 s): robot2 and robot3 see the ball at 0.11, 0.80, 0.95 and 0.71 m, robot1
    # never; poses and truth (3-D, with the velocity) at 240 Hz
    "lobs": {"scenario": "lobs", "seed": 0, "frames": 4, "rate_hz": 5.0,
             "camera": "ideal", "camera_phase": "sync"},
}
"""Golden scene name (= log file stem) -> keyword arguments of ``recorder.record.record``."""

PROFILE = "profile"
"""The "method" of a configuration that is a whole profile."""
CONFIGS: tuple[tuple[str, str], ...] = (
    ("paper", "mean"),  # the paper's method (eq. 3-14) with its mean fusion
    ("corrected", "mean"),
    ("corrected", "nearest"),
    ("corrected", "weighted"),
    ("corrected", "robust"),
    ("corrected", "track"),  # the tracker: a step at every image stamp, with the velocity
    (PROFILE, "best"),  # dsp-replay's default: the best profile, decided from the log
)
"""(method, fusion) pairs replayed for every scene (each expected file is ~5 kB); a pair
(:data:`PROFILE`, NAME) is the profile NAME (:mod:`replay.profiles`), as ``dsp-replay LOG
--profile NAME`` replays it."""

EXTRA_CONFIGS: dict[str, tuple[tuple[str, str], ...]] = {
    # the 3-D fusions: rays crossed into a point, and the ballistic tracker on those points
    "lobs": (("corrected", "triangulate"), ("corrected", "ballistic")),
}
"""Scene -> (method, fusion) pairs replayed for that scene after :data:`CONFIGS`."""


def scene_configs(scene: str) -> tuple[tuple[str, str], ...]:
    """Every (method, fusion) a scene is replayed with: :data:`CONFIGS` and its extras."""
    return CONFIGS + EXTRA_CONFIGS.get(scene, ())

TOLERANCES: dict[str, float] = {
    # replaying a golden log must give the expected file exactly: every field, every byte
    "replay": 0.0,
    # re-recording a golden scene with the golden's renderer (EGL): detections within
    # 0.5 px (renderers differ in the last bit across machines and driver versions)
    "detection_same_renderer_px": 0.5,
    # ... with the other renderer (TinyRenderer when the goldens are EGL). Measured on these
    # five scenes (same options, both renderers, corrected replay): centroids differ by at
    # most 0.459 px (scenario1/4 robot1, the far ball at r ~ 505 px), 0.06-0.35 px
    # elsewhere; blob areas by up to 16 px^2 (EGL rasterises the ball's rim a little wider).
    # That is within 0.5 px, so the same bound holds for both, with a thin margin; kept as
    # its own entry so it can be widened alone if a machine's EGL differs more.
    "detection_other_renderer_px": 0.5,
    # Rerun stores points as float32: the .rrd centroid [px] and field positions [m] equal
    # the golden ones to these
    "rrd_centroid_px": 1e-3,
    "rrd_position_m": 1e-4,
}


def config_label(method: str, fusion: str) -> str:
    return f"{method}-{fusion}"


def expected_name(scene: str, method: str, fusion: str) -> str:
    """File name of a scene's expected output for one configuration."""
    return f"{scene}.{config_label(method, fusion)}.json"


def log_name(scene: str) -> str:
    return f"{scene}.mcap"


def dumps(doc: Any) -> str:
    """The manifest's text form: sorted keys, one-space indent, ASCII, trailing newline."""
    return json.dumps(doc, sort_keys=True, indent=1, ensure_ascii=True, allow_nan=False) + "\n"


def sha256_of(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        while block := f.read(1 << 20):
            h.update(block)
    return h.hexdigest()


# --- generation ----------------------------------------------------------------------------


def replay_text(log: Path, method: str, fusion: str, workdir: Path) -> str:
    """Replay ``log`` with one configuration; the results file's text, as replay wrote it."""
    from replay import ReplayOptions, replay

    out = workdir / f".{log.stem}.{config_label(method, fusion)}.results.json"
    out.unlink(missing_ok=True)
    if method == PROFILE:
        from replay.profiles import options_for

        replay(log, options_for(fusion, out=out, progress=False))
    else:
        replay(log, ReplayOptions(method=method, fusion=fusion, out=out, progress=False))
    text = out.read_text(encoding="ascii")
    out.unlink()
    return text


def replay_results(log: Path, method: str, fusion: str, workdir: Path) -> dict[str, Any]:
    """Replay ``log`` with one configuration; the whole results document (nothing left out:
    it holds no wall-clock time and no absolute path, only the log's file name)."""
    doc: dict[str, Any] = json.loads(replay_text(log, method, fusion, workdir))
    return doc


def topic_counts(log: Path) -> dict[str, int]:
    """Topic -> message count from the MCAP summary (the mcap library's reader)."""
    from mcap.reader import make_reader

    with open(log, "rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None and summary.statistics is not None
    counts = summary.statistics.channel_message_counts
    return dict(sorted((summary.channels[cid].topic, n) for cid, n in counts.items()))


def _recorder_metadata(log: Path) -> dict[str, str]:
    from mcap.reader import make_reader

    from dsp import contract

    with open(log, "rb") as f:
        for m in make_reader(f).iter_metadata():
            if m.name == contract.RECORDER_METADATA:
                return dict(sorted(m.metadata.items()))
    return {}


def targets(*, expected_only: bool = False, scene: str | None = None) -> list[Path]:
    """Every file the script writes (without the logs when ``expected_only``; only one
    scene's files, the manifest aside, when ``scene``)."""
    names = [MANIFEST] if scene is None else []
    for name in SCENES if scene is None else [scene]:
        if not expected_only:
            names.append(log_name(name))
        names += [expected_name(name, m, f) for m, f in scene_configs(name)]
    return [GOLDEN_DIR / n for n in names]


def _manifest_head() -> dict[str, Any]:
    return {
        "format": MANIFEST_FORMAT,
        "version": MANIFEST_VERSION,
        "renderer": RENDERER,
        "expected": "the replay results file as written: every field, the same bytes",
        "configs": [{"method": m, "fusion": f} for m, f in CONFIGS],
        "extra_configs": {scene: [{"method": m, "fusion": f} for m, f in pairs]
                          for scene, pairs in EXTRA_CONFIGS.items()},
        "regenerate": "python scripts/make_golden.py --force",
        "regenerate_scene": "python scripts/make_golden.py --force --scene NAME",
        "regenerate_expected": "python scripts/make_golden.py --force --expected-only",
        "scenes": {},
    }


def _write_expected(scene: str, log: Path, work: Path) -> dict[str, str]:
    """Replay ``log`` in every configuration of ``scene`` into ``work``; config label -> file
    name."""
    expected = {}
    for method, fusion in scene_configs(scene):
        name = expected_name(scene, method, fusion)
        text = replay_text(log, method, fusion, work)
        (work / name).write_text(text, encoding="ascii", newline="\n")
        expected[config_label(method, fusion)] = name
    return expected


def _record_scenes(work: Path, manifest: dict[str, Any], scenes: list[str]) -> dict[str, str]:
    """Record ``scenes`` into ``work``, fill their manifest entries; the package versions."""
    from recorder.record import RecordOptions, record

    versions: dict[str, str] = {}
    for scene in scenes:
        options = SCENES[scene]
        log = work / log_name(scene)
        summary = record(log, RecordOptions(renderer=RENDERER, **options))
        if summary.renderer != RENDERER:  # pragma: no cover - record() raises first
            raise RuntimeError(f"{scene} was rendered with {summary.renderer}")
        print(f"{scene}: {summary.frames} frames, {log.stat().st_size} bytes", flush=True)
        counts = topic_counts(log)
        meta = _recorder_metadata(log)
        versions = {k: v for k, v in meta.items()
                    if k in ("dual_sight", "mcap", "numpy", "opencv", "pybullet", "python")}
        manifest["scenes"][scene] = {
            "log": log_name(scene),
            "sha256": sha256_of(log),
            "bytes": log.stat().st_size,
            "record": {**options, "renderer": RENDERER},
            "renderer": summary.renderer,
            "frames": summary.frames,
            "robots": summary.robots,
            "message_count": sum(counts.values()),
            "topics": counts,
        }
    return versions


def _pinned_scenes(manifest: dict[str, Any], old: dict[str, Any], scenes: list[str]) -> None:
    """Copy the old manifest's entries of ``scenes`` into ``manifest`` after checking that
    every such pinned log is still the one it names (same size and SHA-256)."""
    for scene in scenes:
        entry = dict(old["scenes"][scene])
        log = GOLDEN_DIR / log_name(scene)
        if not log.is_file() or log.stat().st_size != entry["bytes"] or (
                sha256_of(log) != entry["sha256"]):
            raise RuntimeError(f"{log} is missing or differs from {MANIFEST}; re-record the "
                               "goldens with --force (without --expected-only)")
        entry.pop("expected", None)
        manifest["scenes"][scene] = entry


def _old_manifest(scene: str | None, expected_only: bool) -> dict[str, Any] | None:
    """The manifest this run builds on: needed to keep pinned logs or the other scenes."""
    if scene is None and not expected_only:
        return None
    if not (GOLDEN_DIR / MANIFEST).is_file():
        raise RuntimeError(f"{GOLDEN_DIR / MANIFEST} is missing; make every golden first "
                           "(python scripts/make_golden.py)")
    return load_manifest()


def generate(force: bool = False, *, expected_only: bool = False,
             scene: str | None = None) -> dict[str, Any]:
    """Record every scene, replay every configuration, write logs, expected files and the
    manifest into GOLDEN_DIR. With ``expected_only`` the pinned logs are replayed as they
    are and only the expected files and the manifest are rewritten. With ``scene`` only that
    scene is recorded (or replayed) and only its files and its manifest entry are written;
    the other entries are kept as they are. Refuses to overwrite existing goldens unless
    ``force``."""
    if scene is not None and scene not in SCENES:
        raise ValueError(f"unknown golden scene {scene!r}; choose from {', '.join(SCENES)}")
    existing = [p for p in targets(expected_only=expected_only, scene=scene) if p.exists()]
    if existing and not force:
        raise FileExistsError(
            f"{len(existing)} golden file(s) exist in {GOLDEN_DIR} (e.g. {existing[0].name}); "
            "regenerating them is deliberate: pass --force and explain why in the commit"
        )
    scenes = list(SCENES) if scene is None else [scene]
    old = _old_manifest(scene, expected_only)
    GOLDEN_DIR.mkdir(parents=True, exist_ok=True)
    manifest = _manifest_head()
    if old is not None:
        manifest["versions"] = old["versions"]
        if scene is not None:  # the other scenes' entries, as they are
            manifest["scenes"] = {k: v for k, v in old["scenes"].items() if k != scene}
    with tempfile.TemporaryDirectory(dir=GOLDEN_DIR, prefix=".tmp-") as tmp:
        work = Path(tmp)
        if expected_only:
            _pinned_scenes(manifest, old or {}, scenes)
        else:
            versions = _record_scenes(work, manifest, scenes)
            if scene is None:
                manifest["versions"] = versions
            elif versions != manifest["versions"]:  # this scene's own, beside the others'
                manifest["scenes"][scene]["versions"] = versions
        staged = [] if expected_only else [log_name(name) for name in scenes]
        for name in scenes:
            log = GOLDEN_DIR / log_name(name) if expected_only else work / log_name(name)
            expected = _write_expected(name, log, work)
            manifest["scenes"][name]["expected"] = expected
            staged += expected.values()
        (work / MANIFEST).write_text(dumps(manifest), encoding="ascii", newline="\n")
        staged.append(MANIFEST)
        for name in staged:
            shutil.move(str(work / name), GOLDEN_DIR / name)
    total = sum(p.stat().st_size for p in GOLDEN_DIR.rglob("*") if p.is_file())
    print(f"wrote {len(staged)} files to {GOLDEN_DIR} ({total / 1e6:.2f} MB in the folder)")
    return manifest


IMAGE_SETS: dict[str, Path] = {
    # the committed subset (14 real images of one venue) and, where it is beside the
    # repository, the whole shared set (326 images, three venues, four folders)
    "subset": ROOT / "tests" / "data" / "msl-images",
    "msl": ROOT.parent / "shared" / "real" / "msl-images",
}
IMAGES_TRAIN_COUNT = 10


def images_golden(root: Path) -> dict[str, Any]:
    """``dsp-eval --suite images ROOT --train-count 10``'s summary with the shipped check,
    less the wall times (the only figures that change from run to run)."""
    from dsp.ball_file import shipped_check
    from replay.evaluate.images import run_images_suite

    doc, _ = run_images_suite([root], train_count=IMAGES_TRAIN_COUNT, check=shipped_check())
    for row in [*doc["folders"].values(), doc["total"]]:
        row.pop("ms_per_image")
    return doc


def generate_images(force: bool = False) -> list[Path]:
    """Write GOLDEN_DIR/images-<set>.json for every image set on this machine."""
    written = []
    for name, root in IMAGE_SETS.items():
        path = GOLDEN_DIR / f"images-{name}.json"
        if not root.is_dir():
            print(f"{root}: absent; {path.name} left as it is")
            continue
        if path.exists() and not force:
            raise FileExistsError(f"{path} exists; pass --force and explain why in the commit")
        path.write_text(dumps(images_golden(root)), encoding="ascii", newline="\n")
        written.append(path)
    print(f"wrote {', '.join(p.name for p in written) or 'nothing'}")
    return written


def load_manifest() -> dict[str, Any]:
    manifest: dict[str, Any] = json.loads((GOLDEN_DIR / MANIFEST).read_text(encoding="ascii"))
    return manifest


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], allow_abbrev=False)
    parser.add_argument("--force", action="store_true",
                        help="overwrite the existing goldens (explain why in the commit)")
    parser.add_argument("--expected-only", action="store_true",
                        help="keep the pinned logs; replay them and rewrite only the expected "
                             "outputs and the manifest")
    parser.add_argument("--scene", choices=list(SCENES), metavar="NAME",
                        help="only this scene (record, replay, its manifest entry); the other "
                             f"goldens are left as they are ({', '.join(SCENES)})")
    parser.add_argument("--images", action="store_true",
                        help="only the image suite's golden scores (images-*.json)")
    args = parser.parse_args(argv)
    try:
        if args.images:
            generate_images(force=args.force)
        else:
            generate(force=args.force, expected_only=args.expected_only, scene=args.scene)
    except FileExistsError as err:
        print(f"make_golden: {err}", file=sys.stderr)
        return 2
    except RuntimeError as err:
        print(f"make_golden: {err}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    if str(ROOT) not in sys.path:  # run as a file from a clone without an install
        sys.path.insert(0, str(ROOT))
    sys.exit(main())
