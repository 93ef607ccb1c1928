"""``--clock`` on a log whose stamps jump: the ticks are bounded by the images, not by the
span of the stamps, and the replay says what it skipped."""

from __future__ import annotations

from pathlib import Path

import pytest
from synthetic import NS, write_log

from replay import ReplayOptions, replay
from replay.clock import Clock

JUMP_S = 1000


@pytest.fixture(scope="module")
def logs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp("clock")
    paths = {"plain": folder / "plain.mcap", "jump": folder / "jump.mcap"}
    write_log(paths["plain"], duration_s=1.0, image_hz=10.0)
    write_log(paths["jump"], duration_s=1.0, image_hz=10.0, stamp_jump=(0.5, JUMP_S * NS))
    return paths


def test_no_tick_is_made_across_a_jump_of_the_stamps(logs: dict[str, Path]) -> None:
    opts = ReplayOptions(fusion="track", clock_hz=1.0, progress=False)
    plain, jump = replay(logs["plain"], opts), replay(logs["jump"], opts)
    assert not plain.warnings and plain.frames == jump.frames
    # the plain log ticks at 0 and 1 s; the jumped one at 0, 1 s and at 1000 and 1001 s,
    # beside its images: ticked through, the 1000 s without images were 1000 steps more
    assert jump.steps == plain.steps + 2
    assert [w for w in jump.warnings if "--clock" in w] == [
        f"{logs['jump']}: --clock skipped 998 tick(s) in 1 gap(s) without images (ticks "
        "are made only within 1 s of an image)"]


def test_the_ticks_per_image_are_bounded_whatever_the_span() -> None:
    clock = Clock(period_ns=100_000, reach_ns=NS // 10)  # 10 kHz, 0.1 s
    made = [*clock.before(0), *clock.at(0), *clock.before(10**6 * NS), *clock.at(10**6 * NS)]
    assert len(made) == 1 + 1000 + 1000 + 1
    assert clock.skipped == 10**10 + 1 - len(made) and clock.gaps == 1  # none made twice
