"""What ``--recover`` could not read, in words a user can act on: the chunks and messages
lost and the sim-time ranges they held, and what was salvaged from the decodable prefix of a
cut or damaged chunk. An undamaged log loses nothing."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

from dsp.jsonio import Json
from estimator.constants import NS_PER_S
from replay.log.mcap_scan import Damage

__all__ = ["RecoveryLoss", "SalvagedChunk"]


@dataclass(frozen=True)
class SalvagedChunk:
    """The whole records kept from the decodable prefix of a cut or damaged chunk."""

    offset: int
    """Where the chunk record starts in the file."""
    messages: int
    start_ns: int | None
    end_ns: int | None
    """The log-time range of the messages kept (None: none kept)."""
    decoded_bytes: int
    uncompressed_bytes: int
    """Of the chunk's records, the bytes decoded and the size its header declares."""
    reason: str
    """Why the rest of the chunk is lost."""

    def to_dict(self) -> dict[str, Json]:
        """A results file's ``log.recovered.salvaged`` entry."""
        return {"offset": self.offset, "messages": self.messages,
                "start_s": None if self.start_ns is None else self.start_ns / NS_PER_S,
                "end_s": None if self.end_ns is None else self.end_ns / NS_PER_S,
                "decoded_bytes": self.decoded_bytes,
                "uncompressed_bytes": self.uncompressed_bytes, "reason": self.reason}

    def describe(self) -> str:
        when = "" if self.start_ns is None or self.end_ns is None else (
            f", sim time {self.start_ns / NS_PER_S:.3f}..{self.end_ns / NS_PER_S:.3f} s")
        return (f"  salvaged from the chunk at byte {self.offset}: {self.messages} "
                f"message(s){when}, from the first {self.decoded_bytes} of its "
                f"{self.uncompressed_bytes} bytes; the rest is lost: {self.reason}")


@dataclass
class RecoveryLoss:
    """What ``recover=True`` could not read."""

    file_bytes: int = 0
    read_bytes: int = 0
    bad_chunks: int = 0
    truncated: bool = False
    detail: str = ""
    spans: list[Damage] = field(default_factory=list)
    problems: list[str] = field(default_factory=list)
    """Integrity problems that cost no data (a damaged summary, a data CRC mismatch)."""
    readable_end_ns: int | None = None
    """The last sim time read before the log was cut."""
    salvaged: list[SalvagedChunk] = field(default_factory=list)
    """What was kept of the chunks in ``spans`` that are cut or damaged."""

    @property
    def lost_bytes(self) -> int:
        return self.file_bytes - self.read_bytes

    @property
    def lost_messages(self) -> int | None:
        """Messages known lost (None when some span's count is unknown)."""
        counts = [s.messages for s in self.spans]
        return None if any(c is None for c in counts) else sum(c or 0 for c in counts)

    @property
    def nothing_lost(self) -> bool:
        return not self.spans and not self.problems

    @classmethod
    def from_damage(cls, file_bytes: int, damage: list[Damage], problems: list[str],
                    readable_end_ns: int | None,
                    salvaged: list[SalvagedChunk] | None = None) -> RecoveryLoss:
        spans = []
        for d in damage:
            start = d.start_ns
            if start is None and d.offset + d.length >= file_bytes:
                start = readable_end_ns  # cut short: everything after the last read time
            spans.append(dataclasses.replace(d, start_ns=start))
        truncated = any(d.offset + d.length >= file_bytes for d in damage)
        bad_chunks = sum(d.chunks for d in damage)
        return cls(
            file_bytes=file_bytes,
            read_bytes=file_bytes - sum(d.length for d in damage),
            bad_chunks=bad_chunks,
            truncated=truncated,
            detail=damage[0].reason if damage else (problems[0] if problems else ""),
            spans=spans,
            problems=list(problems),
            readable_end_ns=readable_end_ns,
            salvaged=list(salvaged or []),
        )

    def to_dict(self) -> dict[str, Json]:
        """The results file's ``log.recovered``."""
        return {"truncated": self.truncated, "lost_bytes": self.lost_bytes,
                "file_bytes": self.file_bytes, "bad_chunks": self.bad_chunks,
                "lost_messages": self.lost_messages,
                "lost": [s.to_dict() for s in self.spans], "problems": list(self.problems),
                "salvaged": [s.to_dict() for s in self.salvaged]}

    def describe(self) -> list[str]:
        """Lines for a terminal: nothing lost, or each lost stretch with the sim times it
        held."""
        if self.nothing_lost:
            return ["recovered: nothing lost (the log is intact)"]
        lost = self.lost_messages
        lines = [f"recovered: lost {self.lost_bytes} of {self.file_bytes} bytes "
                 f"in {len(self.spans)} stretch(es): {self.bad_chunks} chunk(s), "
                 f"{'an unknown number of' if lost is None else lost} message(s)"
                 f"{'; the log is cut short' if self.truncated else ''}"]
        if self.salvaged:
            lines[0] += (f"; {sum(s.messages for s in self.salvaged)} message(s) salvaged "
                         f"from {len(self.salvaged)} of those chunk(s)")
        for d in self.spans:
            lines.append(f"  bytes {d.offset}..{d.offset + d.length}: {_time_range(d)}: "
                         f"{d.reason}")
        lines.extend(s.describe() for s in self.salvaged)
        lines.extend(f"  problem: {p}" for p in self.problems)
        return lines


def _time_range(d: Damage) -> str:
    start = None if d.start_ns is None else d.start_ns / NS_PER_S
    end = None if d.end_ns is None else d.end_ns / NS_PER_S
    if start is not None and end is not None and end >= start:
        return f"sim time {start:.3f}..{end:.3f} s lost"
    if start is not None:
        return f"sim time from {start:.3f} s on lost"
    return "sim time unknown"
