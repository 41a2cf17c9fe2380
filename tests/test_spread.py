"""Pieces spread in a frame (geometry.spread, a layout's `spread: true`): the gaps it promises hold
for the true distances (shapely, an independent oracle), a row of equal squares ends evenly spaced
(the answer by hand), an even layout stays where it is, and a layout file says when it asks for it."""

from __future__ import annotations

import numpy as np
import pytest
import shapely
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from conftest import SCENES
from ungrasp_ompl.errors import InputError
from ungrasp_ompl.geometry.spread import separation, smallest_gap, spread
from ungrasp_ompl.layout.model import Layout


def _square(x: float, y: float, side: float) -> np.ndarray:
    return np.array([[x, y], [x + side, y], [x + side, y + side], [x, y + side]])


def _true_gap(outlines, inner) -> float:
    """The smallest Euclidean distance between two outlines or an outline and a wall (shapely)."""
    polys = [shapely.Polygon(p) for p in outlines]
    walls = shapely.box(0, 0, *inner).exterior  # the outlines lie inside: their distance to it is to a wall
    assert all(shapely.box(0, 0, *inner).covers(p) for p in polys)
    return min([walls.distance(p) for p in polys] + [polys[i].distance(polys[j]) for i in range(len(polys))
                                                      for j in range(i)])


def test_a_row_of_equal_squares_ends_evenly_spaced():
    """Three 20 mm squares crowded into the west of a 100 x 40 mm frame: four equal gaps of 10 mm
    along the row (the frame's depth leaves them 10 mm above and below too)."""
    outlines = [_square(0.001 + 0.021 * k, 0.01, 0.02) for k in range(3)]
    result = spread(outlines, (0.1, 0.04))
    assert result.gap_before == pytest.approx(0.001)
    assert result.gap == pytest.approx(0.01, abs=1e-8)
    moved = [p + s for p, s in zip(outlines, result.shifts)]
    assert [p[0, 0] for p in moved] == pytest.approx([0.01, 0.04, 0.07], abs=1e-8)
    assert all(p[0, 1] == pytest.approx(0.01, abs=1e-8) for p in moved)  # not moved across: it needs no move


def test_separation_is_the_distance_of_two_squares_side_by_side_and_points_from_the_first():
    gap, axis = separation(_square(0, 0, 1), _square(1.5, 0.2, 1))
    assert gap == pytest.approx(0.5) and axis == pytest.approx([1, 0])


@settings(max_examples=40, deadline=None)
@given(st.lists(st.tuples(st.floats(0.0, 0.08), st.floats(0.0, 0.08), st.floats(0.005, 0.02),
                          st.floats(0, 2 * np.pi)), min_size=1, max_size=5))
def test_what_the_spread_promises_holds_for_the_true_distances(pieces):
    """Random triangles dropped into a 100 mm frame (those that overlap an earlier one left out):
    after the spread, no two lie closer than its gap, nor any to a wall (shapely), the gap is at
    least the one before, and spreading again moves nothing further than a micrometre."""
    inner = (0.1, 0.1)
    outlines = []
    for x, y, r, turn in pieces:
        angles = turn + np.array([0.0, 2.1, 4.0])
        tri = np.column_stack([np.cos(angles), np.sin(angles)]) * r + [x + 0.01, y + 0.01]
        if tri.min() < 0 or tri.max() > 0.1:
            continue
        if any(shapely.Polygon(tri).intersects(shapely.Polygon(o)) for o in outlines):
            continue
        outlines.append(tri)
    if not outlines:
        return
    result = spread(outlines, inner)
    moved = [p + s for p, s in zip(outlines, result.shifts)]
    assert _true_gap(moved, inner) >= result.gap - 1e-9
    assert result.gap >= result.gap_before - 1e-9
    assert result.gap == pytest.approx(smallest_gap(moved, inner))
    again = spread(moved, inner)
    assert again.gap == pytest.approx(result.gap, abs=1e-9)
    assert np.abs(again.shifts).max() < 1e-6


def test_the_shipped_tangram_is_spread_wider_than_its_cut():
    """The tangram's pieces are cut 1 mm smaller on every edge (2 mm between neighbours) inside a
    frame 4 mm wider on every side; spread, its narrowest gap is wider than the cut's, and the
    true distances keep it."""
    doc = yaml.safe_load((SCENES / "tangram.yaml").read_text())
    assert doc["spread"] is True
    as_cut = Layout.from_dict({**doc, "spread": False})
    layout = Layout.from_file("tangram")
    outlines = [layout.footprint(i, world=False) for i in range(len(layout.pieces))]
    assert layout.spread.gap_before == pytest.approx(smallest_gap(
        [as_cut.footprint(i, world=False) for i in range(len(as_cut.pieces))], layout.frame.inner))
    assert layout.spread.gap_before == pytest.approx(0.002, abs=1e-5)
    assert layout.spread.gap > layout.spread.gap_before + 1e-3
    assert _true_gap(outlines, layout.frame.inner) >= layout.spread.gap - 1e-9
    for i, (p, q) in enumerate(zip(layout.pieces, as_cut.pieces)):
        assert np.asarray(p.object3d.position) - q.object3d.position == pytest.approx(layout.spread.shifts[i])
        assert p.object3d.yaw == q.object3d.yaw


def test_a_spread_that_is_not_true_or_false_names_the_field():
    doc = yaml.safe_load((SCENES / "tangram.yaml").read_text())
    with pytest.raises(InputError) as err:
        Layout.from_dict({**doc, "spread": "yes"})
    assert err.value.field == "spread"
