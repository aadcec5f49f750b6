"""Figures of the MRCLAM evaluation (``bearing-slam mrclam-figures``).

* :func:`comparison_figure`: one panel per robot, truth, dead reckoning and
  the methods' trajectories with the surveyed landmarks;
* :func:`ate_figure`: grouped ATE bars, one group per robot.

The per-run plots (trajectory, pose errors, NEES) are those of
:mod:`bearing_slam.plots.run`, drawn with :func:`bearing_slam.mrclam.plot_log`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import matplotlib as mpl

mpl.use("Agg")

import matplotlib.pyplot as plt
import numpy as np

from bearing_slam.mrclam import MrclamRun
from bearing_slam.vocabulary import MRCLAM_METHOD_LABELS

__all__ = ["ate_figure", "comparison_figure"]

_SHORT = {
    "dead-reckoning": "DR",
    "mte": "MTE",
    "mte-clone": "MTE-clone",
    "pi-sr": "PI-SR",
    "range-bearing": "RB",
    "gtsam": "GTSAM",
}

_COLORS = {
    "truth": "#2ca02c",
    "dead-reckoning": "#7f7f7f",
    "mte": "#1f77b4",
    "mte-clone": "#17becf",
    "pi-sr": "#ff7f0e",
    "auto": "#d62728",
    "range-bearing": "#9467bd",
    "gtsam": "#8c564b",
}


def comparison_figure(
    runs: Mapping[tuple[int, str], MrclamRun],
    methods: Sequence[str] = ("mte", "pi-sr", "range-bearing"),
    title: str = "MRCLAM Dataset 6",
) -> Any:
    """One panel per robot: ground truth, dead reckoning and the trajectories
    of ``methods``, with the surveyed landmarks; axes equal, one scale."""
    robots = sorted({r for r, _ in runs})
    fig, axes = plt.subplots(
        1, len(robots), figsize=(3.3 * len(robots), 5.2), layout="constrained", squeeze=False
    )
    for ax, robot in zip(axes[0], robots, strict=True):
        first = runs[(robot, methods[0])]
        truth = first.result.truth
        ok = np.isfinite(truth[:, 0])
        ax.plot(truth[ok, 0], truth[ok, 1], color=_COLORS["truth"], lw=2.2, label="Vicon truth")
        dr = first.result.dead_reckoning
        ax.plot(
            dr[:, 0],
            dr[:, 1],
            color=_COLORS["dead-reckoning"],
            lw=1.0,
            ls="--",
            label="dead reckoning (corrected commands)",
        )
        scores = [f"DR {first.metrics['odometry_ate_rmse_m']:.2f}"]
        for method in methods:
            run = runs.get((robot, method))
            if run is None:
                continue
            est = run.result.estimate
            ate = run.metrics["ate_rmse_m"]
            if ate is not None:
                scores.append(f"{_SHORT[method]} {ate:.2f}")
            ax.plot(
                est[:, 0],
                est[:, 1],
                color=_COLORS[method],
                lw=1.0,
                alpha=0.9,
                label=MRCLAM_METHOD_LABELS[method],
            )
            ids, pos, _ = run.result.landmarks()
            if method == "mte" and len(ids):
                ax.plot(pos[:, 0], pos[:, 1], "o", color=_COLORS[method], ms=4, mfc="none")
        lm = first.log.landmarks
        ax.plot(lm[:, 1], lm[:, 2], "x", color="#d62728", ms=7, mew=1.8, label="landmarks (survey)")
        half = (len(scores) + 1) // 2
        ax.set_title(
            f"robot {robot}, ATE [m]:\n"
            + ", ".join(scores[:half])
            + "\n"
            + ", ".join(scores[half:]),
            fontsize=9,
        )
        ax.set_aspect("equal", adjustable="box")
        ax.set_xlim(-3.0, 7.0)
        ax.set_ylim(-5.5, 7.0)
        ax.grid(True, alpha=0.3)
        ax.set_xlabel("x [m]")
        ax.tick_params(labelsize=8)
    axes[0][0].set_ylabel("y [m]")
    handles, labels = axes[0][0].get_legend_handles_labels()
    keep = list(zip(handles, labels, strict=True))
    keep.append(
        (
            axes[0][0].plot([], [], "o", color=_COLORS["mte"], ms=4, mfc="none")[0],
            "MTE landmarks",
        )
    )
    fig.legend(
        [h for h, _ in keep],
        [lab for _, lab in keep],
        loc="outside lower center",
        ncol=len(keep),
        fontsize=8,
        frameon=False,
    )
    fig.suptitle(f"{title}: whole runs, bearing-only SLAM (MTE, PI-SR) and references")
    return fig


def ate_figure(
    rows: Mapping[tuple[int, str], float | None],
    methods: Sequence[str],
    ylabel: str = "ATE RMSE [m]",
    title: str = "MRCLAM Dataset 6: trajectory error per robot",
) -> Any:
    """Grouped bars: one group per robot, one bar per method (missing values
    are left out)."""
    robots = sorted({r for r, _ in rows})
    fig, ax = plt.subplots(figsize=(9, 3.8), layout="constrained")
    width = 0.8 / len(methods)
    for k, method in enumerate(methods):
        xs, ys = [], []
        for i, robot in enumerate(robots):
            v = rows.get((robot, method))
            if v is not None:
                xs.append(i + (k - 0.5 * (len(methods) - 1)) * width)
                ys.append(v)
        ax.bar(xs, ys, width * 0.92, color=_COLORS[method], label=MRCLAM_METHOD_LABELS[method])
    ax.set_xticks(range(len(robots)), [f"robot {r}" for r in robots])
    ax.set_ylabel(ylabel)
    ax.grid(True, axis="y", alpha=0.3)
    ax.legend(fontsize=8, ncol=3, loc="upper right")
    ax.set_title(title)
    return fig
