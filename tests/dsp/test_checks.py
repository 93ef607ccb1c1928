"""dsp.checks: an integer option's bounds are both inclusive, as its message says."""

from __future__ import annotations

import pytest

from dsp.checks import check_int
from dsp.errors import UsageError


@pytest.mark.parametrize("value", [1, 2, 5, None])
def test_an_integer_on_its_bounds_is_taken(value: int | None) -> None:
    check_int("--count", value, low=1, high=5)
    check_int("--count", value, high=5)
    check_int("--count", value, low=1)


@pytest.mark.parametrize("value", [0, 6, -(10**40), 10**40])
def test_an_integer_past_its_bounds_is_refused(value: int) -> None:
    with pytest.raises(UsageError, match=rf"^--count {value}: give a whole number"):
        check_int("--count", value, low=1, high=5)


def test_the_message_states_the_bounds_that_are_taken() -> None:
    with pytest.raises(UsageError, match=r"^--count 6: give a whole number in \[1, 5\]$"):
        check_int("--count", 6, low=1, high=5)
    with pytest.raises(UsageError, match=r"^--count 6: give a whole number <= 5$"):
        check_int("--count", 6, high=5)
