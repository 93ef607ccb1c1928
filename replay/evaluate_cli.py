"""``dsp-eval``: the paper's experiment end to end (record, replay, score) (thin CLI).

    dsp-eval [--camera ideal] [--calibration calib.json] [--out-dir eval/]
    dsp-eval --suite random --count 200 --seed 1

Prints Table 1 (the paper's beside ours) or the random-scene statistics, and writes them
as Markdown and JSON into --out-dir, beside the recorded logs (which are reused when the
same command runs again).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections.abc import Sequence
from pathlib import Path

from estimator.calibration import calibration_from_json
from estimator.camera import CAMERA_MODELS
from estimator.errors import EstimatorError
from recorder.errors import RecorderError
from replay.errors import ReplayError
from replay.evaluate import (
    Recorder,
    paper_markdown,
    random_markdown,
    run_paper_suite,
    run_random_suite,
)

__all__ = ["build_parser", "main"]


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="dsp-eval",
        description="Record the paper's four scenarios (or N random scenes), replay them with "
        "paper mode and the corrected estimator under each fusion method, and score them.",
    )
    p.add_argument("--suite", choices=("paper", "random"), default="paper",
                   help="the paper's four scenarios (default) or random scenes")
    p.add_argument("--count", type=int, default=200, help="random scenes (default 200)")
    p.add_argument("--seed", type=int, default=0, help="seed of the first scene (default 0)")
    p.add_argument("--camera", choices=CAMERA_MODELS, default="ideal",
                   help="camera model (default %(default)s)")
    p.add_argument("--calibration", type=Path, metavar="FILE",
                   help="calibration from dsp-calibrate for the corrected estimator "
                   "(default: the camera model in the log's metadata)")
    p.add_argument("--out-dir", type=Path, default=Path("eval"), metavar="DIR",
                   help="logs and tables go here (default ./eval)")
    p.add_argument("--renderer", choices=("auto", "egl", "tiny"), default="auto",
                   help="pybullet renderer for recording (default: EGL when it loads)")
    return p


def _recorder(camera: str, renderer: str) -> Recorder:
    from recorder.record import RecordOptions, record  # lazy: replay alone does not need pybullet

    def run(path: Path, scenario: str, seed: int) -> None:
        record(path, RecordOptions(scenario=scenario, seed=seed, camera=camera, renderer=renderer))

    return run


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    out_dir: Path = args.out_dir
    t0 = time.perf_counter()
    progress = None
    if sys.stderr.isatty():
        def progress(msg: str) -> None:
            print(f"\r\033[Kdsp-eval: {msg}", end="", file=sys.stderr, flush=True)
    try:
        if args.count < 1:
            raise ValueError(f"--count {args.count}: give at least 1 scene")
        if args.calibration is not None:
            if not args.calibration.is_file():
                raise ValueError(f"{args.calibration}: calibration file not found")
            try:  # before recording anything: a bad file would only show at the replay
                calibration_from_json(args.calibration.read_text(encoding="utf-8"))
            except (EstimatorError, UnicodeDecodeError) as err:
                raise ValueError(f"{args.calibration}: unusable calibration: {err}") from err
        out_dir.mkdir(parents=True, exist_ok=True)
        record = _recorder(args.camera, args.renderer)
        stem = f"{args.suite}-{args.camera}"
        if args.suite == "paper":
            suite = run_paper_suite(record, out_dir, camera=args.camera,
                                    calibration=args.calibration, seed=args.seed,
                                    on_progress=progress)
            text, doc = paper_markdown(suite), suite.to_dict()
        else:
            rsuite = run_random_suite(record, out_dir, camera=args.camera, count=args.count,
                                      seed=args.seed, calibration=args.calibration,
                                      on_progress=progress)
            text, doc = random_markdown(rsuite), rsuite.to_dict()
            stem += f"-{args.count}-seed{args.seed}"
    except (ReplayError, RecorderError, ValueError, OSError) as err:
        if progress:
            print(file=sys.stderr)
        print(f"dsp-eval: error: {err}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("\ndsp-eval: interrupted", file=sys.stderr)
        return 130
    if progress:
        print("\r\033[K", end="", file=sys.stderr)
    (out_dir / f"{stem}.md").write_text(text, encoding="utf-8")
    (out_dir / f"{stem}.json").write_text(json.dumps(doc, sort_keys=True, indent=2) + "\n",
                                          encoding="utf-8")
    print(text)
    print(f"wrote {out_dir / (stem + '.md')} and .json in {time.perf_counter() - t0:.0f} s")
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
