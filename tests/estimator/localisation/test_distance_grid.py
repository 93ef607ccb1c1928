"""The distance grid measures each block against its nearby markings only: the same numbers,
bit for bit, as every marking at every cell (the pruning must never change a fit)."""

from __future__ import annotations

import numpy as np
import pytest

from estimator.localisation.field_lines import DistanceGrid, FieldLines


def _every_marking(grid: DistanceGrid, lines: FieldLines) -> np.ndarray:
    rows, cols = grid.offset_m.shape[:2]
    xs = grid.x0_m + grid.step_m * np.arange(cols)
    ys = grid.y0_m + grid.step_m * np.arange(rows)
    xy = np.stack(np.broadcast_arrays(xs[None, :], ys[:, None]), axis=-1)
    return lines.offset(xy.reshape(-1, 2)).reshape(rows, cols, 2).astype(np.float32)


@pytest.mark.parametrize("step_m", [0.05, 0.1, 0.13])
def test_the_pruned_grid_is_the_full_one(step_m: float) -> None:
    # a field's kinds of marking, with ties: the two halves of the halfway line meet at the
    # circle's centre, and cells on the diagonal between parallel lines are equidistant
    lines = FieldLines.from_shapes(
        half_length_m=4.0, half_width_m=3.0,
        rects=[(-4.0, -3.0, 4.0, 3.0), (3.0, -1.0, 4.0, 1.0)],
        segments=[(0.0, -3.0, 0.0, 0.0), (0.0, 0.0, 0.0, 3.0)],
        circles=[(0.0, 0.0, 1.0)], marks=[(2.5, 0.0, 0.06), (-2.5, 0.0, 0.06)])
    grid = DistanceGrid.build(lines, step_m=step_m, margin_m=1.0)
    assert np.array_equal(grid.offset_m, _every_marking(grid, lines))


def test_offset_of_a_subset_keeps_the_markings_order() -> None:
    lines = FieldLines.from_shapes(half_length_m=2.0, half_width_m=1.0,
                                   segments=[(0.0, -1.0, 0.0, 1.0), (1.0, -1.0, 1.0, 1.0)],
                                   circles=[(0.0, 0.0, 0.5)])
    p = np.array([[0.5, 0.9], [0.25, 0.0]])
    d = lines.distances(p)
    assert d.shape == (3, 2)
    assert d[:, 0] == pytest.approx([0.5, 0.5, np.hypot(0.5, 0.9) - 0.5])
    # a tie between the two segments at x = 0.5: the first marking's vector, as with all
    assert np.array_equal(lines.offset(p[:1], [0, 1]), lines.offset(p[:1], [0, 1, 2]))
    assert lines.offset(p[:1], [0, 1])[0] == pytest.approx([0.5, 0.0])
    assert lines.offset(p[:1], [1])[0] == pytest.approx([-0.5, 0.0])
