"""6-DOF monocular SLAM on image sequences (issue 17; Munguía & Grau §2, (25)–(30)).

The whole loop runs in Rust (``bearing-slam-vision`` over the core's ``MonoSlam``):
FAST features where the map is thin, active search by normalized cross-correlation
inside the ellipse of ``S_i`` (30), the EKF. Python only drives it:

>>> import bearing_slam as bs
>>> bs.mono.render("/tmp/room", {"frames": 60})  # doctest: +SKIP
>>> result = bs.mono.run("/tmp/room", config={"filter": "undelayed"})  # doctest: +SKIP
>>> result.metrics["ate_sim3"]["rmse_m"]  # doctest: +SKIP

Frames directories have the KITTI clip layout: ``image_l/NNNNNN.png``, ``calib.txt``
(``P0`` gives fx, fy, cx, cy), ``poses.txt`` (3×4 camera-to-world per frame), optional
``times.txt`` (else 10 Hz) and ``known_points.txt`` (the metric reference). The filter
starts at frame 1 from the first two ground-truth poses (pose and velocity: the metric
scale; with ``metric_reference`` the known points hold it too), so the scores cover
frames 1 … N−1:
``ate_sim3`` after a Sim(3) (Umeyama) alignment, ``ate_metric`` with no alignment.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from bearing_slam import _native

__all__ = ["MonoResult", "motion_noise", "render", "run", "write_outputs"]

_PathLike = str | os.PathLike[str]


@dataclass(frozen=True)
class MonoResult:
    """A monocular run.

    ``estimate`` and ``truth`` are ``(n, 7)``: position x, y, z and the camera-to-world
    quaternion w, x, y, z per frame run. ``frames`` is ``(n, 9)``: frame index, seconds
    decoding, in the front end, in the filter, regions searched, found, missed, added,
    patches refreshed. ``searches`` is ``(m, 11)``: frame, feature id, predicted u, v,
    ``S`` entries s_uu, s_uv, s_vv, status (0 found, 1 missed, 2 out of view), matched u,
    v, NCC score. ``added`` is ``(k, 3)``: frame, u, v. ``landmarks`` is ``(l, 13)``: id,
    x, y, z and the 3×3 covariance row-major, at the end of the run.
    """

    estimate: NDArray[np.float64]
    truth: NDArray[np.float64]
    frames: NDArray[np.float64]
    searches: NDArray[np.float64]
    added: NDArray[np.float64]
    landmarks: NDArray[np.float64]
    metrics: dict[str, Any]
    config: dict[str, Any]
    images: list[str]
    width: int
    height: int


def run(
    frames_dir: _PathLike,
    calib: _PathLike | None = None,
    config: dict[str, Any] | None = None,
    mcap: _PathLike | None = None,
) -> MonoResult:
    """Runs monocular SLAM on ``frames_dir`` (calibration from ``calib`` or
    ``frames_dir/calib.txt``); with ``mcap``, also writes the run there for Foxglove:
    ``/camera/image`` (``foxglove.CompressedImage``, the frames as read),
    ``/camera/annotations`` (``foxglove.ImageAnnotations``: the search ellipses, green
    found, red missed, and the matches, as the paper's Fig. 12), ``/tf`` and
    ``/camera/path/estimate|truth`` (the camera's path so far, estimated and true,
    every 10 frames and at the last, thinned past 1000 poses), ``/map``
    (``foxglove.SceneUpdate``: each landmark's 2σ ellipsoid after every frame, blue as a
    point, orange in inverse depth). A failed write leaves no file there.

    ``config`` keys (all optional): ``filter`` (``"delayed"``, ``"delayed_clone"``,
    ``"undelayed"``, ``"oracle"`` — ground truth, rendered sequences only), ``pixel_sigma``,
    ``linear_accel_sigma``, ``angular_accel_sigma``, ``velocity_frame`` (``"world"``, the
    paper's (25), or ``"body"``: constant velocity along the camera, for a camera on a
    car), ``forget_out_of_view`` (features out of view count as misses and leave the map:
    a camera that does not come back), ``metric_reference`` (the directory's
    ``known_points.txt`` enter the map as exact landmarks at the start: the paper's metric
    reference), ``velocity_sigma``,
    ``angular_velocity_sigma``, ``rho_ini``, ``sigma_rho``, ``baseline_min_m``,
    ``alpha_min_deg``, ``candidate_depth_m``, ``candidate_sigma_px``, ``max_frames``,
    ``one_point_ransac``, ``ransac_seed``, ``epipolar_search``,
    ``conversion_depth_linearity`` (an inverse-depth landmark becomes a point only
    once the conversion is linear too: the default, as in every filter; False:
    Civera et al.'s test alone), ``speed_readings`` (a speed reading at every frame, as a
    car's wheel odometry gives: ``"none"``, ``"ground_truth"`` — the ground truth's step
    length over the frame interval, the information the OpenCV yardstick is handed — or
    ``"file"``: the directory's ``speeds.txt``, one speed per frame in m/s, or
    ``time speed`` lines at the sensor's own rate, resampled to the frame intervals),
    ``speed_sigma_mps`` (their σ; default ``linear_accel_sigma · Δt / 2``) and
    ``front_end`` (``search``:
    ``confidence``, ``min_ncc``, ``refresh_ncc``, ``refresh_shift_px``,
    ``max_half_axis_px``, ``patch_half``, ``subpixel``, ``warp``,
    ``warp_window_half``; ``detector``:
    ``fast_threshold``, ``min_distance_px``, ``grid_cols``, ``grid_rows``;
    ``target_features``, ``max_new_per_frame``, ``record_maps``: keep the map after every
    frame, which ``mcap`` turns on). Unknown keys are an error.
    """
    raw = _native.mono_run(
        os.fspath(frames_dir),
        None if calib is None else os.fspath(calib),
        None if config is None else json.dumps(config),
        None if mcap is None else os.fspath(mcap),
    )
    return MonoResult(
        estimate=raw["estimate"],
        truth=raw["truth"],
        frames=raw["frames"],
        searches=raw["searches"],
        added=raw["added"],
        landmarks=raw["landmarks"],
        metrics=json.loads(raw["metrics_json"]),
        config=json.loads(raw["config_json"]),
        images=list(raw["images"]),
        width=int(raw["width"]),
        height=int(raw["height"]),
    )


def motion_noise(
    frames_dir: _PathLike, velocity_frame: str = "world", calib: _PathLike | None = None
) -> dict[str, Any]:
    """The constant-velocity model's acceleration noise fitted to the ground-truth poses of
    ``frames_dir`` (the tuning rule: noise from ground truth on a calibration sequence).

    Returns ``{"linear_accel_sigma", "angular_accel_sigma", "velocity_frame"}``: the root
    mean square, per axis, of the accelerations the path needs between consecutive
    frames, with the velocity in ``velocity_frame`` (``"world"`` or ``"body"``), ready to
    merge into the ``config`` of :func:`run` on another sequence.
    """
    sigma_a, sigma_alpha = _native.mono_motion_noise(
        os.fspath(frames_dir),
        json.dumps(velocity_frame),
        None if calib is None else os.fspath(calib),
    )
    return {
        "linear_accel_sigma": sigma_a,
        "angular_accel_sigma": sigma_alpha,
        "velocity_frame": velocity_frame,
    }


def render(out_dir: _PathLike, config: dict[str, Any] | None = None) -> int:
    """Renders the synthetic room sequence (exact ground truth) into ``out_dir`` in the
    KITTI clip layout; returns the number of frames. ``config`` keys: ``width``,
    ``height`` (default 424×240, the paper's camera), ``hfov_deg``, ``frames``, ``fps``,
    ``seed``, ``path`` (``forward_speed``, ``sway_m``, ``yaw_rad``), ``reference_sheet``
    (the paper's metric reference hung in the room, its corners written to
    ``known_points.txt``)."""
    return _native.mono_render(os.fspath(out_dir), None if config is None else json.dumps(config))


def write_outputs(result: MonoResult, out: _PathLike, figure_frames: int = 3) -> dict[str, Any]:
    """Writes ``metrics.json``, ``trajectory.png`` (X-Y and X-Z views, as the paper's
    Fig. 13) and ``frames.png`` (``figure_frames`` frames with the predicted ellipses and
    the matches, as Fig. 12) into ``out``; returns the metrics."""
    from bearing_slam.plots.mono import plot_search_frames, plot_trajectory_views

    out_dir = Path(out)
    out_dir.mkdir(parents=True, exist_ok=True)
    metrics = dict(result.metrics)
    metrics["config"] = result.config
    (out_dir / "metrics.json").write_text(json.dumps(metrics, indent=2) + "\n")
    plot_trajectory_views(result, out_dir / "trajectory.png")
    plot_search_frames(result, out_dir / "frames.png", count=figure_frames)
    return metrics
