"""Hostile logs, made from golden ones, and one in-process replay of each, classified.

Shared by the bounded run in the test suite (``tests/replay/test_fuzz.py``) and the long
campaign (``scripts/fuzz_replay.py``). A case is a seeded mutation of a seed log:

- byte level: bit flips anywhere or in chunk data, truncation at or near every kind of
  record boundary, hostile length fields (2^40..2^64-1), damaged CRCs, summary edits with
  the summary CRC recomputed (duplicated / removed chunk index entries, a channel topic
  changed), a zstd chunk declaring 1 GiB;
- rewritten (valid MCAP, CRCs right): image bombs (PNG/JPEG/BMP headers declaring huge
  sizes), empty images, NaN/inf/1e308 poses and zero quaternions, stamp disorder, a damaged
  schema text, float64 poses re-declared float32.

:func:`run_case` replays one case through ``dsp-replay``'s ``main`` in this process under a
timer and measures the peak RSS (Linux ``clear_refs``). Outcomes: ``error`` (one line,
non-zero exit), ``ok`` (exit 0, results as the seed's), ``changed`` (exit 0, results differ,
with a warning line), ``silent`` (exit 0, results differ, no warning, and a CRC or the
summary covers the changed bytes), ``uncovered`` (the same where nothing covers them),
``traceback`` (any exception that is not the project's), ``hang`` (timer fired).
"""

from __future__ import annotations

import contextlib
import gc
import io
import json
import random
import signal
import struct
import time
import zlib
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mcap.reader import make_reader
from mcap.writer import CompressionType, Writer

ROOT = Path(__file__).resolve().parents[1]
GOLDEN = ROOT / "logs" / "golden"
MAGIC = b"\x89MCAP0\r\n"
GIB = 1 << 30


# --- reading and rewriting a (trusted) log ---------------------------------------------------
@dataclass
class Raw:
    schemas: dict[int, tuple[str, str, bytes]]
    channels: dict[int, tuple[str, int, str, dict[str, str]]]
    messages: list[tuple[int, int, int, int, bytes]]
    """(channel id, sequence, log time, publish time, data)"""
    metadata: list[tuple[str, dict[str, str]]]


def read_raw(path: Path) -> Raw:
    with path.open("rb") as f:
        return _raw_from_reader(make_reader(f))


def write_raw(raw: Raw, **options: Any) -> bytes:
    """``raw`` as an MCAP file written by the mcap library with ``options`` (its Writer's
    keyword arguments: chunk_size, compression, use_chunking, use_statistics, ...)."""
    out = io.BytesIO()
    w = Writer(out, **options)
    w.start(profile="ros2", library="dsp-fuzz")
    sid_map = {sid: w.register_schema(name, enc, data)
               for sid, (name, enc, data) in sorted(raw.schemas.items())}
    cid_map = {cid: w.register_channel(topic, enc, sid_map[sid], meta)
               for cid, (topic, sid, enc, meta) in sorted(raw.channels.items())}
    for name, data in raw.metadata:
        w.add_metadata(name, data)
    for cid, seq, log_time, publish_time, data in raw.messages:
        w.add_message(cid_map[cid], log_time, data, publish_time, seq)
    w.finish()
    return out.getvalue()


RECORDER_LAYOUT: dict[str, Any] = {"compression": CompressionType.ZSTD,
                                   "chunk_size": 4 * 1024 * 1024}


def seed_log(scene: str = "scenario2", until_s: float = 0.3, **options: Any) -> bytes:
    """A golden log's first ``until_s`` seconds, rewritten (recorder's layout by default)."""
    raw = read_raw(GOLDEN / f"{scene}.mcap")
    raw.messages = [m for m in raw.messages if m[2] < until_s * 1e9]
    return write_raw(raw, **{**RECORDER_LAYOUT, **options})


# --- the file's records ----------------------------------------------------------------------
@dataclass(frozen=True)
class Rec:
    offset: int
    op: int
    length: int
    region: str
    """data / summary / footer"""


def records(data: bytes) -> list[Rec]:
    """The records of a well-formed file, in order (the summary's included)."""
    out, pos = [], 8
    region = "data"
    while pos + 9 <= len(data) - 8:
        op, length = struct.unpack_from("<BQ", data, pos)
        out.append(Rec(pos, op, length, region))
        if op == 0x0F:
            region = "summary"
        pos += 9 + length
        if op == 0x02:
            break
    return [Rec(r.offset, r.op, r.length, "footer" if r.op == 0x02 else r.region) for r in out]


def uncovered(data: bytes) -> list[tuple[int, int]]:
    """Byte ranges whose damage no CRC or summary entry can tell. With a data-section CRC:
    none. Without (the recorder writes none): metadata, attachment, message and message
    index record bodies, the header record's strings, chunks without a CRC."""
    recs = records(data)
    data_end = [r for r in recs if r.op == 0x0F]
    if data_end and struct.unpack_from("<I", data, data_end[0].offset + 9)[0] != 0:
        return []
    out = []
    for r in recs:
        crc_zero = r.op == 0x06 and struct.unpack_from("<I", data, r.offset + 9 + 24)[0] == 0
        if r.region == "data" and (r.op in (0x01, 0x05, 0x07, 0x09, 0x0C) or crc_zero):
            out.append((r.offset + 9, r.offset + 9 + r.length))
    return out


# --- mutations -------------------------------------------------------------------------------
Mutation = Callable[[bytes, random.Random], tuple[bytes, str, list[int]]]
"""(seed bytes, rng) -> (mutated bytes, description, offsets changed ([] = rewritten))"""


def _flip(data: bytes, rng: random.Random, lo: int, hi: int, n: int) -> tuple[bytes, list[int]]:
    buf = bytearray(data)
    where = []
    for _ in range(n):
        i = rng.randrange(lo, hi)
        buf[i] ^= 1 << rng.randrange(8)
        where.append(i)
    return bytes(buf), where


def m_flip_any(data: bytes, rng: random.Random) -> tuple[bytes, str, list[int]]:
    out, where = _flip(data, rng, 0, len(data), rng.choice((1, 1, 2, 3)))
    return out, f"flip bits at {where}", where


def m_flip_chunk(data: bytes, rng: random.Random) -> tuple[bytes, str, list[int]]:
    chunks = [r for r in records(data) if r.op == 0x06]
    if not chunks:
        return m_flip_any(data, rng)
    r = rng.choice(chunks)
    out, where = _flip(data, rng, r.offset + 9, r.offset + 9 + r.length, 1)
    return out, f"flip a bit in the chunk at {r.offset}: {where}", where


def m_truncate(data: bytes, rng: random.Random) -> tuple[bytes, str, list[int]]:
    r = rng.choice(records(data))
    cut = r.offset + rng.choice((0, 1, 8, 9, 10, r.length // 2 + 9, r.length + 8))
    cut = max(0, min(cut + rng.choice((0, 0, -1, 1)), len(data) - 1))
    return data[:cut], f"truncate at {cut} (in/at a record of opcode {r.op:#x})", [cut]


HOSTILE_LENGTHS = (1 << 40, 1 << 48, (1 << 63) - 1, 1 << 63, (1 << 64) - 1, 1 << 32, 1 << 31)


def m_length(data: bytes, rng: random.Random) -> tuple[bytes, str, list[int]]:
    r = rng.choice(records(data))
    value = rng.choice((*HOSTILE_LENGTHS, r.length + 1, max(0, r.length - 1), 0))
    buf = bytearray(data)
    struct.pack_into("<Q", buf, r.offset + 1, value)
    return bytes(buf), f"length of the record at {r.offset} (opcode {r.op:#x}) -> {value}", [
        r.offset + 1]


def m_crc(data: bytes, rng: random.Random) -> tuple[bytes, str, list[int]]:
    recs = records(data)
    choices = []
    for r in recs:
        if r.op == 0x06:
            choices.append(r.offset + 9 + 24)  # uncompressed CRC
        if r.op == 0x02:
            choices.append(r.offset + 9 + 16)  # summary CRC
    if not choices:
        return m_flip_any(data, rng)
    at = rng.choice(choices)
    buf = bytearray(data)
    struct.pack_into("<I", buf, at, rng.randrange(1, 1 << 32))
    return bytes(buf), f"CRC at {at} replaced", [at]


def _summary_edit(data: bytes, edit: Callable[[list[tuple[int, bytes]]], list[tuple[int, bytes]]]
                  ) -> bytes:
    """Rewrite the summary's records with ``edit`` and fix the footer (CRC recomputed), so
    only a comparison with the data can tell."""
    recs = records(data)
    footer = next(r for r in recs if r.op == 0x02)
    summary_start = struct.unpack_from("<Q", data, footer.offset + 9)[0]
    items = [(r.op, data[r.offset + 9:r.offset + 9 + r.length]) for r in recs
             if r.region == "summary"]
    items = edit(items)
    body = b"".join(struct.pack("<BQ", op, len(b)) + b for op, b in items)
    head = data[:summary_start]
    footer_fields = struct.pack("<BQQQ", 0x02, 20, summary_start, 0)
    crc = zlib.crc32(body + footer_fields)
    return head + body + footer_fields + struct.pack("<I", crc) + MAGIC


def m_summary(data: bytes, rng: random.Random) -> tuple[bytes, str, list[int]]:
    kind = rng.choice(("dup chunk index", "drop chunk index", "topic", "dup metadata index"))

    def edit(items: list[tuple[int, bytes]]) -> list[tuple[int, bytes]]:
        items = [i for i in items if i[0] not in (0x0E,)]  # summary offsets would be stale
        if kind == "dup chunk index":
            ci = [i for i in items if i[0] == 0x08]
            return items + [ci[0]] * rng.randint(1, 3)
        if kind == "drop chunk index":
            ci = [i for i in items if i[0] == 0x08]
            items.remove(rng.choice(ci))
            return items
        if kind == "dup metadata index":
            mi = [i for i in items if i[0] == 0x0D]
            return [*items, rng.choice(mi)]
        chans = [k for k, i in enumerate(items) if i[0] == 0x04 and b"omni" in i[1]]
        k = rng.choice(chans)
        body = bytearray(items[k][1])
        body[body.index(b"/robot") + 6] ^= 0x02  # robot1 -> robot3 ...
        items[k] = (0x04, bytes(body))
        return items

    try:
        return _summary_edit(data, edit), f"summary: {kind} (CRC recomputed)", []
    except (StopIteration, ValueError, IndexError):
        return m_flip_any(data, rng)


def m_zstd_bomb(data: bytes, rng: random.Random) -> tuple[bytes, str, list[int]]:
    """A zstd chunk of zeros declaring (or hiding) 1..3 GiB, appended before the data end."""
    size = rng.choice((GIB, 3 * GIB, 64 << 20))
    declared = rng.choice((size, 1000))
    comp = _zeros_zstd(size)
    body = struct.pack("<QQQI", 0, 0, declared, 0) + struct.pack("<I", 4) + b"zstd" + struct.pack(
        "<Q", len(comp)) + comp
    chunk = struct.pack("<BQ", 0x06, len(body)) + body
    recs = records(data)
    data_end = next(r for r in recs if r.op == 0x0F)
    return (data[:data_end.offset] + chunk + data[data_end.offset:],
            f"zstd chunk of {size} zeros declaring {declared}", [data_end.offset])


_ZEROS: dict[int, bytes] = {}


def _zeros_zstd(size: int) -> bytes:
    import zstandard

    if size not in _ZEROS:
        c = zstandard.ZstdCompressor(level=1)
        obj = c.compressobj(size=size)
        block = bytes(1 << 24)
        parts = [obj.compress(block) for _ in range(size // len(block))]
        parts.append(obj.flush())
        _ZEROS[size] = b"".join(parts)
    return _ZEROS[size]


# rewritten mutations: change messages' CDR bytes, write a valid log again
def _cdr_image(data: bytes) -> tuple[int, int]:
    """(offset of the image data's length field, data length) in a CompressedImage CDR."""
    pos = 4 + 8
    n = struct.unpack_from("<I", data, pos)[0]
    pos = (pos + 4 + n + 3) & ~3
    n = struct.unpack_from("<I", data, pos)[0]
    pos = (pos + 4 + n + 3) & ~3
    return pos, struct.unpack_from("<I", data, pos)[0]


def _set_image(data: bytes, image: bytes) -> bytes:
    pos, _n = _cdr_image(data)
    return data[:pos] + struct.pack("<I", len(image)) + image


def bomb_image(rng: random.Random) -> bytes:
    kind = rng.choice(("png", "jpeg", "bmp"))
    w, h = rng.choice(((30000, 30000), (100000, 100000), (65535, 65535), (1 << 31, 1 << 20)))
    if kind == "png":
        ihdr = struct.pack(">IIBBBBB", w & 0xFFFFFFFF, h, 8, 2, 0, 0, 0)
        chunk = b"IHDR" + ihdr
        idat = zlib.compress(bytes(1 << 16))
        png = (b"\x89PNG\r\n\x1a\n" + struct.pack(">I", 13) + chunk
               + struct.pack(">I", zlib.crc32(chunk)))
        png += struct.pack(">I", len(idat)) + b"IDAT" + idat + struct.pack(
            ">I", zlib.crc32(b"IDAT" + idat))
        return png + struct.pack(">I", 0) + b"IEND" + struct.pack(">I", zlib.crc32(b"IEND"))
    if kind == "jpeg":
        w, h = min(w, 65535), min(h, 65535)
        sof = struct.pack(">BBHBHHB", 0xFF, 0xC0, 11, 8, h, w, 1) + bytes(3)
        return b"\xff\xd8" + sof + b"\xff\xda" + bytes(64) + b"\xff\xd9"
    bmp = b"BM" + struct.pack("<IHHI", 0, 0, 0, 54) + struct.pack(
        "<IiiHHIIiiII", 40, min(w, 1 << 30), min(h, 1 << 30), 1, 24, 0, 0, 0, 0, 0, 0)
    return bmp + bytes(256)


def _rewrite(seed: bytes, fn: Callable[[str, bytes], bytes | None]) -> bytes:
    path = io.BytesIO(seed)
    reader = make_reader(path)
    raw = _raw_from_reader(reader)
    msgs = []
    for cid, seq, lt, pt, data in raw.messages:
        new = fn(raw.channels[cid][0], data)
        msgs.append((cid, seq, lt, pt, data if new is None else new))
    raw.messages = msgs
    return write_raw(raw, **RECORDER_LAYOUT)


def _raw_from_reader(reader: Any) -> Raw:
    schemas, channels, messages = {}, {}, []
    for schema, channel, msg in reader.iter_messages(log_time_order=False):
        if schema is not None:
            schemas[schema.id] = (schema.name, schema.encoding, schema.data)
        channels[channel.id] = (channel.topic, channel.schema_id, channel.message_encoding,
                                dict(channel.metadata))
        messages.append((msg.channel_id, msg.sequence, msg.log_time, msg.publish_time,
                         msg.data))
    metadata = [(m.name, dict(m.metadata)) for m in reader.iter_metadata()]
    return Raw(schemas, channels, messages, metadata)


def m_image(seed: bytes, rng: random.Random) -> tuple[bytes, str, list[int]]:
    kind = rng.choice(("bomb", "bomb", "empty", "garbage", "cut"))
    hit = rng.randrange(6)
    count = [0]

    def fn(topic: str, data: bytes) -> bytes | None:
        if not topic.endswith("/compressed"):
            return None
        count[0] += 1
        if count[0] - 1 != hit and rng.random() > 0.2:
            return None
        pos, n = _cdr_image(data)
        image = data[pos + 4:pos + 4 + n]
        if kind == "bomb":
            return _set_image(data, bomb_image(rng))
        if kind == "empty":
            return _set_image(data, b"")
        if kind == "garbage":
            return _set_image(data, bytes(rng.randrange(256) for _ in range(64)))
        return _set_image(data, image[: rng.randrange(len(image))])

    return _rewrite(seed, fn), f"images: {kind}", []


def m_pose(seed: bytes, rng: random.Random) -> tuple[bytes, str, list[int]]:
    bad = rng.choice((float("nan"), float("inf"), -float("inf"), 1e308, "zeroq"))

    def fn(topic: str, data: bytes) -> bytes | None:
        if not topic.endswith("/pose") or rng.random() > 0.3:
            return None
        values = list(struct.unpack_from("<7d", data, len(data) - 56))
        if bad == "zeroq":
            values[3:] = [0.0, 0.0, 0.0, 0.0]
        else:
            values[rng.randrange(7)] = float(bad)
        return data[:-56] + struct.pack("<7d", *values)

    return _rewrite(seed, fn), f"poses: {bad}", []


def m_stamps(seed: bytes, rng: random.Random) -> tuple[bytes, str, list[int]]:
    mode = rng.choice(("shuffle", "future", "negative", "descending"))
    state = {"t": 1 << 30}

    def fn(topic: str, data: bytes) -> bytes | None:
        if rng.random() > 0.4:
            return None
        sec, nsec = struct.unpack_from("<iI", data, 4)
        if mode == "shuffle":
            sec, nsec = sec + rng.randint(-1, 1), rng.randrange(1_000_000_000)
        elif mode == "future":
            sec = rng.choice((1 << 30, (1 << 31) - 1))
        elif mode == "negative":
            sec = -rng.randint(1, 1 << 31)
        else:
            state["t"] -= 1
            sec, nsec = 0, max(0, state["t"] % 1_000_000_000)
        return data[:4] + struct.pack("<iI", sec, nsec) + data[12:]

    return _rewrite(seed, fn), f"stamps: {mode}", []


def m_schema(seed: bytes, rng: random.Random) -> tuple[bytes, str, list[int]]:
    raw = _raw_from_reader(make_reader(io.BytesIO(seed)))
    kind = rng.choice(("float32", "damaged", "swap"))
    sids = sorted(raw.schemas)
    sid = rng.choice(sids)
    name, enc, text = raw.schemas[sid]
    if kind == "float32":
        text = text.replace(b"float64", b"float32")
    elif kind == "damaged":
        i = rng.randrange(len(text))
        text = text[:i] + bytes([rng.randrange(256)]) + text[i + 1:]
    else:
        other = rng.choice(sids)
        name, enc, text = raw.schemas[other][0], enc, raw.schemas[other][2]
    raw.schemas[sid] = (name, enc, text)
    return write_raw(raw, **RECORDER_LAYOUT), f"schema {sid}: {kind}", []


def m_tiny(seed: bytes, rng: random.Random) -> tuple[bytes, str, list[int]]:
    kind = rng.choice(("empty", "magic", "9 bytes", "magic twice", "header only"))
    data = {"empty": b"", "magic": MAGIC, "9 bytes": MAGIC + b"\x01",
            "magic twice": MAGIC + MAGIC, "header only": seed[:8 + 9 + 20]}[kind]
    return data, f"tiny file: {kind}", [0]


MUTATIONS: dict[str, tuple[Mutation, int]] = {
    "flip_any": (m_flip_any, 20),
    "flip_chunk": (m_flip_chunk, 15),
    "truncate": (m_truncate, 15),
    "length": (m_length, 10),
    "crc": (m_crc, 5),
    "summary": (m_summary, 8),
    "image": (m_image, 8),
    "pose": (m_pose, 5),
    "stamps": (m_stamps, 5),
    "schema": (m_schema, 4),
    "tiny": (m_tiny, 2),
    "zstd_bomb": (m_zstd_bomb, 1),
}
"""name -> (mutation, weight)"""


def cases(seeds: list[bytes], n: int, seed: int, kinds: list[str] | None = None
          ) -> Iterator[tuple[int, str, str, bytes, int, list[int]]]:
    """``n`` cases: (index, kind, description, bytes, seed number, changed offsets)."""
    rng = random.Random(seed)
    names = kinds or list(MUTATIONS)
    weights = [MUTATIONS[k][1] for k in names]
    for i in range(n):
        kind = rng.choices(names, weights)[0]
        s = rng.randrange(len(seeds))
        data, what, where = MUTATIONS[kind][0](seeds[s], random.Random(rng.getrandbits(64)))
        yield i, kind, what, data, s, where


# --- running a case --------------------------------------------------------------------------
class Hang(BaseException):
    """The per-case timer fired."""


def _alarm(_sig: int, _frame: object) -> None:
    raise Hang


def reset_peak_rss() -> bool:
    try:
        Path("/proc/self/clear_refs").write_text("5")
        return True
    except OSError:
        return False


def peak_rss_bytes() -> int:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) * 1024
    return 0


@dataclass
class Outcome:
    status: str
    exit_code: int | None
    seconds: float
    peak_rss: int
    message: str = ""
    warnings: tuple[str, ...] = ()
    """The warning lines the replay printed."""


def comparable(results: dict[str, Any]) -> str:
    """The results without what names the file (name, hash) or measures the run."""
    results = dict(results)
    results["log"] = {k: v for k, v in results["log"].items() if k not in ("file", "sha256")}
    summary = dict(results.get("summary", {}))
    results["summary"] = summary
    for frame in results.get("frames", []):
        frame.pop("estimator_s", None)
    return json.dumps(results, sort_keys=True)


def run_case(data: bytes, workdir: Path, *, expected: str | None, covered: bool,
             timeout_s: float = 60.0, extra_args: tuple[str, ...] = (),
             seed_warnings: tuple[str, ...] = ()) -> Outcome:
    """Replay ``data`` through ``dsp-replay``'s main in this process and classify it; a
    warning counts as reporting a change when the seed's own replay (``seed_warnings``) did
    not print it (the rolling seed's robot1 never sees the ball, and says so every time)."""
    from replay.cli import main

    log = workdir / "case.mcap"
    out = workdir / "case.json"
    log.write_bytes(data)
    out.unlink(missing_ok=True)
    err, std = io.StringIO(), io.StringIO()
    gc.collect()
    reset_peak_rss()
    old = signal.signal(signal.SIGALRM, _alarm)
    signal.setitimer(signal.ITIMER_REAL, timeout_s)
    t0 = time.perf_counter()
    status, code, message = "", None, ""
    try:
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(std):
            code = main([str(log), "--out", str(out), "--force", "--no-progress",
                         *extra_args])
    except Hang:
        status, message = "hang", f"over {timeout_s} s"
    except Exception as exc:
        status, message = "traceback", f"{type(exc).__name__}: {exc}"[:300]
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)
    seconds = time.perf_counter() - t0
    rss = peak_rss_bytes()
    text = err.getvalue()
    lines = [ln for ln in text.splitlines() if ln.strip()]
    warnings = tuple(ln for ln in lines if ln.startswith("warning:"))
    if not status:
        if "Traceback" in text or "libpng" in text:
            status, message = "traceback", text[-300:]
        elif code != 0:
            errors = [ln for ln in lines if ": error: " in ln]
            status = "error" if len(errors) == 1 else "traceback"
            message = errors[0] if errors else text[-300:]
        else:
            results = json.loads(out.read_text())
            got = comparable(results)
            # reported: a warning line, or skipped frames the seed does not have
            warned = any(ln not in seed_warnings for ln in warnings) or (
                expected is not None
                and results["summary"]["skipped"] != json.loads(expected)["summary"]["skipped"])
            if expected is None or got == expected:
                status = "ok"
            elif warned:
                status = "changed"
            else:
                status = "silent" if covered else "uncovered"
    return Outcome(status, code, seconds, rss, message, warnings)


def is_covered(seed: bytes, where: list[int]) -> bool:
    """Whether every changed offset is covered by a CRC or mirrored in the summary."""
    if not where:
        return False  # rewritten logs: valid MCAP, nothing to tell by
    holes = uncovered(seed)
    return not any(lo <= w < hi for w in where for lo, hi in holes)
