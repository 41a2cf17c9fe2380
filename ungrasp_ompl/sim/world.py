"""The simulated world as it differs from the world the plan was made for.

A plan, and the aim its hand takes (sim.landing), are made for the scene's friction and the
simulator's nominal contact model. A real cell is not that world: dry friction between such
materials is known to about +-30 %, another engine's friction cone is another model, a part's
density and a gripper's force are known to a few tens of per cent. A World names one such
difference (or several), fixed for a whole campaign: the trials run in it, while the plan and its
aim are made without it (docs/model.md 11.16).

Every factor is dimensionless; 1 (the default) leaves that part of the world as the scene has it.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields
from enum import StrEnum

from ..errors import InputError


class Cone(StrEnum):
    """The friction cone MuJoCo builds each contact with (a member is its name as a string)."""

    #: Coulomb's circular cone (the simulator's own, docs/model.md 11.2).
    ELLIPTIC = "elliptic"
    #: The cone approximated by a pyramid of four edges, as many engines build it: a contact's
    #: friction reaches mu along the pyramid's edges and less between them
    #: (mechanics.release.pyramid_reach). On the table MuJoCo lays the edges along the world's x and
    #: y axes, whatever the object's heading.
    PYRAMIDAL = "pyramidal"


@dataclass(frozen=True)
class World:
    """How the world the trials run in differs from the scene's (the defaults: not at all)."""

    friction: float = 1.0
    """Factor on every contact pair's friction coefficient (> 0; above 1 allowed)."""
    friction_table: float = 1.0
    """Factor on the object's friction on the table, the walls and the pieces already down (mu_G), on top of friction."""
    friction_digits: float = 1.0
    """Factor on the object's friction on the finger and the thumb (mu_A, mu_B), on top of friction."""
    density: float = 1.0
    """Factor on the density of every free object (> 0): its mass, the same shape."""
    cone: Cone = Cone.ELLIPTIC
    """The contacts' friction cone: elliptic or pyramidal."""
    stiffness: float = 1.0
    """Factor on the contacts' stiffness, in (0, 1]: their time constant grows by 1 / sqrt(stiffness)
    (0.25: twice the time constant, softer contacts). A stiffer contact than the scene's would need a
    finer step than sim.timestep allows (docs/model.md 11.2)."""
    jaw_force: float = 1.0
    """Factor on the gripper's force limit (sim.grip_force; > 0)."""

    def __post_init__(self) -> None:
        for f in fields(self):
            if f.name == "cone":
                continue
            value = getattr(self, f.name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0.0):
                raise InputError(f"world.{f.name}", f"must be a positive factor, got {value!r}")
            object.__setattr__(self, f.name, float(value))
        if self.stiffness > 1.0:
            raise InputError("world.stiffness", f"must lie in (0, 1], got {self.stiffness:g}: a contact stiffer "
                             "than the scene's needs a finer step than the simulator's (docs/model.md 11.2)")
        try:
            object.__setattr__(self, "cone", Cone(self.cone))
        except ValueError:
            raise InputError("world.cone", f"must be one of {', '.join(Cone)}, got {self.cone!r}") from None

    @classmethod
    def parse(cls, items: list[str] | tuple[str, ...]) -> "World":
        """The world of KEY=VALUE items (the command line's --world, repeatable): a field's name and
        a number, or cone=elliptic|pyramidal; InputError naming world.KEY for a bad one."""
        names = {f.name for f in fields(cls)}
        values: dict[str, object] = {}
        for item in items:
            key, sep, value = item.partition("=")
            key = key.strip()
            if not sep:
                raise InputError("world", f"expects KEY=VALUE, got {item!r} (keys: {', '.join(sorted(names))})")
            if key not in names:
                raise InputError(f"world.{key}", f"is not a key of the world (keys: {', '.join(sorted(names))})")
            if key in values:
                raise InputError(f"world.{key}", "is given twice")
            if key == "cone":
                values[key] = value.strip()
                continue
            try:
                values[key] = float(value)
            except ValueError:
                raise InputError(f"world.{key}", f"must be a number, got {value!r}") from None
        return cls(**values)  # type: ignore[arg-type]

    @property
    def nominal(self) -> bool:
        """The scene's world itself."""
        return self == World()

    @property
    def friction_factors(self) -> tuple[float, float]:
        """The factors (table, digits) on the scene's friction coefficients."""
        return self.friction * self.friction_table, self.friction * self.friction_digits

    @property
    def fixed_friction(self) -> tuple[bool, bool]:
        """Whether the world sets the friction of the object's pairs with (the table and the
        solids, the digits): a trial then draws no friction error for them (docs/decisions/
        0100-a-world-fixes-its-friction.md)."""
        return (self.friction != 1.0 or self.friction_table != 1.0,
                self.friction != 1.0 or self.friction_digits != 1.0)

    @property
    def time_constant_factor(self) -> float:
        """The factor on the contacts' time constant that the stiffness factor makes (>= 1)."""
        return 1.0 / math.sqrt(self.stiffness)

    def describe(self) -> str:
        """The differences in words ('friction x0.7, pyramidal cones'); 'as modelled' for none."""
        words = [f"{f.name.replace('_', ' ')} x{getattr(self, f.name):g}" for f in fields(self)
                 if f.name != "cone" and getattr(self, f.name) != 1.0]
        if self.cone is not Cone.ELLIPTIC:
            words.append(f"{self.cone} cones")
        return ", ".join(words) or "as modelled"

    def to_dict(self) -> dict[str, float | str]:
        """Every field by name (cone as its name)."""
        d = asdict(self)
        d["cone"] = str(self.cone)
        return d
