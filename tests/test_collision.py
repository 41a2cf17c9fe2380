"""python-fcl collision against an independent 2D oracle (shapely polygons).

Everything is extruded through the manipulation plane with overlapping
widths, so 3D collision equals overlap of the outlines in the plane.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
import shapely

from ungrasp_ompl.geometry import CollisionChecker
from ungrasp_ompl.mechanics import digit_polygons
from ungrasp_ompl.scene import Box


def oracle(scene, q):
    """Per state: does the thumb or finger outline overlap the table or an obstacle, or the
    object an obstacle (interiors, beyond touching)?"""
    l = scene.object_length
    thumb, finger = digit_polygons(q[:, 0], q[:, 1], q[:, 2], scene.digits)
    table = shapely.box(-1e3, -1e3, 1e3, 0.0)
    boxes = [shapely.box(b.lo[0], b.lo[1], b.hi[0], b.hi[1]) for b in scene.obstacles]
    out = []
    for i in range(len(q)):
        th = q[i, 0]
        obj = shapely.LineString([(0, 0), (l * math.cos(th), l * math.sin(th))])
        hit = False
        for outline in (thumb[i], finger[i]):
            poly = shapely.Polygon(outline * l)
            hit |= any(poly.intersection(t).area > 1e-14 for t in [table, *boxes])
        hit |= any(obj.intersects(b) and obj.intersection(b).length > 1e-9 for b in boxes)
        out.append(hit)
    return np.array(out)


@pytest.mark.parametrize("name", ["reference_asymmetric", "reference_upper_obstacle"])
def test_fcl_agrees_with_polygon_oracle(scenes, name):
    scene = scenes[name]
    if name == "reference_asymmetric":  # add a box obstacle in the digits' way too
        scene = dataclasses.replace(scene, obstacles=[Box("block", (0.02, 0.0), (0.05, 0.02))])
    rng = np.random.default_rng(2)
    n = 3000
    q = np.column_stack([rng.uniform(0, math.pi / 2, n), rng.uniform(0.3, 1, n), rng.uniform(0, math.radians(110), n)])
    fcl_hit = CollisionChecker(scene).in_collision(q)
    expected = oracle(scene, q)
    assert 0.05 < expected.mean() < 0.95
    disagree = np.flatnonzero(fcl_hit != expected)
    assert len(disagree) <= 3, q[disagree]  # at most grazing contacts, where the tolerances differ


def test_contacts_name_the_bodies(scenes):
    scene = scenes["reference_upper_obstacle"]
    # digits upright at the start's finger position: the finger reaches into the upper corner
    q = np.array([math.radians(30), 0.8, math.radians(60)])
    names = CollisionChecker(scene).contacts(q)
    assert "finger/upper_corner" in names
    assert CollisionChecker(scene).contacts(scene.start) == []
