"""The energy-bounded cage of a state: how much energy the object must gain to escape the pinch
(docs/model.md, section 4.5; the paper's sec. 3.1 and 6.2.3). Pure numpy and scipy.

The digits and the table are held where the state puts them; the object is free to move in the
manipulation plane (x along the table, z up; metres). Its planar poses are a grid over the
displacement of its centre of mass (x, z, metres) and its rotation about it (rad, turning x
toward z), centred on its pose in the state; the rotations make the whole turn, the last layer
joined to the first. A pose is *free* when the object penetrates neither the table nor any digit
(nor an obstacle) by more than a tolerance: exact for convex shapes, one vertical line of the grid
at a time, since for each rotation a shape's configuration obstacle is a convex polygon
(:func:`~ungrasp_ompl.mechanics.convex.minkowski_difference`) that meets the line in one
interval. The tolerance (default half the largest distance a point of the object moves in one
grid step) lets the contacts the state makes, and the motions that leave them, be resolved on the
grid; it shrinks with the grid.

The potential energy of a pose (J, relative to the state's pose) is the object's weight times the
rise of its centre of mass, optionally minus the work of a constant squeeze (a constant force on
the object's material point under the finger). The *escape energy* is the least, over paths of
free poses (26-connected on the grid) from the state's pose to the border of the grid's
translation box, of the highest potential on the path, minus the potential now. The box reaches
until the object lies wholly outside the bounding box of the digits and of its own pose now, so
its border is "far away": no digit can cage the object there. The escape energy is 0 when the
object can leave without gaining energy (not caged), infinite when no free path leaves at all
(fully caged).

The minimax path is found exactly on the grid. Under gravity alone the potential depends on the
row of the grid alone, and the answer is the lowest row such that the free cells up to it join the
start to the border: connected components (scipy.ndimage.label) of the rows up to a candidate,
searched upward from the start's row in doubling steps, then by bisection; each labelling covers
a window about the start that grows only while the start's component touches its faces, so a cage
costs what its pocket holds. Under a squeeze, a watershed: every free cell descends to its lowest
neighbour (ties by index) and so belongs to the basin of a local minimum; two basins are joined at
the lowest pass between them (the smallest, over adjacent cells of the two, of the higher cell's
potential), a basin reaches far away at its lowest border cell, and the lowest pass from the
start's basin to far away is a bottleneck path in the minimum spanning tree of that small graph.
Any path from the start crosses a chain of basins through passes at least that high, and
descending into each basin and climbing to its next pass never goes higher, so the value is exact.
A bisection on the energy level with connected components of the whole grid (tests/oracle.py) is
the reference the tests compare both with.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import Enum

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import breadth_first_order, connected_components, minimum_spanning_tree

from .convex import ConvexShape, minkowski_difference
from .kinematics import GRAVITY, DigitGeometry, contact_point, digit_axis, digit_bodies, digit_polygons, thumb_normal
#: The 26 neighbours of a grid cell, as index offsets; the first 13 are one of each opposite pair.
_OFFSETS = [o for o in np.ndindex(3, 3, 3) if o != (1, 1, 1)]
_OFFSETS = [tuple(int(x) - 1 for x in o) for o in _OFFSETS]
_HALF = [o for o in _OFFSETS if o > (0, 0, 0)]
_STRUCTURE = np.ones((3, 3, 3), dtype=bool)


#: The most poses a cage's grid may hold (its free-space array alone takes a byte per pose).
MAX_GRID_CELLS = 600_000_000


class GridTooLarge(ValueError):
    """A cage's pose grid would hold more than MAX_GRID_CELLS poses."""

    def __init__(self, shape: tuple[int, int, int]):
        self.shape = shape
        super().__init__(f"a pose grid of {shape[0]} x {shape[1]} x {shape[2]} cells is more than the "
                         f"{MAX_GRID_CELLS:.0e} a cage holds in memory")


@dataclass(frozen=True)
class CageGrid:
    """The grid over the object's planar poses: steps over the object length l (so one grid fits
    every object alike), angles in radians. The translation box is where the object can still
    touch the digits: its centre of mass ranges until the object lies wholly outside the bounding
    box of the digits and its own pose now (CageProblem.near); that border is "far away". The
    rotations cover the whole turn by default, joined end to end."""

    step: float = 1.0 / 48.0
    """Translation step of the centre of mass along x and z, over l."""
    rotation_step: float = math.radians(1.5)
    """Rotation step about the centre of mass, rad (rounded down to divide the turn evenly)."""
    max_rotation: float = math.pi
    """The rotations range over +-max_rotation, rad: pi (the default) is the whole turn, with no
    end; below pi, walls beyond (a cage on a narrower range is an upper bound)."""
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

    @property
    def label(self) -> str:
        """Its name in words ('fully caged'), for tables (files keep the value)."""
        return self.value.replace("_", " ")

    def describe(self) -> str:
        """What it means for the object, in words for a person."""
        return {CageOutcome.NOT_CAGED: "not caged: if the contacts let go, the object can get away without gaining "
                                       "energy",
                CageOutcome.CAGED: "caged: to get away the object must first gain energy",
                CageOutcome.FULLY_CAGED: "fully caged: the object cannot get away at any energy"}[self]


@dataclass(frozen=True)
class Cage:
    """The cage of one state: the outcome with its evidence.

    escape_energy: J (0 not caged, inf fully caged); pass_pose: the object's displacement (x, z,
    m) and rotation (rad) at a highest pose of a best escape path, None unless CAGED; spacing:
    the grid's steps (m, m, rad); shape: its cells (x, z, rotation; a whole turn repeats its
    first layer at the end); tolerance: the penetration allowed (m); free_fraction: the share of
    free poses.
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
    pose is the cell start. periodic: the rotations make the whole turn, the last layer being the
    first turned by 2 pi (the same poses), which joins the two ends."""

    x: NDArray[np.float64]
    z: NDArray[np.float64]
    rotation: NDArray[np.float64]
    start: tuple[int, int, int]
    periodic: bool = False

    @property
    def shape(self) -> tuple[int, int, int]:
        return len(self.x), len(self.z), len(self.rotation)


def pose_grid(problem: CageProblem, grid: CageGrid, length: float) -> PoseGrid:
    """The axes of the grid for an object of length l = length (m), steps grid.step l and
    grid.rotation_step: displacements of the centre of mass until the object (its radius about the
    centre) lies outside the box problem.near, and down until the centre of mass would lie below
    the table; rotations over +-grid.max_rotation, or the whole turn in steps that divide it
    (periodic) when that is pi or more. The state's pose is a grid cell."""
    h = grid.step * length
    reach = problem.radius()
    lo = np.asarray(problem.near[0], dtype=float) - reach - problem.centre
    hi = np.asarray(problem.near[1], dtype=float) + reach - problem.centre
    if problem.table:
        lo[1] = -problem.centre[1]
    n_lo = np.maximum(1, np.ceil(-lo / h - 1e-9).astype(int) + 1)
    n_hi = np.maximum(1, np.ceil(hi / h - 1e-9).astype(int))
    x = h * np.arange(-n_lo[0], n_hi[0] + 1)
    z = h * np.arange(-n_lo[1], n_hi[1] + 1)
    periodic = grid.rotation_step > 0 and grid.max_rotation >= math.pi
    if periodic:
        turn = int(math.ceil(2.0 * math.pi / grid.rotation_step - 1e-9))
        n_rot = turn // 2
        rotation = 2.0 * math.pi / turn * np.arange(-n_rot, turn - n_rot + 1)
    else:
        n_rot = int(math.floor(grid.max_rotation / grid.rotation_step + 1e-9)) if grid.rotation_step > 0 else 0
        rotation = grid.rotation_step * np.arange(-n_rot, n_rot + 1)
    return PoseGrid(x, z, rotation, (int(n_lo[0]), int(n_lo[1]), n_rot), periodic)


def _turned(points: NDArray, centre: NDArray, rotation: NDArray) -> NDArray:
    """points (k, 2) turned about centre by each rotation (nr,): (nr, k, 2)."""
    c, s = np.cos(rotation)[:, None], np.sin(rotation)[:, None]
    rel = points - centre
    return centre + np.stack([c * rel[:, 0] - s * rel[:, 1], s * rel[:, 0] + c * rel[:, 1]], axis=-1)


def free_space(problem: CageProblem, axes: PoseGrid, tolerance: float) -> NDArray[np.bool_]:
    """Free poses (nx, nz, nr): the object penetrates no obstacle and not the table by more than
    tolerance (m). Exact for convex shapes, column by column: for the object turned by r, a shape's
    configuration obstacle (the displacements where the two meet) is the convex polygon
    shape (+) (-object(r)) (convex.minkowski_difference); the poses it blocks are those closer to
    it than the two radii less the tolerance, or deeper inside it than the tolerance when the radii
    are smaller, and that set, being convex, meets each vertical line of the grid in one open
    interval of z."""
    body = problem.body
    moving = _turned(body.vertices, problem.centre, axes.rotation)  # (nr, k, 2) at zero displacement
    nz = len(axes.z)
    free = np.ones(axes.shape, dtype=bool)
    if problem.table:  # the lowest point of the object at most tolerance below the table
        lowest = moving[:, :, 1].min(axis=1) - body.radius  # (nr,)
        first = np.searchsorted(axes.z, -tolerance - lowest, side="left")
        free &= np.arange(nz)[:, None] >= first
    for shape in problem.obstacles:
        cobstacle = minkowski_difference(shape.vertices, moving)
        reach = shape.radius + body.radius - tolerance
        grow = max(reach, 0.0)  # only columns strictly inside the (grown) polygon's x-range can be blocked
        i0 = int(np.searchsorted(axes.x, cobstacle[..., 0].min() - grow, side="right"))
        i1 = int(np.searchsorted(axes.x, cobstacle[..., 0].max() + grow, side="left"))
        if i1 <= i0:
            continue
        lo, hi = _blocked_interval(cobstacle, axes.x[i0:i1], reach)
        index = np.min_scalar_type(nz)  # the smallest integers for the row comparisons below
        j_lo = np.searchsorted(axes.z, lo.T, side="right").astype(index)  # (columns, nr): rows j_lo <= j < j_hi
        j_hi = np.searchsorted(axes.z, hi.T, side="left").astype(index)
        hit = j_hi > j_lo
        if not hit.any():
            continue
        ja, jb = int(j_lo[hit].min()), int(j_hi[hit].max())
        rows = np.arange(ja, jb, dtype=index)[None, :, None]
        free[i0:i1, ja:jb] &= (rows < j_lo[:, None, :]) | (rows >= j_hi[:, None, :])
    return free


def _blocked_interval(cobstacle: NDArray, x: NDArray, reach: float) -> tuple[NDArray, NDArray]:
    """The open interval (lo, hi) of z, (nr, nx) each (lo >= hi: none), of the points (x, z) closer
    than reach (m) to the convex polygon cobstacle[r] (K, 2), CCW, when reach > 0; of its interior
    shrunk by -reach when reach <= 0. The grown polygon's boundary is made of its edges pushed
    outward by reach and of arcs of the discs about its vertices, all inside it, so on a vertical
    line its ends are the extremes of those edges and discs there."""
    v = np.moveaxis(cobstacle, 1, 0)  # (K, nr, 2): reductions over the vertices run on the first axis
    step = np.roll(v, -1, axis=0) - v
    length = np.linalg.norm(step, axis=-1, keepdims=True)
    normal = np.stack([step[..., 1], -step[..., 0]], axis=-1) / np.where(length > 0, length, 1.0)  # outward
    if reach <= 0:
        if len(v) < 3:  # a point or a segment has no interior
            empty = np.zeros((v.shape[1], len(x)))
            return empty, empty
        return _cut(normal, np.einsum("krc,krc->kr", normal, v) + reach, x)
    a = v + reach * normal  # the edges pushed outward, from a to b
    b = np.roll(v, -1, axis=0) + reach * normal
    span = (b[..., 0] - a[..., 0])[..., None]
    with np.errstate(divide="ignore", invalid="ignore"):
        s = (x - a[..., 0, None]) / span  # (K, nr, nx)
    on = (span != 0) & (s >= 0) & (s <= 1)
    z = a[..., 1, None] + s * (b[..., 1] - a[..., 1])[..., None]
    dx = x - v[..., 0, None]  # the vertices' discs
    half = np.sqrt(np.maximum(reach * reach - dx * dx, 0.0))
    inside = np.abs(dx) < reach
    centre = v[..., 1, None]
    lo = np.minimum(np.where(on, z, np.inf), np.where(inside, centre - half, np.inf)).min(axis=0)
    hi = np.maximum(np.where(on, z, -np.inf), np.where(inside, centre + half, -np.inf)).max(axis=0)
    return lo, hi


def _cut(normal: NDArray, offset: NDArray, x: NDArray) -> tuple[NDArray, NDArray]:
    """The interval [lo, hi] of z (lo > hi: empty) where normal . (x, z) <= offset holds for every
    row of normal (m, nr, 2) and offset (m, nr), on each vertical line x (nx,): (nr, nx) each. A
    row with n_z > 0 bounds z from above by the line (offset - n_x x) / n_z, one with n_z < 0 from
    below; one with n_z = 0 bounds x alone."""
    nx, nz = normal[..., 0], normal[..., 1]
    up, down, flat = nz > 0, nz < 0, nz == 0
    with np.errstate(divide="ignore", invalid="ignore"):
        a, b = offset / nz, nx / nz
    lo = (np.where(down, a, -np.inf)[..., None] - np.where(down, b, 0.0)[..., None] * x).max(axis=0)
    hi = (np.where(up, a, np.inf)[..., None] - np.where(up, b, 0.0)[..., None] * x).min(axis=0)
    if flat.any():  # n_x x <= offset: outside that range of x, nothing
        hi = np.where(np.any(flat[..., None] & (offset[..., None] - nx[..., None] * x < 0), axis=0), -np.inf, hi)
    return lo, hi


def potential(problem: CageProblem, axes: PoseGrid) -> NDArray[np.float64]:
    """Potential energy of the poses, J, relative to the state's pose: the weight times the rise of
    the centre of mass, minus the work of the constant force on its point. Shape (nx, nz, nr), or
    (1, nz, 1) without a force (it depends on the height alone; it broadcasts to the grid)."""
    u = problem.weight * axes.z[None, :, None]
    if problem.force is not None and problem.force_point is not None:
        f = np.asarray(problem.force, dtype=float)
        moved = _turned(np.asarray(problem.force_point, dtype=float)[None, :], problem.centre, axes.rotation)[:, 0]
        turn = (moved - problem.force_point) @ f  # (nr,)
        if axes.periodic:
            turn[-1] = turn[0]
        u = u - (f[0] * axes.x[:, None, None] + f[1] * axes.z[None, :, None] + turn[None, None, :])
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
                 border: NDArray[np.bool_], periodic: bool = False) -> tuple[float, int | None]:
    """The least, over 26-connected paths of free cells from start to a border cell, of the
    highest energy on the path (inf when none), and the flat index of a cell where a best path
    is highest (None when it never rises above the start or there is no path). energy broadcasts
    to free's shape; periodic: the last rotation layer is the first (PoseGrid.periodic). Exact.
    An energy that depends on the height alone and grows with it (gravity) is searched row by row
    (:func:`_row_level`). Otherwise two cheap cases come first, by connected components: a path
    that never rises above the start, and no path at all; then the watershed on the start's
    component (see the module docstring)."""
    if not free[start]:
        raise ValueError("the start cell is not free")
    rows = energy.ravel() if energy.shape[0] == energy.shape[2] == 1 else None
    if rows is not None and np.all(np.diff(rows) > 0):
        return _row_level(free, rows, start, border, periodic)
    u0 = float(np.broadcast_to(energy, free.shape)[start])
    low = energy <= u0
    below = low.any(axis=(0, 2))
    j0, j1 = int(np.argmax(below)), len(below) - int(np.argmax(below[::-1]))
    shifted = (start[0], start[1] - j0, start[2])
    if _reaches(free[:, j0:j1] & low[:, j0:j1], shifted, border[:, j0:j1], periodic):
        return u0, None
    if not _reaches(free, start, border, periodic):
        return math.inf, None
    comp = np.isin(*_component(free, start, periodic))
    box = ndimage.find_objects(comp.astype(np.int8))[0]
    level, cell = _watershed(comp[box], np.broadcast_to(energy, free.shape)[box],
                             tuple(start[k] - box[k].start for k in range(3)), border[box],
                             periodic and box[2] == slice(0, free.shape[2]))
    if cell is not None:
        sub = np.unravel_index(cell, comp[box].shape)
        cell = int(np.ravel_multi_index(tuple(sub[k] + box[k].start for k in range(3)), free.shape))
    return level, cell


def _component(mask: NDArray[np.bool_], start: tuple[int, int, int], periodic: bool
               ) -> tuple[NDArray[np.int32], NDArray[np.int64]]:
    """The 26-connected labels of mask and the labels of start's component (none: empty), the
    labels of the first and the last rotation layer joined when periodic."""
    lab, n = ndimage.label(mask, _STRUCTURE)
    s = int(lab[start])
    if s == 0:
        return lab, np.empty(0, dtype=np.int64)
    if not periodic:
        return lab, np.array([s])
    a, b = lab[..., 0].ravel(), lab[..., -1].ravel()
    keep = (a > 0) & (a != b)
    _, joined = connected_components(coo_matrix((np.ones(int(keep.sum())), (a[keep], b[keep])), shape=(n + 1, n + 1)),
                                     directed=False)
    return lab, np.flatnonzero(joined == joined[s])


def _reaches(mask: NDArray[np.bool_], start: tuple[int, int, int], border: NDArray[np.bool_], periodic: bool) -> bool:
    """Whether start's 26-connected component of mask has a border cell. Labels a window about
    start whose faces move out, each doubling its distance from start, wherever the component
    touches them, until the component lies inside the window or reaches the border: where the
    object is caged its component is a small part of the grid."""
    shape, origin = np.array(mask.shape), np.array(start)
    reach = np.full((3, 2), 8)  # each face's distance from start, below and above
    while True:
        lo, hi = np.maximum(0, origin - reach[:, 0]), np.minimum(shape, origin + reach[:, 1] + 1)
        whole_turn = periodic and (lo[2] == 0 or hi[2] == shape[2])  # the window joins the ends of the turn
        if whole_turn:
            lo[2], hi[2] = 0, shape[2]
        window = tuple(slice(int(a), int(b)) for a, b in zip(lo, hi))
        lab, ids = _component(mask[window], tuple(int(k) for k in origin - lo), whole_turn)
        if not len(ids):
            return False
        comp = np.isin(lab, ids)
        if (comp & border[window]).any():
            return True
        grown = False
        for axis in range(3 if not whole_turn else 2):
            for side, (inside, face) in enumerate(((lo[axis] > 0, 0), (hi[axis] < shape[axis], -1))):
                if inside and comp[(slice(None),) * axis + (face,)].any():
                    reach[axis, side] *= 2
                    grown = True
        if not grown:
            return False


def _row_level(free: NDArray[np.bool_], rows: NDArray[np.float64], start: tuple[int, int, int],
               border: NDArray[np.bool_], periodic: bool) -> tuple[float, int | None]:
    """escape_level for an energy rows[j] that grows with the row j: the lowest row j such that
    the free cells of rows 0 to j connect start to the border, searched upward from start's row in
    doubling steps, then by bisection; and a cell of that row next to start's component below it,
    preferably one that also touches another component below it (the saddle between the two)."""
    def reaches(j: int) -> bool:
        return _reaches(free[:, :j + 1], start, border[:, :j + 1], periodic)

    lo = start[1]
    if reaches(lo):
        return float(rows[lo]), None
    step = 1
    while True:
        hi = min(lo + step, len(rows) - 1)
        if reaches(hi):
            break
        if hi == len(rows) - 1:
            return math.inf, None
        lo, step = hi, 2 * step
    while hi - lo > 1:  # start's row and lo do not connect, hi does
        mid = (lo + hi) // 2
        if reaches(mid):
            hi = mid
        else:
            lo = mid
    lab, ids = _component(free[:, :hi], start, periodic)
    mine = np.isin(lab[:, -1], ids)
    row = free[:, hi]
    near = row & ndimage.maximum_filter(mine, size=3, mode="constant", cval=False)
    saddle = near & ndimage.maximum_filter(free[:, hi - 1] & ~mine, size=3, mode="constant", cval=False)
    i, k = np.argwhere(saddle if saddle.any() else near)[0]
    return float(rows[hi]), int(np.ravel_multi_index((i, hi, k), free.shape))


def _watershed(free: NDArray[np.bool_], energy: NDArray[np.float64], start: tuple[int, int, int],
               border: NDArray[np.bool_], periodic: bool = False) -> tuple[float, int | None]:
    """escape_level's watershed on one grid (see the module docstring); periodic: the last
    rotation layer is the first, so each of its cells is joined to its twin.

    Size: one union-find sweep over the grid's cells in the order of their energy; its steps share the
    arrays it fills as it goes, which split parts would pass back and forth."""
    shape = free.shape
    n = free.size
    flat_free = free.ravel()
    start_flat = int(np.ravel_multi_index(start, shape))
    u = np.ascontiguousarray(energy).ravel()
    order = np.argsort(u).astype(np.int32)  # by energy (any order of ties will do)
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
    ci = np.unravel_index(edge_cells, shape)
    room = [(ci[k] > 0, ci[k] < shape[k] - 1) for k in range(3)]  # a neighbour below, above along each axis
    strides = np.array([shape[1] * shape[2], shape[2], 1])
    a_list, b_list, w_list, c_list = [], [], [], []
    pairs = []
    for off in _HALF:
        inside = np.ones(len(edge_cells), dtype=bool)
        for k, o in enumerate(off):
            if o:
                inside &= room[k][o > 0]
        src = edge_cells[inside]
        pairs.append((src, src + int(np.dot(off, strides))))
    if periodic:  # a cell of the last layer and its twin in the first
        twin = np.flatnonzero(free[..., -1].ravel()) * shape[2] + shape[2] - 1
        pairs.append((twin, twin - (shape[2] - 1)))
    for src, dst in pairs:
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
    if not len(a):
        return math.inf, None
    m = n_basin + 1
    pair = np.minimum(a, b).astype(np.int64) * m + np.maximum(a, b)
    if m * m <= 1 << 22:  # the lowest pass of each pair of basins, on a table of all pairs
        lowest = np.full(m * m, np.inf)
        np.minimum.at(lowest, pair, w)
        at = np.empty(m * m, dtype=np.int64)
        hit = w == lowest[pair]
        at[pair[hit]] = cell[hit]
        keys = np.flatnonzero(np.isfinite(lowest))
        w, cell = lowest[keys], at[keys]
    else:  # too many basins for the table: sort the passes by pair, then height
        sel = np.lexsort((w, pair))
        first = np.ones(len(sel), dtype=bool)
        first[1:] = pair[sel][1:] != pair[sel][:-1]
        sel = sel[first]
        keys, w, cell = pair[sel], w[sel], cell[sel]
    a, b = keys // m, keys % m
    base = float(w.min())
    graph = coo_matrix((w - base + 1.0, (a, b)), shape=(n_basin + 1, n_basin + 1)).tocsr()
    tree = minimum_spanning_tree(graph)
    tree = tree + tree.T
    source = int(label[start_flat])
    reached, pred = breadth_first_order(tree, source, directed=False, return_predecessors=True)
    if n_basin not in set(reached.tolist()):
        return math.inf, None
    best, best_cell = -math.inf, None
    node = n_basin
    while node != source:  # walk the tree path back to the start's basin: its highest pass
        prev = int(pred[node])
        k = int(np.searchsorted(keys, min(prev, node) * m + max(prev, node)))  # keys are sorted
        if w[k] > best:
            best, best_cell = float(w[k]), int(cell[k])
        node = prev
    if best <= u_start:
        return u_start, None
    return best, best_cell


# -- a cage ----------------------------------------------------------------------------------------
def escape_energy(problem: CageProblem, grid: CageGrid, length: float) -> Cage:
    """The cage of the problem on the grid (its steps over l = length, m): outcome, escape energy
    (J) and the pass. Raises GridTooLarge for a grid of more than MAX_GRID_CELLS poses."""
    axes = pose_grid(problem, grid, length)
    if math.prod(axes.shape) > MAX_GRID_CELLS:
        raise GridTooLarge(axes.shape)
    rotation_step = float(axes.rotation[1] - axes.rotation[0]) if len(axes.rotation) > 1 else 0.0
    spacing = (float(grid.step * length), float(grid.step * length), rotation_step)
    tol = grid.tolerance
    if tol is None:
        tol = 0.5 * max(spacing[0], problem.radius() * spacing[2])
    free = free_space(problem, axes, tol)
    if axes.periodic:
        free[..., -1] = free[..., 0]
    u = potential(problem, axes)
    level, cell = escape_level(free, u, axes.start, grid_border(axes.shape), axes.periodic)
    energy = level - float(np.broadcast_to(u, axes.shape)[axes.start])
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
    kept = free[..., :-1] if axes.periodic else free
    return Cage(outcome, float(energy), pose, spacing, axes.shape, float(tol), np.count_nonzero(kept) / kept.size)


def pinch_problem(theta: float, d: float, psi: float, digits: DigitGeometry, length: float, thickness: float,
                  centre_x: float, weight: float, obstacles: tuple[NDArray, ...] = (), squeeze: float = 0.0,
                  centre_z: float | None = None) -> CageProblem:
    """The cage problem of a state (theta rad, d over l, psi rad): the object's section by the
    manipulation plane (the chord GB, thickness thick, or a curved section, digits.section; metres)
    at its pose, its centre of mass centre_x (m from G along GB) and centre_z (m above GB; None:
    half the thickness), its weight (N); the thumb, the finger
    and the housing where the state puts them, a rounded finger (digits.finger_tip_radius r > 0)
    as the robot model and the simulator build it: r shorter, its tip's corner on the face
    replaced by a disc of radius r touching the face and the shortened end; the obstacles (CCW
    polygons (k, 2), m); the table. squeeze (N): a constant force pressing the object where the
    finger does (at A, along the finger's normal).

    Size: mechanics lies below the scene, so a cage problem is made from the state's coordinates, the
    digits and the object's size, weight and obstacles given one by one."""
    c, s = math.cos(theta), math.sin(theta)
    u, top = np.array([c, s]), np.array([-s, c])
    section = digits.section if digits.section is not None and not digits.section.is_slab else None
    if section is not None:  # the curved section as the planner collides with it
        corners = section.polygon() * length
    elif thickness > 0:
        corners = np.array([[0.0, 0.0], [length, 0.0], [length, thickness], [0.0, thickness]])
    else:
        corners = np.array([[0.0, 0.0], [length, 0.0]])
    body = ConvexShape(corners[:, :1] * u + corners[:, 1:] * top)
    centre = centre_x * u + (0.5 * thickness if centre_z is None else centre_z) * top
    shapes = []
    bodies = [b[0] * length for b in digit_bodies(theta, d, psi, digits)]
    r = digits.finger_tip_radius * length
    if r > 0:  # as the robot model and the simulator build it: the finger r shorter, and a dome of radius r
        tip, base, base_back, tip_back = digit_polygons(theta, d, psi, digits)[1] * length
        cut = r / (digits.finger_length * length)  # r along the face, the back edge's share alike
        bodies[1] = np.array([tip + cut * (base - tip), base, base_back, tip_back + cut * (base_back - tip_back)])
        shapes.append(ConvexShape.disc(tip + r * (thumb_normal(theta, psi) - digit_axis(theta, psi)), r))
    near = np.vstack([bodies[0], bodies[1], body.vertices])
    near = np.array([near.min(axis=0), near.max(axis=0)])  # the digits and the object now
    shapes = [ConvexShape(b) for b in bodies] + shapes + [ConvexShape(np.asarray(o, dtype=float)) for o in obstacles]
    force = point = None
    if squeeze > 0:
        force = squeeze * np.array([s, -c])
        point = contact_point(theta, d, psi, thickness / length, digits.finger_tip_radius, section) * length
    return CageProblem(body, centre, weight, tuple(shapes), near, True, force, point)


def weight_of(mass: float) -> float:
    """The weight (N) of a mass (kg)."""
    return mass * GRAVITY
