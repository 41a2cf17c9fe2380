"""The out-of-plane margin: how hard a push across the manipulation plane a state's contacts resist
(docs/model.md 5.3 and 11.18).

Section 5.3 says qualitatively what the contacts do off the plane: sticking contacts push along the
plane's normal, two sliding contacts leave no z-moment, x-moments come from the supports. This
module makes it a number per state, for a given friction and friction-cone model, against the loads
the plan must carry:

* the jaws' squeeze: the finger's and the thumb's forces along the jaws' slide axis (n_B) add up
  to twice the gripper's force (sim.grip_force: the servo drives the two coupled carriages), the
  palm taking up the rest (it is position-controlled);
* gravity, the object's weight at its centre of mass;
* the grasp off GB across the plane by +-offset (the `paper` errors' 1 mm): A's force then acts
  beside GB, with moments about x (GB) and z (the vertical through G).

Unknowns are the contact forces. Each contact point carries a friction cone: the pyramid inscribed
in Coulomb's cone with its edges along the plane's axes (n +- mu t, n +- mu y: mu along the plane's
tangent t and its normal y, mu / sqrt 2 between them), which is what a pyramidal engine builds and
a lower bound of the elliptic cone; or the elliptic cone itself, as the inscribed polygon of
``elliptic_sides`` edges. A sliding contact (its sign from section 3.2) keeps the edge opposing its
slip, and the normal too under the relaxed model (section 4.3); along the plane's normal it pushes
only by slipping sideways as well. A slip at the angle beta off its in-plane direction turns the
object about the vertical through G by slide tan(beta) / x over a leg on which it slides ``slide``
at the lever x; ``OutOfPlaneLoads.turn`` bounds that turn, hence beta (tan beta = x tan(turn) /
slide). Under Coulomb's law the force then lies on the cone's rim within beta of the in-plane edge
(lateral friction mu sin beta); on the pyramid its vertex keeps the force until the slip is as fast
sideways as along the plane (beta 45 deg), and only then may it move along the pyramid's edges to
n +- mu y. Without slide lengths a sliding contact pushes only in the plane (section 5.3's rule).

The margin (``OutOfPlaneMargin.push``, newtons) is the largest push across the plane, applied at
the centre of mass either way, that some admissible set of contact forces holds together with
those loads, with the grasp off either way: positive, the state keeps the object in the plane with
that much to spare; negative, even its own loads need a push of that size to be held (the object
turns out of the plane); -inf, no contact forces hold the loads in the plane at all at that
friction (the planar grip fails first). It is a linear programme per state and side the grasp is
off (HiGHS's dual simplex, its interior-point method where the simplex meets numerical trouble;
moments in newtons times the object's length, every row of order 1), the geometry built for all
states at once.

Frame: the manipulation plane's, G at the origin, x along the table toward B, y the plane's normal,
z up; metres, newtons, radians. The object lies in the plane spanned by GB and y.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import StrEnum

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import InputError, ToolError
from ..mechanics.contact import primitive_sliding_signs, sliding_signs
from ..mechanics.force_closure import SlidingModel
from ..mechanics.kinematics import GRAVITY, contact_d, digit_axis, pressed_state, s_b, thumb_normal
from .model import Scene

#: How far (rad) the object may turn out of the plane over a leg by its sliding contacts' sideways
#: slip, by default: the simulated verdict's bound (sim.trial.LEFT_PLANE_DEG, 10 deg).
DEFAULT_TURN = math.radians(10.0)
#: The `paper` errors' bound on the grasp's shift across GB (m, docs/model.md 11.3).
DEFAULT_OFFSET = 1e-3


class ConeModel(StrEnum):
    """How a contact's friction cone is built (a member is its name as a string)."""

    #: The pyramid inscribed in Coulomb's cone, edges along the plane's tangent and its normal.
    PYRAMIDAL = "pyramidal"
    #: Coulomb's circular cone (as its inscribed polygon of OutOfPlaneLoads.elliptic_sides edges).
    ELLIPTIC = "elliptic"


@dataclass(frozen=True)
class OutOfPlaneLoads:
    """What the contacts must carry off the plane, besides the squeeze and the weight."""

    offset: float = DEFAULT_OFFSET
    """How far A lies beside GB, across the plane, either way (m)."""
    jaw_force: float | None = None
    """The gripper's force (N; each digit's share of the servo's pair): the finger's and the thumb's
    forces along the slide axis add up to twice it. None: the scene's sim.grip_force."""
    turn: float = DEFAULT_TURN
    """The turn out of the plane (rad) a sliding contact's sideways slip may cost over its leg."""
    elliptic_sides: int = 32
    """Edges of the polygon inscribed in an elliptic cone (its capacity errs by 1 - cos(pi / sides))."""

    def __post_init__(self) -> None:
        if not (math.isfinite(self.offset) and self.offset >= 0.0):
            raise InputError("offset", f"must be a distance in metres >= 0, got {self.offset!r}")
        if self.jaw_force is not None and not (math.isfinite(self.jaw_force) and self.jaw_force > 0.0):
            raise InputError("jaw_force", f"must be a force in newtons > 0, got {self.jaw_force!r}")
        if not 0.0 <= self.turn < math.pi / 2:
            raise InputError("turn", f"must be an angle in [0, pi/2) rad, got {self.turn!r}")
        if self.elliptic_sides < 8:
            raise InputError("elliptic_sides", f"must be at least 8, got {self.elliptic_sides!r}")


@dataclass(frozen=True)
class ContactLayout:
    """The contact points of states (N of them), plane frame, m. Point k belongs to contact
    ``owner[k]`` (0 G, 1 A, 2 B): G's and B's supports give a point at each end of their reach
    across the plane (one point where they reach 0), a flat finger tip one at each end of its
    width, a rounded tip one, all A's points moved across by the grasp's offset."""

    points: NDArray[np.float64]  #: (N, K, 3)
    normals: NDArray[np.float64]  #: (N, K, 3) unit, the contact's push on the object
    tangents: NDArray[np.float64]  #: (N, K, 3) unit, in the plane, square to the normal
    owner: NDArray[np.int64]  #: (K,)
    slide_axis: NDArray[np.float64]  #: (N, 3) the jaws' slide axis, n_B (toward the object from the thumb)
    centre: NDArray[np.float64]  #: (N, 3) the object's centre of mass
    lever: NDArray[np.float64]  #: (N, 3) horizontal distance (m) of G, A, B from the vertical through G


def object_mass_centre(scene: Scene) -> tuple[float, float, float]:
    """The object's weight (N, from sim.density, its outline's area and its thickness) and its
    centre of mass in its own frame: along GB from G and across GB (m; half the thickness up). A
    scene without an outline is a strip of the digits' width along GB."""
    l, t = scene.object_length, scene.object_thickness
    if scene.object3d is None or scene.plane is None:
        w = scene.digits.width * l
        return scene.sim.density * l * w * t * GRAVITY, l / 2, 0.0
    frame = scene.plane.frame
    xy = (scene.object3d.placed_outline(2e-6) - frame[:2, 3]) @ frame[:2, :2]
    x, y = xy[:, 0], xy[:, 1]
    cross = x * np.roll(y, -1) - np.roll(x, -1) * y
    area = float(cross.sum()) / 2
    cx = float(((x + np.roll(x, -1)) * cross).sum()) / (6 * area)
    cy = float(((y + np.roll(y, -1)) * cross).sum()) / (6 * area)
    return scene.sim.density * abs(area) * t * GRAVITY, cx, cy


def contact_layout(scene: Scene, q: ArrayLike, offset: float) -> ContactLayout:
    """Where the contacts of states q (N, 3) (theta rad, d over l, psi rad) touch and push, with
    A beside GB by offset (m, signed: along +y)."""
    q = np.atleast_2d(np.asarray(q, dtype=float))
    th, d, ps = q[:, 0], q[:, 1], q[:, 2]
    dg, l, t = scene.digits, scene.object_length, scene.object_thickness
    n = len(q)
    u = np.stack([np.cos(th), np.zeros(n), np.sin(th)], axis=1)  # G -> B
    v = np.stack([-np.sin(th), np.zeros(n), np.cos(th)], axis=1)  # the top face's outward normal
    y = np.array([0.0, 1.0, 0.0])
    nb2, e2 = thumb_normal(th, ps), digit_axis(th, ps)
    nb = np.stack([nb2[:, 0], np.zeros(n), nb2[:, 1]], axis=1)
    e = np.stack([e2[:, 0], np.zeros(n), e2[:, 1]], axis=1)
    s_g, s_bb = dg.support[0] * l, dg.support[1] * l
    d_a = contact_d(d, ps, dg.finger_tip_radius)
    a_mid = ((1.0 - d_a) * l)[:, None] * u + t * v + offset * y
    a_ends = (0.0,) if not dg.flat_finger_tip else (-dg.width * l / 2, dg.width * l / 2)
    pts, nrm, tan, own = [], [], [], []
    for s in ((-s_g, s_g) if s_g > 0 else (0.0,)):
        pts.append(np.broadcast_to(s * y, (n, 3)))
        nrm.append(np.broadcast_to([0.0, 0.0, 1.0], (n, 3)))
        tan.append(np.broadcast_to([1.0, 0.0, 0.0], (n, 3)))
        own.append(0)
    for s in a_ends:
        pts.append(a_mid + s * y)
        nrm.append(-v)
        tan.append(u)
        own.append(1)
    for s in ((-s_bb, s_bb) if s_bb > 0 else (0.0,)):
        pts.append(l * u + s * y)
        nrm.append(nb)
        tan.append(e)
        own.append(2)
    _, cx, cy = object_mass_centre(scene)
    centre = cx * u + (t / 2) * v + cy * y
    lever = np.stack([np.zeros(n), np.abs(a_mid[:, 0]), np.abs(l * u[:, 0])], axis=1)
    return ContactLayout(np.stack(pts, axis=1), np.stack(nrm, axis=1), np.stack(tan, axis=1),
                         np.asarray(own), nb, centre, lever)


def _generators(normal: NDArray, tangent: NDArray, mu: float, cone: ConeModel, sliding: int,
                relaxed: bool, drift: float, sides: int) -> NDArray[np.float64]:
    """The forces (M, 3) whose non-negative combinations are what one contact point may push
    with: its friction cone (sliding == 0) or, sliding, the edge opposing its slip (friction
    along -sliding * tangent; section 3.2's sign convention is the caller's), the normal too when
    relaxed, and the sideways edges its allowed drift (rad) reaches."""
    y = np.array([0.0, 1.0, 0.0])
    if sliding == 0:
        if cone is ConeModel.PYRAMIDAL:
            dirs = [tangent, -tangent, y, -y]
        else:
            a = 2 * np.pi * np.arange(sides) / sides
            dirs = list(np.cos(a)[:, None] * tangent + np.sin(a)[:, None] * y)
        return np.array([normal + mu * w for w in dirs])
    f = sliding * tangent  # the friction's direction on the object
    out = [normal + mu * f] + ([normal] if relaxed else [])
    if cone is ConeModel.PYRAMIDAL:
        if drift >= math.pi / 4 - 1e-12:
            out += [normal + mu * y, normal - mu * y]
    elif drift > 0.0:
        k = max(2, int(math.ceil(drift / (2 * np.pi / sides))))
        for a in np.linspace(-drift, drift, 2 * k + 1):
            if a != 0.0:
                out.append(normal + mu * (math.cos(a) * f + math.sin(a) * y))
    return np.array(out)


def _wrench(points: NDArray, forces: NDArray) -> NDArray[np.float64]:
    """Wrenches (..., 6) of forces (..., 3) at points (..., 3): force, then moment about G."""
    return np.concatenate([forces, np.cross(points, forces)], axis=-1)


@dataclass(frozen=True)
class OutOfPlaneMargin:
    """The out-of-plane margin of N states (see the module docstring)."""

    push: NDArray[np.float64]
    """(N,) the largest push across the plane at the centre of mass, either way, held with the
    state's loads, the grasp off either way (N); negative: help needed; -inf: no in-plane hold."""
    friction: tuple[float, float, float]
    """The coefficients at G, A, B it was taken with (the plane's)."""
    cone: ConeModel
    loads: OutOfPlaneLoads
    jaw_force: float
    """The gripper's force used (N)."""
    weight: float
    """The object's weight (N)."""

    @property
    def holds(self) -> NDArray[np.bool_]:
        """(N,) the state keeps the object in the plane (push >= 0)."""
        return self.push >= 0.0


def out_of_plane_margin(scene: Scene, q: ArrayLike, a_sign: ArrayLike = 0, b_sign: ArrayLike = 0,
                        friction: tuple[float, float, float] | None = None,
                        cone: ConeModel | str = ConeModel.PYRAMIDAL, loads: OutOfPlaneLoads = OutOfPlaneLoads(),
                        slide: ArrayLike | None = None) -> OutOfPlaneMargin:
    """The out-of-plane margin of states q (N, 3) (theta rad, d over l, psi rad) in the contact
    mode a_sign, b_sign (N,) each (section 3.2: -1, 0, +1 at A and at B; 0 sticks), with the
    plane's coefficients friction at G, A, B (default: the scene's friction range's low end,
    Scene.friction.low) and the cone model. slide: (N, 2) how far (m) A and B slide over the leg
    each state lies on, which bounds their sideways slip by loads.turn; None: sliding contacts
    push only in the plane. InputError for bad arguments; ToolError where HiGHS fails on a state.

    Size: one vectorised assembly of every state's linear programme (the contacts, the loads, the cone's
    rows) before HiGHS solves them; split, each part would pass the same dozen (N, ...) arrays."""
    from scipy.optimize import linprog  # scipy.optimize: 0.5 s to import, loaded for the margin

    q = np.atleast_2d(np.asarray(q, dtype=float))
    if q.ndim != 2 or q.shape[1] != 3 or not np.all(np.isfinite(q)):
        raise InputError("q", f"must be finite states of shape (N, 3), got shape {q.shape}")
    n = len(q)
    sa = np.broadcast_to(np.asarray(a_sign, dtype=int), (n,))
    sb = np.broadcast_to(np.asarray(b_sign, dtype=int), (n,))
    try:
        cone = ConeModel(cone)
    except ValueError:
        raise InputError("cone", f"must be one of {', '.join(ConeModel)}, got {cone!r}") from None
    mu = tuple(float(m) for m in (scene.friction.low if friction is None else friction))
    if len(mu) != 3 or not all(math.isfinite(m) and m >= 0.0 for m in mu):
        raise InputError("friction", f"must be three coefficients >= 0 (G, A, B), got {friction!r}")
    slides = np.zeros((n, 2)) if slide is None else np.broadcast_to(np.asarray(slide, dtype=float), (n, 2))
    jaw = scene.sim.grip_force if loads.jaw_force is None else loads.jaw_force
    weight, _, _ = object_mass_centre(scene)
    relaxed = scene.options.sliding_model == SlidingModel.RELAXED
    layouts = [contact_layout(scene, q, s * loads.offset) for s in (1.0, -1.0)]
    out = np.empty(n)
    y = np.array([0.0, 1.0, 0.0])
    length_unit = scene.object_length  # moments in N l: every row of the programme of order 1
    for i in range(n):
        blocks, loads_rhs, pushes = [], [], []
        for lay in layouts:
            gens, jaw_row = [], []
            for k, owner in enumerate(lay.owner):
                sign = (0, sa[i], sb[i])[owner]
                # section 3.2: friction on the object at A along -sign(dd) u, at B along +sign(ds_B) e
                friction_dir = (0, -sign, sign)[owner]
                drift = 0.0
                if sign != 0 and slide is not None:
                    length = slides[i, owner - 1]
                    lever = lay.lever[i, owner]
                    drift = math.pi / 2 if length <= 0.0 else math.atan(lever * math.tan(loads.turn) / length)
                g = _generators(lay.normals[i, k], lay.tangents[i, k], mu[owner], cone, friction_dir, relaxed,
                                drift, loads.elliptic_sides)
                gens.append(_wrench(np.broadcast_to(lay.points[i, k] / length_unit, g.shape), g))
                along = {1: -1.0, 2: 1.0}.get(owner, 0.0)
                jaw_row.append(along * g @ lay.slide_axis[i])
            blocks.append((np.vstack(gens).T, np.concatenate(jaw_row)))
            gravity = _wrench(lay.centre[i] / length_unit, np.array([0.0, 0.0, -weight]))
            loads_rhs.append(gravity)
            pushes.append(_wrench(lay.centre[i] / length_unit, y))
        # per side the grasp is off: the pushes held form an interval [lo, hi] along +y (a linear
        # programme's least and largest); the margin is the least of hi and -lo over both sides
        best = math.inf
        for (w, jrow), rhs, push in zip(blocks, loads_rhs, pushes):
            nv = w.shape[1] + 1
            a_eq = np.zeros((7, nv))
            a_eq[:6, :-1], a_eq[:6, -1], a_eq[6, :-1] = w, push, jrow
            b_eq = np.concatenate([-rhs, [2.0 * jaw]])
            bounds = [(0.0, None)] * (nv - 1) + [(None, None)]
            for direction in (1.0, -1.0):
                cost = np.zeros(nv)
                cost[-1] = -direction
                res = linprog(cost, A_eq=a_eq, b_eq=b_eq, bounds=bounds, method="highs-ds")
                if res.status == 4:  # numerical trouble in the simplex: the interior-point method instead
                    res = linprog(cost, A_eq=a_eq, b_eq=b_eq, bounds=bounds, method="highs-ipm")
                if res.status == 2:  # no forces hold the loads in the plane at this friction
                    best = -math.inf
                elif res.status == 3:  # unbounded that way (not expected: the squeeze is bounded)
                    continue
                elif res.status == 0:
                    best = min(best, direction * float(res.x[-1]))
                else:
                    raise ToolError(f"the out-of-plane programme failed at state {i}: {res.message}")
                if best == -math.inf:
                    break
            if best == -math.inf:
                break
        out[i] = best
    return OutOfPlaneMargin(out, mu, cone, loads, jaw, weight)


@dataclass(frozen=True)
class PlanStates:
    """States along a plan for the out-of-plane margin: the start press (robot.start_press, a leg of
    its own, index -1) and every primitive's legs, each state with its leg's contact mode and how
    far A and B slide over that leg (m)."""

    states: NDArray[np.float64]  #: (N, 3)
    primitive: NDArray[np.int64]  #: (N,) the primitive's index, -1 for the start press
    a_sign: NDArray[np.int8]
    b_sign: NDArray[np.int8]
    slide: NDArray[np.float64]  #: (N, 2) m
    names: tuple[str, ...]  #: each primitive's type, in order


def plan_states(scene: Scene, plan, resolution: ArrayLike = (math.radians(2.0), 0.02, math.radians(2.0)),
                press: bool = True) -> PlanStates:
    """The states a solved plan passes (each leg sampled at least every resolution in theta, d, psi,
    its ends included, in the leg's mode), preceded, with press and a scene that presses at the
    start, by the start press: the object turned about G and slid in the pinch from the plan's start
    to where the press puts it (kinematics.pressed_state), A and B sliding as that move makes them."""
    res = np.asarray(resolution, dtype=float)
    l, dg = scene.object_length, scene.digits
    states, prims, sas, sbs, slides = [], [], [], [], []

    def sb_of(x: NDArray) -> NDArray:
        return s_b(x[..., 1], x[..., 2], dg.alpha, dg.object_thickness, dg.finger_tip_radius)

    depth = scene.robot.start_press / l
    if press and depth > 0.0 and plan.primitives:
        a = np.asarray(plan.primitives[0].waypoints[0], dtype=float)
        th, d, ps, found = pressed_state(a[0], a[1], a[2], depth, dg)
        if bool(found):
            b = np.array([float(th), float(d), float(ps)])
            q = a + np.linspace(0.0, 1.0, 6)[:, None] * (b - a)
            sa, sb = sliding_signs(a[1], a[2], b[1] - a[1], b[2] - a[2])
            states.append(q)
            prims.append(np.full(len(q), -1))
            sas.append(np.full(len(q), int(sa), dtype=np.int8))
            sbs.append(np.full(len(q), int(sb), dtype=np.int8))
            slides.append(np.tile([abs(b[1] - a[1]) * l, abs(float(sb_of(b) - sb_of(a))) * l], (len(q), 1)))
    for k, step in enumerate(plan.primitives):
        ways = np.asarray(step.waypoints, dtype=float)
        for a, b in zip(ways[:-1], ways[1:]):
            delta = b - a
            m = max(1, int(math.ceil(float(np.max(np.abs(delta) / res)) - 1e-9)))
            q = a + np.arange(m + 1)[:, None] / m * delta
            sa, sb = primitive_sliding_signs(step.type, q[:, 1], q[:, 2], delta[1], delta[2])
            states.append(q)
            prims.append(np.full(len(q), k))
            sas.append(np.asarray(sa, dtype=np.int8))
            sbs.append(np.asarray(sb, dtype=np.int8))
            slides.append(np.tile([abs(delta[1]) * l, abs(float(sb_of(b) - sb_of(a))) * l], (len(q), 1)))
    if not states:
        raise InputError("plan", "has no primitive: nothing to evaluate")
    return PlanStates(np.vstack(states), np.concatenate(prims), np.concatenate(sas), np.concatenate(sbs),
                      np.vstack(slides), tuple(str(p.type) for p in plan.primitives))


@dataclass(frozen=True)
class PlanOutOfPlane:
    """A plan's out-of-plane margin: its states (PlanStates) and each one's margin."""

    states: PlanStates
    margin: OutOfPlaneMargin

    @property
    def smallest(self) -> float:
        """The smallest push held along the plan, the start press included (N)."""
        return float(self.margin.push.min())

    def of_legs(self) -> list[tuple[str, float]]:
        """(name, smallest push N) of the start press ('press', where there is one) and of each
        primitive, in order."""
        out = []
        for k in sorted(set(self.states.primitive.tolist())):
            name = "press" if k < 0 else self.states.names[k]
            out.append((name, float(self.margin.push[self.states.primitive == k].min())))
        return out

    def first_below(self, level: float = 0.0) -> tuple[str, int] | None:
        """(leg name, state index) of the first state whose push is below level; None if none is."""
        below = np.flatnonzero(self.margin.push < level)
        if not len(below):
            return None
        k = int(self.states.primitive[below[0]])
        return ("press" if k < 0 else self.states.names[k]), int(below[0])


def plan_out_of_plane(scene: Scene, plan, friction: tuple[float, float, float] | None = None,
                      cone: ConeModel | str = ConeModel.PYRAMIDAL, loads: OutOfPlaneLoads = OutOfPlaneLoads(),
                      press: bool = True, drift: bool = True) -> PlanOutOfPlane:
    """The out-of-plane margin along a solved plan (plan_states), each state in its leg's mode;
    drift: let the sliding contacts slip sideways within loads.turn over their legs (False:
    section 5.3's rule, sliding contacts push only in the plane). InputError for an unsolved plan."""
    if not getattr(plan, "solved", True):
        raise InputError("plan", "is not solved: it has no path to evaluate")
    states = plan_states(scene, plan, press=press)
    margin = out_of_plane_margin(scene, states.states, states.a_sign, states.b_sign, friction, cone, loads,
                                 states.slide if drift else None)
    return PlanOutOfPlane(states, margin)
