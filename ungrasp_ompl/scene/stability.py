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
from ..mechanics.roll import RollResult, describe_restoring, roll_simulation
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
        out = []
        for name in "GAB":
            c = self.contacts[name]
            radius = c["radius_m"]
            line = f"  contact {name}: {c['kind']} ({'edge' if c['edge_contact'] else 'point'} contact)"
            if name != "A":
                line += ", radius of curvature " + ("inf" if radius is None else f"{radius * 1000:.2f} mm")
                along, across = c["touched_from_m"]["along"], c["touched_from_m"]["across"]
                if abs(across) >= FELT_OFFSET:
                    face = "the table" if name == "G" else "the thumb's face"
                    line += (f"; {face} touches the outline {abs(across) * 1000:.3f} mm across GB from it "
                             f"({along * 1000:.4f} mm further out): a moment about GB the plan does not count")
            out.append(line)
        out.append(f"  x-moments: {self.x_mechanism} -> {'held' if self.x_stable else 'NOT held'}")
        for r in self.rolls:
            q = r.state
            ranges = describe_restoring({d.sign: x for d, x in zip(r.result.directions, r.ranges_deg())})
            verdict = "self-restoring" if r.result.self_restoring else "NOT self-restoring"
            out.append(f"  prism roll at {r.label} (theta {math.degrees(q[0]):.1f} deg, d {q[1]:.3f}, psi "
                       f"{math.degrees(q[2]):.1f} deg): {verdict}; rolled each way up to "
                       f"{math.degrees(r.result.max_tilt):.0f} deg, restores over tilts {ranges}")
            if r.across is not None:
                out.append(f"    A {r.across * 1000:.2f} mm inside the supports across the plane: a grasp "
                           "further off across GB tips the object out of it")
        return out


def describe(scene: Scene) -> str:
    """The stability command's report on a scene's grasp: its manipulation plane, each contact, how
    x-moments are held, the prism roll at the start and at the goal region's centre, and the
    verdict. Raises InputError when the scene has no outline."""
    if scene.plane is None:
        raise InputError("object.outline", "is missing: the stability analysis needs the object's outline", scene.source)
    plane = scene.plane
    g, b = plane.g.point * 1000, plane.b.point * 1000
    lo, hi = scene.goal.box()
    report = analyse(scene, [("start", scene.start), ("goal centre", (lo + hi) / 2)])
    verdict = "self-restoring" if report.self_restoring else "NOT self-restoring"
    return "\n".join([
        f"{scene.name}: object {scene.object3d.thickness * 1000:.2f} mm thick, l = |GB| = {plane.length * 1000:.2f} mm",
        f"  G ({g[0]:.2f}, {g[1]:.2f}) mm, B ({b[0]:.2f}, {b[1]:.2f}) mm, friction margin "
        f"{math.degrees(plane.margin):.2f} deg{' (fixed by the scene)' if plane.fixed else ''}",
        f"  effective friction: mu'_G {plane.mu_g:.4f} (from {scene.mu_contacts[0]:.4f}), "
        f"mu'_B {plane.mu_b:.4f} (from {scene.mu_contacts[2]:.4f})",
        *report.lines(),
        "  legs: P_theta and P_psi keep full stability (at most one sliding contact); P_dpsi partial "
        f"(two sliding, no z-moments){'; forbidden by the scene' if scene.options.forbid_partial else ''}",
        f"verdict: the grasp is {verdict} in roll; x-moments {'held' if report.x_stable else 'NOT held'}"])


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
