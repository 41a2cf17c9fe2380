"""Random errors of a trial, of the kinds an open-loop set-up like the paper's has: the simulator
draws them (sim/), and a plan's tolerance (scene/tolerance.py) scales their box.

Every error is drawn uniformly within its bound (a bounded error, as calibration leaves),
from a numpy Generator seeded per trial, so a campaign is reproducible trial by trial.
Friction is only ever scaled down: the scene's coefficients are what the plan relies on,
and a simulation that grants more friction than that proves nothing. The one error that is not
bounded is a touch-off's (robot.touch_off): its force sensor's noise, Gaussian, one draw per
reading, from a sequence whose seed the trial draws (sim.probe).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from ..errors import InputError


@dataclass(frozen=True)
class TrialParams:
    """One trial's deviations from the scene (zero deviation: all defaults)."""

    shift_along_mm: float = 0.0  #: the object shifted in the grasp along GB (mm)
    shift_across_mm: float = 0.0  #: shifted across GB in its own plane, out of the manipulation plane (mm)
    yaw_deg: float = 0.0  #: turned in its own plane about the grasp point (deg)
    friction_scale: tuple[float, float, float] = (1.0, 1.0, 1.0)  #: factors on mu at G, A, B (at most 1)
    mass_scale: float = 1.0  #: factor on the object's mass
    thickness_scale: float = 1.0  #: factor on the object's thickness (its mass stays as mass_scale sets it)
    palm_shift_mm: tuple[float, float, float] = (0.0, 0.0, 0.0)  #: the arm's calibration: palm offset along palm x, y, z (mm)
    palm_turn_deg: tuple[float, float, float] = (0.0, 0.0, 0.0)  #: ... and turn about palm x, y, z (deg)
    table_height_mm: float = 0.0  #: the table's top above where the plan believes it (mm)
    probe_noise_n: float = 0.0  #: a touch-off's (robot.touch_off) force sensor: one standard deviation of a reading's noise (N); 0: an ideal sensor; negative: the draws of probe_seed turned the other way
    probe_seed: int = 0  #: seeds the standard normal draws that, times probe_noise_n, are the noise of the touch-off's readings, one a control period

    @property
    def calibrated(self) -> bool:
        """No calibration error: the commanded trajectory and the table are where the plan has them."""
        return not any(self.palm_shift_mm) and not any(self.palm_turn_deg) and self.table_height_mm == 0.0

    def to_dict(self) -> dict:
        d = asdict(self)
        fg, fa, fb = d.pop("friction_scale")
        d.update(friction_scale_G=fg, friction_scale_A=fa, friction_scale_B=fb)
        for key in ("palm_shift_mm", "palm_turn_deg"):
            x, y, z = d.pop(key)
            stem, unit = key.rsplit("_", 1)
            d.update({f"{stem}_x_{unit}": x, f"{stem}_y_{unit}": y, f"{stem}_z_{unit}": z})
        return d


@dataclass(frozen=True)
class Perturbation:
    """Bounds of a trial's random errors; each is drawn uniformly within +-bound (friction in
    [1 - friction, 1]); a touch-off's sensor noise is Gaussian, of standard deviation probe_noise_n."""

    name: str
    shift_mm: float = 0.0  #: object position in the grasp, along and across GB (mm)
    yaw_deg: float = 0.0  #: object turn in the grasp (deg)
    friction: float = 0.0  #: fraction by which each contact's friction may fall short of the scene's
    mass: float = 0.0  #: fraction of mass either way
    thickness: float = 0.0  #: fraction of thickness either way
    palm_shift_mm: float = 0.0  #: the arm's calibration: palm position, along each palm axis (mm)
    palm_turn_deg: float = 0.0  #: the arm's calibration: palm orientation, about each palm axis (deg)
    table_mm: float = 0.0  #: the table's height (mm)
    probe_noise_n: float = 0.0  #: a touch-off's (robot.touch_off) force sensor: one standard deviation of a reading's noise (N)

    def sample(self, rng: np.random.Generator) -> TrialParams:
        """One trial's deviations (the calibration's drawn after the others, and the touch-off's
        sensor noise, its seed, after it, so that adding each left the draws before it as they were;
        the seed takes one 64-bit word of the generator, as much as the uniform draw it replaced)."""
        u = rng.uniform(-1.0, 1.0, size=5)
        fr = rng.uniform(1.0 - self.friction, 1.0, size=3) if self.friction else np.ones(3)
        c = rng.uniform(-1.0, 1.0, size=7)
        return TrialParams(shift_along_mm=self.shift_mm * u[0], shift_across_mm=self.shift_mm * u[1],
                           yaw_deg=self.yaw_deg * u[2], friction_scale=tuple(float(x) for x in fr),
                           mass_scale=1.0 + self.mass * u[3], thickness_scale=1.0 + self.thickness * u[4],
                           palm_shift_mm=tuple(float(x) for x in self.palm_shift_mm * c[:3]),
                           palm_turn_deg=tuple(float(x) for x in self.palm_turn_deg * c[3:6]),
                           table_height_mm=float(self.table_mm * c[6]), probe_noise_n=self.probe_noise_n,
                           probe_seed=int(rng.integers(2**63)) if self.probe_noise_n else 0)

    def mirrored(self, p: TrialParams) -> TrialParams:
        """p reflected through the middle of this box: every error turned the other way, and each
        friction factor reflected about the middle of [1 - friction, 1], and the touch-off's sensor
        noise the same draws turned the other way (its seed kept). With p, an antithetic pair
        whose two errors average to the box's middle, so that an effect linear in the errors
        cancels in the pair's mean (sim.landing.expected_landing)."""
        mid = 2.0 - self.friction  # twice the middle of the friction factors' range
        return TrialParams(shift_along_mm=-p.shift_along_mm, shift_across_mm=-p.shift_across_mm,
                           yaw_deg=-p.yaw_deg, friction_scale=tuple(mid - f for f in p.friction_scale),
                           mass_scale=2.0 - p.mass_scale, thickness_scale=2.0 - p.thickness_scale,
                           palm_shift_mm=tuple(-x for x in p.palm_shift_mm),
                           palm_turn_deg=tuple(-x for x in p.palm_turn_deg),
                           table_height_mm=-p.table_height_mm, probe_noise_n=-p.probe_noise_n,
                           probe_seed=p.probe_seed)


#: The presets. `paper`: what an open-loop, camera-calibrated set-up like the paper's leaves
#: (docs/model.md 11.3 gives the source of each bound): about 1 mm and 2 deg of object pose in
#: the grasp (a hand-over and a camera a few pixels off), friction up to 20% below the scene's
#: (surfaces vary, dust), mass +-20% and thickness +-5% (printing and cutting tolerances), and
#: the arm's calibration: the palm's pose +-1 mm and +-0.5 deg about each axis, the table's
#: height +-0.5 mm, and (when the scene's robot touches the table off) the noise of the UR5e's
#: wrist force sensor, 1.75 N a reading (robot.touch_off.FORCE_NOISE, docs/model.md 11.14). The
#: others draw one kind of error at the paper's size.
PRESETS: dict[str, Perturbation] = {p.name: p for p in (
    Perturbation("none"),
    Perturbation("paper", shift_mm=1.0, yaw_deg=2.0, friction=0.2, mass=0.2, thickness=0.05,
                 palm_shift_mm=1.0, palm_turn_deg=0.5, table_mm=0.5, probe_noise_n=1.75),
    Perturbation("grasp", shift_mm=1.0, yaw_deg=2.0),
    Perturbation("friction", friction=0.2),
    Perturbation("mass", mass=0.2),
    Perturbation("thickness", thickness=0.05),
    Perturbation("calibration", palm_shift_mm=1.0, palm_turn_deg=0.5, table_mm=0.5, probe_noise_n=1.75),
)}


def preset(name: str) -> Perturbation:
    """The named preset; InputError listing the presets for an unknown name."""
    if name not in PRESETS:
        raise InputError("perturb", f"unknown preset {name!r} (one of: {', '.join(PRESETS)})")
    return PRESETS[name]


def trial_params(perturbation: Perturbation, seed: int, trials: int) -> list[TrialParams]:
    """The deviations of trials 0 .. trials-1; trial k draws from a Generator seeded (seed, k),
    so one trial's draw does not depend on how many others run, or where."""
    return [perturbation.sample(np.random.default_rng([seed, k])) for k in range(trials)]
