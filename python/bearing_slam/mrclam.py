"""Bearing-only SLAM on the real UTIAS MRCLAM robots (Leung et al., IJRR 2011).

* :func:`evaluate`: one method on one robot of a dataset directory
  (``MRCLAM_Dataset6/`` with Vicon ground truth, ``MRCLAM_Dataset1/``
  without), with the parameters calibrated on Dataset 6
  (``bearing_slam::real_data`` in Rust, GIL released).
* :func:`mrclam_record`: the content of ``metrics.json`` of
  ``bearing-slam mrclam``; :func:`write_outputs` writes it with the plots and
  ``estimate.mcap``.
* :func:`comparison_figure`, :func:`ate_figure`, :func:`make_readme_figures`:
  the figures of the README (``python -m bearing_slam.mrclam DATA_DIR OUT_DIR``).

Frames. On Dataset 6 the filter starts at the Vicon pose at the log start,
so its map is in the Vicon frame: ``landmark_rmse_m`` is the raw RMSE
against ``Landmark_Groundtruth.dat`` (``landmark_rmse_aligned_m`` after the
best SE(2) alignment of the map onto the surveyed landmarks is given too).
Dataset 1 has no robot ground truth: the filter starts at the origin, its
map is in an arbitrary frame, and ``landmark_rmse_m`` is the SE(2)-aligned
RMSE (``landmark_rmse_raw_m`` is null). ``landmark_frame`` says which.
"""

from __future__ import annotations

import json
import math
import os
import sys
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from bearing_slam._native import RunResult, SensorLog, evaluate_mrclam, write_mcap
from bearing_slam.cli import metrics_record

__all__ = [
    "LANDMARK_FRAME_ALIGNED",
    "LANDMARK_FRAME_VICON",
    "METHODS",
    "METHOD_LABELS",
    "MrclamRun",
    "ate_figure",
    "comparison_figure",
    "default_data_dir",
    "evaluate",
    "make_readme_figures",
    "mrclam_record",
    "plot_log",
    "write_outputs",
]

#: The methods of :func:`evaluate`, in table order.
METHODS = ("dead-reckoning", "mte", "mte-clone", "pi-sr", "range-bearing")

#: Labels of the methods in tables and figures.
METHOD_LABELS = {
    "dead-reckoning": "dead reckoning",
    "mte": "MTE",
    "mte-clone": "MTE-clone",
    "pi-sr": "PI-SR (0.5, 0.25)",
    "range-bearing": "range-bearing EKF",
    "gtsam": "GTSAM batch",
}

#: ``landmark_frame`` with robot ground truth (Dataset 6).
LANDMARK_FRAME_VICON = (
    "vicon: the filter starts at the Vicon pose, landmark_rmse_m is raw "
    "(no alignment); landmark_rmse_aligned_m after the best SE(2) alignment"
)
#: ``landmark_frame`` without robot ground truth (Dataset 1).
LANDMARK_FRAME_ALIGNED = (
    "se2-aligned: no robot ground truth, the filter starts at the origin; "
    "landmark_rmse_m is after the best SE(2) alignment of the map onto "
    "Landmark_Groundtruth.dat"
)


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


def default_data_dir() -> Path:
    """``$BEARING_SLAM_DATA``, or ``../shared/datasets/mrclam`` next to the
    repository (the directory holding ``MRCLAM_Dataset1/`` and ``MRCLAM_Dataset6/``)."""
    env = os.environ.get("BEARING_SLAM_DATA")
    if env:
        return Path(env)
    return Path(__file__).resolve().parents[2].parent / "shared" / "datasets" / "mrclam"


def evaluate(
    dataset_dir: str | os.PathLike[str],
    robot: int,
    method: str = "mte",
    start: float | None = None,
    end: float | None = None,
) -> MrclamRun:
    """Runs ``method`` (one of :data:`METHODS`) on robot ``robot`` (1–5) of
    the dataset in ``dataset_dir``, optionally on ``[start, end)`` seconds
    since the robot's first command."""
    t0 = time.perf_counter()
    result, metrics, log = evaluate_mrclam(dataset_dir, robot, method, start, end)
    return MrclamRun(result, metrics, log, time.perf_counter() - t0)


def _finite(value: Any) -> Any:
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def mrclam_record(run: MrclamRun) -> dict[str, Any]:
    """The content of ``metrics.json``: the ``run`` record of
    :func:`bearing_slam.cli.metrics_record` plus the real-data scores (see the
    module documentation for the frames)."""
    m = run.metrics
    record = metrics_record(run.result, run.log, run.seconds)
    truth = bool(m["has_ground_truth"])
    report = m["report"]
    record.update(
        {
            "dataset": str(m["source"]).rsplit(" robot ", 1)[0],
            "robot": m["robot"],
            "method": m["method"],
            "window_s": [m["start"], m["end"]],
            "has_ground_truth": truth,
            "ate_rmse_m": _finite(m["ate_rmse_m"]),
            "odometry_ate_rmse_m": _finite(m["odometry_ate_rmse_m"]),
            "ate_aligned_rmse_m": _finite(m["ate_aligned_rmse_m"]),
            "mean_nees_pose": _finite(m["mean_nees_pose"]),
            "nees_within_95": _finite(m["nees_within_95"]),
            "landmark_rmse_m": _finite(
                m["landmark_rmse_m"] if truth else m["landmark_rmse_aligned_m"]
            ),
            "landmark_rmse_raw_m": _finite(m["landmark_rmse_m"]),
            "landmark_rmse_aligned_m": _finite(m["landmark_rmse_aligned_m"]),
            "landmark_frame": LANDMARK_FRAME_VICON if truth else LANDMARK_FRAME_ALIGNED,
            "n_landmarks_mapped": m["n_landmarks_mapped"],
            "n_landmarks_truth": m["n_landmarks_truth"],
            "n_init_by_method": dict(
                zip(
                    ("triangulated", "far", "pi_sr", "range_bearing"),
                    m["n_init_by_method"],
                    strict=True,
                )
            ),
            "n_measurements": m["n_measurements"],
            "n_measurements_used": m["n_measurements_used"],
            "n_gated": m["n_gated"],
            "n_not_used_for_update": m["n_not_used_for_update"],
            "n_dropped": m["n_dropped_loader"],
            "n_dropped_by_reason": {
                "other_robot": report["n_dropped_robot"],
                "unknown_barcode": report["n_dropped_unknown_barcode"],
                "outside_log": report["n_dropped_outside"],
                "duplicate": report["n_dropped_duplicate"],
            },
            "filter_seconds": m["run_time_s"],
            "parameters": m["parameters"],
            "loader_report": report,
        }
    )
    if not truth:
        for key in ("final_position_error_m", "final_heading_error_deg"):
            record[key] = None
    return record


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


def write_outputs(run: MrclamRun, out_dir: str | os.PathLike[str]) -> dict[str, Any]:
    """Writes ``metrics.json`` (:func:`mrclam_record`), ``trajectory.png``,
    ``pose_errors.png``, ``nees.png`` and ``estimate.mcap`` (the filter's log
    + estimate) into ``out_dir``; returns the record."""
    from bearing_slam.plots import save_plots

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    record = mrclam_record(run)
    (out / "metrics.json").write_text(json.dumps(record, indent=2) + "\n")
    save_plots(run.result, plot_log(run), out)
    write_mcap(out / "estimate.mcap", run.log, run.result)
    return record


# --------------------------------------------------------------------- figures

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
    import matplotlib.pyplot as plt

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
                label=METHOD_LABELS[method],
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
    import matplotlib.pyplot as plt

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
        ax.bar(xs, ys, width * 0.92, color=_COLORS[method], label=METHOD_LABELS[method])
    ax.set_xticks(range(len(robots)), [f"robot {r}" for r in robots])
    ax.set_ylabel(ylabel)
    ax.grid(True, axis="y", alpha=0.3)
    ax.legend(fontsize=8, ncol=3, loc="upper right")
    ax.set_title(title)
    return fig


def _gtsam_rows(path: Path, key: str) -> dict[tuple[int, str], float | None]:
    if not path.is_file():
        return {}
    data = json.loads(path.read_text())
    return {
        (int(r["robot"]), "gtsam"): r.get(key)
        for r in data.get("results", [])
        if r.get("dataset") == "MRCLAM_Dataset6"
    }


def make_readme_figures(data_dir: Path, out_dir: Path, quiet: bool = False) -> list[Path]:
    """Every method on the five robots of Dataset 6; writes into ``out_dir``
    the MTE plots of each robot (``dataset6_robotN_mte_{trajectory,
    pose_errors,nees}.png``), ``dataset6_trajectories.png`` and
    ``dataset6_ate.png`` (with GTSAM from ``out_dir/gtsam.json`` when there)."""
    import matplotlib.pyplot as plt
    from tqdm import tqdm

    from bearing_slam.plots import plot_nees, plot_pose_errors, plot_trajectory

    out_dir.mkdir(parents=True, exist_ok=True)
    d6 = data_dir / "MRCLAM_Dataset6"
    runs: dict[tuple[int, str], MrclamRun] = {}
    written: list[Path] = []
    with tqdm(total=5 * len(METHODS), desc="Dataset 6", disable=quiet) as bar:
        for robot in range(1, 6):
            for method in METHODS:
                bar.set_postfix_str(f"robot {robot} {method}")
                runs[(robot, method)] = evaluate(d6, robot, method)
                bar.update()
            mte = runs[(robot, "mte")]
            for name, make in (
                ("trajectory", plot_trajectory),
                ("pose_errors", plot_pose_errors),
                ("nees", plot_nees),
            ):
                fig = make(mte.result, plot_log(mte))
                path = out_dir / f"dataset6_robot{robot}_mte_{name}.png"
                fig.savefig(path, dpi=80)
                plt.close(fig)
                written.append(path)
    fig = comparison_figure(runs)
    path = out_dir / "dataset6_trajectories.png"
    fig.savefig(path, dpi=90)
    plt.close(fig)
    written.append(path)
    ate: dict[tuple[int, str], float | None] = {
        key: run.metrics["ate_rmse_m"] for key, run in runs.items()
    }
    ate.update(_gtsam_rows(out_dir / "gtsam.json", "ate_rmse_m"))
    methods = [*METHODS, "gtsam"] if any(m == "gtsam" for _, m in ate) else list(METHODS)
    fig = ate_figure(ate, methods)
    path = out_dir / "dataset6_ate.png"
    fig.savefig(path, dpi=90)
    plt.close(fig)
    written.append(path)
    summary = {
        f"robot{r}_{m}": {
            "ate_rmse_m": run.metrics["ate_rmse_m"],
            "landmark_rmse_m": run.metrics["landmark_rmse_m"],
            "n_landmarks_mapped": run.metrics["n_landmarks_mapped"],
        }
        for (r, m), run in sorted(runs.items())
    }
    if not quiet:
        print(json.dumps(summary, indent=1))
    return written


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m bearing_slam.mrclam [DATA_DIR [OUT_DIR]]``: the README figures."""
    args = list(sys.argv[1:] if argv is None else argv)
    data = Path(args[0]) if args else default_data_dir()
    out = Path(args[1]) if len(args) > 1 else Path("docs/results/mrclam")
    for path in make_readme_figures(data, out):
        print(f"wrote {path} ({path.stat().st_size // 1024} KB)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
