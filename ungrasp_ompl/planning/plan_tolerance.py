"""The tolerance of a plan (docs/model.md, section 4.6): the largest scale s of an error box (the
`paper` perturbation's by default) such that every state of the plan's executed motion, moved by
any error within s times the box, stays secure; with the check and the error component that bind
it. How an error moves a state, and a state's check, are scene.tolerance's."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..mechanics.contact import Primitive
from ..mechanics.path import plan_samples
from ..scene import Scene
from ..scene.tolerance import (COMPONENTS, SOLO_TOLERANCE, ErrorBox, ToleranceOptions, ToleranceReason, checked_box,
                               describe_tolerance)
from .result import Plan


@dataclass(frozen=True)
class Tolerance:
    """A plan's tolerance and what binds it (see module docstring)."""

    scale: float
    """s: the largest scale of the box with every moved state secure (dimensionless)."""
    perturbation: str
    """The box's preset."""
    reason: ToleranceReason
    """The check that fails just above s."""
    component: str
    """The binding error component (COMPONENTS): the one that alone is tolerated least at the binding state."""
    state: tuple[float, float, float]
    """The binding state of the plan, as planned: theta (rad), d (over l), psi (rad)."""
    primitive: int
    """The index of the plan's primitive it lies on."""
    primitive_type: Primitive
    """That primitive's type."""
    component_scales: dict[str, float]
    """Each component's own tolerance at the binding state (the box with that component alone; inf: none)."""
    physical: dict[str, float]
    """The box at scale s in physical units: shift_mm, yaw_deg, friction_loss, thickness_fraction,
    palm_shift_mm, palm_turn_deg, table_mm."""
    samples: int
    """How many states of the plan were checked."""

    def describe(self) -> str:
        """For a person (millimetres, degrees, per cent; two lines): the plan summary's."""
        return describe_tolerance(self.to_dict())

    @classmethod
    def from_dict(cls, doc: dict) -> "Tolerance":
        """Back from to_dict (plan.json's tolerance)."""
        scales = {k: math.inf if v is None else float(v) for k, v in doc["component_scales"].items()}
        return cls(float(doc["scale"]), doc["perturbation"], ToleranceReason(doc["reason"]), doc["component"],
                   tuple(doc["state"]), int(doc["primitive"]), Primitive(doc["primitive_type"]), scales, dict(doc["physical"]),
                   int(doc["samples"]))

    def to_dict(self) -> dict:
        """For plan.json (radians, over l, millimetres where named)."""
        return {"scale": self.scale, "perturbation": self.perturbation, "reason": self.reason.value,
                "component": self.component, "state": list(self.state), "primitive": self.primitive,
                "primitive_type": self.primitive_type,
                "component_scales": {k: (None if math.isinf(v) else v) for k, v in self.component_scales.items()},
                "physical": dict(self.physical), "samples": self.samples}


def _error_box(scene: Scene, plan: Plan, options: ToleranceOptions) -> ErrorBox:
    """The error box over every sample of the solved plan's path (both modes at its corners, the
    last sample terminal); InputError for an unsolved plan, an unknown preset or bad options."""
    if not plan.solved or not plan.primitives:
        raise InputError("plan", "has no path to take the tolerance of (it is not solved)")
    box, res = checked_box(scene, options)
    samples = plan_samples(plan, res, both_modes=True)
    terminal = np.zeros(len(samples.states), dtype=bool)
    terminal[-1] = True
    return ErrorBox(scene, np.asarray(plan.states[0], dtype=float), box, samples, terminal, res, options.housing)


def tolerance_scale(scene: Scene, plan: Plan, options: ToleranceOptions = ToleranceOptions()) -> float:
    """tolerance(scene, plan, options).scale alone: the largest scale of the error box every state
    of the solved plan survives, without the binding component's search (most of tolerance's time)."""
    ctx = _error_box(scene, plan, options)
    return ctx.scale(np.arange(len(ctx.samples.states)), {c: True for c in COMPONENTS}, options.scale_tolerance,
                     options.max_scale)[0]


def tolerance(scene: Scene, plan: Plan, options: ToleranceOptions = ToleranceOptions()) -> Tolerance:
    """The tolerance of a solved plan of scene (see the module docstring and docs/model.md,
    section 4.6). InputError for an unsolved plan, an unknown preset or bad options."""
    ctx = _error_box(scene, plan, options)
    samples, box = ctx.samples, ctx.box
    every = np.arange(len(samples.states))
    all_on = {c: True for c in COMPONENTS}
    s, codes = ctx.scale(every, all_on, options.scale_tolerance, options.max_scale)
    reasons = list(ToleranceReason)
    failing = np.flatnonzero(codes)
    k = int(failing[0]) if len(failing) else len(every) - 1
    reason = reasons[int(codes[k]) - 1] if len(failing) else ToleranceReason.NONE
    solo = {c: math.inf for c in COMPONENTS}
    for c in COMPONENTS if len(failing) else ():
        on = {x: x == c for x in COMPONENTS}
        sc, cc = ctx.scale(np.array([k]), on, SOLO_TOLERANCE, options.max_scale)
        solo[c] = sc if cc.any() else math.inf
    component = min(solo, key=lambda c: solo[c]) if len(failing) else "none"
    p = int(samples.primitive[k])
    physical = {"shift_mm": s * box.shift_mm, "yaw_deg": s * box.yaw_deg, "friction_loss": s * box.friction,
                "thickness_fraction": s * box.thickness, "palm_shift_mm": s * box.palm_shift_mm,
                "palm_turn_deg": s * box.palm_turn_deg, "table_mm": s * box.table_mm}
    return Tolerance(s, box.name, reason, component, tuple(float(x) for x in samples.states[k]), p,
                     plan.primitives[p].type, solo, physical, len(samples.states))
