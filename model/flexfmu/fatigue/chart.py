"""The range histogram of an assessment as a PNG: cycles per range bin (log scale) above the damage per bin, with
the curve's knee and cut-off marked."""
from __future__ import annotations

import math
import textwrap
from pathlib import Path

import numpy as np

from flexfmu.errors import ParameterError

from .assessment import SECONDS_PER_YEAR, FatigueAssessment


def plot_range_histogram(assessment: FatigueAssessment, path) -> Path:
    """Write the chart to ``path`` (PNG, matplotlib's Agg backend) and return the path."""
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise ParameterError("plot", "the chart needs matplotlib", "pip install 'flexfmu[plots]'") from None
    a = assessment
    u = a.curve.unit
    edges = a.bins.edges
    width = np.diff(edges)
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(8, 6.2), sharex=True)
    cycles = a.bins.cycles
    shown = cycles > 0
    top.bar(edges[:-1][shown], cycles[shown], width=width[shown], align="edge", color="tab:blue",
            edgecolor="white", linewidth=0.5)
    if shown.any():
        top.set_yscale("log")
    top.set_ylabel("cycles per bin")
    # a scan's name holds the critical plane or fibre: wrapped, so the curve's name at the end stays on the figure
    top.set_title(textwrap.fill(f"{a.name}: rainflow ranges over {a.duration:.4g} s on {a.curve.name}", 90),
                  fontsize=10)
    share = a.bins.damage / a.damage * 100.0 if a.damage > 0.0 else np.zeros_like(a.bins.damage)
    bottom.bar(edges[:-1], share, width=width, align="edge", color="tab:red", edgecolor="white", linewidth=0.5)
    bottom.set_ylabel("share of the damage, %")
    bottom.set_xlabel(f"stress range, {u}")
    for ax in (top, bottom):
        for value, label, style in ((a.curve.knee_range, "knee", "--"), (a.curve.cutoff, "cut-off", ":")):
            if value is not None and value <= edges[-1]:
                ax.axvline(value, color="0.3", linestyle=style, linewidth=1.0, label=f"{label} {value:.4g} {u}")
        ax.grid(True, which="both", alpha=0.3)
    if bottom.get_legend_handles_labels()[0]:
        bottom.legend(loc="best", fontsize=8)
    life = "unlimited" if math.isinf(a.life_seconds) else f"{a.life_seconds / SECONDS_PER_YEAR:.4g} years"
    bottom.text(0.01, 0.95, f"Miner damage {a.damage:.3e}\nequivalent range {a.equivalent_range:.4g} {u} "
                f"(m {a.curve.m:g}, N_ref {a.n_ref:.2g})\nlife at this rate {life}",
                transform=bottom.transAxes, va="top", fontsize=8,
                bbox={"facecolor": "white", "edgecolor": "0.8", "alpha": 0.9})
    bottom.set_xlim(0.0, edges[-1])
    fig.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
