"""A strip of key frames of the view as one PNG, drawn without a browser (matplotlib 3D polygons of
the same meshes and poses the meshcat page shows).

Top row: the whole arm (the overview viewpoint); bottom row: a close-up of the digits and the
object (looking across the manipulation plane). Each column is one key time, titled with the time
and the running phase. Faces are shaded by a fixed light (Lambert) and sorted back to front by
matplotlib's painter's algorithm, which is good enough for these convex parts.
"""

from __future__ import annotations

import math
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from mpl_toolkits.mplot3d.art3d import Poly3DCollection  # noqa: E402
from numpy.typing import NDArray  # noqa: E402

from ..io import write_atomic  # noqa: E402
from .scene import Camera, ViewScene  # noqa: E402

#: Direction toward the light (world), for shading.
LIGHT = np.array([0.35, -0.45, 0.82])
#: The most key frames a strip takes.
MAX_FRAMES = 24


def key_times(scene: ViewScene, count: int) -> NDArray[np.float64]:
    """count times (s) that show the ungrasp: the start, the end, and the others spread evenly from
    the first primitive's start to the last termination's end (the whole trajectory if none)."""
    starts = [a for name, _, a, _ in scene.phases if name.rpartition("/")[2].startswith("P_")]
    ends = [b for name, _, _, b in scene.phases if name.rpartition("/")[2] == "termination"]
    lo = starts[0] if starts else 0.0
    hi = ends[-1] if ends else scene.duration
    if count == 1:
        return np.array([(lo + hi) / 2])
    inner = np.linspace(lo, hi, count)[1:-1] if count > 2 else np.array([])
    return np.concatenate([[0.0], inner, [scene.duration]])


def _shaded(rgba: tuple[float, ...], normals: NDArray) -> NDArray[np.float64]:
    light = LIGHT / np.linalg.norm(LIGHT)
    lam = np.abs(normals @ light)  # two-sided
    shade = 0.45 + 0.55 * lam
    out = np.empty((len(normals), 4))
    out[:, :3] = np.clip(np.asarray(rgba[:3])[None] * shade[:, None], 0.0, 1.0)
    out[:, 3] = rgba[3]
    return out


def _polygons(scene: ViewScene, frame: int, centre: NDArray, half: float, groups: set[str]) -> tuple[list, list]:
    """The world triangles and face colours of the visible bodies of groups at frame, clipped to the
    cube (centre, half) by dropping triangles wholly outside it."""
    tris, colours = [], []
    for b, body in enumerate(scene.bodies):
        if body.group not in groups or not scene.visible[b, frame]:
            continue
        verts = body.mesh.transformed(scene.poses[b, frame])
        faces = body.mesh.faces
        if body.group == "table":  # its top only, cut to the view, so that its edges do not fill the picture
            verts = verts.copy()
            verts[:, :2] = np.clip(verts[:, :2], centre[:2] - 1.2 * half, centre[:2] + 1.2 * half)
            faces = faces[np.all(np.abs(verts[faces][:, :, 2]) < 1e-9, axis=1)]
        t = verts[faces]
        inside = np.all(np.abs(t - centre) <= 1.6 * half, axis=2).any(axis=1)
        t = t[inside]
        if not len(t):
            continue
        n = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
        n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-18)
        tris.extend(t)
        colours.extend(_shaded(body.rgba, n))
    return tris, colours


def _draw(ax, scene: ViewScene, frame: int, camera: Camera, hidden: frozenset[str] = frozenset()) -> None:
    """One panel: the table, then the target footprints, then the rest (depth-sorted); bodies of
    the groups in hidden are left out."""
    centre, half = camera.target, camera.half
    ax.computed_zorder = False  # layers in the order added; faces depth-sorted within each
    groups = {b.group for b in scene.bodies} - hidden
    layers = ({"table"}, {"target"}, groups - {"table", "target"})
    for z, layer in enumerate(layers):
        tris, colours = _polygons(scene, frame, centre, half, layer & groups)
        if tris:  # opaque faces get a hairline edge of their own colour (no seams); translucent ones none
            edges = np.array(colours)
            edges[edges[:, 3] < 1.0, 3] = 0.0
            ax.add_collection3d(Poly3DCollection(tris, facecolors=colours, edgecolors=edges, linewidths=0.2,
                                                 zorder=z))
    ax.set_xlim(centre[0] - half, centre[0] + half)
    ax.set_ylim(centre[1] - half, centre[1] + half)
    ax.set_zlim(centre[2] - half, centre[2] + half)
    ax.set_box_aspect((1, 1, 1), zoom=1.6)
    off = camera.position - camera.target
    ax.view_init(elev=math.degrees(math.atan2(off[2], math.hypot(off[0], off[1]))),
                 azim=math.degrees(math.atan2(off[1], off[0])))
    ax.set_proj_type("persp", focal_length=0.6)
    ax.set_axis_off()


def draw_frames(scene: ViewScene, count: int, path: str | os.PathLike[str]) -> NDArray[np.float64]:
    """Write the strip of count key frames (key_times) to path (PNG, atomically); returns the times.
    Rows: the arm; a close-up of the digits and the object; for a simulated trial the close-up
    twice, the simulated object and the planned one side by side (one above the other)."""
    times = key_times(scene, count)
    simulated = any(b.group == "simulated" for b in scene.bodies)
    rows = [("overview", frozenset(), "the arm")]
    if simulated:
        rows += [("close", frozenset({"planned"}), "simulated"), ("close", frozenset({"simulated"}), "planned")]
    else:
        rows += [("close", frozenset(), "close-up")]
    width, height = 2.7 * count + 0.4, 2.8 * len(rows)
    fig = plt.figure(figsize=(width, height))
    left = 0.4 / width
    fig.subplots_adjust(left=left, right=1.0, bottom=0.35 / height, top=1.0 - 0.85 / height, wspace=0.0, hspace=0.0)
    for k, t in enumerate(times):
        f = scene.frame_at(float(t))
        for row, (name, hidden, label) in enumerate(rows):
            ax = fig.add_subplot(len(rows), count, row * count + k + 1, projection="3d")
            _draw(ax, scene, f, scene.cameras[name], hidden)
            if row == 0:
                ax.set_title(f"t = {t:.2f} s\n{scene.phase_at(float(t))[0]}", fontsize=9)
            if k == 0:
                box = ax.get_position()
                fig.text(left / 2, (box.y0 + box.y1) / 2, label, rotation=90, ha="center", va="center", fontsize=9)
    close = scene.cameras["close"].half * 200
    fig.suptitle(f"{scene.title}: key frames (close-ups {close:.0f} cm across)", fontsize=10)
    handles = [plt.Rectangle((0, 0), 1, 1, color=c[:3], alpha=max(c[3], 0.5)) for _, c in scene.legend]
    fig.legend(handles, [lab for lab, _ in scene.legend], loc="lower center", ncol=len(handles), fontsize=8,
               frameon=False)
    write_atomic(path, lambda tmp: fig.savefig(tmp, format="png", dpi=100))
    plt.close(fig)
    return times
