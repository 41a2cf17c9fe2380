"""Draw the figures of docs/model.md into docs/figures/ (PNG, matplotlib).

Every pose is computed with the package's own kinematics (ungrasp_ompl.mechanics), so
the figures show what the code computes. Run from the repository's top level:

    python tools/make_docs_figures.py [--out docs/figures]

It writes cspace_convention.png (the planar state and its derived quantities),
primitives.png (the three motion primitives, before and after, with the contacts that
stick or slide) and effective_friction.png (a friction cone cut by the manipulation plane).
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.patches import Arc, FancyArrowPatch, Polygon  # noqa: E402

from ungrasp_ompl.mechanics import DigitGeometry, digit_polygons, finger_tip, thumb_tip  # noqa: E402
from ungrasp_ompl.mechanics.kinematics import digit_axis, object_axis, thumb_normal  # noqa: E402

#: docs/figures of the repository this script lives in.
FIGURES = Path(__file__).resolve().parents[1] / "docs" / "figures"
DPI = 110
TABLE = "#c8c8c8"
OBJECT = "#303030"
FINGER = "#9ecae1"
THUMB = "#fdd0a2"
ARROW = "#b2182b"
NORMAL = "#2166ac"
#: Digits of the primitives figure: long enough for B to stay on the thumb in every pose drawn.
PRIMITIVE_DIGITS = DigitGeometry(alpha=0.3, thumb_length=0.55, thumb_tip_thickness=0.05, thumb_base_thickness=0.12,
                                 finger_tip_thickness=0.05, finger_base_thickness=0.12)
#: Shorter digits for the convention figure, so that the whole pinch fits.
SHORT_DIGITS = DigitGeometry(alpha=0.3, thumb_length=0.45, thumb_tip_thickness=0.05, thumb_base_thickness=0.12,
                             finger_tip_thickness=0.05, finger_base_thickness=0.12)


def _pt(v) -> np.ndarray:
    return np.asarray(v, dtype=float).reshape(2)


def draw_table(ax, x0: float = -0.25, x1: float = 1.25, depth: float = 0.09) -> None:
    ax.add_patch(Polygon([(x0, 0), (x1, 0), (x1, -depth), (x0, -depth)], closed=True, fc=TABLE, ec="none", zorder=0))
    ax.plot([x0, x1], [0, 0], color="#808080", lw=1.0, zorder=1)


def draw_pose(ax, q, digits: DigitGeometry = PRIMITIVE_DIGITS, faded: bool = False, labels: bool = True) -> dict:
    """Object G-B, finger and thumb outlines of state q = (theta, d, psi); returns the key points."""
    th, d, ps = q
    thumb, finger = digit_polygons(th, d, ps, digits)
    alpha = 0.35 if faded else 1.0
    style = dict(closed=True, lw=1.0, alpha=alpha, zorder=2)
    ax.add_patch(Polygon(thumb, fc=THUMB, ec="#a0522d", ls="--" if faded else "-", **style))
    ax.add_patch(Polygon(finger, fc=FINGER, ec="#2b6c99", ls="--" if faded else "-", **style))
    g, b = np.zeros(2), _pt(object_axis(th))
    a = _pt(finger_tip(th, d))
    ax.plot([g[0], b[0]], [g[1], b[1]], color=OBJECT, lw=4 if not faded else 3, alpha=alpha,
            solid_capstyle="round", zorder=3)
    for p in (g, a, b):
        ax.plot(*p, "o", color="black", ms=5 if not faded else 4, alpha=alpha, zorder=4)
    if labels:
        ax.annotate("G", g, xytext=(-14, -4), textcoords="offset points", fontsize=11, weight="bold")
    return {"g": g, "a": a, "b": b, "thumb": thumb, "finger": finger,
            "tip": _pt(thumb_tip(th, d, ps, digits.alpha)), "e": _pt(digit_axis(th, ps)),
            "n_b": _pt(thumb_normal(th, ps)), "u": _pt(object_axis(th))}


def arrow(ax, start, vec, color=ARROW, label=None, offset=(4, 4), lw=1.6, fontsize=10, ha="left"):
    start, end = _pt(start), _pt(start) + _pt(vec)
    ax.add_patch(FancyArrowPatch(start, end, arrowstyle="-|>", mutation_scale=12, color=color, lw=lw, zorder=6))
    if label:
        ax.annotate(label, end, xytext=offset, textcoords="offset points", color=color, fontsize=fontsize, ha=ha,
                    zorder=7)


def angle_arc(ax, centre, radius, start_deg, end_deg, label, label_radius=None, color="black", fontsize=11):
    lo, hi = sorted((start_deg, end_deg))
    ax.add_patch(Arc(centre, 2 * radius, 2 * radius, theta1=lo, theta2=hi, color=color, lw=1.2, zorder=5))
    mid = math.radians((lo + hi) / 2)
    r = label_radius or radius * 1.25
    ax.text(centre[0] + r * math.cos(mid), centre[1] + r * math.sin(mid), label, color=color, fontsize=fontsize,
            ha="center", va="center", zorder=7)


def dimension(ax, p, q, offset, label, color="#444444", fontsize=10, text_shift=0.05, where=0.5):
    """A dimension line between p and q, moved by offset (a vector), labelled at the fraction where of it."""
    p, q, offset = _pt(p), _pt(q), _pt(offset)
    for x in (p, q):
        ax.plot([x[0], x[0] + offset[0]], [x[1], x[1] + offset[1]], color=color, lw=0.6, ls=":", zorder=4)
    ax.add_patch(FancyArrowPatch(p + offset, q + offset, arrowstyle="<|-|>", mutation_scale=9, color=color, lw=0.9,
                                 zorder=5))
    mid = p + where * (q - p) + offset * (1 + text_shift / max(np.linalg.norm(offset), 1e-9))
    ax.text(mid[0], mid[1], label, color=color, fontsize=fontsize, ha="center", va="center", zorder=7,
            bbox=dict(fc="white", ec="none", alpha=0.8, pad=0.5))


def _frame(ax, xlim, ylim) -> None:
    ax.set_xlim(*xlim)
    ax.set_ylim(*ylim)
    ax.set_aspect("equal")
    ax.axis("off")


# -- (a) the planar convention ---------------------------------------------------------------
def figure_convention(path: Path) -> None:
    q = (math.radians(35), 0.55, math.radians(28))
    th, d, ps = q
    digits = SHORT_DIGITS
    fig, ax = plt.subplots(figsize=(7.6, 6.6))
    draw_table(ax, -0.3, 1.5, 0.1)
    ax.text(1.45, -0.05, "table", ha="right", va="center", fontsize=10, color="#505050")
    p = draw_pose(ax, q, digits)
    g, a, b, e, n_b, u = p["g"], p["a"], p["b"], p["e"], p["n_b"], p["u"]
    tip = p["tip"]
    ax.annotate("A", a, xytext=(-16, -2), textcoords="offset points", fontsize=11, weight="bold")
    ax.annotate("B", b, xytext=(7, -4), textcoords="offset points", fontsize=11, weight="bold")
    ax.plot(*tip, "s", color="#a0522d", ms=4, zorder=4)
    ax.annotate("T", tip, xytext=(-12, -4), textcoords="offset points", fontsize=10, color="#a0522d")
    ax.text(*(p["finger"][1] + np.array([-0.2, 0.0])), "finger", fontsize=10, color="#2b6c99")
    ax.text(*(p["thumb"][1] + np.array([0.03, 0.03])), "thumb", fontsize=10, color="#a0522d")
    # angles
    angle_arc(ax, g, 0.28, 0, math.degrees(th), r"$\theta$")
    back = math.degrees(th) + 180.0
    angle_arc(ax, b, 0.26, back, back + math.degrees(ps), r"$\psi$", label_radius=0.32)
    ext = b + 0.32 * e  # the thumb face's line beyond the tip, which psi is measured from
    ax.plot([tip[0], ext[0]], [tip[1], ext[1]], color="#a0522d", lw=0.8, ls=":", zorder=4)
    # lengths
    top = np.array([-u[1], u[0]])
    dimension(ax, a, b, 0.2 * top, r"$d\,l$")
    dimension(ax, g, b, 0.4 * top, r"$l$ (G to B)", where=0.2)
    dimension(ax, tip, b, 0.24 * -n_b, r"$s_B$", text_shift=0.07)
    # unit vectors
    arrow(ax, a, 0.16 * _pt([math.sin(th), -math.cos(th)]), NORMAL, r"$n_A$", offset=(2, -8))
    arrow(ax, b, 0.2 * n_b, NORMAL, r"$n_B$", offset=(-22, 2))
    arrow(ax, g, 0.2 * np.array([0.0, 1.0]), NORMAL, r"$n_G$", offset=(-26, -6))
    side = p["thumb"][2] - 0.14 * n_b
    arrow(ax, side, 0.18 * e, ARROW, r"$e$ (palm $\to$ tips)", offset=(6, -4))
    # axes of the plane
    o = np.array([1.1, 0.12])
    arrow(ax, o, (0.15, 0), "black", "x", offset=(2, -4))
    arrow(ax, o, (0, 0.15), "black", "z", offset=(-4, 2))
    ax.text(-0.28, -0.14, "manipulation plane, G at the origin, lengths over l:\n"
            r"$u=(\cos\theta, \sin\theta)$,  $A=(1-d)\,u$,  $B=u$,  T: the thumb tip, $T = B + s_B\,e$" "\n"
            r"$e=-(\cos(\theta+\psi), \sin(\theta+\psi))$,  $n_B=(-\sin(\theta+\psi), \cos(\theta+\psi))$,"
            r"  $n_A=(\sin\theta, -\cos\theta)$" "\n"
            r"segment (as drawn): $s_B = d\cos\psi-\alpha$, aperture $w = d\sin\psi$;"
            r"  thickness $t$ (over l): $s_B - t\sin\psi$, $w + t\cos\psi$",
            fontsize=9, va="top")
    ax.text(1.45, 1.1, rf"$\theta$ = {math.degrees(th):.0f} deg, $d$ = {d:.2f}, $\psi$ = {math.degrees(ps):.0f} deg,"
            rf" $\alpha$ = {digits.alpha:.2f}", fontsize=8.5, ha="right", va="top", color="#505050")
    _frame(ax, (-0.3, 1.5), (-0.36, 1.12))
    fig.tight_layout(pad=0.3)
    fig.savefig(path, dpi=DPI)
    plt.close(fig)


# -- (b) the motion primitives -----------------------------------------------------------------
def _show(name: str, x: float) -> str:
    return f"{x:.2f}" if name == "d" else f"{math.degrees(x):.0f} deg"


def _friction_arrow(ax, p, vec, label):
    arrow(ax, p, 0.2 * _pt(vec), ARROW, label, offset=(3, -12), lw=1.8, fontsize=9)


def figure_primitives(path: Path) -> None:
    deg = math.radians
    cases = [
        ("P_psi: psi up", (deg(30), 0.8, deg(4)), (deg(30), 0.8, deg(32)),
         "G, A stick; B slides\nfriction on the object at B: toward the palm\n3D stability: full"),
        ("P_theta: theta down", (deg(36), 0.6, deg(20)), (deg(14), 0.6, deg(20)),
         "all contacts stick\nthe pinch turns rigidly about G\n3D stability: full"),
        ("P_dpsi: d down, psi up", (deg(30), 0.8, deg(8)), (deg(30), 0.55, deg(24)),
         "A and B slide\nfriction at A: toward B; at B: toward the palm\n3D stability: partial (no z-moments)"),
    ]
    fig, axes = plt.subplots(1, 3, figsize=(12.6, 4.6))
    for ax, (title, q0, q1, note) in zip(axes, cases):
        change = ", ".join(f"{name} {_show(name, a)} -> {_show(name, b)}" if a != b else f"{name} {_show(name, a)}"
                           for name, a, b in zip(("theta", "d", "psi"), q0, q1))
        draw_table(ax, -0.2, 1.2, 0.08)
        draw_pose(ax, q0, PRIMITIVE_DIGITS, faded=True, labels=False)
        p = draw_pose(ax, q1, PRIMITIVE_DIGITS)
        ax.annotate("A", p["a"], xytext=(-15, -2), textcoords="offset points", fontsize=10, weight="bold")
        ax.annotate("B", p["b"], xytext=(5, -12), textcoords="offset points", fontsize=10, weight="bold")
        ax.set_title(title + "\n" + change, fontsize=11)
        ax.text(0.5, -0.02, note, transform=ax.transAxes, ha="center", va="top", fontsize=9.5)
        name = title.split(":")[0]
        if name == "P_psi":
            b = p["b"]
            ax.add_patch(FancyArrowPatch(b + 0.3 * _pt(digit_axis(q0[0], q0[2])), b + 0.3 * p["e"],
                                         connectionstyle="arc3,rad=-0.35", arrowstyle="-|>", mutation_scale=12,
                                         color="black", lw=1.2, zorder=6))
            _friction_arrow(ax, b, -p["e"], "f_B")
        elif name == "P_theta":
            b0 = _pt(object_axis(q0[0]))
            ax.add_patch(FancyArrowPatch(b0 * 1.08, p["b"] * 1.08, connectionstyle="arc3,rad=-0.2",
                                         arrowstyle="-|>", mutation_scale=12, color="black", lw=1.2, zorder=6))
            ax.text(0.0, -0.05, "G fixed", fontsize=9, color="#505050", va="center")
        else:
            a0 = _pt(finger_tip(q0[0], q0[1]))
            top = np.array([-p["u"][1], p["u"][0]])
            ax.add_patch(FancyArrowPatch(a0 + 0.07 * top, p["a"] + 0.07 * top, arrowstyle="-|>", mutation_scale=12,
                                         color="black", lw=1.2, zorder=6))
            _friction_arrow(ax, p["a"], p["u"], "f_A")
            _friction_arrow(ax, p["b"], -p["e"], "f_B")
        _frame(ax, (-0.2, 1.2), (-0.1, 1.0))
    fig.text(0.5, 0.015, "faded, dashed: before; solid: after; black arrows: the motion; red arrows: friction on "
             "the object at a sliding contact", ha="center", fontsize=9.5, color="#404040")
    fig.tight_layout(rect=(0, 0.1, 1, 1), w_pad=0.5)
    fig.savefig(path, dpi=DPI)
    plt.close(fig)


# -- (c) effective friction --------------------------------------------------------------------
def effective_half_angle(phi: float, gamma: np.ndarray) -> np.ndarray:
    c = math.cos(phi) / np.cos(gamma)
    with np.errstate(invalid="ignore"):
        return np.where(gamma < phi, np.arccos(np.clip(c, -1, 1)), np.nan)


def figure_effective_friction(path: Path) -> None:
    phi, gamma = math.radians(30), math.radians(18)
    phi_p = float(effective_half_angle(phi, np.array(gamma)))
    fig = plt.figure(figsize=(12.0, 5.0))
    grid = fig.add_gridspec(1, 2, width_ratios=(1.15, 1.0))
    # left: the cone and the plane in 3D; the plane is y = 0, the cone's axis leans by gamma out of it
    ax = fig.add_subplot(grid[0], projection="3d", computed_zorder=False)
    axis = np.array([0.0, math.sin(gamma), math.cos(gamma)])
    u1 = np.array([1.0, 0.0, 0.0])
    u2 = np.cross(axis, u1)
    px, pz = np.meshgrid(np.linspace(-0.75, 0.75, 2), np.linspace(0, 1.15, 2))
    ax.plot_surface(px, np.zeros_like(px), pz, color="#92c5de", alpha=0.45, linewidth=0, zorder=1)
    ax.plot([-0.75, 0.75, 0.75, -0.75, -0.75], [0] * 5, [0, 0, 1.15, 1.15, 0], color="#2166ac", lw=0.8, zorder=2)
    t = np.linspace(0, 2 * np.pi, 73)
    h = np.linspace(0, 1.0, 12)
    ring = (math.cos(phi) * axis[None] + math.sin(phi) * (np.cos(t)[:, None] * u1 + np.sin(t)[:, None] * u2))
    ring = ring / math.cos(phi)  # the cone cut at unit height along its axis
    xs, ys, zs = (h[:, None] * ring[None, :, k] for k in range(3))
    ax.plot_surface(xs, ys, zs, color="#f4a582", alpha=0.3, linewidth=0, zorder=3)
    ax.plot(ring[:, 0], ring[:, 1], ring[:, 2], color="#d6604d", lw=1.2, zorder=4)
    for s in (-1, 1):  # the planar cone: where the cone meets the plane
        edge = np.array([s * math.sin(phi_p), 0.0, math.cos(phi_p)]) * 1.1
        ax.plot([0, edge[0]], [0, 0], [0, edge[2]], color="#08306b", lw=2.4, zorder=5)
    ax.plot([0, 1.2 * axis[0]], [0, 1.2 * axis[1]], [0, 1.2 * axis[2]], color="black", lw=1.4, zorder=6)
    ax.plot([0, 0], [0, 0], [0, 1.2], color="black", lw=1.0, ls="--", zorder=6)
    ax.text(*(1.24 * axis), "cone axis", fontsize=9, zorder=7)
    ax.text(-0.05, 0, 1.24, "its projection\non the plane", fontsize=9, ha="right", zorder=7)
    ax.text(0.0, 0.12, 0.62, r"$\gamma$", fontsize=13, zorder=7)
    ax.text(0.62, 0, 0.95, r"$\varphi'$", fontsize=13, color="#08306b", zorder=7)
    ax.text(*(ring[18] * 1.05), r"$\varphi$", fontsize=13, color="#d6604d", zorder=7)
    ax.text(0.72, 0, 0.04, "manipulation plane", color="#2166ac", fontsize=9, zorder=7)
    ax.view_init(elev=16, azim=62)
    ax.set_box_aspect((1.5, 1.0, 1.2))
    ax.set_xlim(-0.75, 0.75)
    ax.set_ylim(-0.1, 0.9)
    ax.set_zlim(0, 1.2)
    ax.set_axis_off()
    ax.set_title(rf"a friction cone (half-angle $\varphi$ = 30 deg) whose axis is $\gamma$ = 18 deg off the plane" "\n"
                 rf"meets it in a planar cone of half-angle $\varphi'$ = {math.degrees(phi_p):.1f} deg (dark blue)",
                 fontsize=10)
    # right: phi' against gamma for the reference friction angles
    ax2 = fig.add_subplot(grid[1])
    g = np.radians(np.linspace(0, 30, 601))
    for deg_phi, color in ((11, "#1b7837"), (17, "#762a83"), (30, "#d6604d")):
        gg = np.append(g[g < math.radians(deg_phi)], math.radians(deg_phi) - 1e-12)  # down to phi' = 0
        ax2.plot(np.degrees(gg), np.degrees(effective_half_angle(math.radians(deg_phi), gg)), color=color, lw=2,
                 label=rf"$\varphi$ = {deg_phi} deg")
    ax2.plot([math.degrees(gamma)], [math.degrees(phi_p)], "o", color="#d6604d")
    ax2.set_xlabel(r"$\gamma$: angle between the cone axis and the plane (deg)")
    ax2.set_ylabel(r"$\varphi'$: half-angle in the plane (deg)")
    ax2.set_xlim(0, 31)
    ax2.set_ylim(0, 32)
    ax2.grid(alpha=0.3)
    ax2.legend(loc="upper right", fontsize=9)
    ax2.set_title(r"$\cos\varphi' = \cos\varphi\,/\cos\gamma$, $\mu' = \tan\varphi'$; no cone left once"
                  r" $\gamma \geq \varphi$" "\n" r"(the code takes $\gamma = \beta$, its largest value)", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=DPI)
    plt.close(fig)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(FIGURES), help="directory for the PNG files (default: docs/figures)")
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for name, draw in (("cspace_convention.png", figure_convention), ("primitives.png", figure_primitives),
                       ("effective_friction.png", figure_effective_friction)):
        draw(out / name)
        print(f"wrote {out / name} ({(out / name).stat().st_size / 1024:.0f} KB)")


if __name__ == "__main__":
    main()
