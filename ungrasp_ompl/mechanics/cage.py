"""The energy-bounded cage of a state: how much energy the object must gain to escape the pinch
(docs/model.md, section 4.5; the paper's sec. 3.1 and 6.2.3). Pure numpy and scipy.

The digits and the table are held where the state puts them; the object is free to move in the
manipulation plane (x along the table, z up; metres). Its planar poses are a grid over the
displacement of its centre of mass (x, z, metres) and its rotation about it (rad, turning x
toward z), centred on its pose in the state. A pose is *free* when the object penetrates neither
the table nor any digit (nor an obstacle) by more than a tolerance: the exact signed distances of
convex shapes (:mod:`~ungrasp_ompl.mechanics.convex`), evaluated for all poses at once by the
separating-axis form of the configuration obstacles. The tolerance (default half the largest
distance a point of the object moves in one grid step) lets the contacts the state makes, and
the motions that leave them, be resolved on the grid; it shrinks with the grid.

The potential energy of a pose (J, relative to the state's pose) is the object's weight times the
rise of its centre of mass, optionally minus the work of a constant squeeze (a constant force on
the object's material point under the finger). The *escape energy* is the least, over paths of
free poses (26-connected on the grid) from the state's pose to the border of the grid's
translation box, of the highest potential on the path, minus the potential now. The box reaches
until the object lies wholly outside the bounding box of the digits and of its own pose now, so
its border is "far away": no digit can cage the object there. The escape energy is
0 when the object can leave without gaining energy (not caged), infinite when no free path leaves
at all (fully caged). Rotations beyond the grid's range are walls, so a cage on a narrower range
is an upper bound of the cage on a wider one.

The minimax path is computed exactly on the grid by a watershed: every free cell descends to its
lowest neighbour (ties by index) and so belongs to the basin of a local minimum; two basins are
joined at the lowest pass between them (the smallest, over adjacent cells of the two, of the
higher cell's potential), a basin reaches far away at its lowest border cell, and the lowest
pass from the start's basin to far away is a bottleneck path in the minimum spanning tree of that
small graph. Any path from the start crosses a chain of basins through passes at least that high,
and descending into each basin and climbing to its next pass never goes higher, so the value is
exact. :func:`escape_level_bisection`, a bisection on the energy level with connected components
(scipy.ndimage.label), is the reference the tests compare it with.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import Enum

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import breadth_first_order, minimum_spanning_tree

from .convex import ConvexShape, edges, signed_distance
from .kinematics import DigitGeometry, digit_axis, digit_bodies, finger_corner, thumb_normal

#: Standard gravity, m/s^2.
GRAVITY = 9.81
#: The 26 neighbours of a grid cell, as index offsets; the first 13 are one of each opposite pair.
_OFFSETS = [o for o in np.ndindex(3, 3, 3) if o != (1, 1, 1)]
_OFFSETS = [tuple(int(x) - 1 for x in o) for o in _OFFSETS]
_HALF = [o for o in _OFFSETS if o > (0, 0, 0)]
_STRUCTURE = np.ones((3, 3, 3), dtype=bool)


@dataclass(frozen=True)
class CageGrid:
    """The grid over the object's planar poses: steps over the object length l (so one grid fits
    every object alike), angles in radians. The translation box is where the object can still
    touch the digits: its centre of mass ranges until the object lies wholly outside the bounding
    box of the digits and its own pose now (CageProblem.near); that border is "far away"."""

    step: float = 1.0 / 48.0
    """Translation step of the centre of mass along x and z, over l (the default resolves a pick
    0.96 mm thick: its cages agree with a grid twice as fine on the states of a plan)."""
    rotation_step: float = math.radians(1.5)
    """Rotation step about the centre of mass, rad."""
    max_rotation: float = math.radians(45.0)
    """The rotations range over +-max_rotation, rad (walls beyond)."""
    tolerance: float | None = None
    """Penetration allowed, m; None: half the largest distance a point of the object moves in one
    grid step."""

    def refined(self, factor: float = 2.0) -> "CageGrid":
        """The same grid with its steps (and a given tolerance) divided by factor."""
        return CageGrid(self.step / factor, self.rotation_step / factor, self.max_rotation,
                        None if self.tolerance is None else self.tolerance / factor)


class CageOutcome(Enum):
    """Whether the object is caged at a state, by its escape energy."""

    #: It reaches far away without gaining energy (escape energy 0).
    NOT_CAGED = "not_caged"
    #: It must gain a finite, positive energy to escape (an energy-bounded cage).
    CAGED = "caged"
    #: No free path leads far away at any energy.
    FULLY_CAGED = "fully_caged"


@dataclass(frozen=True)
class Cage:
    """The cage of one state: the outcome with its evidence.

    escape_energy: J (0 not caged, inf fully caged); pass_pose: the object's displacement (x, z,
    m) and rotation (rad) at the highest pose of the best escape path, None unless CAGED;
    spacing: the grid's steps (m, m, rad); shape: its cells (x, z, rotation); tolerance: the
    penetration allowed (m); free_fraction: the share of free cells.
    """

    outcome: CageOutcome
    escape_energy: float
    pass_pose: tuple[float, float, float] | None
    spacing: tuple[float, float, float]
    shape: tuple[int, int, int]
    tolerance: float
    free_fraction: float

    @property
    def escape_energy_mj(self) -> float:
        """The escape energy in millijoules (for printing)."""
        return self.escape_energy * 1000.0

    def to_dict(self) -> dict:
        return {"outcome": self.outcome.value, "escape_energy_mj": self.escape_energy_mj,
                "pass_pose": None if self.pass_pose is None else
                {"x_mm": self.pass_pose[0] * 1000, "z_mm": self.pass_pose[1] * 1000,
                 "rotation_deg": math.degrees(self.pass_pose[2])},
                "spacing": {"x_mm": self.spacing[0] * 1000, "z_mm": self.spacing[1] * 1000,
                            "rotation_deg": math.degrees(self.spacing[2])},
                "shape": list(self.shape), "tolerance_mm": self.tolerance * 1000, "free_fraction": self.free_fraction}


@dataclass(frozen=True)
class CageProblem:
    """The bodies of a cage, in plane coordinates (metres): the object at its current pose, its
    centre of mass, its weight (N), the fixed convex shapes around it, the box near ((2, 2): lower
    and upper corner) beyond which the object is far away (it can touch nothing that cages it
    there), whether the table (z <= 0) is there, and an optional constant force (N, (2,)) acting
    on the object's material point force_point (its position now)."""

    body: ConvexShape
    centre: NDArray[np.float64]
    weight: float
    obstacles: tuple[ConvexShape, ...]
    near: NDArray[np.float64]
    table: bool = True
    force: NDArray[np.float64] | None = None
    force_point: NDArray[np.float64] | None = None

    def radius(self) -> float:
        """The largest distance of a point of the object from its centre of mass, m."""
        return float(np.linalg.norm(self.body.vertices - self.centre, axis=1).max()) + self.body.radius


# -- the grid --------------------------------------------------------------------------------------
@dataclass(frozen=True)
class PoseGrid:
    """Grid axes: displacements x (nx,), z (nz,) in metres and rotations (nr,) in rad; the state's
    pose is the cell start."""

    x: NDArray[np.float64]
    z: NDArray[np.float64]
    rotation: NDArray[np.float64]
    start: tuple[int, int, int]

    @property
    def shape(self) -> tuple[int, int, int]:
        return len(self.x), len(self.z), len(self.rotation)


def pose_grid(problem: CageProblem, grid: CageGrid, length: float) -> PoseGrid:
    """The axes of the grid for an object of length l = length (m), steps grid.step l and
    grid.rotation_step: displacements of the centre of mass until the object (its radius about the
    centre) lies outside the box problem.near, and down until the centre of mass would lie below
    the table; rotations over +-grid.max_rotation. The state's pose is a grid cell."""
    h = grid.step * length
    reach = problem.radius()
    lo = np.asarray(problem.near[0], dtype=float) - reach - problem.centre
    hi = np.asarray(problem.near[1], dtype=float) + reach - problem.centre
    if problem.table:
        lo[1] = -problem.centre[1]
    n_lo = np.maximum(1, np.ceil(-lo / h - 1e-9).astype(int) + 1)
    n_hi = np.maximum(1, np.ceil(hi / h - 1e-9).astype(int))
    n_rot = int(math.floor(grid.max_rotation / grid.rotation_step + 1e-9)) if grid.rotation_step > 0 else 0
    x = h * np.arange(-n_lo[0], n_hi[0] + 1)
    z = h * np.arange(-n_lo[1], n_hi[1] + 1)
    rotation = grid.rotation_step * np.arange(-n_rot, n_rot + 1)
    return PoseGrid(x, z, rotation, (int(n_lo[0]), int(n_lo[1]), n_rot))


def _turned(points: NDArray, centre: NDArray, rotation: NDArray) -> NDArray:
    """points (k, 2) turned about centre by each rotation (nr,): (nr, k, 2)."""
    c, s = np.cos(rotation)[:, None], np.sin(rotation)[:, None]
    rel = points - centre
    return centre + np.stack([c * rel[:, 0] - s * rel[:, 1], s * rel[:, 0] + c * rel[:, 1]], axis=-1)


def free_space(problem: CageProblem, axes: PoseGrid, tolerance: float) -> NDArray[np.bool_]:
    """Free poses (nx, nz, nr): the object penetrates no obstacle and not the table by more than
    tolerance (m). Exact for convex shapes: the configuration obstacle of a shape S for the object
    turned by r is S (+) (-object(r)), whose edge normals are those of S and of the turned object;
    the largest offset of the displacement beyond those edges is minus the penetration depth
    inside it, and where it is positive but below the radii the exact gap decides."""
    body = problem.body
    moving = _turned(body.vertices, problem.centre, axes.rotation)  # (nr, k, 2) at zero displacement
    free = np.ones(axes.shape, dtype=bool)
    if problem.table:
        lowest = moving[:, :, 1].min(axis=1) - body.radius  # (nr,)
        free &= axes.z[None, :, None] + lowest[None, None, :] >= -tolerance
    _, own_normal, _ = edges(body.vertices)  # the object's edge normals at rotation 0
    turned_normal = _turned(own_normal, np.zeros(2), axes.rotation) if len(own_normal) else np.empty((len(axes.rotation), 0, 2))
    reach = problem.radius()
    for shape in problem.obstacles:
        verts = shape.vertices
        # only displacements that bring the object within reach of the shape's bounding box
        lo_c = verts.min(axis=0) - shape.radius - reach - problem.centre
        hi_c = verts.max(axis=0) + shape.radius + reach - problem.centre
        i0, i1 = int(np.searchsorted(axes.x, lo_c[0], side="left")), int(np.searchsorted(axes.x, hi_c[0], side="right"))
        j0, j1 = int(np.searchsorted(axes.z, lo_c[1], side="left")), int(np.searchsorted(axes.z, hi_c[1], side="right"))
        if i1 <= i0 or j1 <= j0:
            continue
        x, z = axes.x[i0:i1, None, None], axes.z[None, j0:j1, None]
        _, normal, offset = edges(verts)
        worst = np.full((i1 - i0, j1 - j0, len(axes.rotation)), -np.inf)
        for n, h in zip(normal, offset):  # the shape's own edges
            lo = (moving @ n).min(axis=1) - h  # (nr,)
            np.maximum(worst, (n[0] * x + n[1] * z) + lo[None, None, :], out=worst)
        for j in range(turned_normal.shape[1]):  # the turned object's edges
            nr = turned_normal[:, j]  # (nr, 2)
            gap = (verts @ nr.T).min(axis=0) - np.einsum("rkc,rc->rk", moving, nr).max(axis=1)  # (nr,)
            np.maximum(worst, gap[None, None, :] - nr[:, 0][None, None, :] * x - nr[:, 1][None, None, :] * z, out=worst)
        if not np.isfinite(worst).all():  # two points: no edge at all
            worst = np.where(np.isfinite(worst), worst, 0.0)
        need = shape.radius + body.radius - tolerance
        ok = worst >= need
        block = free[i0:i1, j0:j1]
        if need > 0:  # a gap below the radii: the exact distance of the polygons decides
            band = np.flatnonzero(((worst >= 0) & ~ok & block).ravel())
            if len(band):
                i, j, k = np.unravel_index(band, worst.shape)
                placed = moving[k] + np.stack([axes.x[i0 + i], axes.z[j0 + j]], axis=-1)[:, None, :]
                ok.flat[band] = signed_distance(placed, verts) >= need
        block &= ok
    return free


def potential(problem: CageProblem, axes: PoseGrid) -> NDArray[np.float64]:
    """Potential energy of every pose (nx, nz, nr), J, relative to the state's pose: the weight
    times the rise of the centre of mass, minus the work of the constant force on its point."""
    u = np.broadcast_to(problem.weight * axes.z[None, :, None], axes.shape).copy()
    if problem.force is not None and problem.force_point is not None:
        f = np.asarray(problem.force, dtype=float)
        moved = _turned(np.asarray(problem.force_point, dtype=float)[None, :], problem.centre, axes.rotation)[:, 0]
        turn = (moved - problem.force_point) @ f  # (nr,)
        u -= f[0] * axes.x[:, None, None] + f[1] * axes.z[None, :, None] + turn[None, None, :]
    return u


# -- the minimax search ----------------------------------------------------------------------------
def grid_border(shape: tuple[int, int, int]) -> NDArray[np.bool_]:
    """Cells on the faces of the translation box (x or z first or last): far away (below the table
    nothing is free)."""
    out = np.zeros(shape, dtype=bool)
    out[[0, -1], :, :] = True
    out[:, [0, -1], :] = True
    return out


def escape_level(free: NDArray[np.bool_], energy: NDArray[np.float64], start: tuple[int, int, int],
                 border: NDArray[np.bool_]) -> tuple[float, int | None]:
    """The least, over 26-connected paths of free cells from start to a border cell, of the
    highest energy on the path (inf when none), and the flat index of a cell where a best path
    is highest (None when it never rises above the start or there is no path). Exact (watershed,
    see the module docstring). Two cheap cases first, by connected components: a path that never
    rises above the start, and no path at all; the watershed then runs on the start's component."""
    if not free[start]:
        raise ValueError("the start cell is not free")
    u0 = energy[start]
    below = (energy <= u0).any(axis=(0, 2))
    j0, j1 = int(np.argmax(below)), len(below) - int(np.argmax(below[::-1]))
    lab, _ = ndimage.label(free[:, j0:j1] & (energy[:, j0:j1] <= u0), _STRUCTURE)
    if np.any(lab[border[:, j0:j1]] == lab[start[0], start[1] - j0, start[2]]):
        return float(u0), None
    lab, _ = ndimage.label(free, _STRUCTURE)
    comp = lab == lab[start]
    if not np.any(comp[border]):
        return math.inf, None
    box = ndimage.find_objects(comp.astype(np.int8))[0]
    level, cell = _watershed(comp[box], energy[box], tuple(start[k] - box[k].start for k in range(3)), border[box])
    if cell is not None:
        sub = np.unravel_index(cell, comp[box].shape)
        cell = int(np.ravel_multi_index(tuple(sub[k] + box[k].start for k in range(3)), free.shape))
    return level, cell


def _watershed(free: NDArray[np.bool_], energy: NDArray[np.float64], start: tuple[int, int, int],
               border: NDArray[np.bool_]) -> tuple[float, int | None]:
    """escape_level's watershed on one grid (see the module docstring)."""
    shape = free.shape
    n = free.size
    flat_free = free.ravel()
    start_flat = int(np.ravel_multi_index(start, shape))
    if not flat_free[start_flat]:
        raise ValueError("the start cell is not free")
    u = energy.ravel()
    order = _order(energy)
    rank = np.empty(n, dtype=np.int32)
    rank[order] = np.arange(n, dtype=np.int32)
    rank[~flat_free] = n
    low = ndimage.minimum_filter(rank.reshape(shape), size=3, mode="constant", cval=n).ravel()
    parent = np.arange(n, dtype=np.int32)
    parent[flat_free] = order[low[flat_free]]
    while True:  # pointer jumping to each cell's basin root
        nxt = parent[parent]
        if np.array_equal(nxt, parent):
            break
        parent = nxt
    u_start = float(u[start_flat])
    is_root = flat_free & (parent == np.arange(n))
    root_id = np.cumsum(is_root, dtype=np.int32) - 1
    n_basin = int(is_root.sum())
    label = np.where(flat_free, root_id[parent], -1).astype(np.int32)
    # passes between basins: adjacent free cells of different basins, the higher cell's energy
    lab3 = label.reshape(shape)
    hi = ndimage.maximum_filter(lab3, size=3, mode="constant", cval=-1)
    lo = ndimage.minimum_filter(np.where(lab3 >= 0, lab3, n_basin), size=3, mode="constant", cval=n_basin)
    edge_cells = np.flatnonzero(flat_free & ((hi.ravel() > label) | (lo.ravel() < label)))
    ci = np.array(np.unravel_index(edge_cells, shape))  # (3, m)
    a_list, b_list, w_list, c_list = [], [], [], []
    for off in _HALF:
        nb = ci + np.array(off)[:, None]
        inside = np.all((nb >= 0) & (nb < np.array(shape)[:, None]), axis=0)
        src = edge_cells[inside]
        dst = np.ravel_multi_index(tuple(nb[:, inside]), shape)
        keep = flat_free[dst] & (label[dst] != label[src])
        src, dst = src[keep], dst[keep]
        higher = np.where(u[dst] > u[src], dst, src)
        a_list.append(label[src])
        b_list.append(label[dst])
        w_list.append(u[higher])
        c_list.append(higher)
    # far away: each basin's lowest border cell, as a pass to the extra node n_basin
    bcells = np.flatnonzero(flat_free & border.ravel())
    a_list.append(label[bcells])
    b_list.append(np.full(len(bcells), n_basin))
    w_list.append(u[bcells])
    c_list.append(bcells)
    a, b = np.concatenate(a_list), np.concatenate(b_list)
    w, cell = np.concatenate(w_list), np.concatenate(c_list)
    a, b = np.minimum(a, b), np.maximum(a, b)
    if not len(a):
        return math.inf, None
    pair = a * (n_basin + 1) + b
    sel = np.lexsort((w, pair))
    first = np.ones(len(sel), dtype=bool)
    first[1:] = pair[sel][1:] != pair[sel][:-1]
    sel = sel[first]  # the lowest pass of each pair of basins
    a, b, w, cell = a[sel], b[sel], w[sel], cell[sel]
    base = float(w.min())
    graph = coo_matrix((w - base + 1.0, (a, b)), shape=(n_basin + 1, n_basin + 1)).tocsr()
    tree = minimum_spanning_tree(graph)
    tree = tree + tree.T
    source = int(label[start_flat])
    reached, pred = breadth_first_order(tree, source, directed=False, return_predecessors=True)
    if n_basin not in set(reached.tolist()):
        return math.inf, None
    best, best_cell = -math.inf, None
    keys = pair[sel]  # sorted
    node = n_basin
    while node != source:  # walk the tree path back to the start's basin: its highest pass
        prev = int(pred[node])
        k = int(np.searchsorted(keys, min(prev, node) * (n_basin + 1) + max(prev, node)))
        if w[k] > best:
            best, best_cell = float(w[k]), int(cell[k])
        node = prev
    if best <= u_start:
        return u_start, None
    return best, best_cell


def _order(energy: NDArray[np.float64]) -> NDArray[np.int32]:
    """Flat indices of the cells sorted by (energy, flat index). When the energy depends on the
    second axis alone and grows along it (gravity without squeeze) the order is built directly,
    layer by layer, without a sort."""
    layer = energy[0, :, 0]
    if energy.shape[1] > 1 and np.all(np.diff(layer) > 0) and np.array_equal(energy, np.broadcast_to(layer[None, :, None], energy.shape)):
        nx, nz, nr = energy.shape
        i = np.arange(nx, dtype=np.int32)[None, :, None]
        k = np.arange(nr, dtype=np.int32)[None, None, :]
        j = np.arange(nz, dtype=np.int32)[:, None, None]
        return ((i * nz + j) * nr + k).ravel()
    return np.argsort(energy.ravel(), kind="stable").astype(np.int32)


def escape_level_bisection(free: NDArray[np.bool_], energy: NDArray[np.float64], start: tuple[int, int, int],
                           border: NDArray[np.bool_]) -> float:
    """The same minimax level as :func:`escape_level`, by brute force: bisection over the sorted
    energies of the free cells, connectivity by scipy.ndimage.label (26-connected). The reference."""
    def connected(level: float) -> bool:
        lab, _ = ndimage.label(free & (energy <= level), _STRUCTURE)
        s = lab[start]
        return bool(s > 0 and np.any(lab[border] == s))

    levels = np.unique(energy[free])
    levels = levels[levels >= energy[start]]
    if not connected(levels[-1]):
        return math.inf
    lo, hi = -1, len(levels) - 1  # not connected at levels[lo] (or below all), connected at levels[hi]
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if connected(levels[mid]):
            hi = mid
        else:
            lo = mid
    return float(levels[hi])


# -- a cage ----------------------------------------------------------------------------------------
def escape_energy(problem: CageProblem, grid: CageGrid, length: float) -> Cage:
    """The cage of the problem on the grid (its steps over l = length, m): outcome, escape energy
    (J) and the pass."""
    axes = pose_grid(problem, grid, length)
    spacing = (float(grid.step * length), float(grid.step * length), float(grid.rotation_step))
    tol = grid.tolerance
    if tol is None:
        tol = 0.5 * max(spacing[0], problem.radius() * spacing[2] if len(axes.rotation) > 1 else 0.0)
    free = free_space(problem, axes, tol)
    u = potential(problem, axes)
    level, cell = escape_level(free, u, axes.start, grid_border(axes.shape))
    energy = level - float(u[axes.start])
    if math.isinf(level):
        outcome = CageOutcome.FULLY_CAGED
    elif energy <= 0.0:
        outcome, energy = CageOutcome.NOT_CAGED, 0.0
    else:
        outcome = CageOutcome.CAGED
    pose = None
    if cell is not None and outcome is CageOutcome.CAGED:
        i, j, k = np.unravel_index(cell, axes.shape)
        pose = (float(axes.x[i]), float(axes.z[j]), float(axes.rotation[k]))
    return Cage(outcome, float(energy), pose, spacing, axes.shape, float(tol), float(free.mean()))


def pinch_problem(theta: float, d: float, psi: float, digits: DigitGeometry, length: float, thickness: float,
                  centre_x: float, weight: float, obstacles: tuple[NDArray, ...] = (), squeeze: float = 0.0
                  ) -> CageProblem:
    """The cage problem of a state (theta rad, d over l, psi rad): the object's section by the
    manipulation plane (the chord GB, thickness thick; metres) at its pose, its centre of mass
    centre_x (m from G along GB, half the thickness up), its weight (N); the thumb, the finger
    (its tip rounded with digits.finger_tip_radius: the corner cut and a disc) and the housing
    where the state puts them; the obstacles (CCW polygons (k, 2), m); the table. squeeze (N):
    a constant force pressing the object where the finger does (at A, along the finger's normal)."""
    c, s = math.cos(theta), math.sin(theta)
    u, top = np.array([c, s]), np.array([-s, c])
    corners = np.array([[0.0, 0.0], [length, 0.0], [length, thickness], [0.0, thickness]]) if thickness > 0 else \
        np.array([[0.0, 0.0], [length, 0.0]])
    body = ConvexShape(corners[:, :1] * u + corners[:, 1:] * top)
    centre = centre_x * u + 0.5 * thickness * top
    shapes = []
    bodies = [b[0] * length for b in digit_bodies(theta, d, psi, digits)]
    r = digits.finger_tip_radius * length
    if r > 0:  # the finger's tip corner (vertex 0) rounded: the corner cut off, and the dome
        e = digit_axis(theta, psi)
        n_b = thumb_normal(theta, psi)
        finger = bodies[1]
        corner = finger[np.argmin(np.linalg.norm(finger - finger_corner(theta, d, psi, digits.object_thickness, digits.finger_tip_radius) * length, axis=1))]
        cut = np.vstack([finger[np.any(finger != corner, axis=1)], [corner - r * e, corner + r * n_b]])
        bodies[1] = cut
        shapes.append(ConvexShape.disc(corner + r * (n_b - e), r))
    near = np.vstack([bodies[0], bodies[1], body.vertices])
    near = np.array([near.min(axis=0), near.max(axis=0)])  # the digits and the object now
    shapes = [ConvexShape(b) for b in bodies] + shapes + [ConvexShape(np.asarray(o, dtype=float)) for o in obstacles]
    force = point = None
    if squeeze > 0:
        force = squeeze * np.array([s, -c])
        point = (1.0 - d) * length * u + thickness * top
    return CageProblem(body, centre, weight, tuple(shapes), near, True, force, point)


def weight_of(mass: float) -> float:
    """The weight (N) of a mass (kg)."""
    return mass * GRAVITY


__all__ = ["Cage", "CageGrid", "CageOutcome", "CageProblem", "GRAVITY", "PoseGrid", "escape_energy", "escape_level",
           "escape_level_bisection", "free_space", "grid_border", "pinch_problem", "pose_grid", "potential",
           "weight_of"]
