"""replay.log.stamps: a message stamped absurdly far from the rest of the log is dropped;
nothing a real log holds is (another clock, a seam between recordings, a stream in
reverse)."""

from __future__ import annotations

from estimator.constants import NS_PER_S as NS
from replay.log.stamps import AROUND, FAR_NS, StampGate

DAY = 86_400 * NS


def run(items: list[tuple[str, int]]) -> tuple[list[int], list[int]]:
    """(indices passed on, indices dropped) of ``items`` = [(stream, stamp), ...]."""
    dropped: list[int] = []
    gate: StampGate[int] = StampGate(dropped.append)
    passed = list(gate.filter((s, t, i) for i, (s, t) in enumerate(items)))
    return passed, dropped


def log(n: int, start: int = 0, streams: tuple[str, ...] = ("image a", "pose a", "truth"),
        dt: int = NS // 50) -> list[tuple[str, int]]:
    return [(streams[i % len(streams)], start + (i // len(streams)) * dt) for i in range(n)]


def test_a_consistent_log_passes_whole_and_in_order() -> None:
    for start in (0, 1_700_000_000 * NS):  # sim time and Unix epoch stamps
        items = log(300, start)
        assert run(items) == (list(range(300)), [])
    assert run([]) == ([], [])
    assert run(log(3)) == ([0, 1, 2], [])


def test_one_far_stamp_is_dropped_wherever_it_is() -> None:
    """Guards the rule at the start (no stamp before it), in the middle and at the end (no
    stamp after it), ahead and behind."""
    for at in (0, 1, 150, 298, 299):
        for far in (FAR_NS + NS, -(FAR_NS + NS), 1 << 62):
            items = log(300, start=DAY)
            stream, stamp = items[at]
            items[at] = (stream, stamp + far)
            assert run(items) == ([i for i in range(300) if i != at], [at]), (at, far)


def test_the_bound_is_the_bound() -> None:
    items = log(60)
    items[30] = (items[30][0], items[30][1] + FAR_NS)  # at the bound: kept
    items[40] = (items[40][0], items[40][1] + FAR_NS + 1 + NS)
    assert run(items)[1] == [40]


def test_a_seam_between_recordings_a_day_apart_costs_nothing() -> None:
    items = log(200) + log(200, start=DAY)
    assert run(items) == (list(range(400)), [])


def test_a_stream_on_its_own_clock_is_kept() -> None:
    """A pose stream stamped in reverse (or on another clock) is consistent with itself:
    kept for the pairing to judge, though it is far from the majority's stamps."""
    n = 3000
    items: list[tuple[str, int]] = []
    for i in range(n):
        t = i * NS  # a long log: 1 s per step
        items += [("image a", t), ("pose a", (n - i) * NS), ("pose b", (n - i) * NS),
                  ("pose c", (n - i) * NS)]
    assert run(items) == (list(range(4 * n)), [])


def test_a_few_far_stamps_in_a_row_are_dropped() -> None:
    items = log(120, streams=("image a",))
    for i in range(50, 50 + AROUND // 2):
        items[i] = (items[i][0], items[i][1] + 10 * DAY)
    assert run(items)[1] == list(range(50, 50 + AROUND // 2))
