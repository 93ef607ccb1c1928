"""Batch replay (dsp-replay LOG... --out-dir) and dsp-eval on a process pool and on Ray: the
same bytes as the serial path, a bad log reported while the others complete, refusals
before any work, Ctrl-C stopping the workers."""

from __future__ import annotations

import errno
import json
import math
import multiprocessing
import os
import shutil
import socket
import sys
import time
from pathlib import Path
from typing import Any

import pytest
from fake_scenes import FakeRecorder
from synthetic import write_log

import replay.batch.run
import replay.cli
import replay.evaluate.cli
from dsp.errors import EXIT_INPUT, EXIT_OUTPUT_EXISTS, EXIT_USAGE, DspError
from replay.batch import LogTask, collect_logs, replay_log
from replay.options import ReplayOptions
from replay.parallel import Outcome, TaskFailure, Workers, map_tasks

ROBOTS = {"robot1": (-3.0, 0.0, 0.0), "robot2": (2.0, 1.0, math.pi),
          "robot3": (0.0, -4.0, math.pi / 2)}


@pytest.fixture(scope="module")
def logs(tmp_path_factory: pytest.TempPathFactory) -> Path:
    d = tmp_path_factory.mktemp("batch") / "logs"
    d.mkdir()
    for i, ball in enumerate([(0.0, 0.5), (1.0, -1.0), (-1.5, 2.0)]):
        write_log(d / f"run{i}.mcap", robots=ROBOTS, ball=ball, duration_s=0.5)
    (d / "bad.mcap").write_bytes(b"this is no MCAP log")
    (d / "notes.txt").write_text("not a log")
    return d


def files(d: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(d.iterdir())}


def run_batch(logs: Path | list[Path], out: Path, *flags: str) -> int:
    paths = [str(p) for p in (logs if isinstance(logs, list) else [logs])]
    return replay.cli.main([*paths, "--out-dir", str(out), "--estimates", "-q", *flags])


def _record_eval_logs(d: Path, count: int) -> None:
    """The logs dsp-eval would record, made without pybullet (it reuses existing logs)."""
    d.mkdir(parents=True)
    record = FakeRecorder()
    for seed in range(count):
        record(d / f"random-{seed}-ideal.mcap", "random", seed)


def run_eval(d: Path, *flags: str) -> dict[str, bytes]:
    _record_eval_logs(d, 2)
    assert replay.evaluate.cli.main(["--suite", "random", "--count", "2", "--out-dir", str(d),
                                     "-q", *flags]) == 0
    return files(d)


@pytest.fixture(scope="module")
def serial_runs(logs: Path,
                tmp_path_factory: pytest.TempPathFactory) -> dict[str, dict[str, bytes]]:
    """The serial path's outputs (--workers 1): the batch's and dsp-eval's."""
    d = tmp_path_factory.mktemp("serial")
    assert run_batch(logs, d / "batch", "--workers", "1") == EXIT_INPUT  # bad.mcap
    return {"batch": files(d / "batch"), "eval": run_eval(d / "eval", "--workers", "1")}


def test_pool_and_serial_batches_are_the_same_bytes_and_match_single_replays(
        logs: Path, serial_runs: dict[str, dict[str, bytes]], tmp_path: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    assert run_batch(logs, tmp_path / "pool", "--workers", "2") == EXIT_INPUT
    serial = serial_runs["batch"]
    assert serial == files(tmp_path / "pool")
    assert sorted(serial) == sorted([
        "batch-summary.csv", "batch-summary.json", "batch-summary.md",
        *(f"run{i}{ext}" for i in range(3) for ext in (".json", ".estimates.mcap"))])
    single = tmp_path / "single.json"
    assert replay.cli.main([str(logs / "run1.mcap"), "--out", str(single), "-q"]) == 0
    assert single.read_bytes() == serial["run1.json"]
    # the bad log is a row with its one-line error; the others complete; exit 1 at the end
    doc = json.loads(serial["batch-summary.json"])
    assert [r["log"] for r in doc["logs"]] == ["bad.mcap", *(f"run{i}.mcap" for i in range(3))]
    bad = doc["logs"][0]
    assert not bad["ok"]
    assert bad["error"] == f"{logs / 'bad.mcap'}: not an MCAP file (bad magic bytes)"
    assert doc["totals"]["logs"] == 4 and doc["totals"]["failed"] == 1
    run1 = json.loads(serial["run1.json"])["summary"]
    assert doc["logs"][2]["frames"] == run1["frames"]
    assert doc["logs"][2]["fused"]["rmse_m"] == run1["fused"]["rmse_m"]
    assert doc["totals"]["frames"] == sum(r["frames"] for r in doc["logs"])
    # RMSE over all logs from the sums, not the mean of the logs' RMSEs
    robot1 = [json.loads(serial[f"run{i}.json"])["summary"]["robots"]["robot1"]
              for i in range(3)]
    pooled = math.sqrt(sum(r["errors"] * r["rmse_m"] ** 2 for r in robot1)
                       / sum(r["errors"] for r in robot1))
    assert doc["totals"]["robots"]["robot1"]["rmse_m"] == pytest.approx(pooled, abs=1e-6)
    csv_lines = serial["batch-summary.csv"].decode().splitlines()
    assert csv_lines[0].startswith("log,status,frames,steps,fused_steps,detections,robot1_rmse_m")
    assert csv_lines[-1].startswith("total,3/4 ok,")
    err = capsys.readouterr().err.splitlines()
    assert err[-1] == (f"dsp-replay: error: 1 of 4 logs failed (see "
                       f"{tmp_path / 'pool' / 'batch-summary.md'})")
    assert "Traceback" not in "\n".join(err)


def test_same_stem_and_existing_outputs_are_refused_before_any_work(
        logs: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    other = tmp_path / "other"
    other.mkdir()
    shutil.copy(logs / "run0.mcap", other / "run0.mcap")
    out = tmp_path / "out"
    assert run_batch([logs, other], out, "--workers", "1") == EXIT_USAGE
    assert "have the same name 'run0'" in capsys.readouterr().err
    assert not out.exists() or not list(out.iterdir())
    out.mkdir(exist_ok=True)
    (out / "run2.json").write_text("{}")
    assert run_batch([logs / "run0.mcap", logs / "run2.mcap"], out) == EXIT_OUTPUT_EXISTS
    assert sorted(p.name for p in out.iterdir()) == ["run2.json"]
    assert collect_logs([logs]) == [logs / n for n in ("bad.mcap", "run0.mcap", "run1.mcap",
                                                      "run2.mcap")]


@pytest.mark.parametrize(("flags", "message"), [
    (["--workers", "2"], "--workers and --ray replay a batch: give --out-dir DIR"),
    (["--out-dir", "d", "--out", "x.json"], "--out names one file"),
    (["--out-dir", "d", "--out-mcap", "x.mcap"], "--out-mcap names one file"),
    (["--out-dir", "d", "--plot", "x.png"], "--out-csv and --plot name one file"),
    (["--out-dir", "d", "--workers", "0"], "--workers 0: give at least 1"),
    (["--estimates"], "--estimates writes each log's estimates in a batch"),
])
def test_batch_flag_misuse_is_a_usage_error(logs: Path, flags: list[str], message: str,
                                            capsys: pytest.CaptureFixture[str]) -> None:
    assert replay.cli.main([str(logs / "run0.mcap"), *flags]) == EXIT_USAGE
    assert message in capsys.readouterr().err


def test_ray_without_ray_says_how_to_install_it(
        logs: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.setitem(sys.modules, "ray", None)  # import ray -> ImportError
    assert run_batch(logs, tmp_path / "out", "--ray") == EXIT_USAGE
    assert replay.evaluate.cli.main(["--out-dir", str(tmp_path), "--ray"]) == EXIT_USAGE
    err = capsys.readouterr().err.splitlines()
    assert err == ["dsp-replay: error: --ray needs Ray: pip install 'dual-sight[ray]' "
                   "(or pip install -e '.[ray]')",
                   "dsp-eval: error: --ray needs Ray: pip install 'dual-sight[ray]' "
                   "(or pip install -e '.[ray]')"]
    assert not (tmp_path / "out").exists()


def test_a_log_a_worker_cannot_read_names_the_host_and_path(tmp_path: Path) -> None:
    row = replay_log(LogTask(tmp_path / "elsewhere" / "run.mcap", ReplayOptions()))
    assert row.error is not None and not row.ok
    assert row.error.startswith(f"{tmp_path / 'elsewhere' / 'run.mcap'}: cannot read the log "
                                f"on host {socket.gethostname()}")
    assert "shared folder" in row.error


def test_a_log_that_fails_with_an_os_error_is_a_one_line_row(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    """Guards the batch's handling of an OSError (a disk that fails while the log is read):
    the log's row holds the error's one line, as for a bad log, and nothing is printed; it
    is not taken for a bug (a traceback on stderr and an "unexpected OSError" row)."""
    log = tmp_path / "run.mcap"
    log.write_bytes(b"\x89MCAP0\r\n")

    def failing_disk(path: Path, options: ReplayOptions, sinks: Any) -> Any:
        raise OSError(errno.EIO, os.strerror(errno.EIO), str(path))

    monkeypatch.setattr(replay.batch.run, "replay", failing_disk)
    row = replay_log(LogTask(log, ReplayOptions()))
    assert not row.ok
    assert row.error == f"[Errno {errno.EIO}] {os.strerror(errno.EIO)}: '{log}'"
    assert capsys.readouterr().err == ""


def test_a_task_error_comes_back_as_its_message_and_exit_code() -> None:
    # InputNotFoundError(path) would not survive pickling as an exception; as data it does
    outcomes = map_tasks(collect_logs, [[Path("/nowhere/a.mcap")], [Path("/")]],
                         Workers(count=2))
    first = outcomes[0].failure
    assert first is not None
    assert (first.text, first.exit_code) == ("/nowhere/a.mcap: no such file (check the path)", 1)
    with pytest.raises(DspError, match=r"^/nowhere/a.mcap: no such file") as raised:
        outcomes[0].unwrap()
    assert raised.value.exit_code == 1
    # a failure on another machine names it
    assert TaskFailure("x.mcap: bad", host="node7").text == "x.mcap: bad (on host node7)"


def _interrupt(i: int, outcome: Outcome[Any]) -> None:
    raise KeyboardInterrupt


def test_ctrl_c_stops_the_pool_workers_at_once() -> None:
    t0 = time.perf_counter()
    with pytest.raises(KeyboardInterrupt):
        map_tasks(time.sleep, [0.0, 60.0, 60.0], Workers(count=2), on_done=_interrupt)
    assert time.perf_counter() - t0 < 30
    assert not [p for p in multiprocessing.active_children() if p.is_alive()]


def test_dsp_eval_tables_are_the_same_bytes_whatever_the_workers(
        serial_runs: dict[str, dict[str, bytes]], tmp_path: Path) -> None:
    assert run_eval(tmp_path / "eval", "--workers", "2") == serial_runs["eval"]
    doc = json.loads(serial_runs["eval"]["random-ideal-2-seed0.json"])
    assert doc["dual_sight_scenes"] == 1  # seed 1 has one robot within 9 m


def test_ray_batch_and_eval_are_the_same_bytes_as_serial(
        ray_local: Any, serial_runs: dict[str, dict[str, bytes]], logs: Path,
        tmp_path: Path) -> None:
    assert run_batch(logs, tmp_path / "ray", "--ray") == EXIT_INPUT
    assert files(tmp_path / "ray") == serial_runs["batch"]
    assert run_eval(tmp_path / "eval", "--ray") == serial_runs["eval"]
    # Ctrl-C cancels the Ray tasks that are still running
    t0 = time.perf_counter()
    with pytest.raises(KeyboardInterrupt):
        map_tasks(time.sleep, [0.0, 60.0], Workers(ray=True), on_done=_interrupt)
    assert time.perf_counter() - t0 < 30
    assert ray_local.is_initialized()  # the session's instance is left running


def test_logs_may_follow_the_options_and_pool_workers_replay_on_one_thread(
        logs: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    seen: list[int | None] = []
    real = replay.batch.run.replay_log

    def spy(task: LogTask) -> Any:
        seen.append(task.options.threads)
        return real(task)

    monkeypatch.setattr(replay.batch.run, "map_tasks",
                        lambda fn, tasks, workers, on_done: [
                            on_done(i, Outcome(spy(t), None)) for i, t in enumerate(tasks)])
    out = tmp_path / "out"
    # logs after the options, as a shell glob often puts them
    assert replay.cli.main([str(logs / "run0.mcap"), "--out-dir", str(out), "-q",
                            "--workers", "2", str(logs / "run1.mcap")]) == 0
    assert sorted(p.name for p in out.glob("run*.json")) == ["run0.json", "run1.json"]
    assert seen == [1, 1]  # the workers already use the cores: no thread pool per log


def test_an_out_dir_that_cannot_be_made_is_the_project_s_one_line(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    """--out-dir under a read-only folder printed a raw "[Errno 30] ..." line."""
    log = tmp_path / "run.mcap"
    write_log(log, duration_s=0.2)
    out = tmp_path / "ro" / "results"

    def read_only(self: Path, *args: Any, **kwargs: Any) -> None:
        raise OSError(errno.EROFS, os.strerror(errno.EROFS), str(self))

    monkeypatch.setattr(Path, "mkdir", read_only)
    assert replay.cli.main([str(log), "--out-dir", str(out), "-q"]) == EXIT_INPUT
    err = capsys.readouterr().err
    assert err == f"dsp-replay: error: {out}: cannot write: {os.strerror(errno.EROFS)}\n"
