"""The picture of a plan's cage profile: escape energy and friction margin along it (matplotlib)."""

from __future__ import annotations

import math
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from numpy.typing import NDArray  # noqa: E402

from ..mechanics.cage import CageOutcome  # noqa: E402
from ..planning.cage_profile import CageProfile  # noqa: E402
from ..planning.result import Plan  # noqa: E402
from .common import legend_marks, save_png  # noqa: E402

_COLOURS = {CageOutcome.NOT_CAGED: "#d62728", CageOutcome.CAGED: "#ff7f0e", CageOutcome.FULLY_CAGED: "#2ca02c"}


def draw_cage_profile(name: str, plan: Plan, profile: CageProfile, margins: NDArray[np.float64],
                      path: str | os.PathLike[str]) -> None:
    """Write cage_figure's picture to path (PNG)."""
    save_png(cage_figure(name, plan, profile, margins), path)


def cage_figure(name: str, plan: Plan, profile: CageProfile, margins: NDArray[np.float64]):
    """Two panels over the samples of a plan: the escape energy (mJ; fully caged drawn on a dotted
    line at the top of the axis, which no line joins, not caged at 0, coloured by outcome) and the
    friction margin in each leg's contact mode (deg; margins in rad), with the primitives' extents
    shaded and named; a legend in each panel names its marks. Returns the matplotlib Figure."""
    samples = profile.samples
    k = np.arange(len(samples.states))
    energy = profile.escape_energy * 1000.0
    finite = energy[np.isfinite(energy)]
    top = max(float(finite.max()) * 1.25 if len(finite) and finite.max() > 0 else 1.0, 1e-3)
    fig, (ax_e, ax_m) = plt.subplots(2, 1, figsize=(10, 7.2), sharex=True)
    fig.subplots_adjust(left=0.09, right=0.97, top=0.93, bottom=0.17, hspace=0.12)
    for ax in (ax_e, ax_m):
        for p in range(len(plan.primitives)):
            idx = np.flatnonzero(samples.primitive == p)
            ax.axvspan(idx[0] - 0.5, idx[-1] + 0.5, color="0.93" if p % 2 else "0.86", lw=0,
                       label="a primitive's samples (named below)")
            if ax is ax_m:
                ax.text((idx[0] + idx[-1]) / 2, 0.02, plan.primitives[p].type, transform=ax.get_xaxis_transform(),
                        ha="center", va="bottom", fontsize=9)
    shown = np.where(np.isfinite(energy), energy, top)
    for outcome, colour in _COLOURS.items():
        sel = np.array([c.outcome is outcome for c in profile.cages])
        if sel.any():
            ax_e.scatter(k[sel], shown[sel], s=18, color=colour, label=outcome.value.replace("_", " "), zorder=3)
    ax_e.plot(k, np.where(np.isfinite(energy), energy, np.nan), color="0.5", lw=0.8, zorder=2,
              label="escape energy where finite")
    ax_e.axhline(top, color="#2ca02c", lw=0.8, ls=":", zorder=1,  # infinity: no line joins it
                 label="infinite energy (fully caged), drawn at the top")
    ax_e.set_ylim(-0.05 * top, top * 1.08)
    ax_e.set_ylabel("escape energy (mJ)")

    e_min, at = profile.minimum()
    ax_e.set_title(f"{name}: cage and friction margin along the plan (smallest escape energy "
                   f"{'inf' if math.isinf(e_min) else f'{e_min * 1000:.3g}'} mJ at sample {at})")
    ax_m.plot(k, np.degrees(margins), color="#1f77b4", lw=1.5, label="friction margin in the leg's contact mode")
    ax_m.axhline(0.0, color="k", lw=0.8, label="zero margin: a contact slips")
    ax_m.set_ylabel("friction margin (deg)")
    ax_m.set_xlabel("sample along the plan (index)")
    marks = legend_marks(ax_e, ax_m)
    fig.legend(marks.values(), marks.keys(), loc="lower center", ncol=3, fontsize=8)
    return fig
