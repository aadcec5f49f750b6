"""Figures of the paper's experiments (``bearing-slam experiment``), from
the plot-ready dicts of :func:`bearing_slam.experiments.run_experiment`.

* :func:`plot_fig4`: class fractions per initializer, and ATE against scene scale;
* :func:`plot_fig5`: triangulation σ_d and σ_ρ against parallax;
* :func:`plot_fig8`: dead reckoning against SLAM by landmark count;
* :func:`plot_fig10`: position error over time with one source;
* :func:`plot_consistency`: mean pose NEES over time with its 95 % band.

:data:`PLOTS` maps each experiment name to its figure.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

import matplotlib as mpl

mpl.use("Agg")

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter
from numpy.typing import NDArray

from bearing_slam.plots.run import save_figure

__all__ = [
    "PLOTS",
    "plot_consistency",
    "plot_fig4",
    "plot_fig5",
    "plot_fig8",
    "plot_fig10",
    "save_experiment_figure",
]

_COLORS = {"converged": "#2ca02c", "drift": "#ff7f0e", "diverged": "#d62728"}
_DR = "#7f7f7f"
_SLAM = "#1f77b4"


def _nan(values: Iterable[float | None]) -> NDArray[np.float64]:
    return np.array([math.nan if v is None else v for v in values], dtype=np.float64)


def plot_fig4(result: dict[str, Any]) -> Figure:
    """Class fractions (converged, drift, diverged) per method, with and
    without the far landmark: horizontal stacked bars; below them, when the
    result has the tuning study, each method's ATE against the scene scale."""
    scales = result.get("across_scales") or []
    fig = plt.figure(figsize=(13, 9.0 if scales else 4.2))
    grid = fig.add_gridspec(2 if scales else 1, 2, height_ratios=[1, 1] if scales else [1])
    axes = [fig.add_subplot(grid[0, 0])]
    axes.append(fig.add_subplot(grid[0, 1], sharey=axes[0]))
    plt.setp(axes[1].get_yticklabels(), visible=False)
    for ax, key, title in zip(
        axes,
        ("with_far", "without_far"),
        ("with the far landmark (75 m)", "without the far landmark"),
        strict=True,
    ):
        reports = result[key]
        labels = [r["label"].replace(" (near", "\n(near") for r in reports]
        y = np.arange(len(reports))[::-1]
        left = np.zeros(len(reports))
        for cls in ("converged", "drift", "diverged"):
            frac = np.array([r[f"{cls}_fraction"] for r in reports])
            ax.barh(y, frac, left=left, color=_COLORS[cls], label=cls, height=0.65)
            for yi, lo, f in zip(y, left, frac, strict=True):
                if f >= 0.06:
                    ax.text(lo + f / 2, yi, f"{100 * f:.1f} %", ha="center", va="center",
                            color="white", fontsize=9, fontweight="bold")  # fmt: skip
            left += frac
        ax.set_yticks(y, labels)
        ax.set_xlim(0, 1)
        ax.set_xlabel("fraction of runs")
        runs = reports[0]["spec"]["runs"] if reports else 0
        ax.set_title(f"paper_fig4, {title}, {runs} runs each")
        ax.grid(axis="x", alpha=0.3)
    handles, names = axes[0].get_legend_handles_labels()
    if scales:
        _plot_fig4_scales(fig.add_subplot(grid[1, :]), scales)
        fig.legend(handles, names, loc="center", bbox_to_anchor=(0.5, 0.505), ncol=3,
                   fontsize=9, frameon=False)  # fmt: skip
        fig.tight_layout(h_pad=3.0)
    else:
        fig.legend(handles, names, loc="lower center", ncol=3, fontsize=9, frameon=False)
        fig.tight_layout(rect=(0, 0.06, 1, 1))
    return fig


def _plot_fig4_scales(ax: Axes, rows: list[dict[str, Any]]) -> None:
    """ATE (mean over the runs that did not diverge) against the factor on
    the near landmarks' positions, one line per method; the marker is hollow
    where fewer than 95 % of the runs converged."""
    for row in rows:
        cells = row["cells"]
        x = np.array([c["scale"] for c in cells], dtype=np.float64)
        ate = _nan(c["ate_rmse_m"] for c in cells)
        ok = np.array([c["converged_fraction"] >= 0.95 for c in cells])
        mte = row["label"].startswith("MTE")
        style = "-" if mte else "--"
        # MTE and MTE-clone nearly coincide: MTE is drawn wider, beneath.
        width = 4.0 if row["label"] == "MTE" else 2.2 if mte else 1.4
        (line,) = ax.plot(x, ate, style, lw=width, label=row["label"], zorder=3 if mte else 2)
        color = line.get_color()
        ax.plot(x[ok], ate[ok], "o", color=color, ms=6, zorder=4)
        ax.plot(x[~ok], ate[~ok], "o", color=color, mfc="white", ms=6, zorder=4)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xticks(
        [c["scale"] for c in rows[0]["cells"]], [f"×{c['scale']:g}" for c in rows[0]["cells"]]
    )
    ax.minorticks_off()
    ax.set_yticks([0.03, 0.05, 0.1, 0.2, 0.5, 1.0])
    ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    ax.set_xlabel("near landmarks' positions × (first depths 2.5–8.2 m at ×1)")
    ax.set_ylabel("ATE [m] (mean, non-diverged runs)")
    ax.set_title(
        "paper_fig4 scaled: which initializer needs no tuning? "
        "(hollow marker: < 95 % of the runs converged)"
    )
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8, ncol=2, loc="upper left")


def plot_fig5(result: dict[str, Any]) -> Figure:
    """σ_d (depth) and σ_ρ (inverse depth) against parallax, first order
    (lines) and sampled (markers), log y."""
    pts = result["points"]
    a = _nan(p["parallax_deg"] for p in pts)
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(12, 4.5))
    ax1.semilogy(a, _nan(p["sigma_depth_m"] for p in pts), "-", color=_SLAM,
                 label="first order σ_ρ/ρ²")  # fmt: skip
    ax1.semilogy(a, _nan(p["sampled_sigma_depth_m"] for p in pts), "o", color="#d62728", ms=5,
                 label="sampled, rays meeting in front (half 16–84 % range)")  # fmt: skip
    ax1.set_ylabel("σ_d [m]")
    ax1.set_title(f"depth σ_d, landmark at {result['distance_m']:g} m")
    ax2.semilogy(a, _nan(p["sigma_rho"] for p in pts), "-", color=_SLAM, label="first order")
    ax2.semilogy(a, _nan(p["sampled_sigma_rho"] for p in pts), "o", color="#d62728", ms=5,
                 label="sampled (std)")  # fmt: skip
    ax2.set_ylabel("σ_ρ [1/m]")
    ax2.set_title("inverse depth σ_ρ")
    for ax in (ax1, ax2):
        ax.set_xlabel("parallax α [°]")
        ax.grid(which="both", alpha=0.3)
        ax.legend()
    fig.suptitle(
        f"Triangulation with σ = {result['sigma_deg']:g}° bearings, β = 90°, "
        f"{result['samples']} samples per angle"
    )
    fig.tight_layout()
    return fig


def plot_fig8(result: dict[str, Any]) -> Figure:
    """Per-run ATE of dead reckoning and SLAM (MTE) against the number of
    landmarks: boxes over runs, means as diamonds."""
    rows = result["rows"]
    fig, ax = plt.subplots(figsize=(8, 4.8))
    x = np.arange(len(rows))
    for offset, key, color, name in (
        (-0.18, "dead_reckoning_ate_rmse_m", _DR, "dead reckoning"),
        (0.18, "ate_rmse_m", _SLAM, "SLAM (MTE)"),
    ):
        data = []
        for row in rows:
            v = _nan(r[key] for r in row["report"]["runs"] if r["class"] != "diverged")
            data.append(v[np.isfinite(v)])
        bp = ax.boxplot(data, positions=x + offset, widths=0.3, patch_artist=True,
                        showfliers=True, flierprops={"ms": 3})  # fmt: skip
        for box in bp["boxes"]:
            box.set_facecolor(color)
            box.set_alpha(0.45)
        means = [float(np.mean(d)) if len(d) else math.nan for d in data]
        ax.plot(x + offset, means, "D-", color=color, ms=6, label=f"{name}, mean")
    ax.set_xticks(x, [str(r["landmarks"]) for r in rows])
    ax.set_xlabel("number of landmarks")
    ax.set_ylabel("ATE (position RMSE) [m]")
    ax.set_yscale("log")
    runs = rows[0]["report"]["spec"]["runs"] if rows else 0
    ax.set_title(f"paper_fig8: dead reckoning vs SLAM, {runs} runs per count")
    ax.grid(which="both", axis="y", alpha=0.3)
    ax.legend()
    fig.tight_layout()
    return fig


def plot_fig10(result: dict[str, Any]) -> Figure:
    """Mean position error over time (over the runs that did not diverge),
    dead reckoning against SLAM, per scenario and slip setting."""
    reports = result["reports"]
    fig, axes = plt.subplots(2, 2, figsize=(12, 7.5), sharex="row")
    for ax, rep in zip(axes.flat, reports, strict=False):
        e = rep["error_over_time"]
        t = _nan(e["time"])
        ax.plot(
            t, _nan(e["dead_reckoning_mean_m"]), color=_DR, lw=1.6, label="dead reckoning, mean"
        )
        ax.plot(
            t,
            _nan(e["dead_reckoning_rms_m"]),
            color=_DR,
            lw=0.9,
            ls="--",
            label="dead reckoning, RMS",
        )
        ax.plot(t, _nan(e["slam_mean_m"]), color=_SLAM, lw=1.6, label="SLAM (MTE), mean")
        ax.plot(t, _nan(e["slam_rms_m"]), color=_SLAM, lw=0.9, ls="--", label="SLAM (MTE), RMS")
        if len(t):
            for k in range(1, 6):
                ax.axvline(t[-1] * k / 6, color="k", lw=0.5, alpha=0.25)
        sc = rep["spec"]["scenario"]
        slip = "on" if sc["slip"] else "off"
        n = rep["all_finite"]["runs"]
        ax.set_title(f"{sc['name']}, slip {slip} ({n} runs)")
        ax.set_xlabel("time [s] (thin lines: laps)")
        ax.set_ylabel("position error [m]")
        ax.grid(alpha=0.3)
    axes.flat[0].legend(fontsize=8)
    fig.tight_layout()
    return fig


def plot_consistency(result: dict[str, Any]) -> Figure:
    """Mean pose NEES over time with its 95 % band, one panel per method,
    with (left) and without (right) the far landmark; log y."""
    curves = result["curves"]
    with_far = [c for c in curves if "no far" not in c["scenario"]]
    without = [c for c in curves if "no far" in c["scenario"]]
    n = max(len(with_far), len(without), 1)
    fig, axes = plt.subplots(n, 2, figsize=(12, 2.3 * n + 0.6), sharex=True, squeeze=False)
    for col, group, title in ((0, with_far, "with far landmark"), (1, without, "no far landmark")):
        for row in range(n):
            ax = axes[row, col]
            if row >= len(group):
                ax.set_visible(False)
                continue
            c = group[row]
            nees = c["nees"]
            t = _nan(nees["time"])
            ax.fill_between(t, _nan(nees["lower"]), _nan(nees["upper"]), color="#2ca02c",
                            alpha=0.25, lw=0, label="95 % band")  # fmt: skip
            ax.axhline(3.0, color="k", lw=0.7, ls=":", label="expected (3)")
            ax.plot(t, _nan(nees["mean"]), color=_SLAM, lw=1.2, label="mean NEES")
            ax.set_yscale("log")
            # The start is known exactly: the first NEES values are ~0; keep the band readable.
            ax.set_ylim(bottom=0.2)
            ax.yaxis.set_major_locator(LogLocator(base=10, subs=(1.0, 2.0, 5.0), numticks=8))
            ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _pos: f"{v:g}"))
            ax.yaxis.set_minor_formatter(NullFormatter())
            inside = nees.get("fraction_inside")
            frac = "" if inside is None else f", {100 * inside:.0f} % of the time in the band"
            label = c["label"].split(" (near")[0]
            ax.set_title(f"{label}, {title}{frac}", fontsize=9)
            ax.set_ylabel("NEES")
            ax.grid(which="both", alpha=0.25)
            if row == len(group) - 1:
                ax.set_xlabel("time [s]")
    axes[0, 0].legend(fontsize=8, loc="upper left")
    fig.tight_layout()
    return fig


PLOTS: dict[str, Callable[[dict[str, Any]], Figure]] = {
    "fig4": plot_fig4,
    "consistency": plot_consistency,
    "fig5": plot_fig5,
    "fig8": plot_fig8,
    "fig10": plot_fig10,
}


def save_experiment_figure(name: str, result: dict[str, Any], path: str | Path) -> Path:
    """Draws experiment ``name``'s figure (:data:`PLOTS`) from ``result`` and
    writes it to ``path`` as a PNG; returns the path."""
    return save_figure(PLOTS[name](result), path, dpi=110)
