"""The default pipeline beside the switches it replaces, log by log: a Markdown table.

Replay each log three ways into one folder (the file names are the table's key)::

    dsp-replay LOG --out DIR/NAME.default.json                      # no switches
    dsp-replay LOG --localise lines --hops --no-pose-uncertainty \\
        --out DIR/NAME.lineshops.json                               # the best switches before
    dsp-replay LOG --profile fast --no-hops --no-pose-uncertainty \\
        --out DIR/NAME.plain.json                                   # the tracker, believed poses

then ``python scripts/profile_table.py DIR [-o docs/generated/profiles.md]``. Each row is
a log: the fused RMSE and the largest fused error of each replay; the last row pools the
logs' fused steps. The table says when and on which commit it was written.
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import math
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
VARIANTS = {"default": "`dsp-replay LOG`", "lineshops": "`--localise lines --hops`",
            "plain": "tracker, believed poses"}


def _fused(path: Path) -> tuple[float, float, int]:
    doc = json.loads(path.read_text(encoding="utf-8"))
    f = doc["summary"]["fused"]
    return float(f["rmse_m"]), float(f["max_error_m"]), int(f["errors"])


def table(folder: Path) -> str:
    names = sorted({p.name.split(".")[0] for p in folder.glob("*.default.json")})
    if not names:
        raise ValueError(f"{folder}: no NAME.default.json results")
    head = ["log", *(f"{v}: RMSE / max [m]" for v in VARIANTS.values())]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    pooled = {v: [0.0, 0] for v in VARIANTS}
    for name in names:
        cells = [name]
        for v in VARIANTS:
            rmse, worst, n = _fused(folder / f"{name}.{v}.json")
            cells.append(f"{rmse:.3f} / {worst:.2f}")
            pooled[v][0] += rmse * rmse * n
            pooled[v][1] += n
        lines.append("| " + " | ".join(cells) + " |")
    lines.append("| all, pooled | " + " | ".join(
        f"**{math.sqrt(s / n):.3f}**" for s, n in pooled.values()) + " |")
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT,
                            capture_output=True, text=True).stdout.strip() or "unknown"
    lines += ["", f"Written by `python scripts/profile_table.py` on "
              f"{dt.datetime.now(dt.timezone.utc):%Y-%m-%d} at commit {commit}, from the "
              f"replays of {len(names)} logs (commands in the script's docstring)."]
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0], allow_abbrev=False)
    p.add_argument("folder", type=Path, help="the replays' results")
    p.add_argument("-o", "--out", type=Path, help="write the table here (default: print)")
    args = p.parse_args(argv)
    try:
        text = table(args.folder)
    except (OSError, ValueError, KeyError, TypeError) as err:
        print(f"profile_table.py: error: {err}", file=sys.stderr)
        return 1
    if args.out is None:
        print(text, end="")
    else:
        args.out.write_text(text, encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
