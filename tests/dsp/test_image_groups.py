"""dsp.image_groups: folders grouped by day or by a grouping file, and the shared set's
grouping (train/msl-events.txt) covering every folder of it."""

from __future__ import annotations

from pathlib import Path

import pytest

from dsp.errors import InputError
from dsp.image_groups import Grouping, group_folders, read_grouping
from dsp.labelled import labelled_folders

ROOT = Path(__file__).resolve().parents[2]
EVENTS = ROOT / "train" / "msl-events.txt"
SHARED = [ROOT.parent / "shared" / "real" / n for n in ("msl-images", "msl-more")]


def test_folder_and_day() -> None:
    assert read_grouping("folder").group_of("20240716/r5") == "20240716/r5"
    day = read_grouping("day")
    assert day.group_of("20240716/r5") == "20240716"
    assert day.group_of(".") == "."
    assert day.label == "day"


def test_a_file_takes_the_first_line_that_matches_a_folder_or_its_day(tmp_path: Path) -> None:
    path = tmp_path / "g.txt"
    path.write_text("# events\none 20230709/r8   # a folder alone\n"
                    "two 2023* 20240606\n\nthree 2025*\n")
    g = read_grouping(str(path))
    assert g.label == "g.txt"
    assert g.group_of("20230709/r8") == "one"
    assert g.group_of("20230709/r5") == "two"
    assert g.group_of("20240606/r12") == "two"
    assert g.group_of("20250109/r2") == "three"
    with pytest.raises(InputError, match=r"g\.txt: no group takes the folder '20240716/r5'"):
        g.group_of("20240716/r5")
    folders = [(k, k, tmp_path / k) for k in ("20250109/r2", "20230709/r8", "20230709/r5",
                                              "20250114/r2")]
    assert {n: [k for k, _ in m] for n, m in group_folders(g, folders).items()} == {
        "three": ["20250109/r2", "20250114/r2"], "one": ["20230709/r8"],
        "two": ["20230709/r5"]}


@pytest.mark.parametrize(("text", "message"), [
    ("one\n", r"g\.txt:1: not 'NAME PATTERN"),
    ("a b\n\nbad/name x\n", r"g\.txt:3: not 'NAME PATTERN"),
    ("a x\na y\n", r"g\.txt:2: the group 'a' is named twice"),
    ("# nothing\n", r"g\.txt: no group in it"),
])
def test_a_bad_file_is_one_line_naming_it(tmp_path: Path, text: str, message: str) -> None:
    path = tmp_path / "g.txt"
    path.write_text(text)
    with pytest.raises(InputError, match=message):
        read_grouping(str(path))


def test_a_missing_file_is_named() -> None:
    with pytest.raises(InputError, match=r"nowhere\.txt"):
        read_grouping("nowhere.txt")


@pytest.mark.skipif(not all(p.is_dir() for p in SHARED), reason="the shared set is not here")
def test_the_shared_set_falls_into_its_eight_events() -> None:
    g = read_grouping(str(EVENTS))
    assert isinstance(g, Grouping)
    folders = [(f"{r.name}/{p.relative_to(r).as_posix()}", p.relative_to(r).as_posix(), p)
               for r in SHARED for p in labelled_folders(r)]
    groups = group_folders(g, folders)
    assert list(groups) == ["delocht-2019", "bangkok-2022", "bordeaux-2023", "techunited-2024",
                            "july-2024", "hard-2025", "early-2026", "boards-2026"]
    assert sorted(k for k, _ in groups["bordeaux-2023"]) == [
        "msl-images/20230709/r5", "msl-more/20230709/r6", "msl-more/20230709/r8"]
    assert sum(map(len, groups.values())) == len(folders) == 51
