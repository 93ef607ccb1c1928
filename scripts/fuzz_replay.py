"""Fuzz ``dsp-replay`` with seeded mutations of the golden logs, in this process.

    python scripts/fuzz_replay.py --cases 10000 --seed 1 --report fuzz.json

Each case is a mutated log (``tests/fuzzing.py`` lists the mutations) replayed through
``dsp-replay``'s ``main`` under a timer, with the peak RSS measured per case. Prints a table
per mutation kind: cases, one-line errors, ok, changed-with-warning, silent wrong results
(exit 0, different results, no warning, where a CRC or the summary covers the damage),
uncovered (the same where nothing covers it), lost (a case that says what it must give,
such as the frames before a cut with ``--recover``, did not give it), tracebacks, hangs,
peak RSS. Exit status 1 when there is any traceback, hang, silent wrong result, lost case or
a peak RSS over 1 GiB.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import sys
import tempfile
import time
from pathlib import Path
from types import ModuleType
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
GIB = 1 << 30


def load_fuzzing() -> ModuleType:
    """tests/fuzzing.py and the modules beside it that it imports, loaded by path (putting
    tests/ on sys.path would let its test folders shadow the packages of the same name)."""
    for name in ("fuzzing_logs", "fuzzing_recover", "fuzzing"):
        if name in sys.modules:
            continue
        spec = importlib.util.spec_from_file_location(name, ROOT / "tests" / f"{name}.py")
        assert spec is not None and spec.loader is not None
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module
        spec.loader.exec_module(module)
    return sys.modules["fuzzing"]


def seeds(fz: ModuleType) -> list[bytes]:
    """The seed logs: golden scenario2's and rolling's first frames in the recorder's layout,
    scenario2's in small lz4 chunks, and unchunked."""
    from mcap.writer import CompressionType

    return [
        fz.seed_log("scenario2"),
        fz.seed_log("rolling", until_s=0.6),
        fz.seed_log("scenario2", compression=CompressionType.LZ4, chunk_size=32 * 1024),
        fz.seed_log("scenario2", use_chunking=False),
    ]


def expected_results(fz: ModuleType, seed_logs: list[bytes], workdir: Path
                     ) -> list[tuple[str, tuple[str, ...]]]:
    """Each seed's results (comparable) and the warnings its replay prints."""
    out = []
    for data in seed_logs:
        outcome = fz.run_case(data, workdir, expected=None, covered=True)
        assert outcome.status == "ok", outcome
        out.append((fz.comparable(json.loads((workdir / "case.json").read_text())),
                    outcome.warnings))
    return out


def campaign(n: int, seed: int, *, timeout_s: float = 60.0, kinds: list[str] | None = None,
             progress: bool = False) -> dict[str, Any]:
    """Run ``n`` cases; the figures by kind and in total, and the worst cases."""
    fz = load_fuzzing()
    seed_logs = seeds(fz)
    rows: dict[str, dict[str, Any]] = {}
    findings: list[dict[str, Any]] = []
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        expected = expected_results(fz, seed_logs, work)
        for i, kind, what, data, s, where, expect in fz.cases(seed_logs, n, seed, kinds):
            o = fz.run_case(data, work, expected=expected[s][0],
                            covered=fz.is_covered(seed_logs[s], where), timeout_s=timeout_s,
                            seed_warnings=expected[s][1], expect=expect)
            row = rows.setdefault(kind, {"cases": 0, "peak_rss": 0, "max_s": 0.0})
            row["cases"] += 1
            row[o.status] = row.get(o.status, 0) + 1
            row["peak_rss"] = max(row["peak_rss"], o.peak_rss)
            row["max_s"] = max(row["max_s"], round(o.seconds, 2))
            if o.status in ("traceback", "hang", "silent", "lost") or o.peak_rss > GIB:
                findings.append({"case": i, "kind": kind, "what": what, "seed": s,
                                 "status": o.status, "rss": o.peak_rss, "message": o.message})
            if progress and (i + 1) % 100 == 0:
                print(f"{i + 1}/{n} cases, {time.perf_counter() - t0:.0f} s", file=sys.stderr,
                      flush=True)
    total: dict[str, Any] = {"cases": 0, "peak_rss": 0, "max_s": 0.0}
    for row in rows.values():
        for k, v in row.items():
            total[k] = max(total.get(k, 0), v) if k in ("peak_rss", "max_s") else (
                total.get(k, 0) + v)
    return {"seed": seed, "cases": n, "seconds": round(time.perf_counter() - t0, 1),
            "by_kind": rows, "total": total, "findings": findings[:200]}


def merge(reports: list[dict[str, Any]]) -> dict[str, Any]:
    """One report from campaigns run side by side (different seeds)."""
    out: dict[str, Any] = {"seed": "+".join(str(r["seed"]) for r in reports),
                           "cases": sum(r["cases"] for r in reports),
                           "seconds": max(r["seconds"] for r in reports), "by_kind": {},
                           "findings": [f for r in reports for f in r["findings"]][:200]}
    for r in reports:
        for kind, row in r["by_kind"].items():
            into = out["by_kind"].setdefault(kind, {})
            for k, v in row.items():
                into[k] = max(into.get(k, 0), v) if k in ("peak_rss", "max_s") else (
                    into.get(k, 0) + v)
    total: dict[str, Any] = {}
    for row in out["by_kind"].values():
        for k, v in row.items():
            total[k] = max(total.get(k, 0), v) if k in ("peak_rss", "max_s") else (
                total.get(k, 0) + v)
    out["total"] = total
    return out


def format_report(report: dict[str, Any]) -> str:
    cols = ("cases", "error", "ok", "changed", "silent", "uncovered", "lost", "traceback",
            "hang")
    lines = [f"{'kind':12}" + "".join(f"{c:>10}" for c in cols) + f"{'peak RSS':>11}"]
    for name, row in [*sorted(report["by_kind"].items()), ("total", report["total"])]:
        lines.append(f"{name:12}" + "".join(f"{row.get(c, 0):>10}" for c in cols)
                     + f"{row['peak_rss'] / 2**20:>8.0f} MiB")
    lines.append(f"{report['cases']} cases, seed {report['seed']}, {report['seconds']} s")
    return "\n".join(lines)


def failed(report: dict[str, Any]) -> bool:
    t = report["total"]
    return bool(t.get("traceback") or t.get("hang") or t.get("silent") or t.get("lost")
                or t["peak_rss"] > GIB)


def _report(path: Path) -> dict[str, Any]:
    """A campaign's report (--report), read bounded; a file that is none is one line."""
    from dsp.errors import InputError
    from dsp.textfile import read_text_file

    try:
        report = json.loads(read_text_file(path, 64 << 20, what="a report --report wrote"))
    except json.JSONDecodeError as err:
        raise InputError(f"{path}: not JSON ({err.msg}, line {err.lineno})") from None
    if not (isinstance(report, dict) and isinstance(report.get("findings"), list)
            and isinstance(report.get("by_kind"), dict)
            and all(k in report for k in ("seed", "cases", "seconds"))):
        raise InputError(f"{path}: not a report of this script (--report writes one)")
    return report


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(allow_abbrev=False, description=__doc__.split("\n\n")[0])
    p.add_argument("--cases", type=int, default=1000)
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--timeout", type=float, default=60.0, help="seconds per case")
    p.add_argument("--kinds", help="comma-separated mutation kinds (default all)")
    p.add_argument("--report", type=Path, help="write the figures and findings as JSON")
    p.add_argument("--merge", type=Path, nargs="+", metavar="REPORT",
                   help="print one table from reports of campaigns run side by side")
    args = p.parse_args(argv)
    if args.merge:
        merged = merge([_report(r) for r in args.merge])
        print(format_report(merged))
        return 1 if failed(merged) else 0
    kinds = args.kinds.split(",") if args.kinds else None
    report = campaign(args.cases, args.seed, timeout_s=args.timeout, kinds=kinds,
                      progress=True)
    print(format_report(report))
    for f in report["findings"][:20]:
        print(f"  case {f['case']} {f['kind']} seed {f['seed']} ({f['what']}): {f['status']}: "
              f"{f['message']}")
    if args.report is not None:
        args.report.write_text(json.dumps(report, indent=1, sort_keys=True) + "\n")
    return 1 if failed(report) else 0


if __name__ == "__main__":
    sys.path.insert(0, str(ROOT))
    from dsp.cli import run_main

    sys.exit(run_main("fuzz_replay.py", main))
