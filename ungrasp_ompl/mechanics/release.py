"""Where the release puts the object: a planar model of its fall from the plan's last state
(docs/model.md 11.17).

The plan ends with the object pinched at a small theta, its end G on the table and B on the
thumb's face; the termination opens the gripper and the object falls flat. The plan assumes it
turns flat about G. It does not quite: while the pinch lets go the hand carries it a little, and
once free it leans on the table at G and on the thumb's inclined face at B like a ladder on a
wall, so that as it falls its end B rides down the face (and over the thumb's tip), which pushes
it away from the thumb, and G slides on the table as far as the table's friction lets it; it
lands still moving and slides on a little. This module integrates that fall.

The model (every figure in the manipulation plane's frame: G's planned place at the origin, x along
the table toward B, z up; metres, seconds, radians):

* the object is a rigid rectangle of length l = |GB| and the object's thickness, its bottom face
  from G to B; its mass is spread as the outline's area is (uniform density), so that its centre of
  mass lies l_c from G along GB (the outline's centroid projected on GB) and half the thickness up,
  and its radius of gyration about the plane's normal follows from the outline's second moment
  along GB and the thickness. The mass itself drops out (only gravity and contacts act);
* the table is the line z = 0 and touches the object's two bottom corners (G, and B once it lies
  flat); the thumb is a straight face through B turned theta + psi from the table, ending at its
  tip (T = B + s_B e, mechanics.kinematics.thumb_tip), which the object's corner B touches while B
  lies on the face; once B has slid past the tip the thumb no longer touches the object (the face
  meets it at psi > 0, so the tip's corner lies beyond B's end); the finger leaves A along the
  face's normal in every opening termination and is left out once the pinch lets go;
* the hand moves as the termination has it (mechanics.kinematics.release_travel): the commanded
  opening grows from 0 to robot.termination_opening at the rate the export's timing gives it (a
  trapezoid: the contact-speed cap on the faster digit tip and the gripper's acceleration limit,
  both at the timing's 90 %), then the palm lifts straight up (the retreat). The jaws are held by
  the object until the command reaches the object's opening (the pinch's force is gone then): it
  starts the servo's squeeze inside the planned opening (sim.squeeze), and the final press, turning
  the object about G, has opened the digits further (HandMotion.held); the object moves with the
  palm until then, G sliding on the table; after that the thumb's face follows the palm and half
  the opening;
* Coulomb friction at G (mu_G, the object on the table) and B (mu_B, the object on the thumb),
  sticking or sliding, the contacts inelastic: a time-stepping integrator (velocity-level, the
  contact impulses of each 0.5 ms step solved exactly over the contacts' modes: apart, sticking,
  sliding either way) from the moment the pinch lets go until the object lies flat on the table
  and has stopped sliding;
* the planned state is pressed first (mechanics.kinematics.pressed_state): at the termination's
  start the hand runs robot's final press below the plan, which turns the object a little about G;
* a pincer (mechanics.pincer) turns where parallel jaws slide (pincer_hand): its opening is its
  joint's angle, and the palm, the thumb and the finger turn about the joint J by
  mechanics.pincer.release_turns per radian of it, the pinch carrying the object about J with the
  palm until the command has taken up the squeeze and the press's opening; its pressed state is its
  own (mechanics.pincer.pincer_pressed_state: J lowered, the palm turned the same, the joint free).

What it leaves out: anything across the plane (no turn about the vertical is predicted: a centre of
mass off GB turns the object a fraction of a degree as it slides, which the model does not say);
the digits' bending and the contacts' softness (the simulator's digits, bent by the final press,
take it up instead of the object turning about G, and its pinch holds until the command has opened
further than the squeeze, while the object turns down in it: docs/model.md 11.17); the finger after
the pinch; the outline's extent beyond G or B along GB (G and B are the object's ends along GB on
the shipped objects, to micrometres). Where the fall starts is
an input (ReleaseStart): the plan's last state, or, since a force-limited pinch carries the object
through a P_dpsi rather than sliding over it (the simulator's does: docs/model.md 11.13), where
that carry leaves it (planning.predicted_landing.carried_start: B keeps its place on the thumb, G
slides on the table), which planning.predicted_landing.predict_landing takes by default. The
`rotate` termination is not modelled (ReleaseModelError).

This module takes the fall's set-up (ReleaseSetup) as numbers; planning.predicted_landing makes it
from a scene and its plan.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import InputError, UngraspError
from .kinematics import GRAVITY
from .pincer import PincerLinks, PincerPose, chord_angle, release_turns

#: The integrator's step (s): landings move by less than 0.03 mm from 1 ms to 0.1 ms on the shipped plans.
STEP = 5e-4
#: The share of the joint and gripper limits the export's timing uses (robot.timing.TOPPRA_MARGIN).
TIMING_MARGIN = 0.9
#: The gripper's opening speed and acceleration limits (m/s, m/s^2; robot.model.GRIPPER_VEL_LIMIT,
#: GRIPPER_ACCEL_LIMIT).
GRIPPER_SPEED, GRIPPER_ACCELERATION = 0.05, 0.2
#: The retreat's speed (m/s; robot.pipeline.RETREAT_SPEED) and the palm's acceleration into it
#: (m/s^2; about what the export's timing gives the UR5e's joints at the shipped poses).
RETREAT_SPEED, RETREAT_ACCELERATION = 0.05, 1.0
#: The friction factors and cones the spread of a prediction is taken over: every coefficient
#: times 0.7 to 1.3 (dry friction known to +-30 %, docs/model.md 11.16), each with Coulomb's cone
#: and MuJoCo's four-sided pyramid (the pyramid bounded both ways, PyramidReach).
SPREAD_FACTORS = (0.7, 0.85, 1.0, 1.15, 1.3)
#: Longest the integration runs after the termination and the retreat (s).
SETTLE = 0.5


class ReleaseModelError(UngraspError):
    """The release cannot be modelled: the termination (`termination`) is not an opening one, or
    the plan (or the object) does not give what the model needs (`reason`)."""

    def __init__(self, reason: str, termination: str | None = None):
        super().__init__(f"the release cannot be modelled: {reason}")
        self.reason, self.termination = reason, termination


@dataclass(frozen=True)
class ReleaseBody:
    """The object as the fall sees it, in the manipulation plane."""

    length: float
    """l = |GB|, G to B along the bottom face (m)."""
    thickness: float
    """The object's thickness (m)."""
    centre: float
    """l_c: the centre of mass's distance from G along GB (m); it lies half the thickness up."""
    gyration: float
    """The radius of gyration about the plane's normal through the centre of mass (m), thickness included."""

    @classmethod
    def of_outline(cls, outline: NDArray[np.float64], length: float, thickness: float) -> "ReleaseBody":
        """The body of a uniform plate whose outline (N, 2, m) is given in the plane's body frame
        (x along GB from G, y across): l_c = int x dA / A, gyration^2 = int (x - l_c)^2 dA / A +
        thickness^2 / 12."""
        v = np.asarray(outline, dtype=float)
        x, y = v[:, 0], v[:, 1]
        xn, yn = np.roll(x, -1), np.roll(y, -1)
        cross = x * yn - xn * y
        area = cross.sum() / 2.0
        if not abs(area) > 0.0:
            raise ReleaseModelError("the object's outline has no area")
        first = ((x + xn) * cross).sum() / 6.0
        second = ((x * x + x * xn + xn * xn) * cross).sum() / 12.0
        centre = first / area
        spread = max(second / area - centre * centre, 0.0)
        return cls(float(length), float(thickness), float(centre), math.sqrt(spread + thickness ** 2 / 12.0))

    @classmethod
    def strip(cls, length: float, thickness: float) -> "ReleaseBody":
        """A uniform strip from G to B (scenes without an outline)."""
        return cls(float(length), float(thickness), length / 2.0, math.sqrt((length ** 2 + thickness ** 2) / 12.0))


@dataclass(frozen=True)
class HandMotion:
    """How the thumb's face moves over the termination and the retreat, in the plane's frame: the
    parallel jaws' palm sliding by palm per unit of opening, or a pincer's turning about its joint
    (joint, turns; pincer_hand)."""

    tip: tuple[float, float]
    """The thumb's tip on its face when the termination begins (m)."""
    axis: tuple[float, float]
    """e: the digits' axis from the palm toward the tips (unit); the face runs from the tip back along -e."""
    thumb_length: float
    """How far the face runs from the tip toward the palm (m)."""
    palm: tuple[float, float]
    """The palm's travel per unit of opening (mechanics.kinematics.release_travel's 'palm')."""
    opening: float
    """The commanded opening's growth over the termination (m)."""
    held: float
    """How much of it the command takes before the pinch lets go (m): the servo's squeeze and what the
    final press opened the digits beyond the plan (planning.predicted_landing.held_squeeze)."""
    rate: float
    """The opening's cruising rate (m/s)."""
    acceleration: float
    """The opening's acceleration and deceleration (m/s^2)."""
    retreat: float = 0.05
    """How high the palm lifts after the termination (m)."""
    retreat_speed: float = RETREAT_SPEED
    """The retreat's speed (m/s)."""
    retreat_acceleration: float = RETREAT_ACCELERATION
    """The palm's acceleration into and out of the retreat (m/s^2)."""
    joint: tuple[float, float] | None = None
    """A pincer's joint J when the termination begins (m), or None for jaws that slide. With a joint
    the opening is the joint's angle: opening, held, rate and acceleration are in rad, rad/s and
    rad/s^2, the palm (its origin on J) moves only in the retreat (palm (0, 0)), and the hand turns
    about J as turns has it."""
    turns: tuple[float, float, float] = (0.0, 0.0, 0.0)
    """A pincer's palm's, thumb's and finger's turns about J per radian of opening (rad/rad; + turns e
    toward n_B): mechanics.pincer.release_turns."""
    finger: tuple[float, float] | None = None
    """A pincer's finger point finger_at follows, when the termination begins (m): its dome centre C;
    None for jaws that slide (the fall leaves the finger out)."""

    @property
    def normal(self) -> tuple[float, float]:
        """n_B: the face's normal toward the object (unit), e turned a quarter turn clockwise."""
        ex, ez = self.axis
        return ez, -ex

    @cached_property
    def duration(self) -> float:
        """How long the termination takes (s)."""
        return _trapezoid_duration(self.opening, self.rate, self.acceleration)

    @cached_property
    def released(self) -> float:
        """When the pinch lets go (s from the termination's start): the command has taken up held."""
        return _trapezoid_time(min(self.held, self.opening), self.opening, self.rate, self.acceleration)

    @cached_property
    def end(self) -> float:
        """When the retreat is over (s)."""
        return self.duration + _trapezoid_duration(self.retreat, self.retreat_speed, self.retreat_acceleration)

    def palm_at(self, t: float) -> tuple[float, float, float, float, float, float]:
        """The palm's displacement and velocity at t (s): (x, z, vx, vz) (m, m/s), and the commanded
        opening's growth and its rate (m, m/s)."""
        a, da = _trapezoid(t, self.opening, self.rate, self.acceleration)
        px, pz = self.palm
        x, z, vx, vz = px * a, pz * a, px * da, pz * da
        if t > self.duration:
            h, dh = _trapezoid(t - self.duration, self.retreat, self.retreat_speed, self.retreat_acceleration)
            z, vz = z + h, vz + dh
        return x, z, vx, vz, a, da

    def thumb_at(self, t: float) -> tuple[float, float, float, float]:
        """The thumb tip's position and velocity at t (s): (x, z, vx, vz) (m, m/s): the palm's, less half
        the opening beyond held along n_B; a pincer's turned about J (turned_at)."""
        if self.joint is not None:
            return self.turned_at(self.tip, 1, t)[:4]
        x, z, vx, vz, a, da = self.palm_at(t)
        nx, nz = self.normal
        free, dfree = (a - self.held, da) if a > self.held else (0.0, 0.0)
        return (self.tip[0] + x - free / 2 * nx, self.tip[1] + z - free / 2 * nz,
                vx - dfree / 2 * nx, vz - dfree / 2 * nz)

    def finger_at(self, t: float) -> tuple[float, float, float, float]:
        """A pincer's finger point (finger) at t (s), turned about J (turned_at): (x, z, vx, vz) (m, m/s).
        ValueError for a hand set up without it (jaws that slide: the fall leaves the finger out)."""
        if self.finger is None:
            raise ValueError("the hand's motion was set up without the finger")
        return self.turned_at(self.finger, 2, t)[:4]

    def turned_at(self, point: tuple[float, float], body: int, t: float
                  ) -> tuple[float, float, float, float, float, float]:
        """A pincer's point fixed in the palm (body 0), the thumb (1) or the finger (2) at the
        termination's start, at t (s): (x, z, vx, vz, turn, rate) (m, m/s, rad, rad/s), turn the body's
        turn about J so far (+ turns e toward n_B) and rate its rate. Until the command has taken up
        held every body turns with the palm (the pinch holds the digits on the object); beyond it each
        digit turns its own way (turns). J itself moves only in the retreat."""
        if self.joint is None:
            raise ValueError("only a pincer's hand turns about its joint")
        x, z, vx, vz, a, da = self.palm_at(t)
        palm, own = self.turns[0], self.turns[body]
        free, dfree = (a - self.held, da) if a > self.held else (0.0, 0.0)
        turn, rate = palm * a + (own - palm) * free, palm * da + (own - palm) * dfree
        jx, jz = self.joint
        rx, rz = point[0] - jx, point[1] - jz
        c, s = math.cos(turn), math.sin(turn)
        rx, rz = c * rx + s * rz, c * rz - s * rx  # turned clockwise in (x, z): e toward n_B
        return jx + x + rx, jz + z + rz, vx + rate * rz, vz - rate * rx, turn, rate

    def face_at(self, t: float) -> tuple[float, float, float]:
        """The thumb's face direction e at t (s) and its rate of turn: (ex, ez, rate) (unit, rad/s,
        + turning e toward n_B): axis and 0 for jaws that slide."""
        if self.joint is None:
            return self.axis[0], self.axis[1], 0.0
        turn, rate = self.turned_at(self.tip, 1, t)[4:]
        c, s = math.cos(turn), math.sin(turn)
        ex, ez = self.axis
        return c * ex + s * ez, c * ez - s * ex, rate

    @property
    def speed(self) -> float:
        """A bound on the speed the opening gives any point of the thumb's face (m/s): the rate, or a
        pincer's rate times the face's farthest reach from J."""
        if self.joint is None:
            return self.rate
        reach = math.hypot(self.tip[0] - self.joint[0], self.tip[1] - self.joint[1]) + self.thumb_length
        return self.rate * reach * max(abs(x) for x in self.turns)

    def held_at(self, point: tuple[float, float], t: float) -> tuple[float, float, float, float]:
        """A point held in the pinch (moving with the palm) at t (s): (x, z, vx, vz) (m, m/s)."""
        if self.joint is not None:
            return self.turned_at(point, 0, t)[:4]
        px, pz, pvx, pvz, _, _ = self.palm_at(t)
        return point[0] + px, point[1] + pz, pvx, pvz


def pincer_hand(pose: PincerPose, links: PincerLinks, length: float, termination: str, opening: float,
                squeeze: float, contact_speed: float, retreat: float) -> HandMotion:
    """The hand's motion as a pincer lets go from pose (mechanics.pincer.pincer_pose at one state, over
    the object length ``length``, m) by termination ('open' or 'open_symmetric'), as the export
    commands it (robot.pipeline): the joint opens by the turn that moves the finger tip's centre by
    opening (m; at most to the joint's range's end), the palm, the thumb and the finger turning about
    J as mechanics.pincer.release_turns has it (with 'open' the thumb stays where it is); timed as
    the export times it, a trapezoid in the joint's angle under the contact-speed cap on the faster
    of the thumb's tip and the finger's tip corner (links.levers) and the joint's speed and
    acceleration limits (the gripper's at the joint radius, robot.model) at the timing's share; the
    command takes up squeeze (m at the joint radius: the simulator's servo_squeeze and what the final
    press opened the joint beyond the plan, planning.predicted_landing.held_squeeze) before the pinch
    lets go. Then the retreat lifts the palm by retreat (m). ReleaseModelError for any other
    termination."""
    try:
        turns = release_turns(termination)
    except InputError as err:
        raise ReleaseModelError(err.reason, termination) from err
    angle = min(chord_angle(opening, links.radius), links.max_angle - float(pose.angle))
    thumb, finger = links.levers
    fastest = max(abs(turns["thumb"]) * thumb, abs(turns["finger"]) * finger)
    rate = TIMING_MARGIN * GRIPPER_SPEED / links.radius
    if fastest > 0.0:
        rate = min(rate, contact_speed / fastest)

    def point(p: NDArray[np.float64]) -> tuple[float, float]:
        return float(p[0]) * length, float(p[1]) * length

    return HandMotion(tip=point(pose.thumb_tip), axis=(float(pose.thumb_z[0]), float(pose.thumb_z[1])),
                      thumb_length=links.thumb_reach, palm=(0.0, 0.0), opening=angle,
                      held=min(squeeze / links.radius, angle), rate=rate,
                      acceleration=TIMING_MARGIN * GRIPPER_ACCELERATION / links.radius, retreat=retreat,
                      joint=point(pose.joint), turns=(turns["palm"], turns["thumb"], turns["finger"]),
                      finger=point(pose.dome))


def _trapezoid_duration(distance: float, speed: float, accel: float) -> float:
    """The time (s) a rest-to-rest move of distance (m) takes at speed and accel."""
    if distance <= 0.0:
        return 0.0
    ramp = speed * speed / accel
    if distance <= ramp:
        return 2.0 * math.sqrt(distance / accel)
    return 2.0 * speed / accel + (distance - ramp) / speed


def _trapezoid(t: float, distance: float, speed: float, accel: float) -> tuple[float, float]:
    """Position and speed at t (s) of a rest-to-rest move of distance (m) at speed and accel."""
    if distance <= 0.0 or t <= 0.0:
        return 0.0, 0.0
    total = _trapezoid_duration(distance, speed, accel)
    if t >= total:
        return distance, 0.0
    top = min(speed, math.sqrt(distance * accel))
    ramp = top / accel
    if t <= ramp:
        return accel * t * t / 2.0, accel * t
    if t >= total - ramp:
        r = total - t
        return distance - accel * r * r / 2.0, accel * r
    return top * ramp / 2.0 + top * (t - ramp), top


def _trapezoid_time(position: float, distance: float, speed: float, accel: float) -> float:
    """When (s) the move reaches position (m)."""
    lo, hi = 0.0, _trapezoid_duration(distance, speed, accel)
    for _ in range(60):
        mid = (lo + hi) / 2.0
        lo, hi = (mid, hi) if _trapezoid(mid, distance, speed, accel)[0] < position else (lo, mid)
    return hi


@dataclass(frozen=True)
class ReleaseStart:
    """Where the object is when the termination begins: its end G's place along the table (m, from
    the plan's G) and its tilt theta (rad). The plan's last state, pressed, by default
    (release_setup); a measured pose when the execution left it elsewhere."""

    g: float
    """G's x in the plane's frame (m)."""
    theta: float
    """The object's tilt (rad)."""


@dataclass(frozen=True)
class ReleaseSetup:
    """Everything the fall of one placement needs but the friction."""

    body: ReleaseBody
    """The object."""
    hand: HandMotion
    """The thumb's motion."""
    start: ReleaseStart
    """The object's pose when the termination begins."""
    frame: tuple[tuple[float, ...], ...] | None = None
    """The plane's frame in the world (4 x 4) with the object at its target, or None."""


@dataclass(frozen=True)
class Fall:
    """One fall: where it puts G and how it got there."""

    offset: float
    """G's place along the table once the object lies still, less the plan's (m; + toward B)."""
    carried: float
    """Of it, what the hand carried G while the pinch held (m)."""
    landed: bool
    """The object lies flat and still on the table before the integration's end."""
    time_flat: float | None
    """When the object lay flat (s from the termination's start), None if it did not."""
    slid_flat: float
    """How far G slid once the object lay flat (m)."""
    over_tip: bool
    """The thumb last let go of the object with B past its tip (rather than by backing away from B)."""
    thumb_left: float | None
    """When the thumb last touched the object (s), None if it never touched it after the pinch."""
    energy_gain: float
    """The largest rise of the object's energy over one step beyond what the thumb's work gives it
    (J/kg): numerical energy creation, which a sound integration keeps near 0."""
    states: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 7)), repr=False, compare=False)
    """With trace: per step (t s, x_G m, z_G m, theta rad, vx, vz m/s, omega rad/s) of G and the body."""


class Contact:
    """One contact of the object at one instant, per unit of the object's mass, over the generalized
    coordinates q = (X, Z, theta): the centre of mass's place (m) and the tilt (rad). gap (m): the
    distance to close along the normal (negative: overlap); normal and tangent: the rows whose
    product with q's rate is the object's velocity at the contact along the normal acting on it and
    along the contact's tangent (d gap / d q along the normal; the material point's along the
    tangent); wall_normal, wall_tangent: the other body's velocity there along the same two (m/s),
    so that the gap closes at normal . dq/dt - wall_normal and the object slips over the other at
    tangent . dq/dt - wall_tangent; mu: the friction coefficient."""

    __slots__ = ("key", "gap", "normal", "tangent", "wall_normal", "wall_tangent", "mu")

    def __init__(self, key: str, rx: float, rz: float, nx: float, nz: float, tx: float, tz: float,
                 wn: float, wt: float, gap: float, mu: float):
        """Size: a slotted record of floats made at every integration step of fall (contacts_at), from
        the scalars the step has."""
        self.key, self.gap, self.mu, self.wall_normal, self.wall_tangent = key, gap, mu, wn, wt
        self.normal = (nx, nz, rx * nz - rz * nx)
        self.tangent = (tx, tz, rx * tz - rz * tx)


def contacts_at(body: ReleaseBody, hand: HandMotion, X: float, Z: float, th: float, t: float,
                mu_g: float, mu_b: float, reach: float) -> tuple[list[Contact], bool]:
    """The contacts closer than reach (m) of the object whose centre of mass is at (X, Z) (m, plane
    frame) tilted th (rad), at t (s from the termination's start), with friction mu_g on the table
    and mu_b on the thumb: 'G' (its corner G on the table) and 'thumb' (its corner B on the thumb's
    face, while B lies on it); and whether B lies past the thumb's tip. Once B has passed the tip,
    nothing of the thumb touches the object: the face meets the object at psi > 0, so that the tip's
    corner lies beyond B's end and above the bottom face. B's corner on the table is the landing,
    which fall handles itself.

    Size: called at every integration step of fall with the step's state (X, Z, th, t) and the pair's
    friction as floats; an object per step would cost the integrator its speed."""
    c, s = math.cos(th), math.sin(th)
    lc, hc, l = body.centre, body.thickness / 2.0, body.length
    # G and B (bottom corners) relative to the centre of mass
    grx, grz = -lc * c + hc * s, -lc * s - hc * c
    brx, brz = (l - lc) * c + hc * s, (l - lc) * s - hc * c
    out = []
    if Z + grz < reach:
        out.append(Contact("G", grx, grz, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0, Z + grz, mu_g))
    tx, tz, tvx, tvz = hand.thumb_at(t)
    ex, ez, turning = hand.face_at(t)
    nx, nz = ez, -ex
    bx, bz = X + brx, Z + brz
    along = (bx - tx) * -ex + (bz - tz) * -ez
    past = along < 0.0
    if 0.0 <= along <= hand.thumb_length:
        gap = (bx - tx) * nx + (bz - tz) * nz
        if turning:  # a pincer's face turning about J: its point at B moves as the tip does and turns about it
            tvx, tvz = tvx + turning * (bz - tz), tvz - turning * (bx - tx)
        if -body.thickness < gap < reach:  # below: B behind the face, gone round the tip
            out.append(Contact("thumb", brx, brz, nx, nz, -ex, -ez, tvx * nx + tvz * nz, -(tvx * ex + tvz * ez),
                               gap, mu_b))
    return out, past


_MODES = ("stick", 1, -1, "off")  # per contact: sticking, sliding with u_t > 0 or < 0, apart


def _solve(a: list[list[float]], b: list[float]) -> list[float] | None:
    """x with a x = b (a small dense system, Gaussian elimination with partial pivoting); None when
    singular."""
    n = len(b)
    if n == 1:
        return [b[0] / a[0][0]] if a[0][0] else None
    if n == 2:
        det = a[0][0] * a[1][1] - a[0][1] * a[1][0]
        if not det:
            return None
        return [(b[0] * a[1][1] - a[0][1] * b[1]) / det, (a[0][0] * b[1] - a[1][0] * b[0]) / det]
    m = [row[:] + [b[i]] for i, row in enumerate(a)]
    for k in range(n):
        p = max(range(k, n), key=lambda i: abs(m[i][k]))
        if abs(m[p][k]) < 1e-300:
            return None
        m[k], m[p] = m[p], m[k]
        piv = m[k][k]
        for i in range(k + 1, n):
            f = m[i][k] / piv
            if f:
                row, top = m[i], m[k]
                for j in range(k, n + 1):
                    row[j] -= f * top[j]
    x = [0.0] * n
    for i in range(n - 1, -1, -1):
        x[i] = (m[i][n] - sum(m[i][j] * x[j] for j in range(i + 1, n))) / m[i][i]
    return x


def _impulses(contacts: list[Contact], modes: tuple, v: tuple[float, float, float], inv: tuple[float, float, float],
              dt: float) -> tuple[float, float, float] | None:
    """The velocity after the step's impulses with the contacts in modes, or None when that mode is
    not consistent (an impulse pulling, friction outside the cone, a slide against its sign, a
    contact left apart that would close). Per contact the normal velocity u_n = J_n v - w_n + the
    gap's share of the step must be 0 where it pushes and may not be negative where it is apart;
    the tangential u_t = J_t v - w_t is 0 where it sticks and has the slide's sign where it slides."""
    cols, rows, rhs = [], [], []
    for c, mode in zip(contacts, modes):
        if mode == "off":
            continue
        bias = (c.gap if c.gap > 0.0 else 0.2 * c.gap) / dt
        if mode == "stick":
            cols += [c.normal, c.tangent]
            rows += [c.normal, c.tangent]
            rhs += [c.wall_normal - bias, c.wall_tangent]
        else:
            if math.isinf(c.mu):  # no slide against unlimited friction
                return None
            k = mode * c.mu
            n, tg = c.normal, c.tangent
            cols.append((n[0] - k * tg[0], n[1] - k * tg[1], n[2] - k * tg[2]))
            rows.append(c.normal)
            rhs.append(c.wall_normal - bias)
    i0, i1, i2 = inv
    v0, v1, v2 = v
    if cols:
        a = [[r[0] * i0 * k[0] + r[1] * i1 * k[1] + r[2] * i2 * k[2] for k in cols] for r in rows]
        scale = max(a[i][i] for i in range(len(a)))
        for i in range(len(a)):
            a[i][i] += 1e-9 * scale
        b = [h - (r[0] * v0 + r[1] * v1 + r[2] * v2) for r, h in zip(rows, rhs)]
        p = _solve(a, b)
        if p is None:
            return None
        w0 = w1 = w2 = 0.0
        for k, x in zip(cols, p):
            w0 += k[0] * x
            w1 += k[1] * x
            w2 += k[2] * x
        n0, n1, n2 = v0 + i0 * w0, v1 + i1 * w1, v2 + i2 * w2
    else:
        p, n0, n1, n2 = [], v0, v1, v2
    tol_v, tol_p = 1e-7, 1e-10
    k = 0
    for c, mode in zip(contacts, modes):
        jn, jt = c.normal, c.tangent
        if mode == "off":
            un = jn[0] * n0 + jn[1] * n1 + jn[2] * n2 - c.wall_normal + (c.gap if c.gap > 0.0 else 0.2 * c.gap) / dt
            if un < -tol_v:
                return None
            continue
        pn = p[k]
        if pn < -tol_p:
            return None
        if mode == "stick":
            if not math.isinf(c.mu) and abs(p[k + 1]) > c.mu * pn + tol_p:
                return None
            k += 2
        else:
            ut = jt[0] * n0 + jt[1] * n1 + jt[2] * n2 - c.wall_tangent
            if mode * ut < -tol_v:
                return None
            k += 1
    return n0, n1, n2


def fall(setup: ReleaseSetup, mu_g: float, mu_b: float, step: float = STEP, trace: bool = False,
         thumb: bool = True) -> Fall:
    """Integrate the release of setup with friction mu_g on the table and mu_b on the thumb (in-plane
    sliding coefficients; math.inf sticks without limit): the carry while the pinch holds, then the
    fall from the moment it lets go until the object lies flat and still (or SETTLE s after the
    retreat). thumb False leaves the thumb out after the pinch (the object falls against the table
    alone); trace keeps every step's state (Fall.states).

    Size: one explicit integration loop with its events (the release, contacts made and lost, the
    landing); its locals are the integrator's state."""
    body, hand, start = setup.body, setup.hand, setup.start
    l, lc, hc = body.length, body.centre, body.thickness / 2.0
    # the carry: B held in the pinch moves with the palm, G stays on the table
    t0 = hand.released
    bx0, bz0 = start.g + l * math.cos(start.theta), l * math.sin(start.theta)
    bx, bz, pvx, pvz = hand.held_at((bx0, bz0), t0)
    if not 0.0 <= bz < l:
        raise ReleaseModelError(f"the carry lifts B {bz * 1000:.3f} mm, out of the object's reach")
    gx = bx - math.sqrt(l * l - bz * bz)
    th = math.asin(bz / l)
    # velocity at release: B with the palm, G along the table
    omega = pvz / (l * math.cos(th))
    vgx = pvx + l * math.sin(th) * omega
    c, s = math.cos(th), math.sin(th)
    X, Z = gx + lc * c - hc * s, lc * s + hc * c
    vx, vz = vgx - omega * (lc * s + hc * c), omega * (lc * c - hc * s)
    inv = (1.0, 1.0, 1.0 / body.gyration ** 2)
    t, t_end = t0, hand.end + SETTLE
    modes: dict[str, Any] = {}
    over_tip = touching = False
    left = None
    worst = 0.0
    rows = []
    while t < t_end:
        reach = 2.0 * step * (abs(vx) + abs(vz) + abs(omega) * l + hand.speed + hand.retreat_speed) + 1e-5
        contacts, past = contacts_at(body, hand, X, Z, th, t, mu_g, mu_b, reach)
        if not thumb:
            contacts = [k for k in contacts if k.key != "thumb"]
        v0 = (vx, vz - GRAVITY * step, omega)
        chosen = tuple(modes.get(k.key, "off") for k in contacts)
        new = _impulses(contacts, chosen, v0, inv, step)
        if new is None:
            for combo in itertools.product(_MODES, repeat=len(contacts)):
                new = _impulses(contacts, combo, v0, inv, step)
                if new is not None:
                    chosen = combo
                    break
        if new is None:
            raise ReleaseModelError(f"no consistent contact mode at t = {t:.4f} s (contacts "
                                    f"{', '.join(k.key for k in contacts)})")
        modes = {k.key: m for k, m in zip(contacts, chosen)}
        was = touching
        touching = modes.get("thumb", "off") != "off"
        if touching:
            left = t + step
        elif was:
            over_tip = past  # the thumb let go of the object there: over its tip, or by backing away
        # energy per unit mass (kinetic + potential): a step with the thumb still or away may not add any
        e_before = 0.5 * (vx * vx + vz * vz + body.gyration ** 2 * omega * omega) + GRAVITY * Z
        b_before = Z + (l - lc) * math.sin(th) - hc * math.cos(th)
        vx, vz, omega = new
        g_before = X - lc * math.cos(th) + hc * math.sin(th)
        X, Z, th = X + step * vx, Z + step * vz, th + step * omega
        if modes.get("G") == "stick":  # G's velocity is 0 at the step's start: keep its place (no drift)
            X -= X - lc * math.cos(th) + hc * math.sin(th) - g_before
        t += step
        if not touching or hand.thumb_at(t)[2:] == (0.0, 0.0):  # nothing moving does work on the object
            e_after = 0.5 * (vx * vx + vz * vz + body.gyration ** 2 * omega * omega) + GRAVITY * Z
            worst = max(worst, e_after - e_before)
        c, s = math.cos(th), math.sin(th)
        if trace:
            rows.append((t, X - lc * c + hc * s, Z - lc * s - hc * c, th, vx, vz, omega))
        b_after = Z + (l - lc) * s - hc * c
        if b_after <= 0.0:  # B's corner reaches the table: the object lands flat
            back = b_after / (b_after - b_before) if b_after < b_before else 0.0
            X -= back * step * vx
            t -= back * step
            g_flat = X - lc
            # the landing's normal impulse stops the centre of mass's fall and (spread along the
            # bottom face) the turn; its friction, at most mu_G times it, brakes the face's slip
            slip = vx + omega * hc
            brake = mu_g * max(-vz, 0.0)
            after = vx - math.copysign(brake, slip) if slip else vx
            if slip and (after > 0.0) != (slip > 0.0):  # the slip would turn: the face sticks
                after = 0.0
            if after == 0.0:
                slide = 0.0
            elif mu_g > 0.0:
                slide = math.copysign(after * after / (2.0 * mu_g * GRAVITY), after)
            else:
                slide = math.copysign(math.inf, after)
            if trace:
                rows.append((t, g_flat, 0.0, 0.0, after, 0.0, 0.0))
            states = np.array(rows) if trace else np.zeros((0, 7))
            return Fall(g_flat + slide, gx - start.g, True, t, slide, over_tip, left, worst, states)
    c, s = math.cos(th), math.sin(th)
    states = np.array(rows) if trace else np.zeros((0, 7))
    return Fall(X - lc * c + hc * s, gx - start.g, False, None, 0.0, over_tip, left, worst, states)


def _contact_axes(normal: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """MuJoCo's tangent axes of a contact with normal (world, unit): t1 the world y axis made
    orthogonal to the normal (the z axis where the normal lies within 60 deg of y), t2 = normal x t1
    (mju_makeFrame; checked against the simulator's contacts in tools/landing_check.py)."""
    n = normal / np.linalg.norm(normal)
    ref = np.array([0.0, 1.0, 0.0]) if abs(n[1]) < 0.5 else np.array([0.0, 0.0, 1.0])
    t1 = ref - (ref @ n) * n
    t1 /= np.linalg.norm(t1)
    return t1, np.cross(n, t1)


def pyramid_reach(along_first: float, along_second: float) -> float:
    """The share of its coefficient a four-edged friction pyramid holds along a unit direction whose
    components along the pyramid's two edges are along_first and along_second: 1 / (|a| + |b|), 1
    along an edge, 1 / sqrt 2 half way between (the diamond's reach that way)."""
    return 1.0 / (abs(along_first) + abs(along_second))


@dataclass(frozen=True)
class PyramidReach:
    """How much of its coefficient a contact's four-sided friction pyramid gives a slip in the
    manipulation plane, per contact (G on the table, B on the thumb): the pyramid's edges lie along
    the contact frame's tangent axes (t1, t2), so that a slip at angle phi to t1 meets friction mu
    along an axis and mu / sqrt(2) between them: at least mu / (|cos phi| + |sin phi|) (the friction
    held parallel to the slip, the diamond's reach that way) and at most mu max(|cos phi|, |sin phi|)
    (the diamond's corner nearest the slip's opposite, part of it across the plane)."""

    table: tuple[float, float]
    """(least, most) factor on mu_G for G's slip along GB."""
    thumb: tuple[float, float]
    """(least, most) factor on mu_B for B's slip along the thumb's face."""

    @classmethod
    def of(cls, frame: NDArray[np.float64], axis: tuple[float, float]) -> "PyramidReach":
        """The reach for the plane at frame (4 x 4, world) and the thumb's axis e (plane)."""
        frame = np.asarray(frame, dtype=float)
        to_world = frame[:3, [0, 2]]
        ex, ez = axis

        def reach(normal, slip):
            t1, t2 = _contact_axes(normal)
            d = slip / np.linalg.norm(slip)
            c, s = abs(float(d @ t1)), abs(float(d @ t2))
            return pyramid_reach(c, s), max(c, s)

        return cls(reach(np.array([0.0, 0.0, 1.0]), frame[:3, 0]),
                   reach(to_world @ np.array([ez, -ex]), to_world @ np.array([-ex, -ez])))


@dataclass(frozen=True)
class WorldLanding:
    """The landing in one world of the spread."""

    friction: float
    """The factor on every friction coefficient."""
    cone: str
    """'elliptic', or 'pyramidal least' / 'pyramidal most' (PyramidReach's bounds)."""
    mu_g: float
    """The in-plane coefficient at G used."""
    mu_b: float
    """The in-plane coefficient at B used."""
    along: float
    """G's landed place along GB less the plan's (m)."""
    landed: bool
    """The object lay flat and still."""


@dataclass(frozen=True)
class ReleasePrediction:
    """Where the release is predicted to put the object, against the plan's landing (the last state
    turned flat about G), over the worlds of the spread (SPREAD_FACTORS x the cones)."""

    along: float
    """The landed offset along GB (m; + toward B, the plane frame's x) averaged over the worlds of the
    spread: each friction factor alike, within one Coulomb's cone 1/2 and the pyramid's bounds 1/4 each."""
    across: float
    """The landed offset across GB (m): 0, the planar model says nothing across the plane."""
    direction: tuple[float, float]
    """GB's direction in the world's x, y (a unit vector)."""
    nominal: float
    """The offset along GB with the scene's friction and Coulomb's cone (m)."""
    spread: float
    """The largest less the smallest offset along GB over the worlds (m)."""
    carried: float
    """Of the nominal offset, what the hand carries G while the pinch holds (m)."""
    worlds: tuple[WorldLanding, ...]
    """Each world's landing."""
    over_tip: bool
    """B passes the thumb's tip in the nominal fall."""
    termination: str
    """The termination modelled."""
    carried_through: bool = False
    """The fall starts where the pinch leaves the object if it carries it through the plan's P_dpsi legs."""
    start: ReleaseStart = ReleaseStart(0.0, 0.0)
    """The object's pose when the termination begins."""

    @property
    def world(self) -> tuple[float, float]:
        """(along, across) in the world's x, y (m): the offset along GB's direction (across is 0)."""
        return self.along * self.direction[0], self.along * self.direction[1]

    @property
    def middle(self) -> float:
        """The middle of the offsets along GB over the worlds, (low + high) / 2 (m): the point from
        which the farthest world's landing lies least far, what robot.landing modelled aims by
        (record 0123)."""
        return (self.low + self.high) / 2

    @property
    def low(self) -> float:
        """The smallest offset along GB over the worlds (m)."""
        return min(w.along for w in self.worlds)

    @property
    def high(self) -> float:
        """The largest offset along GB over the worlds (m)."""
        return max(w.along for w in self.worlds)

    def to_dict(self) -> dict[str, Any]:
        """plan.json's predicted_landing (docs/plan-json.md)."""
        return {"along_m": self.along, "across_m": self.across, "world_m": list(self.world),
                "middle_m": self.middle, "direction": list(self.direction), "nominal_m": self.nominal,
                "spread_m": self.spread, "low_m": self.low, "high_m": self.high,
                "carried_m": self.carried, "over_tip": self.over_tip, "termination": self.termination,
                "carried_through_p_dpsi": self.carried_through, "start_g_m": self.start.g,
                "start_theta_rad": self.start.theta,
                "model": "planar fall (docs/model.md 11.17)",
                "worlds": [{"friction": w.friction, "cone": w.cone, "mu_G": w.mu_g, "mu_B": w.mu_b,
                            "along_m": w.along, "landed": w.landed} for w in self.worlds]}


def spread_worlds(setup: ReleaseSetup, mu_g: float, mu_b: float, factors: tuple[float, ...] = SPREAD_FACTORS
                  ) -> list[tuple[float, str, float, float, float]]:
    """The worlds of the spread: (factor, cone, weight, mu_G, mu_B) for each friction factor with
    Coulomb's cone (weight 1/2) and the pyramid's two bounds (1/4 each), the weights summing to 1
    over the cones of a factor."""
    out = []
    face = setup.hand.face_at(setup.hand.released)[:2]  # the thumb's face as the fall meets it
    reach = PyramidReach.of(np.array(setup.frame), face) if setup.frame is not None else None
    for f in factors:
        out.append((f, "elliptic", 0.5, f * mu_g, f * mu_b))
        if reach is None:
            out[-1] = (f, "elliptic", 1.0, f * mu_g, f * mu_b)
            continue
        for k, name in enumerate(("pyramidal least", "pyramidal most")):
            out.append((f, name, 0.25, f * mu_g * reach.table[k], f * mu_b * reach.thumb[k]))
    return out


def predict_release(setup: ReleaseSetup, mu_g: float, mu_b: float, termination: str = "", carried: bool = False,
                    factors: tuple[float, ...] = SPREAD_FACTORS) -> ReleasePrediction:
    """The landing of setup with the contacts' coefficients mu_g (the object on the table) and mu_b
    (on the thumb) over the worlds of spread_worlds; falls with the same coefficients are run once."""
    kept: dict[tuple[float, float], Fall] = {}
    worlds, weights = [], []
    for f, cone, w, g, b in spread_worlds(setup, mu_g, mu_b, factors):
        key = (round(g, 12), round(b, 12))
        if key not in kept:
            kept[key] = fall(setup, g, b)
        worlds.append(WorldLanding(f, cone, g, b, kept[key].offset, kept[key].landed))
        weights.append(w)
    nominal = kept.get((round(mu_g, 12), round(mu_b, 12))) or fall(setup, mu_g, mu_b)
    along = float(np.dot(weights, [w.along for w in worlds]) / np.sum(weights))
    frame = np.array(setup.frame) if setup.frame is not None else np.eye(4)
    return ReleasePrediction(along, 0.0, (float(frame[0, 0]), float(frame[1, 0])), nominal.offset,
                             max(w.along for w in worlds) - min(w.along for w in worlds), nominal.carried,
                             tuple(worlds), nominal.over_tip, termination, carried, setup.start)
