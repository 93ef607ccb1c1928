"""A recording cut short loses little and is easy to find.

- Chunks close at every whole sim second (and at a size bound), so a SIGKILLed recording
  loses under one sim second: the partial log replays with ``--recover`` up to there.
- The log is written as a visible ``NAME.partial.mcap``; one never replaces an earlier one
  (planted symlinks neither), and the next recording to the same path names it.
"""

from __future__ import annotations

import signal
import subprocess
import sys
import textwrap
from collections.abc import Callable
from io import BytesIO
from pathlib import Path
from typing import Any

import pytest
from mcap.reader import make_reader

from recorder.cli import main as record_main
from recorder.record import RecordingInterrupted, RecordOptions, partial_logs, record
from recorder.writer import LogWriter
from replay.log import LogReader

NS = 1_000_000_000

# records rolling with one robot at 4 Hz; after writing the image stamped KILL_AT_NS it
# prints the stamp and sleeps, so the test knows exactly how far the recording got
CHILD = textwrap.dedent("""
    import sys, time
    from recorder import writer

    kill_at = int(sys.argv[2])
    real = writer.LogWriter.write_image

    def write_image(self, robot, t_ns, data, fmt):
        real(self, robot, t_ns, data, fmt)
        if t_ns >= kill_at:
            print(t_ns, flush=True)
            time.sleep(600)

    writer.LogWriter.write_image = write_image
    from recorder.cli import main
    sys.exit(main([sys.argv[1], "--duration", "4", "--rate", "4", "--robot-count", "1",
                   "--face-px", "256", "--no-progress"]))
""")


def test_chunks_close_at_every_sim_second() -> None:
    buf = BytesIO()
    with LogWriter(buf) as w:
        for k in range(0, 36):  # 0 .. 3.5 s every 0.1 s
            w.write_pose("/robot1/pose", k * NS // 10, 0.0, 0.0, 0.0, 0.0)
    buf.seek(0)
    chunks = [(i.message_start_time, i.message_end_time)
              for i in make_reader(buf).get_summary().chunk_indexes]  # type: ignore[union-attr]
    assert chunks == [(0, 900_000_000), (NS, 1_900_000_000), (2 * NS, 2_900_000_000),
                      (3 * NS, 3_500_000_000)]
    assert w.chunks_closed == 3  # the last one closes with finish()


def test_a_sigkilled_recording_loses_under_one_sim_second(tmp_path: Path) -> None:
    out = tmp_path / "rolling.mcap"
    kill_at_ns = 2_750_000_000
    with subprocess.Popen([sys.executable, "-c", CHILD, str(out), str(kill_at_ns)],
                          stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True) as child:
        try:
            assert child.stdout is not None
            line = child.stdout.readline()  # blocks until the child reached kill_at
        finally:
            child.send_signal(signal.SIGKILL)
            child.wait(timeout=30)
    assert line.strip() == str(kill_at_ns)
    assert child.returncode == -signal.SIGKILL
    partial = tmp_path / "rolling.partial.mcap"  # visible, beside the output
    assert not out.exists() and [p.name for p in tmp_path.iterdir()] == [partial.name]
    with LogReader(partial, recover=True) as log:
        assert log.info.robots == ("robot1",) and log.info.scenario is not None
        stamps = [m.stamp_ns for m in log.messages()]
    # everything up to the last whole sim second is there; the chunk in progress is lost
    assert max(stamps) == 2 * NS - NS // 8
    lost_ns = kill_at_ns - max(stamps)
    assert lost_ns <= NS
    # the next recording to the same path names the partial log and keeps it
    code = record_main([str(out), "--frames", "1", "--face-px", "256", "--no-progress", "-q"])
    assert code == 0 and partial.exists() and out.exists()


def test_the_next_recording_names_earlier_partial_logs(tmp_path: Path,
                                                       capsys: pytest.CaptureFixture[str]
                                                       ) -> None:
    out = tmp_path / "scenario1.mcap"
    (tmp_path / "scenario1.partial.mcap").write_bytes(b"\x89MCAP0\r\n")
    (tmp_path / "scenario1.partial-2.mcap").write_bytes(b"\x89MCAP0\r\n")
    assert partial_logs(out) == [tmp_path / "scenario1.partial.mcap",
                                 tmp_path / "scenario1.partial-2.mcap"]
    code = record_main([str(out), "--frames", "1", "--face-px", "256", "--no-progress", "-q",
                        "--seed", "-3"])  # refused: the note comes only when work starts
    assert code == 2 and "note" not in capsys.readouterr().err
    assert record_main([str(out), "--frames", "1", "--face-px", "256", "--no-progress",
                        "-q"]) == 0
    err = capsys.readouterr().err.splitlines()
    assert err == [f"dsp-record: note: 2 logs are left in {tmp_path} from earlier recordings "
                   "to scenario1.mcap that were interrupted or killed: scenario1.partial.mcap, "
                   "scenario1.partial-2.mcap (kept; 'dsp-replay --recover FILE' replays one)"]
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "scenario1.mcap", "scenario1.partial-2.mcap", "scenario1.partial.mcap"]
    for k in range(3, 40):  # however many, one line
        (tmp_path / f"scenario1.partial-{k}.mcap").write_bytes(b"\x89MCAP0\r\n")
    assert record_main([str(out), "--frames", "1", "--face-px", "256", "--no-progress", "-q",
                        "--force"]) == 0
    err = capsys.readouterr().err.splitlines()
    assert err == [f"dsp-record: note: 39 logs are left in {tmp_path} from earlier recordings "
                   "to scenario1.mcap that were interrupted or killed: scenario1.partial.mcap, "
                   "scenario1.partial-2.mcap, scenario1.partial-3.mcap and 36 more (kept; "
                   "'dsp-replay --recover FILE' replays one)"]


def test_ctrl_c_never_replaces_an_earlier_partial_or_follows_a_planted_link(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from recorder.omni import OmniRenderer

    real = OmniRenderer.render
    calls = [0]

    def interrupt(self: OmniRenderer, *args: Any, **kwargs: Any) -> Any:
        calls[0] += 1
        if calls[0] == 2:  # the second robot's first image
            raise KeyboardInterrupt
        return real(self, *args, **kwargs)

    monkeypatch.setattr(OmniRenderer, "render", interrupt)
    victim = tmp_path / "victim.txt"
    victim.write_text("precious")
    out = tmp_path / "scenario3.mcap"
    earlier = tmp_path / "scenario3.partial.mcap"
    earlier.write_bytes(b"an earlier partial log")
    (tmp_path / "scenario3.partial-2.mcap").symlink_to(victim)  # planted at the next name
    with pytest.raises(RecordingInterrupted) as info:
        record(out, RecordOptions(frames=2, face_px=256))
    assert info.value.partial_path == tmp_path / "scenario3.partial-3.mcap"
    assert earlier.read_bytes() == b"an earlier partial log"
    assert victim.read_text() == "precious"
    with LogReader(info.value.partial_path) as log:  # finished: readable without --recover
        assert log.info.scenario is not None and log.info.scenario.name == "scenario3"
        assert log.info.robots == ("robot1",)  # the only robot with an image


def test_a_full_disk_is_one_line_naming_the_log(tmp_path: Path,
                                                full_disk: Callable[[int], None],
                                                capsys: pytest.CaptureFixture[str]) -> None:
    full_disk(50_000)
    out = tmp_path / "scenario4.mcap"
    code = record_main([str(out), "--frames", "2", "--face-px", "256", "--no-progress"])
    out_text, err = capsys.readouterr()
    assert code == 1 and out_text == ""
    assert err == f"dsp-record: error: {out}: cannot write: No space left on device\n"
    assert list(tmp_path.iterdir()) == []
