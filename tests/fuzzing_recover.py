"""Fuzz cases that say what they must give, besides no traceback and no hang.

- ``salvage``: a seed log cut at a random byte inside a chunk (a message, when it has no
  chunk), replayed with ``--recover``:
  the frames must be exactly the images an independent reader finds before the cut
  (:func:`fuzzing_logs.messages_before_cut`), or, when there is none, a one-line error;
- ``far_stamps``: one image stamped far in the future (skipped as a bad message: at most
  one fused step lost), or every robot's poses in reverse stamp order (the frames whose
  poses arrive within the look-ahead are fused).

Each mutation returns an :class:`Expect`; :func:`judge` turns a run into ``ok`` (met) or
``lost`` (not met).
"""

from __future__ import annotations

import io
import random
import struct
from dataclasses import dataclass
from typing import Any

from fuzzing_logs import (
    RECORDER_LAYOUT,
    messages_before_cut,
    raw_from_reader,
    records,
    write_raw,
)
from mcap.reader import make_reader

from dsp import contract
from estimator.constants import NS_PER_S as NS

__all__ = ["Expect", "judge", "m_far_stamps", "m_salvage"]


@dataclass(frozen=True)
class Expect:
    """What a case must give."""

    args: tuple[str, ...] = ()
    """More ``dsp-replay`` arguments."""
    frames: frozenset[tuple[str, int]] | None = None
    """Exactly these (robot, stamp) frames replayed..."""
    error: bool = False
    """... or, True: a one-line error (no frame has a pose to pair with)."""
    fused_lost: int | None = None
    """At most this many fused steps fewer than the seed's."""
    min_fused: int | None = None
    """At least this many fused steps."""


def _stamp(data: bytes) -> int:
    sec, nsec = struct.unpack_from("<iI", data, 4)
    return int(sec) * NS + int(nsec)


def _robot(topic: str) -> str | None:
    """The robot whose images ``topic`` carries, if it does."""
    names = contract.robot_names_in([topic], contract.IMAGE_TOPIC)
    return names[0] if names else None


def _pose_robot(topic: str) -> str | None:
    names = contract.robot_names_in([topic], contract.POSE_TOPIC)
    return names[0] if names else None


def _timing() -> Any:
    from replay.options import ReplayOptions

    return ReplayOptions().timing()


def m_salvage(seed: bytes, rng: random.Random) -> tuple[bytes, str, list[int], Expect]:
    # inside a chunk; in an unchunked log, inside a message
    inside = [r for r in records(seed) if r.op == 0x06] or [
        r for r in records(seed) if r.op == 0x05]
    r = rng.choice(inside)
    cut = rng.randrange(r.offset + 9, r.offset + 9 + r.length)
    messages, topics = messages_before_cut(seed, cut)
    # a robot whose pose channel the cut left out is left out (the report says so)
    with_poses = set(contract.robot_names_in(set(topics.values()), contract.POSE_TOPIC))
    frames = frozenset((robot, _stamp(m.data)) for m in messages
                       if (robot := _robot(topics[m.channel_id])) in with_poses)
    poses = {(robot, _stamp(m.data)) for m in messages
             if (robot := _pose_robot(topics[m.channel_id])) is not None}
    tolerance = _timing().tolerance_ns
    paired = [f for f in frames
              if any(r == f[0] and abs(t - f[1]) <= tolerance for r, t in poses)]
    return (seed[:cut], f"cut at {cut}, in the record at {r.offset}: {len(frames)} frames "
            "before it", [cut], Expect(args=("--recover",), frames=frames, error=not paired))


def m_far_stamps(seed: bytes, rng: random.Random) -> tuple[bytes, str, list[int], Expect]:
    raw = raw_from_reader(make_reader(io.BytesIO(seed)))
    topics = {cid: c[0] for cid, c in raw.channels.items()}
    msgs = raw.messages
    if rng.random() < 0.5:
        images = [i for i, m in enumerate(msgs) if _robot(topics[m[0]]) is not None]
        k = rng.choice(images)
        cid, seq, lt, pt, data = msgs[k]
        ahead = rng.choice((1 << 30, 10**6, 3600)) * NS
        msgs[k] = (cid, seq, lt, pt, _restamp(data, _stamp(data) + ahead))
        return (write_raw(raw, **RECORDER_LAYOUT), f"image {k} stamped {ahead // NS} s ahead",
                [], Expect(fused_lost=1))
    arrival: dict[str, list[tuple[int, int]]] = {}  # robot -> (stamp, log time) of poses
    for cid, topic in topics.items():
        robot = _pose_robot(topic)
        if robot is None:
            continue
        idx = [i for i, m in enumerate(msgs) if m[0] == cid]
        datas = [msgs[i][4] for i in idx][::-1]
        for i, data in zip(idx, datas, strict=True):
            c, s, lt, pt, _ = msgs[i]
            msgs[i] = (c, s, lt, pt, data)
            arrival.setdefault(robot, []).append((_stamp(data), lt))
    return (write_raw(raw, **RECORDER_LAYOUT), "every robot's poses in reverse stamp order",
            [], Expect(args=("--fusion", "mean"),  # a step fuses when any frame has a pose
                       min_fused=_usable_steps(msgs, topics, arrival)))


def _usable_steps(msgs: list[tuple[int, int, int, int, bytes]], topics: dict[int, str],
                  arrival: dict[str, list[tuple[int, int]]]) -> int:
    """Image stamps at which every robot's image has a pose within the tolerance that
    arrives within the look-ahead, less one (the step at the seam may miss it)."""
    t = _timing()
    by_stamp: dict[int, list[bool]] = {}
    for cid, _seq, _lt, _pt, data in msgs:
        robot = _robot(topics[cid])
        if robot is None:
            continue
        at = _stamp(data)
        by_stamp.setdefault(at, []).append(any(
            abs(s - at) <= t.tolerance_ns and lt <= at + t.lookahead_ns
            for s, lt in arrival.get(robot, [])))
    return max(0, sum(all(v) for v in by_stamp.values()) - 1)


def _restamp(data: bytes, stamp_ns: int) -> bytes:
    return data[:4] + struct.pack("<iI", stamp_ns // NS, stamp_ns % NS) + data[12:]


def judge(expect: Expect, code: int | None, error_lines: int,
          results: dict[str, Any] | None, seed_fused: int | None) -> bool:
    """Whether a run gave what ``expect`` says."""
    if expect.frames is not None:
        if expect.error:
            return code not in (0, None) and error_lines == 1
        got = {(f["robot"], f["stamp_ns"]) for f in (results or {}).get("frames", [])}
        return code == 0 and got == expect.frames
    if code != 0 or results is None:
        return False
    fused = int(results["summary"]["fused_steps"])
    if expect.fused_lost is not None and seed_fused is not None:
        return fused >= seed_fused - expect.fused_lost
    return expect.min_fused is None or fused >= expect.min_fused
