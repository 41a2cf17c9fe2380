"""Write scenes/tangram.yaml: the seven tangram pieces in a square frame.

The classic dissection of a square of side SIDE into two large, one medium and two small
right triangles, a square and a parallelogram; each piece is cut KERF smaller on every
edge (the saw's width, so neighbours lie 2 KERF apart), and the square sits WALL_GAP
inside the frame on every side. The file asks for the pieces to be spread (`spread: true`), so that
the frame's slack is shared out between the pieces and the walls. The pieces' landing offsets
(pieces[i].landing_offset, measured by tools/landing_offset.py, record 0134) are kept from the file
being written over. Run from the repository's top level:

    python tools/make_tangram.py [--side 0.14] [--kerf 0.001] [--wall-gap 0.004] [--out scenes/tangram.yaml]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import yaml

from ungrasp_ompl.layout.model import Layout

#: The dissection of the unit square, counter-clockwise outlines.
UNIT_PIECES = {
    "large_triangle_1": [(0, 0), (1, 0), (0.5, 0.5)],
    "large_triangle_2": [(0, 0), (0.5, 0.5), (0, 1)],
    "medium_triangle": [(1, 0.5), (1, 1), (0.5, 1)],
    "small_triangle_1": [(1, 0), (1, 0.5), (0.75, 0.25)],
    "square": [(0.5, 0.5), (0.75, 0.25), (1, 0.5), (0.75, 0.75)],
    "small_triangle_2": [(0.5, 0.5), (0.75, 0.75), (0.25, 0.75)],
    "parallelogram": [(0, 1), (0.25, 0.75), (0.75, 0.75), (0.5, 1)],
}

HEADER = """\
# A tangram put into a square frame piece by piece (paper sec. 6.2.4), written by
# tools/make_tangram.py: the classic dissection of a {side_mm:.0f} mm square into seven pieces of
# {thick_mm:.0f} mm plywood, each cut {kerf_mm:.1f} mm smaller on every edge (neighbours {gap_mm:.1f} mm apart),
# the square {wall_mm:.1f} mm inside the frame's walls on every side; spread: true then moves the
# pieces apart (each by at most {shift_mm:.1f} mm, headings kept) so that the narrowest gap between two
# of them or a piece and a wall is the widest the frame allows: {gap_mm:.1f} mm grows to {spread_mm:.1f} mm
# (docs/model.md 11.15).
# Frame coordinates: origin at the frame's inner corner, metres. Outlines are given about
# each piece's centroid; target.position places that centroid in the frame.
# Friction: wood on a laminate table about 0.35, wood on the 3D-printed digits about 0.45.
# uncertainty: dry friction of plywood on laminate and PLA is known to +-30 % (humidity, dust, wear, speed; tables disagree)
# Mass: birch plywood weighs 600-700 kg/m^3, so the pieces are simulated at 650 kg/m^3
# (sim.density; the default, 1250, is a stiff plastic's); the `paper` errors' +-20 % on the
# mass spans 520-780 kg/m^3.
# Digits: a 60 mm thumb and an 80 mm finger (alpha = 20 mm over each piece's l = |GB|).
# Set up as the object scenes are (docs/model.md 11.9-11.14): the digits 2 mm above the table,
# B 1 mm from the thumb's tip, A 1 mm inside the supports across the plane, a 1 mm press, the
# table touched off under the start pinch, each piece let go at theta up to 8 deg
# with the thumb at 30-65 deg (psi), opened as open_lift does, its landing moving at most 4 mm
# over friction 0.7-1.3 times the layout's and both cones (planning.max_landing_spread, as the
# puzzle piece's), planned for the widest friction margin (planning.objective, as the puzzle
# piece is), and aimed by the middle of where the model of the fall lands it over that range
# (robot.landing: modelled, fitted in no simulated world; a piece whose whole aim would take it
# or the robot into a wall or a piece is aimed as far as it fits; docs/model.md 11.15, 11.17).
# Every plan keeps its digits, housing and piece 1 mm from the pieces down (placed_clearance): the
# palm's 0.5 deg turn over the housing's 40 mm half-width, the touch-off's 0.5 mm and the piece's
# 5 % of thickness, the `paper` errors' bounds (record 0132).
# Each piece's landing_offset is where its release lands beyond the model of the fall, along GB
# (m; tools/landing_offset.py over the `paper` errors and friction x0.7-1.3 with both cones,
# record 0134); the aim moves the hand back by it too.
"""


def shrink(poly: np.ndarray, k: float) -> np.ndarray:
    """The convex CCW polygon with every edge moved inward by k."""
    n = len(poly)
    edges = np.roll(poly, -1, axis=0) - poly
    normals = np.column_stack([-edges[:, 1], edges[:, 0]]) / np.linalg.norm(edges, axis=1)[:, None]
    offsets = np.sum(normals * poly, axis=1) + k
    out = []
    for i in range(n):  # vertex i joins edges i - 1 and i
        a = np.array([normals[i - 1], normals[i]])
        out.append(np.linalg.solve(a, [offsets[i - 1], offsets[i]]))
    return np.array(out)


def layout(side: float, kerf: float, wall_gap: float, thickness: float) -> dict:
    pieces = []
    for name, unit in UNIT_PIECES.items():
        poly = shrink(np.array(unit, dtype=float) * side, kerf) + wall_gap
        centre = poly.mean(axis=0)
        pieces.append({"name": name, "thickness": thickness,
                       "outline": {"polygon": [[round(float(x), 6), round(float(y), 6)] for x, y in poly - centre]},
                       "target": {"position": [round(float(centre[0]), 6), round(float(centre[1]), 6)], "yaw_deg": 0}})
    inner = round(side + 2 * wall_gap, 6)
    return {
        "name": "tangram",
        "description": "Seven tangram pieces put into a square frame by successive ungrasps.",
        "spread": True,
        "placed_clearance": 0.001,
        "frame": {"center": [0.45, 0.0], "yaw_deg": 0, "inner_size": inner, "wall_height": 0.006,
                  "wall_thickness": 0.01},
        "friction": {"G": 0.35, "A": 0.45, "B": 0.45, "uncertainty": 0.3},
        "digits": {"thumb_length": 0.06, "finger_length": 0.08, "thumb_tip_thickness": 0.002,
                   "thumb_base_thickness": 0.008, "finger_tip_thickness": 0.002, "finger_base_thickness": 0.008,
                   "width": 0.02, "palm_width": 0.08, "palm_length": 0.11},
        "start": {"theta_deg": 30, "d": 0.8, "psi_deg": 0},
        "goal": {"theta_max_deg": 8, "d": [0.0, 1.0], "psi_deg": [30, 65]},
        "planning": {"table_clearance": 0.002, "thumb_tip_margin": 0.001, "across_margin": 0.001,
                     "max_landing_spread": 0.004, "objective": "margin"},
        "robot": {"termination": "open_lift", "termination_opening": 0.004, "start_press": 0.001,
                  "end_press": 0.0005, "touch_off": True, "landing": "modelled"},
        "sim": {"density": 650},
        "pieces": pieces,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--side", type=float, default=0.14)
    ap.add_argument("--kerf", type=float, default=0.001)
    ap.add_argument("--wall-gap", type=float, default=0.004)
    ap.add_argument("--thickness", type=float, default=0.003)
    ap.add_argument("--out", default="scenes/tangram.yaml")
    args = ap.parse_args()
    data = layout(args.side, args.kerf, args.wall_gap, args.thickness)
    kept = {}  # the landing offsets the file being written over measured
    if Path(args.out).exists():
        kept = {p["name"]: p["landing_offset"] for p in yaml.safe_load(Path(args.out).read_text()).get("pieces", [])
                if "landing_offset" in p}
    data["pieces"] = [{"name": p["name"], **({"landing_offset": kept[p["name"]]} if p["name"] in kept else {}),
                      **{k: v for k, v in p.items() if k != "name"}} for p in data["pieces"]]
    moved = Layout.from_dict(data).spread
    head = HEADER.format(side_mm=args.side * 1000, thick_mm=args.thickness * 1000, kerf_mm=args.kerf * 1000,
                         gap_mm=2 * args.kerf * 1000, wall_mm=args.wall_gap * 1000,
                         shift_mm=np.abs(moved.shifts).max() * 1000, spread_mm=moved.gap * 1000)
    with open(args.out, "w") as f:
        f.write(head + yaml.safe_dump(data, sort_keys=False, default_flow_style=None, width=110))
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
