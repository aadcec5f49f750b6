"""The particle cloud of a FastSLAM run (issue 15), matplotlib (Agg).

* :func:`plot_particle_cloud`: the map of :func:`~bearing_slam.plots.run.plot_trajectory`
  (truth, estimate, dead reckoning, the *best particle's* landmarks with their
  2σ ellipses) with the recorded clouds over it: every recorded cloud as faint
  dots coloured by time, the last one as heading ticks whose opacity follows
  the weight, the best particle in red.

``bearing-slam run --estimator fastslam2`` writes it as ``particles.png``
(:func:`~bearing_slam.plots.run.save_plots`); the clouds are
``result.trace.particle_clouds()`` (at most 100 per run, the last always kept),
and ``estimate.mcap`` carries them on ``/slam/particle_cloud`` (exact) and
``/slam/particles`` (Foxglove view).
"""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.figure import Figure

from bearing_slam._native import RunResult, SensorLog

__all__ = ["has_particle_clouds", "plot_particle_cloud"]

#: Length of a heading tick of the last cloud, as a fraction of the map's extent.
_TICK_FRACTION = 0.015


def has_particle_clouds(result: RunResult) -> bool:
    """Whether ``result`` recorded particle clouds (a FastSLAM run)."""
    return len(result.trace.particle_clouds()) > 0


def plot_particle_cloud(result: RunResult, log: SensorLog | None = None) -> Figure:
    """Two panels: the whole map (the best particle's landmarks with their 2σ
    ellipses, the true ones, the paths), and a zoom on the path with the
    recorded particle clouds."""
    from bearing_slam.plots.run import _draw_map, _fit_to_points, _title

    clouds = result.trace.particle_clouds()
    if not clouds:
        raise ValueError("this run recorded no particle cloud (run it with a FastSLAM estimator)")
    fig, (whole, zoom) = plt.subplots(
        1, 2, figsize=(14.5, 6.2), layout="constrained", width_ratios=[1, 1.3]
    )
    _draw_map(whole, result, log, legend=False)
    _fit_to_points(whole, result, log)
    whole.set_aspect("equal", adjustable="box")
    whole.set_title("whole map (the best particle's)", fontsize=10)
    _draw_map(zoom, result, log, legend=False)
    t0, t1 = float(clouds[0]["time"]), float(clouds[-1]["time"])
    span = max(t1 - t0, 1e-9)
    for c in clouds[:-1]:
        p = c["poses"]
        shade = 0.6 * (1.0 - (float(c["time"]) - t0) / span) + 0.2
        zoom.plot(p[:, 0], p[:, 1], ".", color=(0.2, shade, 0.3), ms=1.5, alpha=0.3)
    zoom.plot([], [], ".", color=(0.2, 0.5, 0.3), ms=4, label="earlier clouds (darker: later)")
    last = clouds[-1]
    p, w = last["poses"], last["weights"]
    every = np.concatenate([c["poses"][:, :2] for c in clouds])
    every = every[np.isfinite(every).all(axis=1)]
    lo, hi = every.min(axis=0), every.max(axis=0)
    size = max(float((hi - lo).max()), 0.5)
    tick = _TICK_FRACTION * size
    alpha = 0.15 + 0.85 * (w / max(float(w.max()), 1e-300))
    rgba = np.zeros((len(p), 4))
    rgba[:, 1] = 0.55
    rgba[:, 2] = 0.25
    rgba[:, 3] = alpha
    zoom.quiver(
        p[:, 0],
        p[:, 1],
        np.cos(p[:, 2]),
        np.sin(p[:, 2]),
        color=rgba,
        angles="xy",
        scale_units="xy",
        scale=1.0 / tick,
        width=0.003,
        label=f"last cloud (t = {t1:.1f} s; opacity: weight)",
    )
    b = last["poses"][int(last["best"])]
    zoom.plot(b[0], b[1], "*", color="#d62728", ms=12, label="best particle (its map shown)")
    margin = 0.15 * size
    zoom.set_xlim(float(lo[0]) - margin, float(hi[0]) + margin)
    zoom.set_ylim(float(lo[1]) - margin, float(hi[1]) + margin)
    zoom.set_aspect("equal", adjustable="box")
    zoom.set_title("around the path: the particle clouds", fontsize=10)
    config = result.config
    fig.suptitle(
        f"{_title(result, log)} — {config.estimator}, M = {config.particles}: "
        f"{len(clouds)} recorded clouds"
    )
    handles, labels = zoom.get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside right center", fontsize=8)
    return fig
