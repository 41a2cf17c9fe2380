"""The commands' workflows as library functions: options in, a typed result out.

Each workflow chains the floors below it (scene -> plan -> robot -> export -> sim -> view) the
way its command does, takes an options dataclass whose fields are checked and named in its
errors, and returns a result with ``summary()`` (what the command prints) and ``write(dir)``
(what it writes, atomically). ``cli`` only parses, calls, prints and maps the options' field
names to the flags a person typed.

The names below load on first use (PEP 562): a workflow loads its own stack (the simulator, the
pictures) and no other's.
"""

from .._lazy import lazy_exports

_WHERE = {"PlanOptions": ".plan", "ScenePlan": ".plan", "plan_scene": ".plan",
          "SimulateOptions": ".simulate", "SceneSimulation": ".simulate", "LayoutSimulation": ".simulate",
          "simulate_scene": ".simulate", "simulate_layout": ".simulate",
          "TiledLayout": ".tile", "tile_layout": ".tile",
          "CageOptions": ".cage", "CageReport": ".cage", "cage_report": ".cage"}

__all__ = sorted(_WHERE)

__getattr__, __dir__ = lazy_exports(__name__, _WHERE)
