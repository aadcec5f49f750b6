"""Bearing-only SLAM on the real UTIAS MRCLAM robots (Leung et al., IJRR 2011).

* :func:`evaluate`: one method on one robot of a dataset directory
  (``MRCLAM_Dataset6/`` with Vicon ground truth, ``MRCLAM_Dataset1/``
  without), with the parameters calibrated on Dataset 6 (the Rust real-data
  evaluation, GIL released); :func:`evaluate_robots` every method on every robot.
* :func:`data_dir`: the directory holding the datasets, given or from
  ``$BEARING_SLAM_DATA``.
* :func:`plot_log`: the log to draw a run with (true landmarks moved into
  the filter's frame when there is no robot ground truth).

Records and files: :mod:`bearing_slam.outputs` (``metrics.json``,
:func:`~bearing_slam.outputs.write_mrclam_figures`); figures:
:mod:`bearing_slam.plots.mrclam`; command line: ``bearing-slam mrclam`` and
``bearing-slam mrclam-figures``.

Frames. On Dataset 6 the filter starts at the Vicon pose at the log start,
so its map is in the Vicon frame: ``landmark_rmse_m`` is the raw RMSE
against ``Landmark_Groundtruth.dat`` (``landmark_rmse_aligned_m`` after the
best SE(2) alignment of the map onto the surveyed landmarks is given too).
Dataset 1 has no robot ground truth: the filter starts at the origin, its
map is in an arbitrary frame, and ``landmark_rmse_m`` is the SE(2)-aligned
RMSE (``landmark_rmse_raw_m`` is null). ``landmark_frame`` says which.
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from bearing_slam._native import RunResult, SensorLog, evaluate_mrclam
from bearing_slam.vocabulary import DEFAULT_INIT, MRCLAM_METHOD_LABELS, MRCLAM_METHODS

__all__ = [
    "DATA_ENV",
    "METHODS",
    "METHOD_LABELS",
    "MrclamRun",
    "data_dir",
    "evaluate",
    "evaluate_robots",
    "plot_log",
]

#: The methods of :func:`evaluate`, in table order.
METHODS = MRCLAM_METHODS

#: Labels of the methods (and of the GTSAM yardstick) in tables and figures.
METHOD_LABELS = MRCLAM_METHOD_LABELS

#: The environment variable naming the directory that holds
#: ``MRCLAM_Dataset1/`` and ``MRCLAM_Dataset6/``.
DATA_ENV = "BEARING_SLAM_DATA"


@dataclass(frozen=True)
class MrclamRun:
    """One method on one MRCLAM robot."""

    #: The run (estimate, covariance, truth, dead reckoning, map, trace).
    result: RunResult
    #: The real-data scores from Rust (``ate_rmse_m``, ``odometry_ate_rmse_m``,
    #: ``landmark_rmse_m`` raw, ``landmark_rmse_aligned_m``, counts, ``report``,
    #: ``parameters``, ``landmark_alignment``, ``has_ground_truth``, ...).
    metrics: dict[str, Any]
    #: The log the filter was given (commands delayed and scaled).
    log: SensorLog
    #: Wall-clock seconds of load + filter + scoring.
    seconds: float


def data_dir(path: str | os.PathLike[str] | None = None) -> Path:
    """The directory holding ``MRCLAM_Dataset1/`` and ``MRCLAM_Dataset6/``:
    ``path`` when given, else ``$BEARING_SLAM_DATA``.

    Raises :class:`FileNotFoundError` when neither is set or the directory
    does not exist; the message says where the data was looked for."""
    if path is None:
        env = os.environ.get(DATA_ENV)
        if not env:
            raise FileNotFoundError(
                f"no MRCLAM data directory: give one (the folder holding MRCLAM_Dataset1/ "
                f"and MRCLAM_Dataset6/) or set {DATA_ENV}"
            )
        path, origin = env, f" (from {DATA_ENV})"
    else:
        origin = ""
    folder = Path(path)
    if not folder.is_dir():
        raise FileNotFoundError(f"no such MRCLAM data directory: {folder}{origin}")
    return folder


def evaluate(
    dataset_dir: str | os.PathLike[str],
    robot: int,
    method: str = DEFAULT_INIT,
    start: float | None = None,
    end: float | None = None,
    estimator: str = "filter",
    particles: int | None = None,
    on_scan: Callable[[dict[str, Any]], object] | None = None,
    association: str = "known",
    online_window: str | None = None,
    landmark_chart: str | None = None,
    auto_visits: int | None = None,
    auto_max_wait: float | None = None,
    auto_stalled_parallax: bool | None = None,
    auto_insignificant_parallax: bool | None = None,
    auto_keep_first_ray: bool | None = None,
    second_order: bool | None = None,
    conversion_depth_linearity: bool | None = None,
) -> MrclamRun:
    """Runs ``method`` (one of :data:`METHODS`) on robot ``robot`` (1–5) of
    the dataset in ``dataset_dir``, optionally on ``[start, end)`` seconds
    since the robot's first command, with ``estimator`` (one of
    :data:`~bearing_slam.vocabulary.ESTIMATORS`; ``particles`` for FastSLAM).
    ``on_scan`` (the filter only): called with each scan's step as the filter
    goes (as in :func:`bearing_slam.run`, e.g. a
    :class:`bearing_slam.rerun.RerunLogger`). ``association``: ``"known"``
    (the barcodes' ids), or ``"nn"``/``"jcbb"``/``"ransac"`` with the barcodes hidden from
    the filter (they then only score it: ``result.association``).
    ``online_window`` (``"keyframes"``, the default, or ``"scans"``) and ``landmark_chart``
    (``"inverse-depth"``, ``"point"``): the online smoother's
    (``estimator="filter+smoother"`` only; None: the defaults).
    ``auto_visits``, ``auto_max_wait``, ``auto_stalled_parallax``,
    ``auto_insignificant_parallax``, ``auto_keep_first_ray``: the ``auto``
    initializer's options, as
    :class:`~bearing_slam.Config`'s fields (method ``"auto"`` only; None: the
    defaults). ``second_order``: the bearing update (None: the default, second
    order; False: the paper's first-order one). ``conversion_depth_linearity``:
    an inverse-depth landmark becomes a point only once the conversion is
    linear too (None: the default, True; False: Civera et al.'s test alone)."""
    t0 = time.perf_counter()
    result, metrics, log = evaluate_mrclam(
        dataset_dir,
        robot,
        method,
        start,
        end,
        estimator=estimator,
        particles=particles,
        on_scan=on_scan,
        association=association,
        online_window=online_window,
        landmark_chart=landmark_chart,
        auto_visits=auto_visits,
        auto_max_wait=auto_max_wait,
        auto_stalled_parallax=auto_stalled_parallax,
        auto_insignificant_parallax=auto_insignificant_parallax,
        auto_keep_first_ray=auto_keep_first_ray,
        second_order=second_order,
        conversion_depth_linearity=conversion_depth_linearity,
    )
    return MrclamRun(result, metrics, log, time.perf_counter() - t0)


def _to_map_frame(
    landmarks: NDArray[np.float64], alignment: Sequence[float]
) -> NDArray[np.float64]:
    """True landmarks ``(id, x, y)`` moved into the filter's frame by the
    inverse of ``alignment`` (the map → truth rigid motion ``(x, y, θ)``)."""
    x, y, theta = alignment
    c, s = math.cos(theta), math.sin(theta)
    dx = landmarks[:, 1] - x
    dy = landmarks[:, 2] - y
    out = landmarks.copy()
    out[:, 1] = c * dx + s * dy
    out[:, 2] = -s * dx + c * dy
    return out


def plot_log(run: MrclamRun) -> SensorLog:
    """The log to plot ``run`` with: the filter's log on Dataset 6; without
    robot ground truth (Dataset 1) a log holding only the true landmarks,
    moved into the filter's frame by the SE(2) alignment (or none when fewer
    than two landmarks were mapped)."""
    if run.metrics["has_ground_truth"]:
        return run.log
    alignment = run.metrics["landmark_alignment"]
    source = str(run.log.info.get("source") or "")
    if alignment is None or not len(run.log.landmarks):
        return SensorLog.from_arrays(info={"source": f"{source} (no landmark alignment)"})
    return SensorLog.from_arrays(
        landmarks=_to_map_frame(run.log.landmarks, alignment),
        info={"source": f"{source} (true landmarks SE(2)-aligned)"},
    )


def evaluate_robots(
    dataset_dir: str | os.PathLike[str],
    robots: Iterable[int] = range(1, 6),
    methods: Iterable[str] = MRCLAM_METHODS,
    progress: Callable[[int, str], object] | None = None,
) -> dict[tuple[int, str], MrclamRun]:
    """Every method on every robot of one dataset, whole runs, keyed by
    ``(robot, method)``; ``progress(robot, method)`` is called after each."""
    runs: dict[tuple[int, str], MrclamRun] = {}
    for robot in robots:
        for method in methods:
            runs[(robot, method)] = evaluate(dataset_dir, robot, method)
            if progress is not None:
                progress(robot, method)
    return runs


if __name__ == "__main__":
    # ``python -m bearing_slam.mrclam [DATA_DIR] [--out DIR]`` is ``bearing-slam mrclam-figures``.
    import sys

    from bearing_slam.cli import main

    sys.exit(main(["mrclam-figures", *sys.argv[1:]]))
