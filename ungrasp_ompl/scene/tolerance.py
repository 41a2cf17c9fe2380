"""The tolerance of states to the errors of a set-up: the largest scale s of an error box (the
`paper` perturbation's by default) such that a state, moved by any error within s times the box,
stays secure (docs/model.md, section 4.6). From the model alone, no simulation. A plan's tolerance
(planning.plan_tolerance) is that of every state of its executed motion at once; the words for it
(describe_tolerance) are here, beside the reasons and the error components they name.

How an error moves a state (lengths over l, angles rad; section 4.6 derives each):

* grasp shift along GB by a (m): the object slides along the thumb's face in the pinch, so A
  sits a further from B: d' = d + a / l (psi kept); G then lies a u(theta') from where the plan
  has it, which raises the digits by a sin(theta') over the table;
* the arm's calibration, one rigid motion of the hand and the object it holds: a turn phi about
  the palm's y axis (the plane's normal) turns the state about the palm's origin P0 at the start,
  theta' = theta + phi, and lifts G by (P0 - R(phi) P0)_z; the palm's shift along its x (n_B) and
  z (e) axes at the start lifts it by their vertical parts; the table's height error lowers
  everything by it; turns about the palm's x and z axes tip the plane, lowering the digits' edges
  by half their width (or the housing's thickness) times the horizontal part of the turn;
* friction lost: every nominal coefficient times (1 - loss) before the plane's reduction (a range
  of the scene's friction, section 4.7, is not applied on top of it); a turn gamma
  in the grasp turns the chord GB against the outline's normals at G and B, which reduces as
  beta + |gamma| (section 5.2);
* thickness: the object's thickness times (1 + k) in every kinematic quantity (s_B, the opening,
  where the digits stand);
* shift across GB by c moves nothing in the plane; it puts A c beside GB, which the supports
  across the plane must hold (across_support >= c, as planned and pressed: section 5.3);
* the palm's shift along y moves nothing in the plane;
* with a start press p (the hand run p below the plan, G held by the table), the hand stands
  p - lift below what the moved state needs, lift being G's lift above, so the digits stand that
  much lower and B and A are looked at also where the object then lies: the moved state pressed
  by p - lift (mechanics.pressed_state; none found counts as B lost);
* a hand that lifts G at the start by more than p leaves the object hanging with G above the
  table, unless it was handed over (sim.handed_over: it then slides down in the pinch onto the
  table): the plan's contact modes never begin (G_LIFTED).

A moved state with theta' < 0 lies flat with the hand turned against it: (0, d', psi + theta').
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from enum import Enum

import numpy as np
from numpy.typing import NDArray

from ..errors import InputError
from ..geometry.collision import CollisionChecker
from ..mechanics import force_closure, s_b
from ..mechanics.antipodal import effective_friction
from ..mechanics.contact import Primitive
from ..mechanics.kinematics import (DigitGeometry, across_support, aperture, contact_d, digit_axis, pressed_state,
                                   thumb_normal, thumb_tip)
from ..mechanics.margin import kinematic_margins
from ..mechanics.path import PlanSamples
from .model import Scene
from .perturbation import PRESETS, Perturbation


class ToleranceReason(Enum):
    """Which check a moved state fails first at the scale just above the tolerance."""

    NOT_FORCE_CLOSED = "not_force_closed"  #: no force closure in the leg's contact mode
    B_PAST_THUMB_TIP = "b_past_thumb_tip"  #: s_B < 0: B off the thumb's tip
    B_PAST_THUMB_BASE = "b_past_thumb_base"  #: s_B beyond the thumb's length
    A_OFF_OBJECT = "a_off_object"  #: d' outside (0, 1]: the finger off the object
    A_OFF_SUPPORT = "a_off_support"  #: A beside GB beyond the supports across the plane: the object tips out of it
    APERTURE = "aperture"  #: the opening beyond the gripper's stroke (or negative)
    DIGIT_IN_TABLE = "digit_in_table"  #: a digit or the housing below the table
    OBSTACLE = "obstacle"  #: a digit or the housing in an obstacle
    G_LIFTED = "g_lifted"  #: the hand lifts G at the start by more than the start press: the object hangs
    NO_TERMINATION = "no_termination"  #: the gripper cannot let go from the moved last state
    NONE = "none"  #: nothing fails up to the largest scale (all friction lost)

    def describe(self) -> str:
        """What fails, in words for a person (plan.json keeps the value)."""
        return _REASON_WORDS[self]


_REASON_WORDS = {
    ToleranceReason.NOT_FORCE_CLOSED: "the contacts can no longer hold the object (force closure is lost: some push in "
                                      "the plane would make it slip)",
    ToleranceReason.B_PAST_THUMB_TIP: "the object's end B slides off the thumb's tip",
    ToleranceReason.B_PAST_THUMB_BASE: "the object's end B moves past the base of the thumb",
    ToleranceReason.A_OFF_OBJECT: "the finger's contact A comes off the object",
    ToleranceReason.A_OFF_SUPPORT: "the finger presses beside the supports across the plane, so the object tips out "
                                   "of the plane",
    ToleranceReason.APERTURE: "the gripper would have to open wider than its stroke",
    ToleranceReason.DIGIT_IN_TABLE: "a digit or the gripper's housing would go into the table",
    ToleranceReason.OBSTACLE: "a digit or the gripper's housing would hit an obstacle",
    ToleranceReason.G_LIFTED: "the hand lifts the object's end G off the table, so the object hangs in the pinch "
                              "and the plan's first motion never begins",
    ToleranceReason.NO_TERMINATION: "the gripper can no longer let go without a digit hitting the table or an "
                                    "obstacle",
    ToleranceReason.NONE: "nothing fails",
}

#: Each error component (COMPONENTS) in words for a person, and the bound of the box it takes
#: (Perturbation's field), its unit and the factor from that field to the unit.
COMPONENT_WORDS = {
    "shift_along": ("a grasp shifted along the object (along GB)", "shift_mm", "mm", 1.0),
    "shift_across": ("a grasp shifted across the object (across GB)", "shift_mm", "mm", 1.0),
    "yaw": ("the object turned in the grasp", "yaw_deg", "deg", 1.0),
    "friction": ("less friction at every contact", "friction", "% less", 100.0),
    "thickness": ("an object thicker or thinner than the scene says", "thickness", "%", 100.0),
    "palm_shift": ("the hand off its calibrated position", "palm_shift_mm", "mm", 1.0),
    "palm_turn": ("the hand turned off its calibrated orientation", "palm_turn_deg", "deg", 1.0),
    "table_height": ("the table higher or lower than calibrated", "table_mm", "mm", 1.0),
}


#: The error components, as TrialParams names them (the friction loss counts G, A, B together).
#: The first scale tried (dimensionless); the scale doubles from it until a state fails.
FIRST_SCALE = 1.0 / 64.0

#: Relative precision of each component's own tolerance (it only names the binding component).
SOLO_TOLERANCE = 1e-2

COMPONENTS = ("shift_along", "shift_across", "yaw", "friction", "thickness", "palm_shift", "palm_turn",
              "table_height")


@dataclass(frozen=True)
class ToleranceOptions:
    """How the tolerance is computed."""

    perturbation: str = "paper"
    """The preset whose bounds make the box at scale 1 (perturbation.PRESETS)."""
    box: Perturbation | None = None
    """Bounds of the box at scale 1 instead of the preset's (mm, deg and fractions as perturbation.Perturbation has them)."""
    scale_tolerance: float = 1e-3
    """Bisection stops when the bracket on s is this narrow relative to s (dimensionless)."""
    max_scale: float = 5.0
    """The largest scale tried (dimensionless); at 5 the `paper` box loses all friction."""
    housing: bool = False
    """Count the gripper housing's clearance over the table beside the digits' (bool; the simulator's palm is kinematic and never meets the table)."""
    resolution: tuple[float, float, float] | None = None
    """Sampling of the plan's legs and of the box's (turn, shift) face: theta rad, d over l, psi rad;
    None: the scene's planning.resolution."""


class ErrorBox:
    """The error box of a set of states moved from one start, ready to move them at any scale (the
    module docstring): samples holds the states and their contact modes, terminal marks those from
    which the gripper must still be able to let go."""

    def __init__(self, scene: Scene, start: NDArray[np.float64], box: Perturbation, samples: PlanSamples,
                 terminal: NDArray[np.bool_], resolution: NDArray[np.float64], housing: bool = False,
                 start_lift: bool = True):
        self.scene, self.box, self.samples, self.terminal, self.housing = scene, box, samples, terminal, housing
        l, dg = scene.object_length, scene.digits
        self.l = l
        self.res = resolution
        th0, d0, ps0 = (float(x) for x in start)
        # the palm's origin and axes at the start (robot.placement.palm_poses), over l
        tip = thumb_tip(th0, d0, ps0, dg.alpha, dg.object_thickness, dg.finger_tip_radius)
        e0, n0 = digit_axis(th0, ps0), thumb_normal(th0, ps0)
        self.p0 = tip - dg.thumb_length * e0 + aperture(d0, ps0, dg.object_thickness, dg.finger_tip_radius) / 2 * n0
        self.lift_per_shift = abs(float(n0[1])) + abs(float(e0[1]))  # palm x and z shifts' vertical parts
        self.sin_start = math.sin(th0)  # a grasp shift along GB lifts G at the start by this much of it
        # a hand too high leaves the object hanging (unless handed over: it slides down); start_lift
        # False leaves the check out (it depends on the start alone, which no path changes)
        self.hangs = start_lift and not scene.sim.handed_over
        self.drop_per_turn = max(dg.width, dg.palm_thickness if dg.palm_width > 0 else 0.0) / 2 \
            * (abs(float(n0[0])) + abs(float(e0[0])))  # palm x and z turns tip the plane
        self.obstacles = tuple(np.array([[b.lo[0], b.lo[1]], [b.hi[0], b.lo[1]], [b.hi[0], b.hi[1]],
                                         [b.lo[0], b.hi[1]]]) / l for b in scene.obstacles)
        plane = scene.plane
        self.beta = (plane.g.beta, plane.b.beta) if plane is not None else None
        self.mu_contacts = scene.mu_contacts
        self.checker = CollisionChecker(scene.collision_model())

    # -- the moved quantities ------------------------------------------------------------------
    def mu(self, loss: float, yaw: float) -> tuple[float, float, float]:
        """Friction at G, A, B with every coefficient lost by the fraction loss and the grasp turned
        by yaw (rad): the plane's reduction taken at beta + yaw (0 where nothing is left)."""
        mg, ma, mb = (m * (1.0 - loss) for m in self.mu_contacts)
        if self.beta is not None:
            mg, mb = (float(np.nan_to_num(effective_friction(m, b + yaw), nan=0.0)) if m > 0 else 0.0
                      for m, b in zip((mg, mb), self.beta))
        return max(mg, 0.0), max(ma, 0.0), max(mb, 0.0)

    def face_axes(self, s: float, on: dict[str, bool], shift_ends: bool = False) -> tuple[NDArray, NDArray]:
        """The axes of the grid over the box's face of the two components the states depend on
        nonlinearly, at scale s: the palm's turn about y (rad) and the grasp shift along GB (over
        l), each from -s to s times its bound at no coarser a step than the sampling resolution,
        ends included; with shift_ends, the shift's two ends alone."""
        b = self.box
        phi = s * math.radians(b.palm_turn_deg) if on["palm_turn"] else 0.0
        shift = s * b.shift_mm / 1000 / self.l if on["shift_along"] else 0.0
        n_phi = 1 if phi == 0 else 2 * int(math.ceil(phi / min(self.res[0], self.res[2]))) + 1
        n_d = 1 if shift == 0 else 2 if shift_ends else 2 * int(math.ceil(shift / self.res[1])) + 1
        return np.linspace(-phi, phi, n_phi), np.linspace(-shift, shift, n_d)

    def failures(self, s: float, rows: NDArray, on: dict[str, bool], closure: bool = True,
                 kinematic: bool = True) -> NDArray[np.int8]:
        """For the samples rows: 0 where every error of s times the box (components on) leaves the
        state secure, else the ToleranceReason index (in its order) of the first check failing;
        with closure or kinematic False, that part of the checks (force closure; everything
        else) is left out.

        Size: one vectorised pass over rows x turns x shifts, each check masking the states the next
        one sees; the checks share the broadcast arrays built at its top."""
        b, sc, dg = self.box, self.scene, self.scene.digits
        q = self.samples.states[rows]
        n = len(q)
        # without force closure, obstacles and the termination, every check is linear in d or (the
        # digits' lowest point) the least of linear functions of it: the shift's ends are its worst
        phi_axis, shift_axis = self.face_axes(s, on, not closure and not self.obstacles and not self.terminal[rows].any())
        phi, shift = (x.ravel() for x in np.meshgrid(phi_axis, shift_axis, indexing="ij"))
        g = len(phi)
        # the moved states as (state, turn, shift), which force closure takes as they are (B's
        # wrenches then cost one per turn, not per shift) and the other checks flat in that order; a
        # state turned below theta 0 lies flat with the hand turned against it
        th3 = q[:, 0, None, None] + phi_axis[None, :, None]
        d3 = q[:, 1, None, None] + shift_axis[None, None, :]
        ps3 = np.where(th3 < 0.0, q[:, 2, None, None] + th3, q[:, 2, None, None])
        th3 = np.where(th3 < 0.0, 0.0, th3)
        full = (n, len(phi_axis), len(shift_axis))
        th, d, ps = (np.broadcast_to(x, full).ravel() for x in (th3, d3, ps3))
        loss = s * b.friction if on["friction"] else 0.0
        yaw = s * math.radians(b.yaw_deg) if on["yaw"] else 0.0
        fc = np.ones(len(th), dtype=bool)
        if not closure or not any(on[c] for c in ("shift_along", "palm_turn", "friction", "yaw")):
            corners = []  # nothing moves what force closure depends on: it holds as at scale 0
        elif sc.options.sliding_model == "relaxed":
            corners = [(loss, yaw)]
        else:
            corners = [(lo, y) for lo in (0.0, loss) for y in (0.0, yaw)]
        sa3, sb3 = self.samples.a_sign[rows][:, None, None], self.samples.b_sign[rows][:, None, None]
        # the true friction, lost by lo from the scene's nominal coefficients and known exactly: a
        # range the scene gives (docs/model.md 4.7) bounds the same uncertainty and is not counted again
        for lo, y in corners:  # relaxed: closure only shrinks with friction, so the worst corner suffices
            fc &= force_closure(th3, d3, ps3, sa3, sb3, sc.friction.with_mu(self.mu(lo, y))).ravel()
        if not kinematic:
            return (~fc).reshape(n, g).any(axis=1).astype(np.int8)
        # G's lift over the table: the grasp shift's (a sin theta') and the calibration's (the turn
        # about P0 exactly on the face's grid; the palm's shift and the table's height at their
        # worst corners, as they enter linearly); the digits' lowest point also drops by the
        # plane's tip
        p0 = self.p0
        turned = p0[:, None] - np.stack([np.cos(phi) * p0[0] - np.sin(phi) * p0[1],
                                         np.sin(phi) * p0[0] + np.cos(phi) * p0[1]])  # P0 - R(phi) P0, (2, g)
        worst = 0.0
        if on["palm_shift"]:
            worst += s * b.palm_shift_mm / 1000 / self.l * self.lift_per_shift
        if on["table_height"]:
            worst += s * b.table_mm / 1000 / self.l
        lift_g = np.tile(turned[1], n) + np.tile(shift, n) * np.sin(th) - worst
        # the most a hand too high lifts G at the start: beyond the press the object hangs there (the
        # palm's turns about its x and z axes lift G by second-order terms, bounded by 2 |P0| t^2)
        if self.hangs:
            t = s * math.radians(b.palm_turn_deg) if on["palm_turn"] else 0.0
            up = turned[1] + shift * self.sin_start + worst + 2.0 * float(np.hypot(*p0)) * t * t
            hanging = np.tile(up > dg.press + 1e-12, n)
        else:
            hanging = np.zeros(len(th), dtype=bool)
        tipped = s * math.radians(b.palm_turn_deg) * self.drop_per_turn if on["palm_turn"] else 0.0
        worst += tipped
        # with a start press the hand runs press below the plan and the table holds G: the hand
        # stands press - lift_g lower than the moved state needs, and the object lies at the
        # state pressed by that much (docs/model.md 11.9), where the digits are that much lower
        press = dg.press
        lift = lift_g - tipped - press
        # how far the hand may stand from where the moved state puts it, for the obstacles
        away = s * math.sqrt(2.0) * b.palm_shift_mm / 1000 / self.l if on["palm_shift"] else 0.0
        moved = np.tile(np.abs(shift) + np.hypot(turned[0], turned[1]), n) + away + worst + press
        code = np.zeros(len(th), dtype=np.int8)
        across = s * b.shift_mm / 1000 / self.l if on["shift_across"] and dg.held_by_supports else None
        kappas = (-1.0, 1.0) if on["thickness"] and b.thickness else (0.0,)
        for k in kappas:
            t = dg.object_thickness * (1.0 + k * s * b.thickness)
            digits = replace(dg, object_thickness=t)
            sbv = s_b(d, ps, dg.alpha, t, dg.finger_tip_radius)
            tip = sbv.copy()  # B's least distance from the thumb's tip
            tips = np.zeros(len(th), dtype=bool) if across is None else across_support(d, ps, dg) < across
            if press > 0.0:  # B and A where the press puts the object (none found: pressed flat, B lost)
                _, dp, pp, found = pressed_state(th, d, ps, press - lift_g, digits)
                tip = np.where(found, np.minimum(tip, s_b(dp, pp, dg.alpha, t, dg.finger_tip_radius)), -np.inf)
                if across is not None:
                    tips |= found & (across_support(dp, pp, dg) < across)
            w = aperture(d, ps, t, dg.finger_tip_radius)
            low = _lowest(th, d, ps, digits if self.housing else replace(digits, palm_width=0.0))
            near = kinematic_margins(th, d, ps, digits, 1.0, self.obstacles)["obstacles"] if self.obstacles else np.inf
            checks = (~fc, tip < 0.0, sbv > dg.thumb_length, (d <= 0.0) | (d > 1.0), tips,
                      (w < 0.0) | (w > dg.max_aperture), low + lift < 0.0, near - moved < 0.0, hanging)
            for i, bad in enumerate(checks):
                code = np.where((code == 0) & bad, i + 1, code)
        ends = np.flatnonzero(self.terminal[rows])
        if len(ends):  # every moved copy of a terminal state
            sl = (ends[:, None] * g + np.arange(g)[None, :]).ravel()
            r = sc.robot
            stuck = self.checker.termination_collides(np.column_stack([th[sl], d[sl], ps[sl]]), r.termination,
                                                      r.termination_amount)
            code[sl] = np.where((code[sl] == 0) & stuck, list(ToleranceReason).index(ToleranceReason.NO_TERMINATION) + 1,
                                code[sl])
        code = code.reshape(n, g)
        first = np.where(code > 0, code, 127).min(axis=1)
        return np.where(first == 127, 0, first).astype(np.int8)

    def scale(self, rows: NDArray, on: dict[str, bool], tol: float, top: float) -> tuple[float, NDArray]:
        """The largest scale in [0, top] with no failure at rows, to the relative tolerance tol
        (and at least 1e-6), and the failure codes of rows just above it (all zero when nothing
        fails at top). The scale doubles from FIRST_SCALE until a state fails, then bisects; a
        state secure at a scale is secure below it (the boxes nest), so once a scale fails only
        the states failing there are examined further."""
        codes = np.zeros(len(rows), dtype=np.int8)
        live = np.arange(len(rows))
        first = self.failures(0.0, rows, on)
        if first.any():
            return 0.0, first
        lo, hi, s = 0.0, None, min(FIRST_SCALE, top)
        while hi is None:
            c = self.failures(s, rows, on)
            if c.any():
                hi, codes[:] = s, c
                live = np.flatnonzero(c)
            elif s >= top:
                return top, codes
            else:
                lo, s = s, min(2.0 * s, top)
        while hi - lo > max(tol * hi, 1e-6):
            mid = 0.5 * (lo + hi)
            c = self.failures(mid, rows[live], on)
            if c.any():
                hi = mid
                codes[:] = 0
                codes[live] = c
                live = live[c > 0]
            else:
                lo = mid
        return lo, codes


def describe_tolerance(tol: dict) -> str:
    """A plan's tolerance (plan.json's, planning.plan_tolerance.Tolerance.to_dict) for a person, in millimetres,
    degrees and per cent: what errors the plan survives together, then (a second line, indented)
    where a larger error first breaks it, what fails there and which error alone it tolerates least."""
    s, p, name = tol["scale"], tol["physical"], tol["perturbation"]
    reason = ToleranceReason(tol["reason"])
    bounds = "the paper's error bounds (docs/model.md 11.3)" if name == "paper" else f"the '{name}' error bounds"
    theta, d, psi = tol["state"]
    at = f"theta {math.degrees(theta):.1f} deg, d {d:.3f}, psi {math.degrees(psi):.1f} deg"
    k, kind = tol["primitive"], tol["primitive_type"]
    if reason is ToleranceReason.G_LIFTED:
        where = "at the start"
    elif reason is ToleranceReason.NO_TERMINATION:
        where = f"at the end, where the gripper lets go ({at})"
    else:
        words = Primitive(kind).describe() if kind in tuple(Primitive) else kind
        where = f"during primitive {k + 1} ({kind}: {words}), at {at}"
    least = COMPONENT_WORDS.get(tol["component"], (tol["component"],))[0] + _alone(tol)
    if reason is ToleranceReason.NONE:
        return (f"tolerance of errors: the plan stays secure under any error up to {s:.3f} times {bounds}: "
                f"{_errors(p)}; nothing fails up to there (docs/model.md 4.6)")
    if s <= 0.0:
        first = COMPONENT_WORDS.get(tol["component"], (tol["component"],))[0]
        return (f"tolerance of errors: none (docs/model.md 4.6): the smallest error within {bounds} breaks the plan "
                f"{where}: {reason.describe()}\n  the error that does it first: {first}")
    return (f"tolerance of errors: the plan stays secure under any error up to {s:.3f} times {bounds}, all at once: "
            f"{_errors(p)} (docs/model.md 4.6)\n  a larger error first breaks it {where}: {reason.describe()}; "
            f"the error it tolerates least there: {least}")


def _errors(p: dict) -> str:
    """The box at the tolerance's scale (Tolerance.physical) in words, the components with a bound."""
    words = []
    if p.get("shift_mm"):
        words.append(f"the grasp {p['shift_mm']:.3f} mm off along and across the object")
    if p.get("yaw_deg"):
        words.append(f"the object turned {p['yaw_deg']:.2f} deg in the grasp")
    if p.get("friction_loss"):
        words.append(f"{100 * p['friction_loss']:.1f} % less friction")
    if p.get("thickness_fraction"):
        words.append(f"the object {100 * p['thickness_fraction']:.1f} % thicker or thinner")
    if p.get("palm_shift_mm") or p.get("palm_turn_deg"):
        words.append(f"the hand {p.get('palm_shift_mm', 0.0):.3f} mm and {p.get('palm_turn_deg', 0.0):.2f} deg off "
                     "its calibrated pose")
    if p.get("table_mm"):
        words.append(f"the table {p['table_mm']:.3f} mm higher or lower")
    return ", ".join(words) or "no error"


def _alone(tol: dict) -> str:
    """' (alone, up to 0.287 mm)': the binding component's own tolerance in its unit, when the box's
    bound is known (a preset's, or the tolerance's box at a scale above 0); empty otherwise."""
    scale = tol.get("component_scales", {}).get(tol["component"])
    if tol["component"] not in COMPONENT_WORDS or scale is None or math.isinf(scale):
        return ""
    _, field, unit, factor = COMPONENT_WORDS[tol["component"]]
    if tol["perturbation"] in PRESETS:
        bound = getattr(PRESETS[tol["perturbation"]], field)
    else:
        physical = {"shift_mm": "shift_mm", "yaw_deg": "yaw_deg", "friction": "friction_loss",
                    "thickness": "thickness_fraction", "palm_shift_mm": "palm_shift_mm",
                    "palm_turn_deg": "palm_turn_deg", "table_mm": "table_mm"}[field]
        if tol["scale"] <= 0.0:
            return ""
        bound = tol["physical"][physical] / tol["scale"]
    value = scale * bound * factor
    if value <= 0.0:
        return ""
    return f" (alone, up to {value:.3f} {unit})" if unit in ("mm",) else f" (alone, up to {value:.2f} {unit})"


def _lowest(theta: NDArray, d: NDArray, psi: NDArray, digits: DigitGeometry) -> NDArray[np.float64]:
    """The height over the table of the lowest point of the thumb, the finger and the housing
    (over l): kinematic_margins' table margin, from the heights alone of digit_polygons' and the
    housing's vertices (with e = -(cos, sin)(theta + psi) and n_B = (-sin, cos)(theta + psi), a
    vertex's height is its tip's plus the vertical parts of its offsets along them)."""
    c, s = np.cos(theta + psi), np.sin(theta + psi)  # -e's and n_B's vertical parts: s and c
    r, t = digits.finger_tip_radius, digits.object_thickness
    thumb = np.sin(theta) - s_b(d, psi, digits.alpha, t, r) * s  # thumb_tip: B + s_B e
    # finger_corner: the dome's centre (contact_point + r n_top) + r (e - n_B)
    finger = (1.0 - contact_d(d, psi, r)) * np.sin(theta) + (t + r) * np.cos(theta) - r * (s + c)

    def below(length: float, t_tip: float, t_base: float, side: float) -> NDArray[np.float64]:
        """The lowest of digit_offsets' vertex heights: 0 (the tip), the base, its back corner, the tip's back corner."""
        return np.minimum(np.minimum(0.0, length * s), np.minimum(length * s + side * t_base * c, side * t_tip * c))

    low = np.minimum(thumb + below(digits.thumb_length, digits.thumb_tip_thickness, digits.thumb_base_thickness, -1.0),
                     finger + below(digits.finger_length, digits.finger_tip_thickness, digits.finger_base_thickness,
                                    1.0))
    if digits.palm_width > 0 and digits.palm_length > 0:  # housing_centre, then housing_offsets' lowest
        centre = thumb + (digits.thumb_length + digits.palm_length / 2) * s + aperture(d, psi, t, r) / 2 * c
        low = np.minimum(low, centre - np.abs(digits.palm_length / 2 * s) - np.abs(digits.palm_width / 2 * c))
    return low


def checked_box(scene: Scene, options: ToleranceOptions) -> tuple[Perturbation, NDArray[np.float64]]:
    """The box at scale 1 and the sampling resolution of options; InputError naming a bad field."""
    if options.box is None and options.perturbation not in PRESETS:
        raise InputError("perturbation", f"unknown preset {options.perturbation!r} (one of: {', '.join(PRESETS)})")
    if not (math.isfinite(options.max_scale) and options.max_scale > 0):
        raise InputError("max_scale", f"must be a positive number, got {options.max_scale!r}")
    if not (math.isfinite(options.scale_tolerance) and 0 < options.scale_tolerance < 1):
        raise InputError("scale_tolerance", f"must lie in (0, 1) (relative), got {options.scale_tolerance!r}")
    res = np.asarray(options.resolution if options.resolution is not None else scene.options.resolution, dtype=float)
    if res.shape != (3,) or not np.all(np.isfinite(res) & (res > 0)):
        raise InputError("resolution", f"must be three positive numbers (theta rad, d, psi rad), got {options.resolution!r}")
    box = options.box if options.box is not None else PRESETS[options.perturbation]
    bounds = {k: getattr(box, k) for k in ("shift_mm", "yaw_deg", "friction", "thickness", "palm_shift_mm",
                                           "palm_turn_deg", "table_mm")}
    bad = [k for k, v in bounds.items() if not (math.isfinite(v) and v >= 0)] + \
        (["friction"] if box.friction > 1 else [])
    if bad:
        raise InputError(f"box.{bad[0]}", f"must be a finite bound >= 0 (friction at most 1), got {bounds[bad[0]]!r}")
    return box, res


#: The scales state_tolerances tells apart (dimensionless): 0, then from FIRST_SCALE / 4 up by a
#: factor 2^(1/4) (19 % apart), the last at most ToleranceOptions.max_scale.
LADDER_STEP = 2.0 ** 0.25

#: Moved states per batch of state_tolerances (bounds its memory: a few hundred bytes each).
BATCH_MOVED_STATES = 200_000


def ladder(max_scale: float) -> NDArray[np.float64]:
    """state_tolerances' scales: 0, FIRST_SCALE / 4 * LADDER_STEP^k up to max_scale."""
    n = int(math.floor(math.log(max_scale / (FIRST_SCALE / 4)) / math.log(LADDER_STEP) + 1e-9)) + 1
    return np.concatenate([[0.0], FIRST_SCALE / 4 * LADDER_STEP ** np.arange(n)])


def state_tolerances(scene: Scene, states: NDArray[np.float64], a_sign: NDArray, b_sign: NDArray,
                     terminal: NDArray[np.bool_] | None = None, start: NDArray[np.float64] | None = None,
                     options: ToleranceOptions = ToleranceOptions(), closure: bool = True,
                     kinematic: bool = True, upto: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
    """Each state's own tolerance in its contact mode (states (n, 3): theta rad, d over l, psi rad;
    the sliding signs at A and B, (n,) each): the largest scale of ladder(options.max_scale) at which
    every error within that scale of the box leaves it secure, as a plan's tolerance checks a state
    (the termination at the terminal ones; the calibration's turn about the palm's origin at the
    start, the scene's by default). A state insecure without any error has -inf; one secure at every
    scale has the ladder's top. A plan's tolerance is at least the least of its states' in ladder
    steps (the plan's own is found to options.scale_tolerance instead). closure or kinematic False
    leaves that part of the checks out (a state's tolerance is the smaller of the two parts', since
    both ask of the same box). upto (n,), scales: where only min(tolerance, upto) is wanted (upto
    the state's kinematic part, as the tolerance objective asks), that minimum, with upto taken
    down to the ladder as every value is: the search starts there and looks no higher, where the
    boxes are larger and cost more moved states. Where upto is -inf the state is not checked (-inf).
    The start's lift (G_LIFTED: a hand so high that the press leaves G above the table) is left out:
    it depends on the start alone, the same for every state, so a plan's tolerance is the least of its
    states' and of that.

    Size: the planner's margins call it on lattice slices (states, their modes and terminal flags as
    arrays, no plan's samples), with the check's switches as the plan's tolerance has them."""
    box, res = checked_box(scene, options)
    q = np.asarray(states, dtype=float).reshape(-1, 3)
    n = len(q)
    samples = PlanSamples(q, np.zeros(n, dtype=np.int64), np.broadcast_to(np.asarray(a_sign, dtype=np.int8), (n,)),
                          np.broadcast_to(np.asarray(b_sign, dtype=np.int8), (n,)))
    terminal = np.zeros(n, dtype=bool) if terminal is None else np.broadcast_to(np.asarray(terminal, dtype=bool), (n,))
    ctx = ErrorBox(scene, np.asarray(scene.start if start is None else start, dtype=float), box, samples, terminal, res,
               options.housing, start_lift=False)
    levels = ladder(options.max_scale)
    on = {c: True for c in COMPONENTS}
    # per state, a bisection over the ladder's indices: levels[lo] passes (lo = -1: not even 0),
    # levels[hi] fails (hi = len(levels): none fails); the boxes nest, so passing is monotone. The
    # top (or upto) is tried first: most states of a lattice pass it and are done
    lo = np.full(n, -1)
    hi = np.full(n, len(levels))
    top = np.full(n, len(levels) - 1)
    if upto is not None:  # the highest ladder level at most upto; -1: below the ladder, not searched
        top = np.searchsorted(levels, np.broadcast_to(np.asarray(upto, dtype=float), (n,)), side="right") - 1
        hi = np.where(top < 0, 0, top + 1)
    first = True
    while True:
        live = np.flatnonzero(hi - lo > 1)
        if not len(live):
            break
        mid = top[live] if first else (lo[live] + hi[live]) // 2
        first = False
        for level in np.unique(mid):
            rows = live[mid == level]
            g = math.prod(len(axis) for axis in ctx.face_axes(levels[level], on))  # the face's points
            batch = max(1, BATCH_MOVED_STATES // g)
            for group in (rows[~terminal[rows]], rows[terminal[rows]]):  # the terminal ones need the whole face
                for k in range(0, len(group), batch):
                    part = group[k:k + batch]
                    bad = ctx.failures(float(levels[level]), part, on, closure, kinematic) > 0
                    hi[part[bad]] = level
                    lo[part[~bad]] = level
    return np.where(lo >= 0, levels[np.maximum(lo, 0)], -np.inf)
