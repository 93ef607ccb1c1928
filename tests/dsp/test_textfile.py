"""Small input files are read bounded, only when they are regular files, and never block:
a device (/dev/zero), a FIFO (with or without a writer), a folder and a missing file are
each one line naming the file, through every command that reads one."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from dsp.errors import InputError
from dsp.textfile import read_text_file

MAX = 1000


pytestmark = pytest.mark.usefixtures("no_hang")


def refused(path: Path) -> str:
    with pytest.raises(InputError) as err:
        read_text_file(path, MAX, what="a test file")
    text = str(err.value)
    assert text.startswith(f"{path}: ") and "\n" not in text
    return text.removeprefix(f"{path}: ")


def test_a_device_is_refused_without_reading_it() -> None:
    assert refused(Path("/dev/zero")) == ("not a regular file (a device, pipe or socket); "
                                          "give a test file")


def test_a_fifo_is_refused_without_blocking(tmp_path: Path) -> None:
    fifo = tmp_path / "pipe.json"
    os.mkfifo(fifo)
    assert refused(fifo).startswith("not a regular file")  # no writer: open does not wait
    # a writer holding the FIFO open, with bytes waiting: opened without threads, so no
    # order of events can leave an open blocked (a writer may open without blocking only
    # while a reader is there)
    reader = os.open(fifo, os.O_RDONLY | os.O_NONBLOCK)
    writer = os.open(fifo, os.O_WRONLY | os.O_NONBLOCK)
    try:
        os.write(writer, b"{}")
        os.close(reader)
        assert refused(fifo).startswith("not a regular file")  # a writer: read never waits
    finally:
        os.close(writer)


def test_a_folder_and_a_missing_file_are_told_apart(tmp_path: Path) -> None:
    assert refused(tmp_path) == "is a folder; give a test file"
    assert refused(tmp_path / "missing.json") == "cannot read: No such file or directory"


def test_size_is_bounded_and_the_text_is_utf8(tmp_path: Path) -> None:
    big = tmp_path / "big.json"
    big.write_bytes(b" " * (MAX + 1))
    assert refused(big) == f"{MAX + 1} bytes; a test file holds at most {MAX} bytes"
    ok = tmp_path / "ok.json"
    ok.write_bytes(b"\xef\xbb\xbf{}" + b" " * (MAX - 5))
    assert read_text_file(ok, MAX) == "{}" + " " * (MAX - 5)  # the byte-order mark dropped
    bad = tmp_path / "bad.json"
    bad.write_bytes(b"{\xff}")
    assert refused(bad) == "not UTF-8 text (byte 1)"


def test_a_symlink_to_a_device_is_refused(tmp_path: Path) -> None:
    link = tmp_path / "link.json"
    link.symlink_to("/dev/zero")
    assert refused(link).startswith("not a regular file")
