"""Solids grown by a clearance (geometry.solids.Solid.grown) against FCL's distances, and a layout's
placed_clearance read from its file."""

from __future__ import annotations

import math

import fcl
import numpy as np
import pytest
import yaml

from conftest import SCENES
from ungrasp_ompl.errors import InputError
from ungrasp_ompl.geometry.solids import Solid, convex_shape, prism
from ungrasp_ompl.layout.model import Layout

#: The grown solid's furthest reach over the margin: at an edge of its top, the octagon's corner
#: (its circumradius over its inradius) and the margin up.
REACH = math.hypot(1.0 / math.cos(math.pi / 8), 1.0)


def _distances(solid: Solid, points: np.ndarray) -> np.ndarray:
    """FCL's distance (m) from each point (a sphere of 1 um) to the solid's convex hull; 0 inside."""
    body = fcl.CollisionObject(convex_shape(solid.vertices))
    out = []
    for p in points:
        dot = fcl.CollisionObject(fcl.Sphere(1e-6), fcl.Transform(p))
        if fcl.collide(body, dot, fcl.CollisionRequest(), fcl.CollisionResult()):
            out.append(0.0)
        else:
            out.append(fcl.distance(body, dot, fcl.DistanceRequest(), fcl.DistanceResult()) + 1e-6)
    return np.array(out)


def _inside(solid: Solid, points: np.ndarray) -> np.ndarray:
    """Whether each point lies in the solid's convex hull (scipy's facets, an oracle apart from FCL)."""
    from scipy.spatial import ConvexHull

    eq = ConvexHull(solid.vertices).equations
    return np.all(points @ eq[:, :3].T + eq[:, 3] <= 1e-12, axis=1)


def _samples(solid: Solid, margin: float, rng: np.random.Generator, floor: float | None) -> np.ndarray:
    lo, hi = solid.vertices.min(axis=0) - 2 * margin, solid.vertices.max(axis=0) + 2 * margin
    if floor is not None:
        lo[2] = floor
    return rng.uniform(lo, hi, size=(3000, 3))


@pytest.mark.parametrize("kind", ["upright", "tilted"])
def test_a_grown_solid_holds_every_point_within_its_margin_and_none_far_beyond(kind):
    """Every point nearer the solid than the margin lies in the grown solid, and none further than
    its corners' reach (margin / cos 22.5 deg across, margin up); an upright prism's foot stays
    where it was (it stands on the table), another solid grows down as well."""
    rng = np.random.default_rng(7)
    margin = 0.001
    triangle = [[0.0, 0.0], [0.03, 0.004], [0.01, 0.02]]
    if kind == "upright":
        solid, floor = prism("piece", triangle, 0.0, 0.003), 0.0
    else:
        tetra = np.array([[0.0, 0.0, 0.01], [0.02, 0.0, 0.012], [0.005, 0.02, 0.011], [0.01, 0.01, 0.03]])
        solid, floor = Solid("block", tetra), None
    grown = solid.grown(margin)
    points = _samples(solid, margin, rng, floor)
    dist, inside = _distances(solid, points), _inside(grown, points)
    near, far = dist < margin * (1 - 1e-6), dist > margin * REACH * (1 + 1e-6)
    assert near.sum() > 100 and far.sum() > 100 and (~near & ~far).sum() > 10  # every band is sampled
    assert inside[near].all()
    assert not inside[far].any()
    low = grown.vertices[:, 2].min()
    assert low == pytest.approx(0.0 if kind == "upright" else solid.vertices[:, 2].min() - margin, abs=1e-12)
    assert grown.vertices[:, 2].max() == pytest.approx(solid.vertices[:, 2].max() + margin, abs=1e-12)
    assert (grown.upright_foot() is not None) == (kind == "upright") and grown.name == solid.name


def test_no_margin_leaves_the_solid_as_it_is():
    solid = prism("piece", [[0.0, 0.0], [0.01, 0.0], [0.0, 0.01]], 0.0, 0.002)
    assert solid.grown(0.0) is solid


def _tangram(tmp_path, **top) -> Layout:
    doc = yaml.safe_load((SCENES / "tangram.yaml").read_text())
    doc.update(top)
    path = tmp_path / "layout.yaml"
    path.write_text(yaml.safe_dump(doc))
    return Layout.from_file(path)


def test_a_layout_grows_its_pieces_down_by_its_placed_clearance_and_not_its_walls(tmp_path):
    """A piece down, as a later piece's scene holds it, is the piece at its target grown by the
    layout's placed_clearance; the walls are as the frame has them."""
    bare, kept = _tangram(tmp_path, placed_clearance=0.0), _tangram(tmp_path, placed_clearance=0.0015)
    for layout, clearance in ((bare, 0.0), (kept, 0.0015)):
        scene = layout.scene(1, placed=[0])
        walls, (down,) = scene.solids[:-1], scene.solids[-1:]
        assert [w.vertices.tolist() for w in walls] == [w.vertices.tolist() for w in layout.frame.walls()]
        foot = layout.footprint(0)
        rng = np.random.default_rng(3)
        edge = rng.integers(len(foot), size=200)
        t = rng.uniform(size=(200, 1))
        on = foot[edge] + t * (np.roll(foot, -1, axis=0)[edge] - foot[edge])  # points on the target's outline
        top = layout.pieces[0].object3d.thickness + clearance
        dist = _distances(down, np.column_stack([on, np.full(200, top)]))
        assert dist.max() < 1e-9  # the top's outline lies on the grown solid
        assert down.vertices[:, 2].max() == pytest.approx(top, abs=1e-12)
    assert Layout.from_file(SCENES / "tangram.yaml").placed_clearance == 0.001


def test_a_negative_placed_clearance_names_the_field(tmp_path):
    with pytest.raises(InputError) as err:
        _tangram(tmp_path, placed_clearance=-0.001)
    assert err.value.field == "placed_clearance"
