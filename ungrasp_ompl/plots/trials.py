"""The picture of simulated trials: where each put the object, and success against each error the
trials drew (matplotlib)."""

from __future__ import annotations

import math
import os
import textwrap

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from .common import legend_marks, save_png  # noqa: E402


#: The errors a simulated trial draws (scene.perturbation.TrialParams.to_dict keys) in words, with units.
TRIAL_PARAM_LABELS = {
    "shift_along_mm": "object shifted in the grasp along GB (mm)",
    "shift_across_mm": "object shifted in the grasp across GB (mm)",
    "yaw_deg": "object turned in the grasp (deg)",
    "mass_scale": "object mass (x the scene's)",
    "thickness_scale": "object thickness (x the scene's)",
    **{f"friction_scale_{c}": f"friction at {c} (x the scene's)" for c in "GAB"},
    **{f"palm_shift_{a}_mm": f"palm offset along palm {a}, calibration (mm)" for a in "xyz"},
    **{f"palm_turn_{a}_deg": f"palm turn about palm {a}, calibration (deg)" for a in "xyz"},
    "table_height_mm": "table top above the planned height (mm)",
    "probe_noise_n": "touch-off force reading noise, one sd (N)",
    "probe_seed": "touch-off force noise draws, their seed (index)",
}


def draw_trials(report, outline: np.ndarray, target: np.ndarray, path: str | os.PathLike[str]) -> None:
    """Write trials_figure's picture to path (PNG)."""
    save_png(trials_figure(report, outline, target), path, fast=True)


def trials_figure(report, outline: np.ndarray, target: np.ndarray):
    """Simulated trials: (top left, large) each trial's final object outline over the target
    outline, top view in mm about the target's centroid, green for success and red for failure;
    (small panels, in a grid) success against each perturbation the trials drew. report: a sim SimulationReport; outline: the
    object's outline (N, 2) in its body frame (m); target: its body pose at the target (4x4).
    Returns the matplotlib Figure."""
    def placed(pose: np.ndarray) -> np.ndarray:
        pts = np.column_stack([outline, np.zeros(len(outline))]) @ np.asarray(pose)[:3, :3].T + np.asarray(pose)[:3, 3]
        return pts[:, :2]

    outcome = {True: ("tab:green", "placed"), False: ("tab:red", "failed")}
    want = placed(target)
    centre = want.mean(axis=0)
    keys = [k for k in report.trials[0].params if len({round(t.params[k], 9) for t in report.trials}) > 1]
    fig, axes = _trial_axes(max(1, len(keys)))
    ax = axes[0]
    ax.fill(*((want - centre) * 1000).T, color="0.85", label="target outline")
    for t in report.trials:
        got = (placed(t.final_pose) - centre) * 1000
        colour, word = outcome[bool(t.success)]
        ax.plot(*np.vstack([got, got[:1]]).T, color=colour, lw=0.8, alpha=0.7, label=f"final outline, {word}")
    ax.set_aspect("equal")
    ax.set_xlabel("world x from the target's centre (mm)")
    ax.set_ylabel("world y from the target's centre (mm)")
    ax.set_title(f"{report.scene}: {report.successes}/{len(report.trials)} placed", fontsize=10)
    if not keys:
        axes[1].text(0.5, 0.5, f"perturbation '{report.perturbation.name}':\nno random error drawn",
                     ha="center", va="center")
        axes[1].set_axis_off()
    for ax, key in zip(axes[1:], keys):
        x = np.array([t.params[key] for t in report.trials])
        y = np.array([1.0 if t.success else 0.0 for t in report.trials])
        jitter = np.random.default_rng(0).uniform(-0.06, 0.06, len(y))
        for success, (colour, word) in outcome.items():
            sel = (y > 0) == success
            if sel.any():
                ax.scatter(x[sel], y[sel] + jitter[sel], color=colour, s=14, label=f"trial {word}")
        ax.set_yticks([0, 1], ["failed", "placed"])
        ax.set_ylim(-0.4, 1.4)
        ax.set_xlabel(textwrap.fill(TRIAL_PARAM_LABELS.get(key, key.replace("_", " ")), 34), fontsize=8)
        ax.tick_params(labelsize=7)
        if key.endswith("_seed"):  # a seed names its draws: its size means nothing
            ax.set_xticks([])
    drawn = legend_marks(*axes)
    fig.legend(drawn.values(), drawn.keys(), loc="outside lower center", ncol=5, fontsize=8)
    return fig


#: The size of one small panel of the trials' picture (inches): readable at the pictures' dpi.
TRIAL_PANEL_INCHES = (2.8, 2.3)


def _trial_axes(panels: int):
    """A figure of a grid of small panels, the first axes (the outlines) over the top-left 2 x 2
    cells and one axes per panel after it, row by row: ceil(sqrt(panels + 4)) columns (at least
    3). Returns the figure and its axes."""
    cols = max(3, math.ceil(math.sqrt(panels + 4)))
    rows = max(2, math.ceil((panels + 4) / cols))
    w, h = TRIAL_PANEL_INCHES
    fig = plt.figure(figsize=(w * cols, h * rows + 0.7), layout="constrained")
    grid = fig.add_gridspec(rows, cols)
    free = [(r, c) for r in range(rows) for c in range(cols) if not (r < 2 and c < 2)]
    return fig, [fig.add_subplot(grid[:2, :2])] + [fig.add_subplot(grid[r, c]) for r, c in free[:panels]]
