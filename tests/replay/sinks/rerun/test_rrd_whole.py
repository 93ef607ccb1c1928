"""dsp-replay --save keeps no .rrd cut short: a Rerun writer that a full disk or a file-size
limit stops while the recording closes may say nothing (its flush and disconnect return),
and the file then lacks its footer; it is checked before it is renamed into place."""

from __future__ import annotations

from pathlib import Path

import pytest
import rerun as rr
from synthetic import write_log

from replay.cli import main


def test_an_rrd_cut_short_at_the_end_is_one_line_and_not_kept(
        tmp_path: Path, capsys: pytest.CaptureFixture[str],
        monkeypatch: pytest.MonkeyPatch) -> None:
    log = write_log(tmp_path / "in.mcap", duration_s=0.3).path
    out = tmp_path / "out"
    out.mkdir()
    disconnect = rr.RecordingStream.disconnect

    def cut_short(self: rr.RecordingStream) -> None:
        disconnect(self)
        for f in out.iterdir():  # the last writes lost, as a full disk loses them
            f.write_bytes(f.read_bytes()[: f.stat().st_size // 2])

    rrd = out / "r.rrd"
    assert main([str(log), "--save", str(rrd), "-q", "--no-progress"]) == 0  # whole: kept
    rrd.unlink()
    monkeypatch.setattr(rr.RecordingStream, "disconnect", cut_short)
    capsys.readouterr()
    assert main([str(log), "--save", str(rrd), "-q", "--no-progress"]) == 1
    err = capsys.readouterr().err
    assert err.startswith(f"dsp-replay: error: {rrd}: cannot write: the Rerun file writer "
                          "stopped after ") and err.count("\n") == 1, err
    assert list(out.iterdir()) == []
