"""3D stability of a grasp in its manipulation plane (paper sec. 4, docs/model.md, section 5).

Off the plane, y-forces and z-moments are balanced while at most one contact
slides (full stability); a leg with two sliding contacts (P_dpsi) keeps only
y-forces (partial). x-moments come directly from an edge contact at G, A or
B, or else from the restoring effect of A, which needs finite, non-zero radii
of curvature at G and B (no cusp) and, for an object with thickness, a
prism that restores itself when rolled about GB (the roll simulation).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError
from ..mechanics.kinematics import across_support, pressed_state
from ..mechanics.roll import ROLL_WAYS, ROLL_WAYS_NOTE, RollResult, roll_simulation
from .model import Scene


#: The least offset (m) across GB between a contact and where its face touches the outline that the
#: stability report names: half the Hertz indentation of the simulated contacts (docs/model.md 11.2).
FELT_OFFSET = 1e-5


@dataclass
class RollReport:
    """The prism roll simulation at one state of the plan."""

    label: str
    state: list[float]
    result: RollResult
    across: float | None = None
    """How far A lies inside the table's and the thumb's supports across the plane (m), where the
    start press puts the object and as planned, whichever is less (docs/model.md 5.3); None with
    a flat tip or no straight side at G or B."""

    def ranges_deg(self) -> list[tuple[float, float] | None]:
        return [None if r is None else (math.degrees(r[0]), math.degrees(r[1]))
                for r in (d.restoring_range() for d in self.result.directions)]

    def to_dict(self) -> dict:
        return {"label": self.label, "state": self.state, "self_restoring": self.result.self_restoring,
                "restoring_tilt_deg": {"positive": self.ranges_deg()[0], "negative": self.ranges_deg()[1]},
                "max_tilt_deg": math.degrees(self.result.max_tilt), "across_support_m": self.across}


@dataclass
class StabilityReport:
    """Contacts, x-moment mechanism and roll simulation of a scene's grasp."""

    contacts: dict[str, dict]
    edge_contacts: list[str]
    x_mechanism: str
    x_stable: bool
    rolls: list[RollReport] = field(default_factory=list)

    @property
    def self_restoring(self) -> bool:
        return all(r.result.self_restoring for r in self.rolls)

    def to_dict(self) -> dict:
        return {"contacts": self.contacts, "edge_contacts": self.edge_contacts,
                "x_moments": {"mechanism": self.x_mechanism, "ok": self.x_stable},
                "roll_simulation": [r.to_dict() for r in self.rolls],
                "self_restoring": self.self_restoring}

    def lines(self) -> list[str]:
        """The stability command's lines on the contacts, the roll about GB and each state's roll
        simulation (for a person: no identifiers)."""
        out = []
        for name in "GAB":
            out.append("  " + _contact_words(name, self.contacts[name]))
        out.append("  rolling about GB: " + describe_x_moments(self.to_dict()))
        for r in self.rolls:
            q = r.state
            ranges = {d.sign: x for d, x in zip(r.result.directions, r.ranges_deg())}
            out.append(f"  at the {r.label} (theta {math.degrees(q[0]):.1f} deg, d {q[1]:.3f}, psi "
                       f"{math.degrees(q[2]):.1f} deg): "
                       + describe_roll(ranges, r.result.self_restoring, math.degrees(r.result.max_tilt)))
            if r.across is not None:
                out.append(f"    the finger presses {r.across * 1000:.2f} mm inside the supports across the plane (the "
                           "table's and the thumb's): a grasp shifted further than that across GB tips the object out "
                           "of the plane")
        return out


def _contact_words(name: str, c: dict) -> str:
    """One contact of StabilityReport.contacts in words: what touches what, the outline there."""
    what = {"G": "G, the object on the table", "A": "A, the finger on the object",
            "B": "B, the object on the thumb's face"}[name]
    kind = "an edge contact (a line)" if c["edge_contact"] else "a point contact"
    if name == "A":
        tip = "flat" if c["kind"].startswith("flat") else "rounded"
        return f"contact {what}: the finger's {tip} tip, {kind}"
    radius = c["radius_m"]
    outline = {"edge": "a straight side of the outline", "corner": "a sharp corner of the outline",
               "smooth": "a curve of the outline"}.get(c["kind"], c["kind"])
    shape = "" if radius is None or radius == 0.0 else f" (radius of curvature {radius * 1000:.2f} mm)"
    line = f"contact {what}: {outline}{shape}, {kind}"
    along, across = c["touched_from_m"]["along"], c["touched_from_m"]["across"]
    if abs(across) >= FELT_OFFSET:
        face = "the table" if name == "G" else "the thumb's face"
        line += (f"; {face} touches the outline {abs(across) * 1000:.3f} mm across GB from it "
                 f"({along * 1000:.4f} mm further out): a moment about GB the plan does not count")
    return line


def describe_x_moments(report: dict) -> str:
    """How the grasp holds the object against rolling about GB (x-moments), in words, from
    StabilityReport.to_dict() (plan.json's stability_report)."""
    contacts, edges, ok = report["contacts"], report["edge_contacts"], report["x_moments"]["ok"]
    if edges:
        return f"held, directly by the edge contact at {' and '.join(edges)}"
    cusps = [n for n in "GB" if contacts[n]["radius_m"] == 0.0]
    if cusps:
        return (f"NOT held: the outline has a sharp corner at {' and '.join(cusps)}, where the finger's push at A "
                "cannot bring the object back")
    radii = " and ".join(f"{_radius(contacts[n]['radius_m'])} at {n}" for n in "GB")
    if ok:
        return f"held by the finger's push at A, which brings the object back when it rolls (outline radius {radii})"
    return (f"NOT held: the finger's push at A would bring the object back (outline radius {radii}), but the "
            "object does not roll back on its own")


def _reduced(mu_plane: float, mu: float, beta: float) -> str:
    """A contact's friction coefficient in the plane, against the scene's when GB meets the outline off its normal."""
    if abs(mu_plane - mu) < 5e-5:
        return f"{mu_plane:.3f}"
    return (f"{mu_plane:.3f} (the scene's {mu:.3f}, less because GB meets the outline {math.degrees(beta):.1f} deg "
            "off its normal)")


def _radius(radius: float | None) -> str:
    return "infinite" if radius is None else f"{radius * 1000:.2f} mm"


def describe_roll(ranges_deg: dict[int, tuple[float, float] | None], restoring: bool,
                  max_tilt_deg: float | None = None) -> str:
    """The roll simulation's verdict in words: whether the object, tipped sideways about GB, rolls
    back on its own, and over which tilts (ranges_deg by mechanics.roll.RollDirection.sign, a
    (first, last) tilt in deg or None: never)."""
    def span(r: tuple[float, float] | None) -> str:
        return "at no tilt" if r is None else f"from {r[0]:.2f} to {r[1]:.2f} deg"

    pos, neg = ranges_deg.get(1), ranges_deg.get(-1)
    same = (pos is None and neg is None) or (pos is not None and neg is not None
                                             and all(abs(a - b) < 5e-3 for a, b in zip(pos, neg)))
    where = (f"{span(pos)} either way" if same else
             f"{span(pos)} with its {ROLL_WAYS[1]} and {span(neg)} with its {ROLL_WAYS[-1]} ({ROLL_WAYS_NOTE})")
    tried = "" if max_tilt_deg is None else f", tried up to {max_tilt_deg:.0f} deg each way"
    if restoring:
        return f"tipped sideways about GB, the object rolls back on its own {where}{tried}"
    return f"tipped sideways about GB, the object does NOT always roll back on its own: only {where}{tried}"


def describe(scene: Scene) -> str:
    """The stability command's report on a scene's grasp: its manipulation plane, each contact, how
    x-moments are held, the prism roll at the start and at the goal region's centre, and the
    verdict. Raises InputError when the scene has no outline."""
    if scene.plane is None:
        raise InputError("object.outline", "is missing: the stability analysis needs the object's outline", scene.source)
    plane = scene.plane
    g, b = plane.g.point * 1000, plane.b.point * 1000
    lo, hi = scene.goal.box()
    report = analyse(scene, [("start", scene.start), ("goal region's centre", (lo + hi) / 2)])
    restores = "rolls back on its own when tipped sideways" if report.self_restoring else \
        "does NOT roll back on its own when tipped sideways"
    partial = ("; the scene forbids motions with two sliding contacts" if scene.options.forbid_partial else "")
    return "\n".join([
        f"{scene.name}: how the grasp holds the object out of its manipulation plane (docs/model.md 5); the object "
        f"is {scene.object3d.thickness * 1000:.2f} mm thick",
        f"  the manipulation plane is the vertical plane through G, where the object touches the table, at "
        f"({g[0]:.2f}, {g[1]:.2f}) mm on its outline, and B, where the thumb holds it, at ({b[0]:.2f}, {b[1]:.2f}) mm"
        f"{' (both fixed by the scene)' if plane.fixed else ''}: l = |GB| = {plane.length * 1000:.2f} mm; the line GB "
        f"lies {math.degrees(plane.margin):.2f} deg inside the friction cones at G and B (the pinch's room before it "
        "slips)",
        f"  friction in the plane: {_reduced(plane.mu_g, scene.mu_contacts[0], plane.g.beta)} at G, "
        f"{_reduced(plane.mu_b, scene.mu_contacts[2], plane.b.beta)} at B",
        *report.lines(),
        "  out of the plane, P_theta (the pivot about G) and P_psi (the thumb's turn) hold every sideways force and "
        "twist (at most one contact slides); P_dpsi (the finger's slide) holds sideways forces but not twists "
        f"about the vertical (two contacts slide){partial}",
        f"verdict: the grasp {restores}; rolling about GB is {'held' if report.x_stable else 'NOT held'}"])


def _across(scene: Scene, q) -> float | None:
    """RollReport.across at state q (m)."""
    dg = scene.digits
    if not dg.held_by_supports:
        return None
    held = float(across_support(q[1], q[2], dg))
    if dg.press > 0.0:
        _, d, psi, found = pressed_state(q[0], q[1], q[2], dg.press, dg)
        held = min(held, float(across_support(d, psi, dg))) if found else held
    return held * scene.object_length


def analyse(scene: Scene, states: list[tuple[str, np.ndarray]]) -> StabilityReport:
    """Stability of the scene's grasp, with the prism roll simulated at each (label, state)."""
    if scene.plane is None or scene.object3d is None:
        raise ValueError("the scene has no object outline")
    plane, obj = scene.plane, scene.object3d
    contacts = {"G": plane.g.to_dict(), "B": plane.b.to_dict()}
    flat = scene.digits.flat_finger_tip
    contacts["A"] = {"kind": "flat finger tip" if flat else "rounded finger tip", "radius_m": None,
                     "edge_contact": flat, "point": None}
    edges = [n for n in "GAB" if contacts[n]["edge_contact"]]
    cusps = [n for n, c in (("G", plane.g), ("B", plane.b)) if c.radius == 0.0]
    phi_a = math.atan(scene.mu[1])
    rolls = [RollReport(label, [float(x) for x in q],
                        roll_simulation(obj.outline.vertices, obj.thickness, plane.g.point, plane.b.point,
                                        plane.g.normal, plane.b.normal, (1.0 - q[1]) * plane.length,
                                        q[0], q[2], phi_a, max_tilt=scene.max_tilt), _across(scene, q))
             for label, q in states]
    restoring = all(r.result.self_restoring for r in rolls)
    if edges:
        mechanism = f"edge contact at {', '.join(edges)} (direct x-couples)"
        ok = True
    elif cusps:
        mechanism = f"restoring effect of A fails: cusp (zero radius of curvature) at {', '.join(cusps)}"
        ok = False
    else:
        mechanism = (f"restoring effect of A (radii of curvature {plane.g.radius * 1000:.2f} mm at G, "
                     f"{plane.b.radius * 1000:.2f} mm at B)")
        ok = restoring
        if not restoring:
            mechanism += ", but the prism does not restore itself"
    return StabilityReport(contacts, edges, mechanism, ok, rolls)
