"""Trajectories in the TUM format, the one `evo <https://github.com/MichaelGrupp/evo>`_
and most SLAM benchmarks read: one pose a line, ``timestamp x y z qx qy qz qw``.

:func:`write_tum` writes a run's estimate and, beside it, the ground truth at the
same times, so that ::

    evo_ape tum run.truth.tum run.tum

prints as its APE RMSE the run's ``ate_rmse_m``. The convention is the same on both
sides: the position error at every track time that has ground truth, with **no
alignment** (the filter starts at the true initial pose, so the estimate is already
in the truth's frame). Do not pass ``--align`` (``-a``) or ``--correct_scale``
(``-s``) to evo for that number; ``ate_aligned_rmse_m`` is the same RMSE after the
best planar rigid motion (SE(2)). evo's ``--align`` (a 3-D Umeyama fit) refuses
exactly planar trajectories ("Degenerate covariance rank"), so use
``ate_aligned_rmse_m`` for the aligned number.

Poses are planar: ``z = 0`` and the heading θ is the quaternion of a rotation
about z, ``(qx, qy, qz, qw) = (0, 0, sin θ/2, cos θ/2)``. Timestamps are the
track times in seconds (since the log's start for simulations; for MRCLAM,
since the robot's first command), written with nanosecond resolution so evo
associates the two files exactly.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from bearing_slam._native import RunResult

__all__ = ["TRUTH_SUFFIX", "truth_path", "tum_lines", "write_tum"]

#: What :func:`truth_path` inserts before a TUM file's extension.
TRUTH_SUFFIX = ".truth"


def truth_path(path: str | os.PathLike[str]) -> Path:
    """Where :func:`write_tum` writes the truth beside the estimate ``path``:
    ``run.tum`` → ``run.truth.tum``, ``out/est.txt`` → ``out/est.truth.txt``,
    ``traj`` → ``traj.truth``."""
    p = Path(path)
    return p.with_name(p.stem + TRUTH_SUFFIX + p.suffix)


def tum_lines(times: NDArray[np.float64], poses: NDArray[np.float64]) -> list[str]:
    """TUM lines ``timestamp x y 0 0 0 qz qw`` of planar poses ``(n, 3)``
    ``[x, y, θ]`` at ``times`` ``(n,)``."""
    if poses.ndim != 2 or poses.shape[1] != 3 or len(times) != len(poses):
        raise ValueError(
            f"TUM poses must be (n, 3) with n times, got {poses.shape} and {len(times)} times"
        )
    lines = []
    for t, (x, y, theta) in zip(times, poses, strict=True):
        half = 0.5 * float(theta)
        lines.append(f"{t:.9f} {x:.17g} {y:.17g} 0 0 0 {math.sin(half):.17g} {math.cos(half):.17g}")
    return lines


def write_tum(
    path: str | os.PathLike[str],
    result: RunResult,
    truth: str | os.PathLike[str] | None = None,
) -> tuple[Path, Path | None]:
    """Writes ``result``'s estimated trajectory to ``path`` in the TUM format and,
    when the run has ground truth, the true poses at the same times to ``truth``
    (default :func:`truth_path` of ``path``, e.g. ``run.truth.tum``). Returns
    ``(estimate path, truth path or None)``.

    The estimate has every track time; the truth only those with a true pose,
    which are the times ``ate_rmse_m`` is computed over, without alignment (see the
    module's documentation for evo's matching options). Each file is written
    atomically (:func:`bearing_slam.outputs.atomic_path`): a write that fails
    or is killed leaves the old file or the complete new one."""
    # Imported here: bearing_slam.outputs draws with matplotlib, which
    # `import bearing_slam` does not load.
    from bearing_slam.outputs import atomic_path

    est_path = Path(path)
    est_path.parent.mkdir(parents=True, exist_ok=True)
    times = np.asarray(result.time, dtype=np.float64)
    estimate = np.asarray(result.estimate, dtype=np.float64)
    if not np.isfinite(estimate).all():
        raise ValueError(f"the estimate has non-finite poses: cannot write {est_path}")
    with atomic_path(est_path) as tmp:
        tmp.write_text(
            "\n".join(["# timestamp x y z qx qy qz qw", *tum_lines(times, estimate)]) + "\n"
        )
    true_poses = np.asarray(result.truth, dtype=np.float64)
    has_truth = np.isfinite(true_poses).all(axis=1)
    if not has_truth.any():
        return est_path, None
    out = truth_path(est_path) if truth is None else Path(truth)
    out.parent.mkdir(parents=True, exist_ok=True)
    body = tum_lines(times[has_truth], true_poses[has_truth])
    with atomic_path(out) as tmp:
        tmp.write_text("\n".join(["# timestamp x y z qx qy qz qw", *body]) + "\n")
    return est_path, out
