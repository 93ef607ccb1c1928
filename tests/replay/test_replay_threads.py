"""Pipelined replay (replay.ahead): decoding and detection run ahead in threads, and the
outputs are the same bytes whatever the thread count."""

from __future__ import annotations

import random
import threading
import time
from pathlib import Path

import pytest
from synthetic import write_log

from dsp.errors import UsageError
from replay import ReplayOptions, replay
from replay.ahead import Ahead, Decoded, decode_and_detect
from replay.cli import main
from replay.estimation import Detected
from replay.log import ImageMessage
from replay.records import FrameStatus

ROOT = Path(__file__).resolve().parents[2]
GOLDEN = ROOT / "logs" / "golden"


def _outputs(log: Path, out: Path, **kw: object) -> tuple[bytes, bytes]:
    out.mkdir()
    replay(log, ReplayOptions(out=out / "r.json", out_mcap=out / "e.mcap", progress=False,
                              **kw))  # type: ignore[arg-type]
    return (out / "r.json").read_bytes(), (out / "e.mcap").read_bytes()


@pytest.mark.parametrize("scene", ["rolling", "scenario3"])
def test_golden_outputs_are_byte_identical_for_1_2_4_threads(scene: str, tmp_path: Path) -> None:
    log = GOLDEN / f"{scene}.mcap"
    runs = [_outputs(log, tmp_path / f"t{n}", method="paper", fusion="mean", threads=n)
            for n in (1, 2, 4)]
    assert runs[1] == runs[0] and runs[2] == runs[0]
    expected = (GOLDEN / f"{scene}.paper-mean.json").read_bytes()
    assert runs[0][0] == expected


def test_synthetic_jpeg_log_with_bad_images_and_a_time_range(tmp_path: Path) -> None:
    log = tmp_path / "j.mcap"
    write_log(log, duration_s=1.0, image_encoding="jpeg", corrupt_images=(2, 7, 8))
    kw = {"start_s": 0.15, "end_s": 0.85}
    runs = [_outputs(log, tmp_path / f"t{n}", threads=n, **kw) for n in (1, 2, 3)]
    assert runs[1] == runs[0] and runs[2] == runs[0]
    assert b'"bad_image"' in runs[0][0]


def _message(i: int) -> ImageMessage:
    return ImageMessage(robot=f"r{i % 3}", stamp_ns=i, log_time_ns=i, fmt="png",
                        data=b"not a png", encoding="", width_px=0, height_px=0, step=0)


def test_results_come_in_push_order_with_at_most_depth_in_flight() -> None:
    lock = threading.Lock()
    running = peak = 0
    rng = random.Random(0)

    def work(msg: ImageMessage) -> Decoded:
        nonlocal running, peak
        with lock:
            running += 1
            peak = max(peak, running)
        time.sleep(rng.uniform(0, 0.003))  # finish out of order
        with lock:
            running -= 1
        return Decoded(None, Detected(None), float(msg.stamp_ns))

    msgs = [_message(i) for i in range(60)]
    with Ahead(3, depth=4, work=work) as ahead:
        taken = []
        for i, msg in enumerate(msgs):
            ahead.push(msg)
            assert ahead.in_flight <= 4
            if i % 3 == 2:  # the runner takes images a little behind the reading
                for m in msgs[i - 2:i + 1]:
                    taken.append(ahead.take(m).seconds)
    assert taken == [float(i) for i in range(60)]
    assert 1 < peak <= 3


def test_one_thread_works_in_the_caller_and_unpushed_images_work_too() -> None:
    callers = []

    def work(msg: ImageMessage) -> Decoded:
        callers.append(threading.current_thread())
        return Decoded(None, Detected(None), 0.0)

    with Ahead(1, work=work) as serial:
        serial.push(_message(0))
        assert serial.in_flight == 0
        serial.take(_message(0))
    assert callers == [threading.current_thread()]
    with Ahead(2) as ahead:  # the real work; a message that was never pushed
        decoded = ahead.take(_message(5))
    assert decoded.image is None
    assert decoded.detected == decode_and_detect(_message(5)).detected == Detected(
        FrameStatus.BAD_IMAGE)


def test_threads_must_be_positive(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(UsageError, match="--threads 0"):
        ReplayOptions(threads=0)
    assert ReplayOptions().thread_count >= 1
    assert "threads" not in ReplayOptions(threads=3).as_dict()  # not in the recording id
    log = tmp_path / "s.mcap"
    write_log(log, duration_s=0.2)
    assert main([str(log), "--threads", "0"]) == 2
    assert "--threads 0" in capsys.readouterr().err
    assert main([str(log), "--threads", "2", "--quiet"]) == 0
