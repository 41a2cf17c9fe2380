"""Pictures of the configuration space: the C-space map and a plan drawn in it (matplotlib)."""

from __future__ import annotations

import math
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.colors import ListedColormap  # noqa: E402

from ..geometry.collision import CollisionChecker  # noqa: E402
from ..planning.atlas import SecurityAtlas, planning_box  # noqa: E402
from ..planning.result import HoldableMap, Plan  # noqa: E402
from ..scene import Scene  # noqa: E402
from .common import legend_marks, save_png  # noqa: E402

#: Labels of the C-space map's state classes (scene.StateClass values, in drawing order).
REGION_CLASSES = ("free (force-closed)", "not force-closed", "in collision", "kinematically invalid")
_REGION_COLOURS = ("#7fc97f", "#fdc086", "#e7298a", "#bdbdbd")
_PRIMITIVE_COLOURS = {"P_theta": "#1b9e77", "P_psi": "#d95f02", "P_dpsi": "#7570b3"}
#: The state's coordinates (theta, d, psi) as axes name them: in words, with the plotted units
#: (docs/model.md, section 2.2).
AXIS_LABELS = ("theta: object-table angle at G (deg)", "d: A's distance from B (fraction of l = |GB|)",
              "psi: object-thumb angle at B (deg)")


def draw_regions(scene: Scene, path: str | os.PathLike[str], d_values: int = 6, step_deg: float = 1.0,
                 plan: Plan | None = None) -> None:
    """Write regions_figure's picture to path (PNG)."""
    save_png(regions_figure(scene, d_values, step_deg, plan), path, fast=True)


#: The class of a kinematically invalid state (scene.StateClass.KINEMATICS's value).
_INVALID = 3
#: The share of a slice's states (0-1) that other classes than its commonest must cover for it to be drawn.
_REGION_OTHERS = 0.03
#: Candidate values of d that regions_figure screens for slices that carry information (count).
_REGION_CANDIDATES = 24


def regions_figure(scene: Scene, d_values: int = 6, step_deg: float = 1.0, plan: Plan | None = None):
    """The C-space map as theta-psi slices at up to d_values values of d, sampled every step_deg
    (deg): free, not force-closed, in collision, kinematically invalid (all contacts sticking),
    like the reference planner's map. Only slices that carry information are drawn (classes other
    than the slice's commonest cover _REGION_OTHERS of it or more): first at the d values the
    plan's path holds (with a plan), the start's and the middle of the goal's range, then others
    spread over d. On every slice: the start, the goal region's theta-psi box and, with a solved
    plan, its path (thick where it is at the slice's d, dashed elsewhere). psi above the rows that
    differ in some slice is left out (the title says so). One legend names the classes' colours
    and the marks. Returns the matplotlib Figure."""
    lo, hi = scene.bounds
    th = np.arange(lo[0], hi[0] + 1e-9, math.radians(step_deg))
    ps = np.arange(lo[2], hi[2] + 1e-9, math.radians(step_deg))
    route = _path_points(plan) if plan is not None and plan.primitives else None
    glo, ghi = scene.goal.box()
    slices = _RegionSlices(scene, th, ps)
    ds = slices.informative(d_values, [float(d) for d in (route[:, 1] if route is not None else [])]
                            + [float(scene.start[1]), float((glo[1] + ghi[1]) / 2)])
    classes, close = slices.classes, slices.close
    psi_top = _informative_psi(ps, [classes(d) for d in ds], [float(scene.start[2]), float(ghi[2])]
                               + ([float(route[:, 2].max())] if route is not None else []), step_deg)
    nrows = max(1, int(math.ceil(len(ds) / 3)))
    cols = min(3, max(1, len(ds)))
    fig, axes = plt.subplots(nrows, cols, figsize=(4.2 * cols, 3.6 * nrows + 0.6), squeeze=False,
                             constrained_layout=True)
    cmap = ListedColormap(_REGION_COLOURS)
    fine = _densified(route) if route is not None else None
    for ax, d in zip(axes.flat, ds):
        ax.imshow(classes(d).T, origin="lower", aspect="auto", cmap=cmap, vmin=-0.5, vmax=3.5,
                  interpolation="nearest",
                  extent=[math.degrees(th[0]), math.degrees(th[-1]), math.degrees(ps[0]), math.degrees(ps[-1])])
        _mark_slice(ax, scene, d, close, route, fine)
        # a margin about the map: marks on its edges (psi 0, theta 0) stay in sight
        ax.set_xlim(math.degrees(th[0]) - 3, math.degrees(th[-1]) + 3)
        ax.set_ylim(math.degrees(ps[0]) - 3, psi_top)
    for ax in list(axes.flat)[len(ds):]:
        ax.axis("off")
    handles = [plt.Rectangle((0, 0), 1, 1, color=c) for c in _REGION_COLOURS]
    marks = legend_marks(*axes.flat)
    fig.legend(handles + list(marks.values()), list(REGION_CLASSES) + list(marks.keys()), loc="outside lower center",
               ncol=4, fontsize=9)
    title = f"{scene.name}: C-space map ({scene.options.sliding_model} sliding, contacts sticking)"
    if route is not None:
        title += f" with {plan.planner}'s path"
    if psi_top < math.degrees(ps[-1]) - 1e-6:
        title += f"\npsi above {psi_top:.0f} deg: {REGION_CLASSES[_INVALID]} in every slice (not drawn)"
    if not ds:
        title += "\nno value of d shows more than one class"
    fig.suptitle(title)
    return fig


class _RegionSlices:
    """The theta-psi slices of a scene's C-space map at values of d (regions_figure): each slice's
    classes, computed once, and which d values carry information."""

    def __init__(self, scene: Scene, th: np.ndarray, ps: np.ndarray):
        self.scene, self.T, self.P = scene, *np.meshgrid(th, ps, indexing="ij")
        self.checker = CollisionChecker(scene.collision_model())
        self._cache: dict[float, np.ndarray] = {}
        lo, hi = scene.bounds
        # B stays on the thumb (s_B = d cos psi - alpha >= 0) only for d >= alpha
        self.d_lo, self.d_hi = max(lo[1], scene.digits.alpha, 0.05), float(hi[1])
        self.close = (self.d_hi - self.d_lo) / (2 * _REGION_CANDIDATES)  # d values this near show the same slice

    def classes(self, d: float) -> np.ndarray:
        """The class of every (theta, psi) of the slice at d (REGION_CLASSES' index)."""
        if d not in self._cache:
            T = self.T
            q = np.column_stack([T.ravel(), np.full(T.size, d), self.P.ravel()])
            self._cache[d] = self.scene.classify(q, self.checker).reshape(T.shape)
        return self._cache[d]

    def wanted(self, d: float, chosen: list[float]) -> bool:
        """A new slice, whose commonest class leaves others their share of it."""
        commonest = np.bincount(self.classes(d).ravel()).max()
        return all(abs(d - e) > self.close for e in chosen) and commonest <= (1 - _REGION_OTHERS) * self.T.size

    def informative(self, count: int, anchors: list[float]) -> list[float]:
        """Up to count values of d, ascending, whose slices carry information: the anchors' first
        (the path's, the start's and the goal's d), then others, each as far as can be from those chosen."""
        ds: list[float] = []
        for d in anchors:
            if len(ds) < count and self.d_lo - 1e-9 <= d <= self.d_hi + 1e-9 and self.wanted(d, ds):
                ds.append(d)
        rest = [float(d) for d in np.linspace(self.d_lo, self.d_hi, _REGION_CANDIDATES) if self.wanted(float(d), ds)]
        while rest and len(ds) < count:
            d = max(rest, key=lambda x: min([abs(x - e) for e in ds], default=math.inf))
            ds.append(d)
            rest = [x for x in rest if abs(x - d) > self.close]
        return sorted(ds)


def _mark_slice(ax, scene: Scene, d: float, close: float, route: np.ndarray | None, fine: np.ndarray | None) -> None:
    """On the slice at d: the goal region's theta-psi box, the plan's path (route, densified as
    fine; thick within close of d), the start, the title naming what lies at this d, the axes' labels."""
    conv = np.array([180 / math.pi, 1.0, 180 / math.pi])
    glo, ghi = scene.goal.box()
    ax.add_patch(plt.Rectangle((glo[0] * conv[0], glo[2] * conv[2]), (ghi[0] - glo[0]) * conv[0],
                               (ghi[2] - glo[2]) * conv[2], fill=False, color="#1f78b4", lw=2,
                               label=f"goal region: theta-psi box (d {glo[1]:.2f}-{ghi[1]:.2f} l)"))
    if fine is not None:
        ax.plot(fine[:, 0] * conv[0], fine[:, 2] * conv[2], color="k", lw=1, ls="--",
                label="the plan's path, theta and psi (at any d)")
        here = np.where(np.abs(fine[:, 1] - d) <= close, fine[:, 2], np.nan)
        ax.plot(fine[:, 0] * conv[0], here * conv[2], color="k", lw=3,
                label=f"the plan's path at this slice's d (within {close:.2f} l)")
    start = scene.start * conv
    ax.plot(start[0], start[2], "o", color="white", markeredgecolor="k", ms=8, zorder=4, label="start (theta, psi)")
    roles = [r for r, hit in (("start", abs(d - scene.start[1]) <= close),
                              ("goal", glo[1] - close <= d <= ghi[1] + close),
                              ("path", route is not None and bool(np.any(np.abs(route[:, 1] - d) <= close))))
             if hit]
    ax.set_title(f"d = {d:.2f} l" + (f" ({', '.join(roles)})" if roles else ""))
    ax.set_xlabel(AXIS_LABELS[0])
    ax.set_ylabel(AXIS_LABELS[2])


def _path_points(plan: Plan) -> np.ndarray:
    """The plan's path as the corners of its straight legs (theta rad, d, psi rad), in order."""
    points = [plan.primitives[0].start]
    for p in plan.primitives:
        points += (p.waypoints or [p.start, p.end])[1:]
    return np.array(points, dtype=float)


def _densified(points: np.ndarray, per_leg: int = 40) -> np.ndarray:
    """The polyline through points with per_leg points on each leg (to mark where d is near a value)."""
    t = np.linspace(0.0, 1.0, per_leg)[:, None]
    legs = [a + t * (b - a) for a, b in zip(points[:-1], points[1:])]
    return np.vstack(legs) if legs else points


def _informative_psi(ps: np.ndarray, slices: list[np.ndarray], keep: list[float], step_deg: float) -> float:
    """The top of the psi axis (deg): the rows above it are kinematically invalid in every slice
    and above every psi in keep (rad); a margin of a few rows is left."""
    top = math.degrees(ps[-1])
    if not slices:
        return top
    uniform = np.all([np.all(c == _INVALID, axis=0) for c in slices], axis=0)  # per psi row
    varied = np.flatnonzero(~uniform)
    last = max([ps[varied[-1]] if varied.size else ps[0]] + keep)
    return min(top, math.degrees(last) + max(8.0, 4 * step_deg))


def draw_plan(scene: Scene, plan: Plan, path: str | os.PathLike[str], max_points: int = 5000) -> None:
    """Write plan_figure's picture to path (PNG)."""
    save_png(plan_figure(scene, plan, max_points), path, fast=True)


def plan_figure(scene: Scene, plan: Plan, max_points: int = 5000):
    """The force-closed free region around the path with the path's primitives drawn in it.

    Three projections (theta-psi, theta-d, psi-d), each shading how much of the
    hidden coordinate's range is free and force-closed with sticking
    contacts, and a 3D view of free, force-closed lattice states (at most max_points of them);
    the goal box in red. One legend names every mark. Returns the matplotlib Figure.
    """
    lattice = plan.holdable_map or _holdable_map(scene)
    conv = np.array([180 / math.pi, 1.0, 180 / math.pi])  # plotted units: deg, d, deg
    names = AXIS_LABELS
    # a fixed layout: matplotlib's constrained layout would draw the figure twice (half the time)
    fig = plt.figure(figsize=(12, 10.6))
    fig.subplots_adjust(left=0.06, right=0.89, bottom=0.11, top=0.94, wspace=0.22, hspace=0.2)
    glo, ghi = scene.goal.box()
    segments = [(p.type, np.array(p.start) * conv, np.array(p.end) * conv) for p in plan.primitives]
    start = scene.start * conv
    goal_label = "goal region (box)"
    for n, (x, y) in enumerate(((0, 2), (0, 1), (2, 1))):
        ax = fig.add_subplot(2, 2, n + 1)
        hidden = 3 - x - y
        share = lattice.holdable.mean(axis=hidden)
        if x > y:
            share = share.T
        ext = [*_cell_span(lattice.axes[x], conv[x]), *_cell_span(lattice.axes[y], conv[y])]
        im = ax.imshow(share.T if x < y else share.T, origin="lower", aspect="auto", cmap="Greens",
                       vmin=0, vmax=1, extent=ext)
        ax.add_patch(plt.Rectangle((glo[x] * conv[x], glo[y] * conv[y]), (ghi[x] - glo[x]) * conv[x],
                                   (ghi[y] - glo[y]) * conv[y], fill=False, color="r", lw=1.2, label=goal_label))
        for kind, a, b in segments:
            ax.plot([a[x], b[x]], [a[y], b[y]], lw=3, color=_PRIMITIVE_COLOURS[kind], label=kind)
        ax.plot(start[x], start[y], "ko", label="start")
        if plan.states:
            ax.plot(plan.states[-1][x] * conv[x], plan.states[-1][y] * conv[y], "o", color="r", label="end")
        ax.set_xlabel(names[x])
        ax.set_ylabel(names[y])
    fig.colorbar(im, cax=fig.add_axes((0.915, 0.3, 0.014, 0.4)),
                 label="free and force-closed (share of the hidden coordinate's range)")
    ax = fig.add_subplot(2, 2, 4, projection="3d")
    idx = np.argwhere(lattice.holdable)
    free = np.column_stack([lattice.axes[a][idx[:, a]] for a in range(3)])
    shown = f"free, force-closed lattice state ({min(len(free), max_points)} of {len(free)} drawn)"
    if len(free) > max_points:
        free = free[np.random.default_rng(0).choice(len(free), max_points, replace=False)]
    ax.scatter(np.degrees(free[:, 0]), np.degrees(free[:, 2]), free[:, 1], s=1, color="#a1d99b", depthshade=False,
               rasterized=True, label=shown)
    _wire_box(ax, glo, ghi, goal_label)
    for kind, a, b in segments:
        ax.plot([a[0], b[0]], [a[2], b[2]], [a[1], b[1]], lw=3, color=_PRIMITIVE_COLOURS[kind], label=kind)
    ax.scatter([start[0]], [start[2]], [start[1]], color="k", s=40, label="start")
    ax.set_xlabel(names[0], fontsize=8)
    ax.set_ylabel(names[2], fontsize=8)
    ax.set_zlabel(names[1], fontsize=8)
    marks = legend_marks(*fig.axes)
    sample = marks.pop(shown)  # its dots are tiny: a bigger one for the legend
    marks[shown] = plt.Line2D([], [], marker="o", ls="", color=sample.get_facecolor()[0])
    fig.legend(marks.values(), marks.keys(), loc="lower center", ncol=4, fontsize=9)
    title = f"{scene.name}: {plan.planner}"
    title += f", cost {plan.cost:.1f} ({plan.mode_switches} changes)" if plan.solved else f": {plan.reason}"
    fig.suptitle(title)
    return fig


def _cell_span(values: np.ndarray, unit: float) -> tuple[float, float]:
    """The plotted span of a lattice axis's cells (each centred on its value), in plotted units;
    an axis of one value spans a unit cell about it."""
    half = (values[-1] - values[0]) / (len(values) - 1) / 2 if len(values) > 1 else 0.5 / unit
    return (values[0] - half) * unit, (values[-1] + half) * unit


def _holdable_map(scene: Scene) -> HoldableMap:
    """The planner's lattice for a plan that does not carry it (one read from plan.json)."""
    return HoldableMap.of(SecurityAtlas(scene, planning_box(scene)))


def _wire_box(ax, lo: np.ndarray, hi: np.ndarray, label: str) -> None:
    """The box's twelve edges in a 3D axes (theta and psi in deg, d), drawn as one line."""
    lo_p = np.array([math.degrees(lo[0]), math.degrees(lo[2]), lo[1]])
    hi_p = np.array([math.degrees(hi[0]), math.degrees(hi[2]), hi[1]])
    points = []
    for i in range(3):
        j, k = [x for x in range(3) if x != i]
        for a in (lo_p, hi_p):
            for b in (lo_p, hi_p):
                p0, p1 = np.empty(3), np.empty(3)
                p0[i], p1[i] = lo_p[i], hi_p[i]
                p0[j] = p1[j] = a[j]
                p0[k] = p1[k] = b[k]
                points += [p0, p1, np.full(3, np.nan)]  # NaN breaks the line between edges
    x, y, z = np.array(points).T
    ax.plot(x, y, z, color="r", lw=0.8, alpha=0.6, label=label)
