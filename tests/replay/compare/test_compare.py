"""dsp-compare: pairing, the metrics against direct computation, bootstrap verdicts that
follow the data, determinism, and one-line refusals of bad input."""

from __future__ import annotations

import json
import math
import shutil
from pathlib import Path

import numpy as np
import pytest
from results_files import noisy_errors, results_doc, write

import replay.cli
from replay.compare import compare
from replay.compare.bootstrap import weighted_quantile
from replay.compare.cli import main

GOLDEN = Path(__file__).resolve().parents[2].parent / "logs" / "golden"


def _folder(root: Path, name: str, docs: dict[str, dict]) -> Path:
    for stem, doc in docs.items():
        write(root / name / f"{stem}.json", doc)
    return root / name


def test_weighted_quantile_is_numpy_percentile_of_the_repeated_values() -> None:
    rng = np.random.default_rng(3)
    values = np.sort(rng.normal(size=37))
    weights = rng.integers(0, 4, size=(60, 37)).astype(float)
    weights[0] = 0
    weights[1] = 0
    weights[1, 5] = 1
    expected = [np.nan if w.sum() == 0 else np.percentile(np.repeat(values, w.astype(int)), 95)
                for w in weights]
    full, reached = weighted_quantile(values, weights, 0.95)
    np.testing.assert_allclose(full, expected, rtol=0, atol=1e-12)
    assert reached.all()
    # from the tail alone, with the rows' whole counts: the same where the tail reaches
    tail, reached = weighted_quantile(values, weights[:, -8:], 0.95, weights.sum(axis=1))
    assert reached.sum() > 30 and not reached.all()
    np.testing.assert_allclose(tail[reached], full[reached], rtol=0, atol=1e-12)


def test_metrics_are_those_of_the_paired_data(tmp_path: Path) -> None:
    ea = [0.1, None, 0.3, 0.2, 0.05, 0.4]
    eb = [0.1, 0.2, None, 0.1, 0.05, 0.1]
    det_a = [True] * 15 + [False] * 3
    a = write(tmp_path / "a.json", results_doc(ea, detected=det_a,
                                               velocity=[0.5, None, 1, 2, 0, 1]))
    b = write(tmp_path / "b.json", results_doc(eb, fusion="track"))
    r = compare(a, b, replicates=50).total
    fa = np.array([e for e in ea if e is not None])
    assert r["rmse_m"].a == pytest.approx(math.sqrt(np.mean(fa**2)))
    assert r["p95_m"].a == pytest.approx(np.percentile(fa, 95))
    assert r["fused_rate"].a == pytest.approx(5 / 6) and r["fused_rate"].b == pytest.approx(5 / 6)
    assert r["detection_rate"].a == pytest.approx(15 / 18)
    assert r["detection_rate"].b == 1.0
    # velocity where the step has both an estimate and a velocity error: 0.5, 1, 2, 0, 1
    assert r["velocity_rmse_m_s"].a == pytest.approx(math.sqrt(np.mean(
        np.array([0.5, 1, 2, 0, 1]) ** 2)))
    assert r["velocity_rmse_m_s"].verdict == "n/a"  # B has no velocity


def test_a_clear_improvement_is_better_and_noise_is_no_difference(tmp_path: Path) -> None:
    docs_a, docs_b, docs_n = {}, {}, {}
    for i in range(8):
        base = noisy_errors(i, 200)
        sha = f"{i:064x}"
        docs_a[f"log{i}"] = results_doc(base, sha=sha, log=f"log{i}.mcap")
        docs_b[f"log{i}"] = results_doc([0.6 * e for e in base], sha=sha, log=f"log{i}.mcap",
                                        fusion="track")
        # same distribution, other draws: no real difference
        docs_n[f"log{i}"] = results_doc(noisy_errors(100 + i, 200), sha=sha, log=f"log{i}.mcap")
    a, b, n = (_folder(tmp_path, k, d) for k, d in
               (("a", docs_a), ("b", docs_b), ("n", docs_n)))
    better = compare(a, b, replicates=300)
    for key in ("rmse_m", "p95_m"):
        res = better.total[key]
        assert res.verdict == "better" and res.ci is not None and res.ci[1] < 0
        assert res.ci[0] <= res.diff <= res.ci[1]
    assert better.total["fused_rate"].verdict == "no difference"
    worse = compare(b, a, replicates=300)
    assert worse.total["rmse_m"].verdict == "worse" and worse.worse == ["rmse_m", "p95_m"]
    same = compare(a, n, replicates=300)
    assert same.total["rmse_m"].verdict == "no difference"
    assert same.total["p95_m"].verdict == "no difference"
    # the exit code follows --fail-if-worse
    assert main([str(a), str(b), "-q", "--fail-if-worse"]) == 0
    assert main([str(b), str(a), "-q", "--fail-if-worse"]) == 1
    assert main([str(b), str(a), "-q"]) == 0


def test_outputs_are_byte_identical_and_the_seed_matters(tmp_path: Path) -> None:
    a = write(tmp_path / "a.json", results_doc(noisy_errors(1, 120)))
    b = write(tmp_path / "b.json", results_doc(noisy_errors(2, 120), fusion="track"))
    outs = []
    for run, seed in ((1, "0"), (2, "0"), (3, "5")):
        d = tmp_path / f"out{run}"
        d.mkdir()
        assert main([str(a), str(b), "-q", "--bootstrap-seed", seed, "--out", str(d / "c.json"),
                     "--out-csv", str(d / "c.csv"), "--out-md", str(d / "c.md"),
                     "--plot", str(d / "c.png")]) == 0
        outs.append({p.name: p.read_bytes() for p in sorted(d.iterdir())})
    assert outs[0] == outs[1]
    assert outs[0]["c.json"] != outs[2]["c.json"]
    doc = json.loads(outs[0]["c.json"])
    assert doc["differences"] == {"fusion": ["mean", "track"]}
    assert doc["total"]["steps"] == 120 and doc["total"]["frames"] == 360
    csv_rows = outs[0]["c.csv"].decode().splitlines()
    assert len(csv_rows) == 1 + 2 * 5 and csv_rows[-1].startswith("total,velocity_rmse_m_s")


def test_frames_and_steps_pair_by_stamp(tmp_path: Path) -> None:
    a_doc = results_doc([0.1] * 10)
    b_doc = results_doc([0.1] * 10)
    b_doc["fused"] = b_doc["fused"][3:]  # B starts later (--start)
    b_doc["frames"] = b_doc["frames"][9:]
    r = compare(write(tmp_path / "a.json", a_doc), write(tmp_path / "b.json", b_doc),
                replicates=20)
    (pair,) = r.pairs
    assert len(pair.error_a) == 7 and pair.unpaired_steps == (3, 0)
    assert len(pair.detected_a) == 21 and pair.unpaired_frames == (9, 0)
    assert all(m.verdict in ("no difference", "n/a") for m in r.total.values())


def test_identical_replays_of_golden_logs_show_no_difference(tmp_path: Path) -> None:
    logs = [GOLDEN / f"{n}.mcap" for n in ("rolling", "scenario2")]
    for name, extra in (("a", ["--threads", "1"]), ("b", ["--threads", "2", "--progress"])):
        assert replay.cli.main([*map(str, logs), "--out-dir", str(tmp_path / name), "-q",
                                *extra]) == 0
    r = compare(tmp_path / "a", tmp_path / "b", replicates=100)
    assert len(r.pairs) == 2
    for res in r.results:
        for key, m in res.items():
            assert m.verdict in ("no difference", "n/a"), key
            assert m.diff in (0.0, None)


def test_golden_mean_against_track(tmp_path: Path) -> None:
    a, b = tmp_path / "mean", tmp_path / "track"
    for scene in ("match", "rolling"):
        for folder, fusion in ((a, "mean"), (b, "track")):
            folder.mkdir(exist_ok=True)
            shutil.copy(GOLDEN / f"{scene}.corrected-{fusion}.json", folder / f"{scene}.json")
    r = compare(a, b, replicates=200)
    assert r.total["rmse_m"].verdict == "better"
    # a run against itself: every step pairs, and its RMSEs are the results' own
    golden = json.loads((GOLDEN / "match.corrected-track.json").read_text())["summary"]
    (res, _) = compare(b / "match.json", b / "match.json", replicates=10).results
    assert res["rmse_m"].a == pytest.approx(golden["fused"]["rmse_m"], abs=1e-6)
    assert res["velocity_rmse_m_s"].b == pytest.approx(golden["fused"]["velocity"]["rmse_m_s"],
                                                       abs=1e-6)
    assert res["rmse_m"].ci == (0.0, 0.0) and res["rmse_m"].verdict == "no difference"


def _error(capsys: pytest.CaptureFixture[str], argv: list[str]) -> tuple[int, str]:
    code = main(argv)
    err = capsys.readouterr().err
    return code, err


def test_bad_input_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    good = write(tmp_path / "good.json", results_doc([0.1, 0.2]))
    other = write(tmp_path / "other.json", results_doc([0.1, 0.2], sha="b" * 64))
    bad_json = tmp_path / "bad.json"
    bad_json.write_text('{"format": "dsp-replay-results", "version": 1, "x": NaN}')
    not_results = write(tmp_path / "summary.json", {"format": "dsp-replay-batch"})
    broken = results_doc([0.1])
    broken["fused"][0]["error_m"] = "far"
    broken_path = write(tmp_path / "broken.json", broken)
    negative = write(tmp_path / "negative.json", results_doc([0.1, -0.2]))
    backwards = write(tmp_path / "backwards.json", results_doc([0.1, 0.2], velocity=[0.1, -1]))
    empty = tmp_path / "empty"
    empty.mkdir()
    cases = [
        ([str(good), str(other)], "other.json", "--allow-different-logs"),
        ([str(good), str(bad_json)], "bad.json", "not JSON"),
        ([str(good), str(not_results)], "summary.json", "not a dsp-replay results file"),
        ([str(good), str(broken_path)], "broken.json", "fused[0].error_m"),
        ([str(good), str(negative)], "negative.json",
         "fused[1].error_m is -0.2; an error is a distance, never negative"),
        ([str(backwards), str(good)], "backwards.json", "fused[1].velocity_error_m_s is -1.0"),
        ([str(good), str(tmp_path / "missing.json")], "missing.json", "no such"),
        ([str(good), str(empty)], "empty", "no dsp-replay results"),
    ]
    for argv, name, what in cases:
        code, err = _error(capsys, argv)
        assert code == 1, argv
        assert err.count("\n") == 1 and name in err and what in err, err
        assert "Traceback" not in err
    # told to, it compares different logs
    assert main([str(good), str(other), "-q", "--allow-different-logs"]) == 0
    code, err = _error(capsys, [str(good), str(good), "--out", str(tmp_path / "x.csv")])
    assert code == 2 and ".json" in err



def test_a_log_given_for_results_is_named_as_one(tmp_path: Path,
                                                  capsys: pytest.CaptureFixture[str]) -> None:
    """An MCAP log is not "not UTF-8 text": the error says what it is and what makes results."""
    good = write(tmp_path / "good.json", results_doc([0.1, 0.2]))
    log = tmp_path / "match.mcap"
    shutil.copyfile(GOLDEN / "match.mcap", log)
    code, err = _error(capsys, [str(good), str(log)])
    assert code == 1 and err.count("\n") == 1 and "UTF-8" not in err
    assert err.startswith(f"dsp-compare: error: {log}: an MCAP log, not a results file: "
                          f"dsp-compare compares the results of replays (dsp-replay {log} --out "
                          "r.json writes them); --log LOG --rerun shows")


def test_a_folder_missing_a_log_is_refused_unless_allowed(tmp_path: Path,
                                                          capsys: pytest.CaptureFixture[str]
                                                          ) -> None:
    a = _folder(tmp_path, "a", {"l1": results_doc([0.1], sha="1" * 64, log="l1.mcap"),
                                "l2": results_doc([0.1], sha="2" * 64, log="l2.mcap")})
    b = _folder(tmp_path, "b", {"l1": results_doc([0.1], sha="1" * 64, log="l1.mcap")})
    code, err = _error(capsys, [str(a), str(b)])
    assert code == 1 and "l2.json" in err and "l2.mcap" in err
    r = compare(a, b, allow_different_logs=True, replicates=10)
    assert [p.log for p in r.pairs] == ["l1.mcap"] and list(r.left_out) == ["l2.mcap"]


@pytest.mark.parametrize("run", ["A", "B"])
def test_an_output_never_overwrites_a_results_file_inside_a_run_folder(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], run: str) -> None:
    """A folder run reads each of its *.json: --out naming one (or a link to it) is refused
    before any work, with --force too, and the file is left as it was."""
    for name in ("a", "b"):
        write(tmp_path / name / "x.json", results_doc(noisy_errors(1, 20), log="x.mcap"))
    target = tmp_path / run.lower() / "x.json"
    before = target.read_bytes()
    link = tmp_path / "link.json"
    link.symlink_to(target)
    for out in (target, link):
        code = main([str(tmp_path / "a"), str(tmp_path / "b"), "-q", "--force",
                     "--out", str(out)])
        err = capsys.readouterr().err
        assert code == 2 and f"a results file of run {run}" in err, err
        assert err.count("\n") <= 2
    assert target.read_bytes() == before


def test_replicates_are_bounded_by_the_work_they_make(
        tmp_path: Path, capsys: pytest.CaptureFixture[str],
        monkeypatch: pytest.MonkeyPatch) -> None:
    # 40 steps and 120 frames: 160 units per replicate
    a = write(tmp_path / "a.json", results_doc(noisy_errors(1, 40)))
    b = write(tmp_path / "b.json", results_doc(noisy_errors(2, 40)))
    monkeypatch.setattr("replay.compare.MAX_RESAMPLED", 160 * 5000)
    assert main([str(a), str(b), "-q", "--replicates", "5000"]) == 0
    code, err = _error(capsys, [str(a), str(b), "--replicates", "5001"])
    assert code == 2 and "Traceback" not in err
    assert err.endswith("--replicates 5001 over 160 paired steps and frames is 8e+05 draws; "
                        "give at most 5000 here\n"), err
    # the default is never refused: its work grows with the (capped) input alone
    monkeypatch.setattr("replay.compare.MAX_RESAMPLED", 10)
    assert main([str(a), str(b), "-q"]) == 0
    code, err = _error(capsys, [str(a), str(b), "--replicates", "1001"])
    assert code == 2 and "give at most 1000 here" in err
