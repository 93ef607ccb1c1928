"""One Markdown table across camera models from dsp-calibrate and dsp-eval outputs.

    python scripts/summarise_eval.py DIR [DIR ...]

Each DIR is a dsp-eval ``--out-dir`` holding ``paper-<camera>.json`` and
``random-<camera>-<count>-seed<seed>.json``; the calibration each suite used is read from
the file the suite names, looked up beside DIR (as ``dsp-calibrate -o ../cal-<camera>.json``
leaves it). For every camera: the calibration model dsp-calibrate chose and its held-out
RMS, Table 1's RMSE (paper mode, and the corrected estimator with each fusion), and the
random suite's fused RMSE / p95 / max over the scenes with two robots within 9 m (and how
many of those had an estimate to fuse).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

from estimator.fusion import FUSION_METHODS

FUSIONS: list[str] = list(FUSION_METHODS)


def _load(path: Path) -> dict[str, Any]:
    doc: dict[str, Any] = json.loads(path.read_text(encoding="utf-8"))
    return doc


def _mm(v: float | None) -> str:
    return "-" if v is None else f"{v:.4f}"


def _rmse(table: dict[str, Any], label: str) -> str:
    """A configuration's RMSE, "-" when the file predates it (e.g. a fusion added since)."""
    return _mm(table[label]["rmse_m"]) if label in table else "-"


def summarise(dirs: list[Path]) -> str:
    papers = [path for d in dirs for path in sorted(d.glob("paper-*.json"))]
    # the fusions the files hold (a file that predates a fusion shows "-" for it)
    fusions = [x for x in FUSIONS
               if any(f"corrected/{x}" in _load(path)["configs"] for path in papers)] or FUSIONS
    lines = [
        "| camera | calibration (held-out RMS) | Table 1, paper mode | Table 1, corrected: "
        + " / ".join(fusions) + " | random scenes (two robots within 9 m) | fused RMSE: "
        + " / ".join(fusions) + " | weighted p95 / max |",
        "|---|---|---|---|---|---|---|",
    ]
    for d in dirs:
        for paper_path in sorted(d.glob("paper-*.json")):
            paper = _load(paper_path)
            camera = paper["camera"]
            configs = paper["configs"]
            cal_name = paper["calibration"]
            cal_path = d.parent / cal_name
            cal = "camera metadata"
            if cal_path.is_file():
                c = _load(cal_path)
                cal = f"{c['model']} ({_mm(c.get('holdout_rms_m'))} m)"
            randoms = sorted(d.glob(f"random-{camera}-*-seed*.json"),
                             key=lambda p: _load(p)["count"])
            scenes = fused = tail = "-"
            if randoms:
                r = _load(randoms[-1])
                f = r["fused"]
                fused_n = f["corrected/weighted"]["scenes"]
                scenes = (f"{r['dual_sight_scenes']} of {r['count']} (seed {r['seed']}); "
                          f"{fused_n} fused")
                fused = " / ".join(_rmse(f, f"corrected/{x}") for x in fusions)
                w = f["corrected/weighted"]
                tail = f"{_mm(w['p95_m'])} / {_mm(w['max_m'])}"
            lines.append(
                f"| {camera} | {cal} | {_mm(configs['paper/mean']['rmse_m'])} | "
                + " / ".join(_rmse(configs, f"corrected/{x}") for x in fusions)
                + f" | {scenes} | {fused} | {tail} |")
    return "\n".join(lines) + "\n"


def main(argv: list[str]) -> int:
    if not argv:
        print(__doc__.strip().splitlines()[2].strip(), file=sys.stderr)
        return 2
    dirs = [Path(a) for a in argv]
    missing = [str(d) for d in dirs if not d.is_dir()]
    if missing:
        print(f"summarise_eval: error: not a folder: {', '.join(missing)}", file=sys.stderr)
        return 2
    sys.stdout.write(summarise(dirs))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
