"""The field's geometry (dsp.field): one source for the recorder's carpet and replay's view."""

from __future__ import annotations

from pathlib import Path

import pytest

from dsp.field import DEFAULT_FIELD, FIELDS, Circle, FieldSpec, Rect, Segment, markings, polylines


def _extent(strips: list[list[tuple[float, float]]]) -> tuple[float, float, float, float]:
    xs = [x for s in strips for x, _ in s]
    ys = [y for s in strips for _, y in s]
    return min(xs), max(xs), min(ys), max(ys)


@pytest.mark.parametrize("name", sorted(FIELDS))
def test_markings_match_the_spec(name: str) -> None:
    spec = FIELDS[name]
    hl, hw = spec.half_length_m, spec.half_width_m
    rects = [m for m in markings(spec) if isinstance(m, Rect)]
    assert rects[0] == Rect(-hl, -hw, hl, hw)
    areas = rects[1:]
    assert len(areas) == 4  # a penalty and a goal area per half
    for r in areas:
        assert abs(r.x0) == hl  # on the goal line
        got = (round(hl - abs(r.x1), 9), -r.y0, r.y1)
        assert got in [(spec.goal_area_depth_m, spec.goal_area_half_width_m,
                        spec.goal_area_half_width_m),
                       (spec.penalty_area_depth_m, spec.penalty_area_half_width_m,
                        spec.penalty_area_half_width_m)]
    assert [m for m in markings(spec) if isinstance(m, Segment)] == [Segment(0, -hw, 0, hw)]
    circles = [m for m in markings(spec) if isinstance(m, Circle)]
    assert [c.radius_m for c in circles if not c.filled] == [spec.centre_circle_radius_m]
    spots = sorted(c.x for c in circles if c.filled)
    assert spots == [-(hl - spec.penalty_mark_distance_m), 0.0, hl - spec.penalty_mark_distance_m]


def test_the_22x14_areas_are_simatchs() -> None:
    spec = FIELDS["22x14"]
    assert (spec.length_m, spec.width_m) == (22.0, 14.0)
    assert spec.half_length_m - spec.goal_area_depth_m == 10.25
    assert spec.goal_area_half_width_m == 1.95
    assert spec.half_length_m - spec.penalty_area_depth_m == 8.75
    assert spec.penalty_area_half_width_m == 3.45


@pytest.mark.parametrize("spec", [FIELDS["18x12"], FIELDS["22x14"],
                                  FieldSpec("test", 12.0, 8.0, 0.5, 1.0, 1.5, 2.0)])
def test_polylines_span_the_field(spec: FieldSpec) -> None:
    strips = polylines(spec)
    assert _extent(strips) == (-spec.half_length_m, spec.half_length_m,
                               -spec.half_width_m, spec.half_width_m)
    for strip, marking in zip(strips, markings(spec), strict=True):
        if isinstance(marking, (Rect, Circle)):
            assert strip[0] == pytest.approx(strip[-1])  # closed


def test_the_default_field_is_the_papers() -> None:
    assert FIELDS[DEFAULT_FIELD].length_m == 18.0 and FIELDS[DEFAULT_FIELD].width_m == 12.0


def test_a_22x14_log_is_drawn_22x14_in_rerun(tmp_path: Path) -> None:
    """Recorded with --field 22x14, replayed with --save: the field view spans 22 x 14 m."""
    from rerun.chunk import RrdReader

    from recorder.record import RecordOptions, record
    from replay import ReplayOptions, RerunTarget, replay

    log = tmp_path / "scenario1.mcap"
    record(log, RecordOptions(frames=1, field="22x14", face_px=256))
    rrd = tmp_path / "x.rrd"
    replay(log, ReplayOptions(rerun=RerunTarget("save", str(rrd)), progress=False))
    strips = []
    for chunk in RrdReader(rrd).stream().to_chunks():
        if chunk.entity_path != "/field/lines":
            continue
        rb = chunk.to_record_batch()
        for row in rb.column("LineStrips3D:strips").to_pylist():
            if row:
                strips += [[(p[0], p[1]) for p in strip] for strip in row]
    assert strips, "no /field/lines in the recording"
    assert _extent(strips) == pytest.approx((-11.0, 11.0, -7.0, 7.0))
    # the goal areas end where the 22x14 field's do (x = +-10.25, y = +-1.95)
    assert any(pytest.approx((10.25, 1.95)) == p for s in strips for p in s)
