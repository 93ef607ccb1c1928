"""A batch of the golden logs on a real two-node Ray cluster on this machine (a head and one
worker node, 1 CPU each, started with ``ray.cluster_utils.Cluster``): the same bytes as the
serial run, tasks on both nodes, and a worker node killed mid-batch retried by Ray with the
same results.

Ray can be initialised once per process, so this module shuts down the session's local
instance (``ray_local``, used by tests/replay/batch, which run before it) and connects to its
own cluster; the code under test finds Ray initialised and uses it as it is."""

from __future__ import annotations

import logging
import sys
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

import replay.cli
from replay.batch import LogRow, LogTask, replay_log
from replay.options import ReplayOptions
from replay.parallel import Outcome, Workers, map_tasks

ray = pytest.importorskip(
    "ray", reason="Ray is not installed (pip install -e '.[ray]'; the test extra has it)")
cluster_utils = pytest.importorskip("ray.cluster_utils", reason="this Ray has no cluster_utils")

GOLDEN = Path(__file__).resolve().parents[3] / "logs" / "golden"
LOGS = sorted(GOLDEN.glob("scenario*.mcap"))
NODE_ARGS: dict[str, Any] = {"num_cpus": 1, "object_store_memory": 100 * 1024 * 1024}


@pytest.fixture(scope="module")
def cluster() -> Iterator[Any]:
    if ray.is_initialized():
        ray.shutdown()
    c = cluster_utils.Cluster(initialize_head=True, head_node_args=dict(NODE_ARGS))
    try:
        c.add_node(**NODE_ARGS)
        c.wait_for_nodes()
        ray.init(address=c.address, logging_level=logging.ERROR, log_to_driver=False)
        # workers are pickled by value: Ray's workers cannot import this test module
        ray.cloudpickle.register_pickle_by_value(sys.modules[__name__])
        yield c
    finally:
        ray.shutdown()
        c.shutdown()


def on_node(args: tuple[LogTask, Path | None]) -> tuple[str, LogRow]:
    """Replay one log in a Ray task; the node it ran on with its row. With a marker folder,
    each attempt leaves a file there naming its log and node, and with a ``hold`` file there
    it lasts a second longer."""
    task, marks = args
    node = ray.get_runtime_context().get_node_id()
    if marks is not None:
        (marks / f"{task.log.stem}.{node}").touch()
        if marks.joinpath("hold").exists():
            time.sleep(1.0)
    return node, replay_log(task)


def tasks(marks: Path | None = None) -> list[tuple[LogTask, Path | None]]:
    return [(LogTask(log, ReplayOptions()), marks) for log in LOGS]


@pytest.fixture(scope="module")
def serial_rows() -> list[LogRow]:
    return [o.unwrap() for o in map_tasks(replay_log, [t for t, _ in tasks()],
                                          Workers(count=1))]


def _files(d: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in sorted(d.iterdir())}


def _batch(out: Path, *flags: str) -> dict[str, bytes]:
    argv = [*map(str, LOGS), "--out-dir", str(out), "--estimates", "-q", *flags]
    assert replay.cli.main(argv) == 0
    return _files(out)


def test_a_batch_on_two_nodes_is_the_serial_bytes_and_uses_both_nodes(
        cluster: Any, serial_rows: list[LogRow], tmp_path: Path) -> None:
    assert len([n for n in ray.nodes() if n["Alive"]]) == 2
    assert _batch(tmp_path / "ray", "--ray") == _batch(tmp_path / "serial", "--workers", "1")
    outcomes = map_tasks(on_node, tasks(), Workers(ray=True))
    assert [o.unwrap()[1] for o in outcomes] == serial_rows
    nodes = {o.unwrap()[0] for o in outcomes}
    assert nodes == {cluster.head_node.node_id, *(n.node_id for n in cluster.worker_nodes)}


def test_a_worker_node_killed_mid_batch_is_retried_with_the_same_results(
        cluster: Any, serial_rows: list[LogRow], tmp_path: Path) -> None:
    worker = next(iter(cluster.worker_nodes))
    (tmp_path / "hold").touch()  # every attempt lasts a second longer: one is in flight

    done: set[str] = set()

    def note(i: int, outcome: Outcome[tuple[str, LogRow]]) -> None:
        done.add(LOGS[i].stem)

    def kill_the_worker_mid_task() -> None:  # once a log has begun there and not ended
        deadline = time.monotonic() + 30
        while time.monotonic() < deadline:
            begun = {p.name.split(".")[0] for p in tmp_path.glob(f"*.{worker.node_id}")}
            if begun - done:
                cluster.remove_node(worker, allow_graceful=False)
                return
            time.sleep(0.02)

    killer = threading.Thread(target=kill_the_worker_mid_task)
    killer.start()
    try:
        outcomes = map_tasks(on_node, tasks(tmp_path), Workers(ray=True), on_done=note)
    finally:
        killer.join()
    assert worker not in cluster.worker_nodes
    assert [o.unwrap()[1] for o in outcomes] == serial_rows
    # a log begun on the killed node ended on the head: Ray re-ran it there
    begun_there = {p.name.split(".")[0] for p in tmp_path.glob(f"*.{worker.node_id}")}
    ended_there = {LOGS[i].stem for i, o in enumerate(outcomes)
                   if o.unwrap()[0] == worker.node_id}
    assert begun_there - ended_there
    assert all(o.unwrap()[0] == cluster.head_node.node_id
               for i, o in enumerate(outcomes) if LOGS[i].stem in begun_there - ended_there)
    cluster.add_node(**NODE_ARGS)  # leave the cluster as the fixture made it
