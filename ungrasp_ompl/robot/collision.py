"""Collision of the arm and gripper with the table and the scene's obstacles (python-fcl).

The robot's collision shapes come from its Pinocchio geometry model (boxes and
cylinders), placed by forward kinematics. The table fills z < -TABLE_GAP in
the world: the digits may touch the table's surface (the thumb tip closes in
on it at the end) but not enter it. The scene's obstacles are boxes of the
manipulation plane, extruded through it, and its solids (a frame's walls, pieces
placed already) are convex bodies in the world. The held object is excluded. The
arm's base and shoulder are mounted on the table and are not checked against it.
"""

from __future__ import annotations

import fcl
import numpy as np
import pinocchio as pin
from numpy.typing import NDArray

from ..scene import Scene
from .model import RobotModel, configuration

TABLE_GAP = 5e-4  # m: how far below z = 0 the table's solid starts for the robot checks
_MOUNTED = ("shoulder_link",)  # links resting on the table with the base


def _fcl_shape(geometry) -> fcl.CollisionGeometry:
    kind = type(geometry).__name__
    if kind == "Box":
        return fcl.Box(*(2 * np.asarray(geometry.halfSide)))
    if kind == "Cylinder":
        return fcl.Cylinder(geometry.radius, 2 * geometry.halfLength)
    raise ValueError(f"unsupported collision shape {kind}")


def _reach(geometry) -> float:
    """Radius (m) of a ball about the shape's centre holding the whole shape (box or cylinder)."""
    if type(geometry).__name__ == "Box":
        return float(np.linalg.norm(geometry.halfSide))
    return float(np.hypot(geometry.radius, geometry.halfLength))


class RobotCollisionChecker:
    """Checks robot configurations against the table and the scene's obstacles."""

    def __init__(self, robot: RobotModel, scene: Scene, plane_frame: NDArray):
        self.robot = robot
        self.geom = robot.collision_model
        self.gdata = pin.GeometryData(self.geom)
        self.links = [(g.name, fcl.CollisionObject(_fcl_shape(g.geometry)), _reach(g.geometry))
                      for g in self.geom.geometryObjects]
        big = 10.0
        table = fcl.CollisionObject(fcl.Box(2 * big, 2 * big, big), fcl.Transform(np.array([0.0, 0.0, -big / 2 - TABLE_GAP])))
        #: (name, FCL object, world bounding box (2, 3) low/high corners, m)
        self.targets = [("table", table, np.array([[-big, -big, -big - TABLE_GAP], [big, big, -TABLE_GAP]]))]
        rot = plane_frame[:3, :3]
        for box in scene.obstacles:
            lo, hi = np.array(box.lo), np.array(box.hi)
            size, centre = hi - lo, (hi + lo) / 2
            world_centre = rot @ np.array([centre[0], 0.0, centre[1]]) + plane_frame[:3, 3]
            half = np.array([size[0], 1.0, size[1]]) / 2  # 1 m through the plane
            shape = fcl.Box(*(2 * half))
            extent = np.abs(rot) @ half
            self.targets.append((box.name, fcl.CollisionObject(shape, fcl.Transform(rot, world_centre)),
                                 np.array([world_centre - extent, world_centre + extent])))
        for solid in scene.solids:  # already in the world frame
            self.targets.append((solid.name, fcl.CollisionObject(solid.shape()),
                                 np.array([solid.vertices.min(axis=0), solid.vertices.max(axis=0)])))
        self.request = fcl.CollisionRequest()
        self._boxes = np.array([box for _, _, box in self.targets])  # (T, 2, 3)
        self._reach2 = np.array([reach for _, _, reach in self.links])[:, None] ** 2
        #: which (link, target) pairs are checked: not the links mounted on the table against it
        self._checked = np.ones((len(self.links), len(self.targets)), dtype=bool)
        for li, (name, _, _) in enumerate(self.links):
            self._checked[li, 0] = not any(name.startswith(m) for m in _MOUNTED)

    def collisions(self, q: NDArray) -> list[str]:
        """The colliding (link, obstacle) pairs of one configuration (6 or 7 values) as 'link/obstacle'."""
        model, data = self.robot.model, self.robot.data
        pin.forwardKinematics(model, data, configuration(self.robot, q))
        pin.updateGeometryPlacements(model, data, self.geom, self.gdata)
        placements = self.gdata.oMg
        # broad phase, all pairs at once: FCL only where a link's ball reaches a target's box
        centres = np.array([p.translation for p in placements])[:, None, :]
        gap = centres - np.clip(centres, self._boxes[None, :, 0], self._boxes[None, :, 1])
        near = (np.einsum("ltk,ltk->lt", gap, gap) <= self._reach2) & self._checked
        hits = []
        for li, ti in zip(*(ix.tolist() for ix in np.nonzero(near))):
            name, obj, _ = self.links[li]
            if ti == 0 or not near[li, :ti].any():  # first target of this link: place it
                obj.setTransform(fcl.Transform(placements[li].rotation, placements[li].translation))
            target_name, target, _ = self.targets[ti]
            if fcl.collide(obj, target, self.request, fcl.CollisionResult()):
                hits.append(f"{name}/{target_name}")
        return hits

    def first_collision(self, path: NDArray) -> tuple[int, list[str]] | None:
        """The first configuration of a path (N, 6 or 7) in collision and its pairs, or None."""
        for i, q in enumerate(path):
            hits = self.collisions(q)
            if hits:
                return i, hits
        return None
