"""Figures of a monocular run: the camera path and map in the paper's X-Y and X-Z views
(Fig. 13), and frames with the predicted search ellipses and the matches (Fig. 12)."""

from __future__ import annotations

import math
import os
from typing import TYPE_CHECKING

import matplotlib

matplotlib.use("Agg")
import matplotlib.image as mpimg
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.patches import Ellipse

if TYPE_CHECKING:
    from bearing_slam.mono import MonoResult

__all__ = ["plot_search_frames", "plot_trajectory_views"]


def _ellipse(center: tuple[float, float], cov: np.ndarray, k: float, **style: object) -> Ellipse:
    """The ellipse ``νᵀ cov⁻¹ ν = k²`` around ``center``."""
    values, vectors = np.linalg.eigh(cov)
    values = np.clip(values, 0.0, None)
    angle = math.degrees(math.atan2(vectors[1, 1], vectors[0, 1]))
    return Ellipse(
        center,
        2 * k * math.sqrt(values[1]),
        2 * k * math.sqrt(values[0]),
        angle=angle,
        fill=False,
        **style,
    )


def plot_trajectory_views(result: MonoResult, path: str | os.PathLike[str]) -> None:
    """Truth and estimate in the X-Y and X-Z planes, with the final map's landmarks and
    their 2σ ellipses (projections of the 3-D covariance)."""
    fig, axes = plt.subplots(1, 2, figsize=(11, 5))
    for ax, (i, j, name) in zip(axes, [(0, 1, "X-Y"), (0, 2, "X-Z")], strict=True):
        ax.plot(result.truth[:, i], result.truth[:, j], "k-", lw=2, label="ground truth")
        ax.plot(result.estimate[:, i], result.estimate[:, j], "r-", lw=1.5, label="estimate")
        for row in result.landmarks:
            p = row[1:4]
            cov = row[4:13].reshape(3, 3)
            sub = cov[np.ix_([i, j], [i, j])]
            if np.all(np.isfinite(sub)) and np.trace(sub) < 100.0:
                ax.add_patch(_ellipse((p[i], p[j]), sub, 2.0, color="tab:blue", lw=0.6))
            ax.plot(p[i], p[j], ".", color="tab:blue", ms=3)
        ax.set_xlabel("x [m]")
        ax.set_ylabel(f"{'y' if j == 1 else 'z'} [m]")
        ax.set_title(f"{name} view")
        ax.set_aspect("equal", adjustable="box")
        ax.grid(alpha=0.3)
    # The path's span with a margin: far landmarks do not squash the path.
    span = np.concatenate([result.truth[:, :3], result.estimate[:, :3]])
    for ax, (i, j) in zip(axes, [(0, 1), (0, 2)], strict=True):
        lo, hi = span.min(axis=0), span.max(axis=0)
        margin = max(2.0, 0.3 * float(np.max(hi - lo)))
        ax.set_xlim(lo[i] - margin, hi[i] + margin)
        ax.set_ylim(lo[j] - margin, hi[j] + margin)
    axes[0].legend(loc="best")
    ate = result.metrics["ate_sim3"]["rmse_m"]
    path_m = result.metrics["path_length_m"]
    fig.suptitle(f"monocular SLAM: ATE after Sim(3) {ate:.3f} m over {path_m:.1f} m")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_search_frames(result: MonoResult, path: str | os.PathLike[str], count: int = 3) -> None:
    """``count`` frames spread over the run, each with the predicted ellipses (χ² level
    of the run's config) coloured by outcome (green found, red missed) and the matches."""
    confidence = float(result.config["front_end"]["search"]["confidence"])
    k = math.sqrt(-2.0 * math.log(1.0 - confidence))
    run_frames = result.frames[:, 0].astype(int)
    picks = np.unique(np.linspace(1, len(run_frames) - 1, max(count, 1)).astype(int))
    fig, axes = plt.subplots(len(picks), 1, figsize=(9, 3.2 * len(picks)), squeeze=False)
    for ax, pick in zip(axes[:, 0], picks, strict=True):
        frame = int(run_frames[pick])
        image = mpimg.imread(result.images[frame])
        ax.imshow(image, cmap="gray", vmin=0.0, vmax=1.0)
        rows = result.searches[result.searches[:, 0] == frame]
        for r in rows:
            cov = np.array([[r[4], r[5]], [r[5], r[6]]])
            found = r[7] == 0
            color = "lime" if found else ("red" if r[7] == 1 else "gray")
            ax.add_patch(_ellipse((r[2], r[3]), cov, k, color=color, lw=0.8))
            if found:
                ax.plot([r[2], r[8]], [r[3], r[9]], "-", color="yellow", lw=0.8)
                ax.plot(r[8], r[9], "+", color="yellow", ms=6)
        new = result.added[result.added[:, 0] == frame]
        ax.plot(new[:, 1], new[:, 2], "s", mfc="none", mec="cyan", ms=5)
        n_found = int(np.sum(rows[:, 7] == 0))
        ax.set_title(f"frame {frame}: {n_found} of {len(rows)} found, {len(new)} added")
        ax.set_xlim(0, result.width)
        ax.set_ylim(result.height, 0)
        ax.axis("off")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
