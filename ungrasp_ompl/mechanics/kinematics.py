"""Kinematic quantities of the pinch (docs/model.md, section 2).

Frame: the manipulation plane, G at the origin, x along the table, z up.
Lengths are over the object length l, angles in radians. Every function
broadcasts over numpy arrays of states.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .section import Section, finger_contact


@dataclass(frozen=True)
class DigitGeometry:
    """Finger and thumb of the gripper, lengths over l.

    alpha is how much longer the finger is than the thumb along the digit
    axis; the finger length is therefore thumb_length + alpha. Thicknesses
    are measured from the digit's contact face into its body, at the tip and
    at the base (the digits are trapezoids in the plane). width is the
    digits' extent normal to the manipulation plane. flat_finger_tip: the
    finger ends in a flat face across its width (an edge contact at A)
    rather than a rounded tip (a point contact). palm_width, palm_length,
    palm_thickness: the gripper's housing behind the digit bases, centred
    between the digit faces (a symmetric parallel gripper), across the gap,
    along the digits and normal to the plane; zero width or length leaves it
    out of collision checks. finger_tip_radius: radius of the rounded finger
    tip (0 for a flat tip); it moves the digits so that the dome touches the
    object at A (see finger_corner), and the dome rolls on the object as the
    finger turns against it (see contact_d), not the planar force analysis.
    thumb_tip_margin: how far B must stay from the thumb's tip (s_B >= it);
    0 lets a plan end with B on the tip's edge, which a real thumb loses.
    table_clearance: how far above the table the digits and the housing must
    stay (their lowest point >= it); 0 lets a plan graze the table, which an
    arm calibrated to a millimetre hits. press: how far below the plan the hand
    runs (a start press); the object, its end held by the table, then lies at
    the pressed state (pressed_state), and B must keep thumb_tip_margin there too.
    support: how far the table at G and the thumb's face at B hold the object
    across the plane, each way from G and from B (the nearer end of a straight
    side there, the thumb's face no wider than its half width; 0 at a point
    contact). across_margin: how far across the plane the rounded tip's contact
    A must lie inside those supports (across_support), so that a grasp that far
    off does not tip the object about the line from G's to B's support ends; 0,
    or no straight side at G or B (the object then rolls on their curves and A's
    restoring effect holds it, docs/model.md 5.3), leaves it unchecked.
    object_thickness: the object's thickness t. G and B are on its bottom face
    and the finger presses its top face, so the digits stand t cos(psi)
    further apart and the whole gripper t sin(psi) further back along the
    digit axis than for a segment: s_B shrinks by t sin(psi).
    section: the object's section (mechanics.section), over l; None (or a slab) is the slab of
    object_thickness above, with the closed forms of docs/model.md 2.4 and 2.6. A curved one puts
    A where the finger touches its top, rolling on it (finger_contact), and d is then the slide
    coordinate of mechanics.section (arc length over l).
    """

    alpha: float
    thumb_length: float = 0.75
    thumb_tip_thickness: float = 0.05
    thumb_base_thickness: float = 0.2
    finger_tip_thickness: float = 0.05
    finger_base_thickness: float = 0.2
    width: float = 0.3
    max_aperture: float = float("inf")
    flat_finger_tip: bool = False  # a flat tip across the width touches the object along an edge at A
    palm_width: float = 0.0  # the gripper housing across the gap, centred between the digits (0: none)
    palm_length: float = 0.0  # the housing from the palm line back toward the wrist
    palm_thickness: float = 0.0  # the housing normal to the plane (0: as wide as the digits)
    finger_tip_radius: float = 0.0  # the rounded finger tip's radius (0: a flat tip)
    thumb_tip_margin: float = 0.0  # B kept at least this far from the thumb's tip (s_B >= margin)
    table_clearance: float = 0.0  # the digits and the housing kept at least this far above the table
    object_thickness: float = 0.0  # the object's thickness: the finger presses its top face
    press: float = 0.0  # how far below the plan the hand runs: B keeps its margin at the pressed state too
    support: tuple[float, float] = (0.0, 0.0)  # the supports' reach across the plane at G and at B
    across_margin: float = 0.0  # A kept at least this far inside the supports across the plane
    section: Section | None = None  # the object's section over l (None: the slab of object_thickness)

    @property
    def finger_length(self) -> float:
        return self.thumb_length + self.alpha

    @property
    def held_by_supports(self) -> bool:
        """Whether the supports alone hold A's push beside GB (a rounded tip, a straight side at G
        or B), so that across_support bounds how far off across GB the grasp may be."""
        return not self.flat_finger_tip and any(self.support)


def _arrays(*xs: ArrayLike) -> list[NDArray[np.float64]]:
    return [np.asarray(x, dtype=float) for x in xs]


def _curved(section: Section | None) -> bool:
    """Whether section is a curved one (the kinematics then roll the finger on it)."""
    return section is not None and not section.is_slab


def _turn(v: NDArray, theta: NDArray) -> NDArray[np.float64]:
    """Object-frame vectors (..., 2) turned by theta into the plane's frame."""
    c, s = np.cos(theta), np.sin(theta)
    return np.stack([c * v[..., 0] - s * v[..., 1], s * v[..., 0] + c * v[..., 1]], axis=-1)


def section_pinch(d: ArrayLike, psi: ArrayLike, tip_radius: float, section: Section) -> dict[str, NDArray]:
    """The finger on a curved section in the object's frame (G at the origin, B at (1, 0)), over
    l, at slide coordinates d and thumb angles psi: the contact (``a``, on the top, and its
    outward normal ``normal``), the finger's tip corner on its face (``corner``: the dome's
    centre, r along the normal from the contact, plus r (e - n_B); on the face, the contact plus
    (r - sigma_f) e), the digit axis ``e`` and the thumb's normal ``n`` there, and the contact
    (``contact``: mechanics.section.FingerContact)."""
    d, psi = np.broadcast_arrays(*_arrays(d, psi))
    key = (d.shape, d.tobytes(), psi.tobytes(), float(tip_radius), id(section))
    for held, value in _PINCHES:  # the last few: a state's checks ask for the same states
        if held[0] == key and held[1] is section:
            return value
    c = finger_contact(section, d, psi, tip_radius)
    e = -np.stack([np.cos(psi), np.sin(psi)], axis=-1)
    n = np.stack([-np.sin(psi), np.cos(psi)], axis=-1)
    r = float(tip_radius)
    back = np.minimum(c.sigma_f, 0.0)[..., None]
    corner = c.top.point + r * c.top.normal + r * (e - n) - back * e
    out = {"a": c.top.point, "normal": c.top.normal, "corner": corner, "e": e, "n": n, "contact": c}
    _PINCHES.insert(0, ((key, section), out))
    del _PINCHES[4:]
    return out


#: section_pinch's last answers, newest first: ((key, section), answer).
_PINCHES: list = []


def _section_corner(theta, d, psi, tip_radius, section) -> tuple[NDArray, dict]:
    """The finger's tip corner in the plane (..., 2) on a curved section, and section_pinch (at
    the shape of d and psi alone: theta only turns it)."""
    theta = np.asarray(theta, dtype=float)
    pinch = section_pinch(d, psi, tip_radius, section)
    return _turn(pinch["corner"], theta), pinch


def object_axis(theta: ArrayLike) -> NDArray[np.float64]:
    """Unit vector from G to B, shape (..., 2)."""
    (theta,) = _arrays(theta)
    return np.stack([np.cos(theta), np.sin(theta)], axis=-1)


def digit_axis(theta: ArrayLike, psi: ArrayLike) -> NDArray[np.float64]:
    """Unit digit axis e, pointing from the palm toward the tips, shape (..., 2)."""
    theta, psi = _arrays(theta, psi)
    return -np.stack([np.cos(theta + psi), np.sin(theta + psi)], axis=-1)


def thumb_normal(theta: ArrayLike, psi: ArrayLike) -> NDArray[np.float64]:
    """Normal n_B of the thumb face, acting on the object at B, shape (..., 2)."""
    theta, psi = _arrays(theta, psi)
    return np.stack([-np.sin(theta + psi), np.cos(theta + psi)], axis=-1)


#: Standard gravity (m/s^2), for the mechanics' statics and dynamics and the simulator's rules.
GRAVITY = 9.81
#: How each opening termination moves the digits and the housing per unit of opening: the
#: parts of n_B and of the face's normal in each body's travel (docs/model.md 7).
_RELEASES = {"open": {"palm": (0.5, 0.0), "finger": (1.0, 0.0), "thumb": (0.0, 0.0)},
             "open_symmetric": {"palm": (0.0, 0.0), "finger": (0.5, 0.0), "thumb": (-0.5, 0.0)},
             "open_lift": {"palm": (-0.5, 1.0), "finger": (0.0, 1.0), "thumb": (-1.0, 1.0)}}


def release_travel(theta: ArrayLike, psi: ArrayLike, kind: str) -> dict[str, NDArray[np.float64]]:
    """Where the palm (the housing), the finger and the thumb go, per unit of opening, as the
    gripper lets go from states (theta, psi) by opening (kind 'open', 'open_symmetric' or
    'open_lift'): plane vectors (..., 2), in the opening's unit. The jaws part along n_B, the
    finger by half the opening more than the palm and the thumb by half less; 'open' keeps the
    thumb on B, 'open_symmetric' keeps the palm still, and 'open_lift' moves the palm so that
    the finger leaves A along the object's face normal while the thumb goes down as far as the
    gripper's own opening takes it (half the opening's part along z; with the thumb's face turned
    down, theta + psi > pi/2, it rises by that much more), backing off B across as well
    (docs/model.md 7)."""
    theta, psi = _arrays(theta, psi)
    n = thumb_normal(theta, psi)
    up = np.stack([-np.sin(theta), np.cos(theta)], axis=-1)  # the top face's outward normal
    lift = (np.abs(np.cos(theta + psi)) / (2.0 * np.cos(theta)))[..., None]  # the finger's rise per opening
    return {body: a * n + b * lift * up for body, (a, b) in _RELEASES[kind].items()}


def contact_d(d: ArrayLike, psi: ArrayLike, tip_radius: ArrayLike = 0.0, section: Section | None = None
              ) -> NDArray[np.float64]:
    """Distance of the contact A from B along the object, over l: d + r psi for a finger tip
    rounded with radius r (d itself for a point or a flat tip).

    d is where A touches while the digits lie along the object (psi = 0) and changes only when A
    slides; a dome that sticks rolls on the object as the finger turns against it (by psi), so
    its contact moves toward G by r times that turn. On a curved section, 1 - x of the contact
    (x along GB from G) where the finger rolls on the top (section_pinch)."""
    if _curved(section):
        return 1.0 - section_pinch(d, psi, float(tip_radius), section)["a"][..., 0]
    d, psi, tip_radius = _arrays(d, psi, tip_radius)
    return d + tip_radius * psi


def aperture(d: ArrayLike, psi: ArrayLike, thickness: ArrayLike = 0.0, tip_radius: ArrayLike = 0.0,
             section: Section | None = None) -> NDArray[np.float64]:
    """Distance between the digit faces, over l: d_A sin psi + t cos psi + r (cos psi - 1), for an
    object of thickness t (the finger on its top face) and a finger tip rounded with radius r
    (d_A = contact_d, where the rolled dome touches). On a curved section, (corner - B) . n_B with
    the finger's corner of section_pinch (thickness unused)."""
    if _curved(section):
        p = section_pinch(d, psi, float(tip_radius), section)
        rel = p["corner"] - np.array([1.0, 0.0])
        return np.sum(rel * p["n"], axis=-1)
    d, psi, thickness, tip_radius = _arrays(d, psi, thickness, tip_radius)
    d_a = contact_d(d, psi, tip_radius)
    return d_a * np.sin(psi) + thickness * np.cos(psi) + tip_radius * (np.cos(psi) - 1.0)


def s_b(d: ArrayLike, psi: ArrayLike, alpha: float, thickness: ArrayLike = 0.0, tip_radius: ArrayLike = 0.0,
        section: Section | None = None) -> NDArray[np.float64]:
    """Position of B on the thumb face from the thumb tip toward the palm, over l:
    d_A cos psi - alpha - t sin psi + r (1 - sin psi) (t the thickness, r the finger tip's radius,
    d_A = contact_d). On a curved section, (corner - B) . e - alpha with the finger's corner of
    section_pinch (the finger's tip lies alpha beyond the thumb's along e)."""
    if _curved(section):
        p = section_pinch(d, psi, float(tip_radius), section)
        rel = p["corner"] - np.array([1.0, 0.0])
        return np.sum(rel * p["e"], axis=-1) - alpha
    d, psi, thickness, tip_radius = _arrays(d, psi, thickness, tip_radius)
    d_a = contact_d(d, psi, tip_radius)
    return d_a * np.cos(psi) - alpha - thickness * np.sin(psi) + tip_radius * (1.0 - np.sin(psi))


def across_support(d: ArrayLike, psi: ArrayLike, digits: DigitGeometry) -> NDArray[np.float64]:
    """How far across the plane, either way, A may lie before its force tips the object, over l:
    the half width at A of the quadrilateral the supports span (G's reach across the plane at G,
    B's at B, joined by straight lines), s_G d_A + s_B (1 - d_A), with d_A = contact_d. The
    table and the thumb's face push along their normals through the supports, so A's push on the
    face, outside that, has a moment about the line through the nearer support ends that nothing
    balances (docs/model.md 5.3)."""
    d_a = contact_d(d, psi, digits.finger_tip_radius, digits.section)
    s_g, s_b_ = digits.support
    return s_g * d_a + s_b_ * (1.0 - d_a)


def finger_tip(theta: ArrayLike, d: ArrayLike) -> NDArray[np.float64]:
    """Contact A (the finger tip) on the segment: (1 - d)(cos theta, sin theta), shape (..., 2)
    (a rounded tip's contact, rolled and on the top face, is contact_point)."""
    theta, d = _arrays(theta, d)
    return (1.0 - d)[..., None] * object_axis(theta)


def contact_point(theta: ArrayLike, d: ArrayLike, psi: ArrayLike, thickness: ArrayLike = 0.0,
                  tip_radius: ArrayLike = 0.0, section: Section | None = None) -> NDArray[np.float64]:
    """Contact A on the object's top face, shape (..., 2): (1 - d_A) u + t n_top, with
    d_A = contact_d (a rounded tip's contact rolled by r psi toward G) and n_top the top face's
    normal (-sin theta, cos theta). On a curved section, where the finger touches its top
    (section_pinch), turned by theta."""
    if _curved(section):
        return _turn(section_pinch(d, psi, float(tip_radius), section)["a"], np.asarray(theta, dtype=float))
    theta, thickness = _arrays(theta, thickness)
    u = object_axis(theta)
    top = np.stack([-u[..., 1], u[..., 0]], axis=-1)
    return finger_tip(theta, contact_d(d, psi, tip_radius)) + thickness[..., None] * top


def dome_centre(theta: ArrayLike, d: ArrayLike, psi: ArrayLike, thickness: ArrayLike = 0.0,
                tip_radius: ArrayLike = 0.0, section: Section | None = None) -> NDArray[np.float64]:
    """Centre of the rounded finger tip's dome, shape (..., 2): r above A along the top face's
    normal, A + r n_top (A itself for a point or a flat tip, r = 0). On a curved section, the
    corner less r (e - n_B) (r along the top's normal from A while the dome touches)."""
    if _curved(section):
        corner, _ = _section_corner(theta, d, psi, float(tip_radius), section)
        theta, psi = _arrays(theta, psi)
        return corner - float(tip_radius) * (digit_axis(theta, psi) - thumb_normal(theta, psi))
    theta, tip_radius = _arrays(theta, tip_radius)
    top = np.stack([-np.sin(theta), np.cos(theta)], axis=-1)
    return contact_point(theta, d, psi, thickness, tip_radius) + tip_radius[..., None] * top


def finger_corner(theta: ArrayLike, d: ArrayLike, psi: ArrayLike, thickness: ArrayLike = 0.0,
                  tip_radius: ArrayLike = 0.0, section: Section | None = None) -> NDArray[np.float64]:
    """The finger's tip corner on its contact face, shape (..., 2): A itself for a segment and a
    flat tip; for thickness t, A lifted to the top face (A + t n_top); a tip rounded with radius r
    touches the top face with its dome (contact_point, rolled by r psi), whose centre lies r along
    n_top from the contact and r from the face and from the tip's end, so the corner is
    dome_centre + r (e - n_B). On a curved section, section_pinch's corner turned by theta."""
    if _curved(section):
        return _section_corner(theta, d, psi, float(tip_radius), section)[0]
    theta, psi, tip_radius = _arrays(theta, psi, tip_radius)
    corner = digit_axis(theta, psi) - thumb_normal(theta, psi)
    return dome_centre(theta, d, psi, thickness, tip_radius) + tip_radius[..., None] * corner


def thumb_tip(theta: ArrayLike, d: ArrayLike, psi: ArrayLike, alpha: float, thickness: ArrayLike = 0.0,
              tip_radius: ArrayLike = 0.0, section: Section | None = None) -> NDArray[np.float64]:
    """Thumb tip on its face: B + s_B e, shape (..., 2)."""
    theta, d, psi = _arrays(theta, d, psi)
    return object_axis(theta) + s_b(d, psi, alpha, thickness, tip_radius, section)[..., None] * digit_axis(theta, psi)


def thumb_clearance(theta: ArrayLike, d: ArrayLike, psi: ArrayLike, digits: DigitGeometry) -> NDArray[np.float64]:
    """Height of the thumb tip's lowest corner above the table, over l.

    sin theta - s_B sin(theta + psi) - t_tip cos(theta + psi); it must stay >= 0.
    """
    theta, d, psi = _arrays(theta, d, psi)
    sb = s_b(d, psi, digits.alpha, digits.object_thickness, digits.finger_tip_radius, digits.section)
    return np.sin(theta) - sb * np.sin(theta + psi) - digits.thumb_tip_thickness * np.cos(theta + psi)


def digits_clearance(theta: ArrayLike, d: ArrayLike, psi: ArrayLike, digits: DigitGeometry) -> NDArray[np.float64]:
    """Height of the digits' lowest point above the table, over l: the lowest vertex of the thumb's
    outline and of the finger's (digit_polygons); a rounded finger is ball-nosed, its body ending r
    short of the outline's tip (at the dome's centre) and its dome reaching down to the centre's
    height less r. A touch-off (robot.touch_off) lowers the empty hand by this much before a digit
    meets the table."""
    thumb, finger = digit_polygons(theta, d, psi, digits)
    r = digits.finger_tip_radius
    dome = dome_centre(theta, d, psi, digits.object_thickness, r, digits.section) if r > 0 else None
    return outlines_clearance(thumb, finger, digit_axis(theta, psi), dome, r)


def outlines_clearance(thumb: NDArray[np.float64], finger: NDArray[np.float64], finger_axis: NDArray[np.float64],
                       dome: NDArray[np.float64] | None, r: float) -> NDArray[np.float64]:
    """Height of the lowest point of two digits above the table, over l, from their outlines in the
    plane (..., 4, 2), in digit_polygons' vertex order: a rounded finger (r > 0, over l) is
    ball-nosed, its body ending r short of its outline's tip along finger_axis (..., 2, toward the
    tip) and its dome, of centre dome (..., 2), reaching down to the centre's height less r.
    digits_clearance's for the parallel digits, mechanics.pincer.pincer_clearance's for a pincer's."""
    if r > 0:
        finger = finger.copy()
        finger[..., [0, 3], :] -= r * finger_axis[..., None, :]
    low = np.minimum(thumb[..., 1].min(axis=-1), finger[..., 1].min(axis=-1))
    return np.minimum(low, dome[..., 1] - r) if r > 0 else low


def digit_polygons(
    theta: ArrayLike, d: ArrayLike, psi: ArrayLike, digits: DigitGeometry
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Thumb and finger outlines in the plane, each shape (..., 4, 2), over l.

    Vertices in order: tip on the contact face, base on the contact face, base
    back corner, tip back corner. The thumb's body lies behind its face
    (against n_B), the finger's behind its own face (along n_B). Each outline is
    its tip (thumb_tip, finger_corner) plus digit_offsets.
    """
    thumb, finger = digit_offsets(theta, psi, digits)
    t_tip = thumb_tip(theta, d, psi, digits.alpha, digits.object_thickness, digits.finger_tip_radius, digits.section)
    a_tip = finger_corner(theta, d, psi, digits.object_thickness, digits.finger_tip_radius, digits.section)
    return t_tip[..., None, :] + thumb, a_tip[..., None, :] + finger


def digit_offsets(theta: ArrayLike, psi: ArrayLike, digits: DigitGeometry
                  ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The thumb's and the finger's outlines (digit_polygons' vertex order) relative to their
    tips, each shape (..., 4, 2), over l: they turn with the digits (theta + psi) and nothing else."""
    e = digit_axis(theta, psi)
    n = thumb_normal(theta, psi)

    def outline(length, t_tip, t_base, side):
        base = -length * e
        return np.stack([np.zeros_like(e), base, base + side * t_base * n, side * t_tip * n], axis=-2)

    return (outline(digits.thumb_length, digits.thumb_tip_thickness, digits.thumb_base_thickness, -1.0),
            outline(digits.finger_length, digits.finger_tip_thickness, digits.finger_base_thickness, 1.0))


def housing_centre(theta: ArrayLike, d: ArrayLike, psi: ArrayLike, digits: DigitGeometry,
                   tip: ArrayLike | None = None) -> NDArray[np.float64]:
    """The centre of the gripper's housing (behind the digit bases, centred between the digit
    faces), shape (..., 2), over l. tip: the thumb's tip (thumb_tip) when already computed."""
    if tip is None:
        tip = thumb_tip(theta, d, psi, digits.alpha, digits.object_thickness, digits.finger_tip_radius,
                        digits.section)
    w = aperture(d, psi, digits.object_thickness, digits.finger_tip_radius, digits.section)
    return tip - (digits.thumb_length + digits.palm_length / 2) * digit_axis(theta, psi) \
        + (w / 2)[..., None] * thumb_normal(theta, psi)


def pressed_state(theta: ArrayLike, d: ArrayLike, psi: ArrayLike, depth: float, digits: DigitGeometry,
                  iterations: int = 8) -> tuple[NDArray, NDArray, NDArray, NDArray[np.bool_]]:
    """Where the object lies when the hand is held depth (over l; negative: higher) straight below
    the pose the states (theta, d, psi) give it, turned the same, with G where it is (the object's
    end held by the table): the states whose palm (the digits' base line, midway between their
    faces) lies that much lower with beta = theta + psi kept, the object turned about G and slid
    in the pinch to meet the digits (docs/model.md 11.9). Returns theta, d, psi (broadcast shape)
    and where such a state was found with 0 < theta < pi/2 and 0 < d <= 1.

    In the hand's frame (e, n) the palm (the thumb's tip B + s_B e, B = (cos theta, sin theta),
    less thumb_length e, plus half the aperture along n) lies at ((d_A - 1) cos psi - k sin psi,
    ((d_A - 2) sin psi + k cos psi) / 2) plus terms no state changes, k = t + r; the press moves
    it by (depth sin beta, -depth cos beta). Eliminating d_A leaves one equation in psi,
    P sin psi - Q cos psi - sin(2 psi) / 2 + k = 0, P and Q the pressed palm's two terms, solved
    by Newton's method from the state's psi; d_A then follows from the first term. On a curved
    section (DigitGeometry.section) the same two equations in (d, psi) are solved by Newton's
    method with finite-difference derivatives (_pressed_on_section)."""
    if _curved(digits.section):
        return _pressed_on_section(theta, d, psi, depth, digits, iterations)
    theta, d, psi = np.broadcast_arrays(*_arrays(theta, d, psi))
    t, r = digits.object_thickness, digits.finger_tip_radius
    k = t + r
    beta = theta + psi
    d_a = contact_d(d, psi, r)
    p_term = (d_a - 1.0) * np.cos(psi) - k * np.sin(psi) + depth * np.sin(beta)
    q_term = (d_a - 2.0) * np.sin(psi) + k * np.cos(psi) - 2.0 * depth * np.cos(beta)
    x = psi.copy()
    with np.errstate(divide="ignore", invalid="ignore"):  # a flat derivative: no state found there
        for _ in range(iterations):
            s, c = np.sin(x), np.cos(x)
            step = (p_term * s - q_term * c - s * c + k) / (p_term * c + q_term * s - (c * c - s * s))
            x = x - step
            if not np.any(np.abs(step) > 1e-15):  # converged everywhere (NaN where no state is)
                break
        residual = p_term * np.sin(x) - q_term * np.cos(x) - np.sin(x) * np.cos(x) + k
        d_new = 1.0 + (p_term + k * np.sin(x)) / np.cos(x) - r * x
    th = beta - x
    found = (np.abs(residual) < 1e-12) & (th > 0.0) & (th < np.pi / 2) & (d_new > 0.0) & (d_new <= 1.0)
    return th, d_new, x, found


def _pressed_on_section(theta, d, psi, depth: float, digits: DigitGeometry, iterations: int
                        ) -> tuple[NDArray, NDArray, NDArray, NDArray[np.bool_]]:
    """pressed_state on a curved section: the palm in the hand's frame (e, n) lies at
    (s_B - cos psi, w / 2 - sin psi) plus terms the pressed state keeps; solve for (d, psi) that
    put it (depth sin beta, -depth cos beta) further, by Newton's method from the state itself,
    the derivatives of the finger's corner from the rolling (_palm_on_section), each state
    iterated until its step is below 1e-14."""
    theta, d, psi = np.broadcast_arrays(*_arrays(theta, d, psi))
    shape = theta.shape
    theta, d, psi = (np.ravel(x).astype(float) for x in (theta, d, psi))
    beta = theta + psi
    f0, _ = _palm_on_section(d, psi, digits)
    target = f0 + np.stack([depth * np.sin(beta), -depth * np.cos(beta)], axis=-1)
    x = np.stack([d, psi], axis=-1)
    todo = np.arange(len(d))
    for _ in range(iterations + 8):
        if not len(todo):
            break
        f, jac = _palm_on_section(x[todo, 0], x[todo, 1], digits)
        f = f - target[todo]
        (a, b), (c, e) = (jac[..., 0, 0], jac[..., 0, 1]), (jac[..., 1, 0], jac[..., 1, 1])
        det = a * e - b * c
        with np.errstate(divide="ignore", invalid="ignore"):
            step = np.stack([(f[:, 0] * e - f[:, 1] * b) / det, (a * f[:, 1] - c * f[:, 0]) / det], axis=-1)
        step = np.where(np.isfinite(step), step, 0.0)
        x[todo] -= step
        todo = todo[np.any(np.abs(step) > 1e-14, axis=-1)]
    f, _ = _palm_on_section(x[:, 0], x[:, 1], digits)
    residual = np.abs(f - target).max(axis=-1)
    d_new, psi_new = x[:, 0], x[:, 1]
    th = beta - psi_new
    s = finger_contact(digits.section, d_new, psi_new, digits.finger_tip_radius).top.s
    found = (residual < 1e-10) & (th > 0.0) & (th < np.pi / 2) & (s > 0.0) & (s < digits.section.top_length)
    return th.reshape(shape), d_new.reshape(shape), psi_new.reshape(shape), found.reshape(shape)


def _palm_on_section(d: NDArray, psi: NDArray, digits: DigitGeometry) -> tuple[NDArray, NDArray]:
    """The palm's terms that the state changes, (s_B - cos psi, w / 2 - sin psi) (N, 2), and their
    derivatives in (d, psi) (N, 2, 2), on a curved section. The finger's corner moves with d by the
    top's unit tangent T toward G (on the dome, s + r phi = d + r psi gives ds/dd = 1/(1 + r kappa),
    and P + r N moves by (1 + r kappa) T ds) or by e (on the face, whose contact stays), and with psi
    by r T - r (e + n_B) on the dome and (sigma_f - r) n_B on the face (e' = -n_B, n_B' = e)."""
    sec, r, alpha = digits.section, digits.finger_tip_radius, digits.alpha
    p = section_pinch(d, psi, r, sec)
    c = p["contact"]
    e, n = p["e"], p["n"]
    tangent = np.stack([-c.top.normal[..., 1], c.top.normal[..., 0]], axis=-1)  # toward G
    face = c.on_face[..., None]
    by_d = np.where(face, e, tangent)
    by_psi = np.where(face, (c.sigma_f[..., None] - r) * n, r * tangent - r * (e + n))
    rel = p["corner"] - np.array([1.0, 0.0])
    sb, w = np.sum(rel * e, axis=-1), np.sum(rel * n, axis=-1)
    f = np.stack([sb - alpha - np.cos(psi), w / 2 - np.sin(psi)], axis=-1)
    jac = np.empty(f.shape + (2,))
    jac[..., 0, 0] = np.sum(by_d * e, axis=-1)
    jac[..., 1, 0] = np.sum(by_d * n, axis=-1) / 2
    jac[..., 0, 1] = np.sum(by_psi * e, axis=-1) - w + np.sin(psi)  # (corner - B) . e' = -w
    jac[..., 1, 1] = (np.sum(by_psi * n, axis=-1) + sb) / 2 - np.cos(psi)  # (corner - B) . e = s_B + alpha
    return f, jac


def housing_offsets(theta: ArrayLike, psi: ArrayLike, digits: DigitGeometry) -> NDArray[np.float64]:
    """The housing's outline relative to its centre, shape (..., 4, 2), over l: -a - c, a - c,
    a + c, -a + c, with a half its length toward the palm and c half its width along n_B."""
    a = digits.palm_length / 2 * -digit_axis(theta, psi)
    c = digits.palm_width / 2 * thumb_normal(theta, psi)
    return np.stack([-a - c, a - c, a + c, -a + c], axis=-2)


def kinematic_checks(
    theta: ArrayLike, d: ArrayLike, psi: ArrayLike, digits: DigitGeometry
) -> dict[str, NDArray[np.bool_]]:
    """Each kinematic condition of a state, by name (True where it holds).

    - ``d``: 0 < d_A <= 1 (A lies on the object; d_A = contact_d);
    - ``s_B >= 0`` / ``s_B <= thumb_length``: B lies on the thumb face (and at least
      ``thumb_tip_margin`` from its tip);
    - ``thumb clearance``: the thumb tip stays ``table_clearance`` above the table;
    - ``aperture``: 0 <= aperture <= max_aperture (gripper stroke);
    - ``across support`` (with ``across_margin``, a rounded tip and a straight side at G or B):
      A at least ``across_margin`` inside the supports across the plane (across_support);
    - ``s_B >= 0 pressed`` (with a press): at the pressed state too, B at least
      ``thumb_tip_margin`` from the thumb's tip; ``across support pressed`` (with a press and the
      margin across): A that far inside the supports there too; both looked at only where the
      others hold (True elsewhere, where the state fails already).
    """
    theta, d, psi = _arrays(theta, d, psi)
    sec = digits.section
    sb = s_b(d, psi, digits.alpha, digits.object_thickness, digits.finger_tip_radius, sec)
    w = aperture(d, psi, digits.object_thickness, digits.finger_tip_radius, sec)
    tol = 1e-12
    if _curved(sec):
        on_top = section_checks(theta, d, psi, digits)
    else:
        d_a = contact_d(d, psi, digits.finger_tip_radius)
        on_top = {"d": (d_a > 0.0) & (d_a <= 1.0 + tol)}
    checks = {
        **on_top,
        "s_B >= 0": sb >= digits.thumb_tip_margin - tol,
        "s_B <= thumb_length": sb <= digits.thumb_length + tol,
        "thumb clearance": thumb_clearance(theta, d, psi, digits) >= digits.table_clearance - tol,
        "aperture": (w >= -tol) & (w <= digits.max_aperture + tol),
    }
    across = digits.across_margin > 0.0 and digits.held_by_supports
    if across:
        checks["across support"] = across_support(d, psi, digits) >= digits.across_margin - tol
    if digits.press > 0.0:
        rest = np.bool_(True)
        for holds in checks.values():
            rest = rest & holds
        th, dd, ps, rest = np.broadcast_arrays(theta, d, psi, rest)
        _, dp, pp, found = pressed_state(th[rest], dd[rest], ps[rest], digits.press, digits)
        sbp = s_b(dp, pp, digits.alpha, digits.object_thickness, digits.finger_tip_radius, sec)
        pressed = {"s_B >= 0 pressed": sbp >= digits.thumb_tip_margin - tol}
        if across:
            pressed["across support pressed"] = across_support(dp, pp, digits) >= digits.across_margin - tol
        for name, holds in pressed.items():
            checks[name] = np.ones(rest.shape, dtype=bool)
            checks[name][rest] = found & holds
    return checks


def section_checks(theta: ArrayLike, d: ArrayLike, psi: ArrayLike, digits: DigitGeometry
                   ) -> dict[str, NDArray[np.bool_]]:
    """kinematic_checks' conditions on where the digits and the table touch a curved section
    (True where each holds):

    - ``d``: A lies inside the top (0 < s < top_length), on the dome or the corner no further
      round than its tip's end (psi - phi <= 90 deg) or on the face within the finger's length;
    - ``B on its corner``: the thumb's face touches the section at B alone: psi at least the
      bottom's rise at B (a lens) and, where the top starts at B, at most 180 deg plus the top's
      turn there (90 deg for a semi-ellipse), else at most 90 deg (a vertical end);
    - ``G on its rim`` (a lens's bottom rising at G): theta at least that rise, so that the table
      touches the section at G alone.
    """
    sec, r = digits.section, digits.finger_tip_radius
    theta, d, psi = _arrays(theta, d, psi)
    c = section_pinch(d, psi, r, sec)["contact"]
    tol = 1e-12
    length = sec.top_length
    face_ok = -c.sigma_f <= digits.finger_length - r + tol
    out = {"d": (c.top.s > tol) & (c.top.s < length - tol) & (c.beta <= np.pi / 2 + tol) & face_ok}
    rim_g, rim_b = sec.rim_angles
    phi_b = sec.end_angles[0]
    starts_at_b = sec.ends_on_gb[1]
    psi_max = np.pi + phi_b if starts_at_b else np.pi / 2
    out["B on its corner"] = (psi >= rim_b - tol) & (psi <= psi_max + tol)
    if rim_g > 0.0:
        out["G on its rim"] = theta >= rim_g - tol
    return out


def kinematic_validity(theta: ArrayLike, d: ArrayLike, psi: ArrayLike, digits: DigitGeometry) -> NDArray[np.bool_]:
    """True where every kinematic condition of :func:`kinematic_checks` holds."""
    ok = np.bool_(True)
    for holds in kinematic_checks(theta, d, psi, digits).values():
        ok = ok & holds
    return ok


def digit_bodies(theta: ArrayLike, d: ArrayLike, psi: ArrayLike, digits: DigitGeometry) -> list[NDArray[np.float64]]:
    """The thumb, the finger and (when sized) the housing as counter-clockwise polygons (N, 4, 2),
    over l: the digits of :func:`digit_polygons` and the housing as geometry/collision.py places it,
    behind the digit bases, centred between the faces."""
    theta, d, psi = np.broadcast_arrays(*(np.ravel(x) for x in _arrays(theta, d, psi)))
    thumb, finger = digit_polygons(theta, d, psi, digits)
    out = [_ccw(thumb), _ccw(finger)]
    if digits.palm_width > 0 and digits.palm_length > 0:
        centre = housing_centre(theta, d, psi, digits, thumb[:, 0])
        out.append(_ccw(centre[:, None, :] + housing_offsets(theta, psi, digits)))
    return out


def _ccw(poly: NDArray) -> NDArray:
    """Polygons (N, k, 2) with their vertex order reversed where it runs clockwise."""
    x, z = poly[..., 0], poly[..., 1]
    area = np.sum(x * np.roll(z, -1, axis=-1) - np.roll(x, -1, axis=-1) * z, axis=-1)
    return np.where((area < 0)[:, None, None], poly[:, ::-1], poly)
