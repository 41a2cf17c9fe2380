"""Independent re-validation of planned legs with the exact mechanics (no atlas).

Every leg is sampled in its travel direction at a resolution no coarser than
the lattice's (default: half a lattice step), and each sample is checked for
kinematic validity, collision (python-fcl) and force closure in the contact
mode the leg's velocity makes there.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from ..geometry.collision import CollisionChecker
from ..mechanics import force_closure, kinematic_checks, primitive_sliding_signs
from ..scene import Scene


def verify_leg(
    scene: Scene,
    primitive: str,
    q0: ArrayLike,
    q1: ArrayLike,
    resolution: ArrayLike,
    checker: CollisionChecker | None = None,
) -> str | None:
    """Check one leg from q0 to q1 (states (theta, d, psi)); None if secure, else the reason."""
    q0, q1 = np.asarray(q0, dtype=float), np.asarray(q1, dtype=float)
    step = q1 - q0
    n = max(1, int(math.ceil(np.max(np.abs(step) / np.asarray(resolution)) - 1e-9)))
    q = q0 + np.linspace(0.0, 1.0, n + 1)[:, None] * step
    th, d, ps = q.T
    for name, ok in kinematic_checks(th, d, ps, scene.digits).items():
        if not ok.all():
            return f"{name} fails at {_fmt(q[np.argmin(ok)])}"
    sa, sb = primitive_sliding_signs(primitive, d, ps, step[1], step[2])
    fc = force_closure(th, d, ps, sa, sb, scene.mu, scene.options.sliding_model)
    if not fc.all():
        return f"not force-closed in its contact mode at {_fmt(q[np.argmin(fc)])}"
    checker = checker or CollisionChecker(scene.collision_model())
    hit = checker.in_collision(q)
    if hit.any():
        bad = q[np.argmax(hit)]
        return f"collision {', '.join(checker.contacts(bad))} at {_fmt(bad)}"
    return None


def _fmt(q: ArrayLike) -> str:
    th, d, ps = q
    return f"(theta {math.degrees(th):.2f} deg, d {d:.4f}, psi {math.degrees(ps):.2f} deg)"
