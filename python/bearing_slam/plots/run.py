"""Plots of one run (matplotlib, Agg backend: files only, no window).

* :func:`plot_trajectory`: truth, estimate, dead reckoning, true landmarks and
  estimated landmarks with their 2σ ellipses, axes equal.
* :func:`plot_pose_errors`: x, y and θ errors over time with ±3σ bounds.
* :func:`plot_nees`: pose NEES over time with the one-sided χ²(3) 95 % bound
  and, in its title, :func:`nees_caption` (the numbers of ``metrics.json``).
* :func:`save_plots`: all three as PNG files; :func:`save_figure`: one figure.
"""

from __future__ import annotations

import math
from pathlib import Path

import matplotlib as mpl

mpl.use("Agg")

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.patches import Ellipse
from numpy.typing import NDArray

from bearing_slam._native import RunResult, SensorLog, nees_summary

__all__ = [
    "SCAN_GAP_S",
    "covariance_ellipse",
    "landmark_clusters",
    "nees_caption",
    "plot_nees",
    "plot_pose_errors",
    "plot_trajectory",
    "save_figure",
    "save_plots",
    "scan_gaps",
]

_TRUTH = "#2ca02c"
_ESTIMATE = "#1f77b4"
_DEAD_RECKONING = "#7f7f7f"
_LANDMARK = "#d62728"


def covariance_ellipse(
    mean: NDArray[np.float64], cov: NDArray[np.float64], n_sigma: float = 2.0, **kwargs: object
) -> Ellipse:
    """The ``n_sigma`` ellipse of a 2-D Gaussian as a matplotlib patch."""
    vals, vecs = np.linalg.eigh(0.5 * (cov + cov.T))
    vals = np.clip(vals, 0.0, None)
    angle = math.degrees(math.atan2(float(vecs[1, 1]), float(vecs[0, 1])))
    width, height = 2.0 * n_sigma * np.sqrt(vals[::-1])
    return Ellipse(
        (float(mean[0]), float(mean[1])),
        float(width),
        float(height),
        angle=angle,
        **kwargs,
    )


def _title(result: RunResult, log: SensorLog | None) -> str:
    source = str(log.info.get("source", "")) if log is not None else ""
    config = result.config
    init = config.init
    if init == "pi-sr":
        init = f"pi-sr (ρ_ini={config.rho_ini:g}, σ_ρ={config.sigma_rho:g})"
    elif init == "mte-clone" and config.history > 0:
        init = f"mte-clone (waiting bearings kept: history={config.history})"
    return f"{source} — {init}" if source else init


def _draw_map(ax: Axes, result: RunResult, log: SensorLog | None, legend: bool) -> None:
    truth = result.truth
    if np.isfinite(truth).any():
        ax.plot(truth[:, 0], truth[:, 1], color=_TRUTH, lw=2.0, label="ground truth")
    dr = result.dead_reckoning
    ax.plot(dr[:, 0], dr[:, 1], color=_DEAD_RECKONING, lw=1.2, ls="--", label="dead reckoning")
    est = result.estimate
    ax.plot(est[:, 0], est[:, 1], color=_ESTIMATE, lw=1.5, label="SLAM estimate")
    if len(est):
        ax.plot(est[0, 0], est[0, 1], "k^", ms=8, label="start")
    if log is not None and len(log.landmarks):
        lm = log.landmarks
        ax.plot(lm[:, 1], lm[:, 2], "x", color=_LANDMARK, ms=10, mew=2, label="landmarks (truth)")
        for members in landmark_clusters(lm[:, 1:], _label_radius(result, lm)):
            # One label per group of close landmarks ("16, 17, 18"), above the group.
            top = members[np.argmax(lm[members, 2])]
            ax.annotate(
                ", ".join(str(int(lm[k, 0])) for k in sorted(members, key=lambda k: lm[k, 0])),
                (lm[top, 1], lm[top, 2]),
                textcoords="offset points",
                xytext=(0, 8),
                ha="center",
                va="bottom",
                color=_LANDMARK,
                fontsize=9,
                annotation_clip=True,
            )
    ids, pos, cov = result.landmarks()
    if len(ids):
        ax.plot(pos[:, 0], pos[:, 1], "o", color=_ESTIMATE, ms=5, label="landmarks (estimate)")
        for k in range(len(ids)):
            ax.add_patch(
                covariance_ellipse(pos[k], cov[k], 2.0, fill=False, ec=_ESTIMATE, lw=1.0, alpha=0.8)
            )
        ax.plot([], [], color=_ESTIMATE, lw=1.0, label="landmark 2σ ellipse")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.grid(True, alpha=0.3)
    if legend:
        # A figure legend right of the map (constrained layout makes room for
        # it): a legend inside the axes hides landmarks.
        handles, labels = ax.get_legend_handles_labels()
        ax.figure.legend(handles, labels, loc="outside right center", fontsize=8)


def landmark_clusters(points: NDArray[np.float64], radius: float) -> list[list[int]]:
    """Groups of landmark indices whose points are chained by gaps of at most
    ``radius`` (single linkage), each group in index order, groups by their
    first index: the landmarks that share one label on a map."""
    n = len(points)
    parent = list(range(n))

    def root(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for i in range(n):
        for j in range(i + 1, n):
            if float(np.hypot(*(points[i] - points[j]))) <= radius:
                parent[root(j)] = root(i)
    groups: dict[int, list[int]] = {}
    for i in range(n):
        groups.setdefault(root(i), []).append(i)
    return sorted(groups.values())


def _label_radius(result: RunResult, landmarks: NDArray[np.float64]) -> float:
    """How close two landmarks must be to share a label: 4 % of the map's extent."""
    pts = [landmarks[:, 1:], result.estimate[:, :2]]
    xy = np.concatenate(pts)
    xy = xy[np.isfinite(xy).all(axis=1)]
    if not len(xy):
        return 0.0
    return 0.04 * max(float(np.ptp(xy[:, 0])), float(np.ptp(xy[:, 1])), 1.0)


def _path_box(result: RunResult) -> tuple[float, float, float, float]:
    pts = [result.estimate[:, :2], result.dead_reckoning[:, :2]]
    truth = result.truth[:, :2]
    if np.isfinite(truth).all() and len(truth):
        pts.append(truth)
    xy = np.concatenate(pts)
    return (
        float(xy[:, 0].min()),
        float(xy[:, 0].max()),
        float(xy[:, 1].min()),
        float(xy[:, 1].max()),
    )


def _fit_to_points(ax: Axes, result: RunResult, log: SensorLog | None) -> None:
    """Limits the axes to the paths and the landmark points (true and
    estimated) with a 10 % margin, so that one badly constrained landmark's
    ellipse is clipped instead of shrinking the whole map to a corner."""
    pts = [result.estimate[:, :2], result.dead_reckoning[:, :2]]
    truth = result.truth[:, :2]
    pts.append(truth[np.isfinite(truth).all(axis=1)])
    _, pos, _ = result.landmarks()
    pts.append(pos)
    if log is not None and len(log.landmarks):
        pts.append(log.landmarks[:, 1:])
    nonempty = [p for p in pts if len(p)]
    if not nonempty:
        return
    xy = np.concatenate(nonempty)
    xy = xy[np.isfinite(xy).all(axis=1)]
    if not len(xy):
        return
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    margin = 0.1 * max(float((hi - lo).max()), 1.0)
    ax.set_xlim(float(lo[0]) - margin, float(hi[0]) + margin)
    ax.set_ylim(float(lo[1]) - margin, float(hi[1]) + margin)


def plot_trajectory(result: RunResult, log: SensorLog | None = None) -> Figure:
    """Trajectories (truth, estimate, dead reckoning) and the map: true
    landmarks (red crosses) and estimates (blue dots) with 2σ ellipses, axes
    equal. When the map reaches far beyond the path (a distant landmark), a
    second panel zooms on the path and the near landmarks."""
    x0, x1, y0, y1 = _path_box(result) if len(result.time) else (0.0, 1.0, 0.0, 1.0)
    size = max(x1 - x0, y1 - y0, 1.0)
    _, pos, _ = result.landmarks()
    pts = [pos] if len(pos) else []
    if log is not None and len(log.landmarks):
        pts.append(log.landmarks[:, 1:])
    far = False
    if pts:
        allp = np.concatenate(pts)
        reach = max(
            float(np.max(np.abs(allp[:, 0] - 0.5 * (x0 + x1)))),
            float(np.max(np.abs(allp[:, 1] - 0.5 * (y0 + y1)))),
        )
        far = reach > 2.0 * size
    if far:
        fig, (ax, zoom) = plt.subplots(
            1, 2, figsize=(14.5, 6), layout="constrained", width_ratios=[1, 1.3]
        )
        _draw_map(ax, result, log, legend=False)
        _fit_to_points(ax, result, log)
        ax.set_aspect("equal", adjustable="box")
        ax.set_title("whole map")
        _draw_map(zoom, result, log, legend=True)
        half = 0.5 * size + 0.2 * size
        cx, cy = 0.5 * (x0 + x1), 0.5 * (y0 + y1)
        zoom.set_xlim(cx - half, cx + half)
        zoom.set_ylim(cy - 0.6 * half, cy + 0.6 * half)
        zoom.set_aspect("equal", adjustable="box")
        zoom.set_title("around the path")
    else:
        fig, ax = plt.subplots(figsize=(9.5, 6.5), layout="constrained")
        _draw_map(ax, result, log, legend=True)
        _fit_to_points(ax, result, log)
        ax.set_aspect("equal", adjustable="box")
    fig.suptitle(f"Trajectory and map: {_title(result, log)}")
    return fig


def _wrap(a: NDArray[np.float64]) -> NDArray[np.float64]:
    return np.asarray((a + np.pi) % (2.0 * np.pi) - np.pi, dtype=np.float64)


#: A pause in the scans longer than this (s) is shaded on the pose-error plot.
SCAN_GAP_S = 5.0


def scan_gaps(result: RunResult, min_gap: float = SCAN_GAP_S) -> list[tuple[float, float]]:
    """The ``(start, end)`` times between consecutive scans (the trace's
    snapshot times) that are more than ``min_gap`` seconds apart."""
    times = np.asarray(result.trace.times, dtype=np.float64)
    if len(times) < 2:
        return []
    gaps = np.flatnonzero(np.diff(times) > min_gap)
    return [(float(times[i]), float(times[i + 1])) for i in gaps]


def plot_pose_errors(result: RunResult, log: SensorLog | None = None) -> Figure:
    """Pose errors (estimate − truth) in x, y [m] and θ [deg] over time, with
    the filter's ±3σ bounds (square roots of the covariance's diagonal; θ's is
    not wrapped). The bounds grow while the robot only drives (prediction) and
    drop when it sees mapped landmarks (update): a saw-tooth that is the filter
    telling the truth. Pauses in the scans longer than :data:`SCAN_GAP_S` are
    shaded grey, which is where the bounds grow the most."""
    fig, axes = plt.subplots(3, 1, figsize=(9, 7), sharex=True, layout="constrained")
    t = result.time
    gaps = scan_gaps(result)
    err = result.estimate - result.truth
    err[:, 2] = _wrap(err[:, 2])
    cov = result.covariance
    sigma = np.sqrt(np.clip(np.diagonal(cov, axis1=1, axis2=2), 0.0, None))
    labels = ["x error [m]", "y error [m]", "θ error [deg]"]
    scale = [1.0, 1.0, 180.0 / np.pi]
    for i, ax in enumerate(axes):
        e = err[:, i] * scale[i]
        b = 3.0 * sigma[:, i] * scale[i]
        ax.fill_between(t, -b, b, color=_ESTIMATE, alpha=0.15, label="±3σ")
        ax.plot(t, b, color=_ESTIMATE, lw=0.5)
        ax.plot(t, -b, color=_ESTIMATE, lw=0.5)
        ax.plot(t, e, color="k", lw=1.0, label="error")
        ax.axhline(0.0, color="0.5", lw=0.5)
        for k, (start, end) in enumerate(gaps):
            label = f"no scan for > {SCAN_GAP_S:g} s" if k == 0 else None
            ax.axvspan(start, end, color="0.6", alpha=0.25, lw=0, label=label)
        ax.set_ylabel(labels[i])
        ax.grid(True, alpha=0.3)
    axes[0].legend(loc="upper left", fontsize=9)
    axes[-1].set_xlabel("time [s]")
    if not np.isfinite(result.truth).any():
        axes[0].set_title("no ground truth: the filter's ±3σ only, no error", fontsize=9)
    fig.suptitle(f"Pose errors with ±3σ bounds: {_title(result, log)}")
    return fig


def nees_caption(result: RunResult) -> str:
    """The NEES numbers of a run as the plot's title prints them: mean, median
    and the percentage of scored times under the one-sided χ²(3) 95 % bound.
    They are ``nees_summary(result.nees)``, the Rust summary behind
    ``metrics.json``'s ``mean_nees_pose``, ``median_nees_pose`` and
    ``nees_within_95`` (one definition; ``tests/test_nees_metrics.py`` pins it)."""
    s = nees_summary(result.nees)
    return (
        f"mean {s['mean']:.2f}, median {s['median']:.2f}, "
        f"{100 * s['fraction_within_bound']:.0f} % under the χ² 95 % bound"
    )


def plot_nees(result: RunResult, log: SensorLog | None = None) -> Figure:
    """Pose NEES over time (the scored times of ``result.nees``) against the
    one-sided 95 % bound of χ²(3): a consistent filter stays under it about
    95 % of the time. The title gives :func:`nees_caption`."""
    fig, ax = plt.subplots(figsize=(9, 4.5), layout="constrained")
    t = result.time
    nees = result.nees
    bound = float(nees_summary(nees)["bound"])
    ok = np.isfinite(nees)
    ax.axhline(bound, color=_TRUTH, lw=1.2, label=f"χ²(3) 95 % bound ({bound:.2f})")
    ax.axhline(3.0, color=_TRUTH, lw=1.0, ls="--", label="expected (3)")
    ax.plot(t[ok], nees[ok], color="k", lw=0.8, label="pose NEES")
    if ok.any():
        ax.set_title(f"Pose NEES: {_title(result, log)}\n{nees_caption(result)}")
        ax.set_yscale("log")
    else:
        ax.set_title(f"Pose NEES: {_title(result, log)} (no ground truth)")
        ax.text(
            0.5,
            0.5,
            "no ground truth: the NEES cannot be computed",
            transform=ax.transAxes,
            ha="center",
            va="center",
            fontsize=12,
        )
        if len(t):
            ax.set_xlim(float(t[0]), float(t[-1]) + 1e-9)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("NEES (log scale)" if ok.any() else "NEES")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(loc="best", fontsize=9, framealpha=0.85)
    return fig


def save_plots(result: RunResult, log: SensorLog | None, out_dir: str | Path) -> list[Path]:
    """Writes ``trajectory.png``, ``pose_errors.png`` and ``nees.png`` (and,
    for a FastSLAM run, ``particles.png``) into ``out_dir`` and returns their
    paths."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    written = [
        save_figure(make(result, log), out / name, dpi=110)
        for name, make in (
            ("trajectory.png", plot_trajectory),
            ("pose_errors.png", plot_pose_errors),
            ("nees.png", plot_nees),
        )
    ]
    # Issue 15: a FastSLAM run also gets its particle clouds (particles.png).
    from bearing_slam.plots.particles import has_particle_clouds, plot_particle_cloud

    if has_particle_clouds(result):
        written.append(save_figure(plot_particle_cloud(result, log), out / "particles.png", 110))
    return written


def save_figure(fig: Figure, path: str | Path, dpi: int) -> Path:
    """Writes ``fig`` to ``path`` (PNG) at ``dpi`` and closes it; returns the
    path. The file is written under a temporary name and renamed when complete
    (:func:`bearing_slam.outputs.atomic_path`)."""
    from bearing_slam.outputs import atomic_path

    try:
        with atomic_path(path) as tmp:
            fig.savefig(tmp, dpi=dpi, format="png")
    finally:
        plt.close(fig)
    return Path(path)
