"""dsp-compare --log LOG --save: both runs of one log in one recording under /A and /B, each the
single replay's entities, their plotted errors those of their results files."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

import replay.cli
from replay.beliefs import learnt_markdown
from replay.compare.cli import main

chunk = pytest.importorskip("rerun.chunk")
LOG = Path(__file__).resolve().parents[3] / "logs" / "golden" / "rolling.mcap"
ROBOTS = ("robot1", "robot2", "robot3")


def _fused_errors(chunks: list, path: str) -> list[float]:
    out: list[float] = []
    for ch in chunks:
        if ch.entity_path == path and not ch.is_static:
            rb = ch.to_record_batch()
            if "Scalars:scalars" in rb.schema.names:
                out += [v[0] for v in rb.column("Scalars:scalars").to_pylist()]
    return out


def test_both_runs_side_by_side(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    a, b = tmp_path / "mean.json", tmp_path / "track.json"
    for out, fusion in ((a, "mean"), (b, "track")):
        assert replay.cli.main([str(LOG), "--fusion", fusion, "--out", str(out), "-q"]) == 0
    rrd = tmp_path / "side.rrd"
    assert main([str(a), str(b), "--log", str(LOG), "--save", str(rrd), "-q"]) == 0
    reader = chunk.RrdReader(rrd)
    assert [r.application_id for r in reader.recordings()] == ["dual_sight_replay_compare"]
    assert reader.blueprints()
    chunks = list(reader.stream())
    paths = {ch.entity_path for ch in chunks}
    for robot in ("robot1", "robot2", "robot3"):  # the images once, the detections twice
        assert f"/A/robots/{robot}/camera/image" in paths
        assert f"/B/robots/{robot}/camera/image" not in paths
        assert f"/B/robots/{robot}/camera/centre" in paths
    for prefix in ("/A", "/B"):
        assert f"{prefix}/field/fused" in paths and f"{prefix}/plots/error/fused" in paths
    assert "/B/field/track/trail" in paths and "/A/field/track/trail" not in paths  # B tracks
    assert not any(p.startswith("/field") or p.startswith("/robots") for p in paths)
    for prefix, results in (("/A", a), ("/B", b)):
        doc = json.loads(results.read_text())
        expected = [s["error_m"] for s in doc["fused"] if s["error_m"] is not None]
        assert _fused_errors(chunks, f"{prefix}/plots/error/fused") == pytest.approx(
            expected, abs=1e-6)
        # each run's last camera tab: what its replay learnt, as its results file says
        docs = [ch for ch in chunks if ch.entity_path == f"{prefix}/summary/learnt"]
        assert len(docs) == 1 and docs[0].is_static
        text = docs[0].to_record_batch().column("TextDocument:text").to_pylist()[0][0]
        assert text == learnt_markdown(ROBOTS, doc["summary"].get("learnt"))


def test_the_log_must_be_the_results_log(tmp_path: Path,
                                         capsys: pytest.CaptureFixture[str]) -> None:
    a = tmp_path / "a.json"
    assert replay.cli.main([str(LOG), "--out", str(a), "-q"]) == 0
    capsys.readouterr()  # the replay's own warning
    other = LOG.with_name("scenario1.mcap")
    assert main([str(a), str(a), "--log", str(other), "--save", str(tmp_path / "x.rrd"),
                 "-q"]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "scenario1.mcap" in err
    assert not (tmp_path / "x.rrd").exists()
    assert main([str(a), str(a), "--save", str(tmp_path / "x.rrd")]) == 2


def test_an_rrd_whose_writer_stopped_at_the_end_is_not_kept(
        tmp_path: Path, capsys: pytest.CaptureFixture[str],
        monkeypatch: pytest.MonkeyPatch) -> None:
    """A Rerun writer stopped by a full disk or a file-size limit while closing says
    nothing (its flush and disconnect return): the .rrd lacks its footer, and was kept."""
    import rerun as rr

    a = tmp_path / "a.json"
    assert replay.cli.main([str(LOG), "--out", str(a), "-q"]) == 0
    out = tmp_path / "out"
    out.mkdir()
    disconnect = rr.RecordingStream.disconnect

    def cut_short(self: rr.RecordingStream) -> None:
        disconnect(self)
        for f in out.iterdir():  # the last writes lost, as a full disk loses them
            f.write_bytes(f.read_bytes()[: f.stat().st_size // 2])

    monkeypatch.setattr(rr.RecordingStream, "disconnect", cut_short)
    capsys.readouterr()
    rrd = out / "c.rrd"
    assert main([str(a), str(a), "--log", str(LOG), "--save", str(rrd), "-q"]) == 1
    err = capsys.readouterr().err
    assert err.startswith(f"dsp-compare: error: {rrd}: cannot write: the Rerun file writer "
                          "stopped after ") and err.count("\n") == 1, err
    assert list(out.iterdir()) == []
