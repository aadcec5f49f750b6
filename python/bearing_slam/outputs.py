"""What the commands write: the ``metrics.json`` records and the files of a run.

* :func:`metrics_record`: the record of a run on a log (``bearing-slam run``,
  ``demo``); :func:`mrclam_record`: the record of a run on a real MRCLAM
  robot (``bearing-slam mrclam``), the run's record plus the real-data scores.
* :func:`write_outputs`: ``metrics.json``, the three PNG plots and
  ``estimate.mcap`` (log + estimate) of one run into a folder.
* :func:`write_mrclam_figures`: the MRCLAM figures of ``docs/results/mrclam``.

Numbers that are not finite are written as ``null`` (:func:`finite_or_none`).

Every file is written so that a run killed at any moment leaves either the old
file or the complete new one, never a part: :func:`atomic_path` gives a
temporary name in the same folder and renames it onto the target once the
file is complete (:func:`write_text_atomic` for text, ``save_figure`` for
PNG; ``write_mcap`` does the same in Rust). The files of one run are written
into a new folder next to the target and swapped in whole
(:func:`publish_folder`), so its ``metrics.json`` and plots always belong to
the same run.
"""

from __future__ import annotations

import contextlib
import ctypes
import ctypes.util
import itertools
import json
import math
import os
import shutil
from collections.abc import Iterable, Iterator, Mapping
from pathlib import Path
from typing import Any

from bearing_slam._native import RunResult, SensorLog, write_mcap
from bearing_slam.mrclam import MrclamRun, plot_log
from bearing_slam.plots.mrclam import ate_figure, comparison_figure
from bearing_slam.plots.run import (
    plot_nees,
    plot_pose_errors,
    plot_trajectory,
    save_figure,
    save_plots,
)
from bearing_slam.vocabulary import MRCLAM_METHODS, init_name

__all__ = [
    "LANDMARK_FRAME_ALIGNED",
    "LANDMARK_FRAME_VICON",
    "RUN_FILES",
    "atomic_path",
    "finite_or_none",
    "metrics_record",
    "mrclam_record",
    "new_folder_beside",
    "publish_folder",
    "write_mrclam_figures",
    "write_outputs",
    "write_text_atomic",
]

#: The files :func:`write_outputs` writes into a run's folder.
RUN_FILES = ("metrics.json", "trajectory.png", "pose_errors.png", "nees.png", "estimate.mcap")

_counter = itertools.count()


def _sibling(path: Path, tag: str) -> Path:
    """A hidden name next to ``path``, unique in this process."""
    return path.with_name(f".{path.name}.{tag}-{os.getpid()}-{next(_counter)}")


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike[str]) -> Iterator[Path]:
    """Yields a temporary path in ``path``'s folder; when the block ends
    without an exception, the file written there is flushed to disk and renamed
    onto ``path`` (atomic on POSIX), else removed. A process killed at any
    moment leaves either the old ``path`` or the complete new one."""
    target = Path(path)
    tmp = _sibling(target, "tmp")
    try:
        yield tmp
        with open(tmp, "rb") as f:
            os.fsync(f.fileno())
        os.replace(tmp, target)
    finally:
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()


def write_text_atomic(path: str | os.PathLike[str], text: str) -> Path:
    """Writes ``text`` to ``path`` through :func:`atomic_path`; returns the path."""
    with atomic_path(path) as tmp:
        tmp.write_text(text)
    return Path(path)


def new_folder_beside(path: str | os.PathLike[str]) -> Path:
    """A new, empty hidden folder next to ``path`` (its parent is created),
    where the files of ``path`` are written before :func:`publish_folder`."""
    target = Path(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    tmp = _sibling(target, "new")
    tmp.mkdir()
    return tmp


_RENAME_EXCHANGE = 2
_AT_FDCWD = -100


def _exchange(a: Path, b: Path) -> bool:
    """Swaps two paths in one step (Linux ``renameat2(RENAME_EXCHANGE)``);
    False where the system cannot."""
    name = ctypes.util.find_library("c")
    try:
        libc = ctypes.CDLL(name, use_errno=True)
        renameat2 = libc.renameat2
    except (OSError, AttributeError, TypeError):
        return False
    renameat2.argtypes = [
        ctypes.c_int,
        ctypes.c_char_p,
        ctypes.c_int,
        ctypes.c_char_p,
        ctypes.c_uint,
    ]
    renameat2.restype = ctypes.c_int
    return bool(
        renameat2(_AT_FDCWD, os.fsencode(a), _AT_FDCWD, os.fsencode(b), _RENAME_EXCHANGE) == 0
    )


def publish_folder(new: Path, target: str | os.PathLike[str], names: Iterable[str]) -> Path:
    """Puts the folder ``new`` (from :func:`new_folder_beside`) in place of
    ``target``. When ``target`` does not exist, or holds nothing but entries
    named in ``names`` (what the command writes), the folders are swapped in
    one step where the system can (Linux), so ``target`` is always either the
    old folder or the new one, whole; the old one is then deleted. When
    ``target`` holds other files too, only the entries of ``new`` are moved in,
    each in one step, and the other files are left alone."""
    out = Path(target)
    if not out.exists():
        os.rename(new, out)
        return out
    ours = set(names)
    if all(p.name in ours for p in out.iterdir()):
        if _exchange(new, out):
            shutil.rmtree(new)
            return out
        old = _sibling(out, "old")
        os.rename(out, old)
        os.rename(new, out)
        shutil.rmtree(old)
        return out
    for entry in sorted(new.iterdir()):
        dest = out / entry.name
        if entry.is_dir() and dest.is_dir():
            if not _exchange(entry, dest):
                old = _sibling(dest, "old")
                os.rename(dest, old)
                os.rename(entry, dest)
                entry = old
            shutil.rmtree(entry)
        else:
            os.replace(entry, dest)
    shutil.rmtree(new)
    return out


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


def finite_or_none(value: Any) -> Any:
    """``value``, or ``None`` when it is a float that is not finite (JSON has no NaN)."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def metrics_record(result: RunResult, log: SensorLog, seconds: float) -> dict[str, Any]:
    """The content of ``metrics.json``: the run's summary (NaN → null) plus
    counts, the log's source and the configuration."""
    summary = result.summary
    record: dict[str, Any] = {}
    if summary is None:
        record.update(
            {
                k: None
                for k in (
                    "ate_rmse_m",
                    "final_position_error_m",
                    "final_heading_error_deg",
                    "mean_nees_pose",
                    "median_nees_pose",
                    "nees_within_95",
                )
            }
        )
        ids, _, _ = result.landmarks()
        record["n_landmarks_initialized"] = len(ids)
        record["landmark_rmse_m"] = None
    else:
        record.update({k: finite_or_none(v) for k, v in summary.items()})
    record["init"] = init_name(result.config.init, result.config.history)
    record["source"] = log.info.get("source")
    record["seed"] = log.info.get("seed")
    record["counts"] = result.counts
    # Data association scores against the log's ids (issue 16); None with known ids.
    record["association"] = result.association
    record["run_seconds"] = seconds
    record["config"] = {k: finite_or_none(v) for k, v in result.config.to_dict().items()}
    record["config"]["per_landmark_priors"] = {
        str(k): v for k, v in result.config.per_landmark_priors.items()
    }
    return record


def mrclam_record(run: MrclamRun) -> dict[str, Any]:
    """The content of ``metrics.json`` of ``bearing-slam mrclam``: the
    :func:`metrics_record` of the run plus the real-data scores (frames: see
    :mod:`bearing_slam.mrclam`)."""
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
            "ate_rmse_m": finite_or_none(m["ate_rmse_m"]),
            "odometry_ate_rmse_m": finite_or_none(m["odometry_ate_rmse_m"]),
            "ate_aligned_rmse_m": finite_or_none(m["ate_aligned_rmse_m"]),
            "mean_nees_pose": finite_or_none(m["mean_nees_pose"]),
            "median_nees_pose": finite_or_none(m["median_nees_pose"]),
            "nees_within_95": finite_or_none(m["nees_within_95"]),
            "landmark_rmse_m": finite_or_none(
                m["landmark_rmse_m"] if truth else m["landmark_rmse_aligned_m"]
            ),
            "landmark_rmse_raw_m": finite_or_none(m["landmark_rmse_m"]),
            "landmark_rmse_aligned_m": finite_or_none(m["landmark_rmse_aligned_m"]),
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
            "n_outside_window": m["n_outside_window"],
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


def write_outputs(
    out_dir: str | os.PathLike[str],
    record: Mapping[str, Any],
    result: RunResult,
    log: SensorLog,
    plot_log: SensorLog | None = None,
    *,
    snapshot_every: float = 0.0,
) -> Path:
    """Writes into ``out_dir``: ``metrics.json`` (``record``), ``trajectory.png``,
    ``pose_errors.png``, ``nees.png`` (drawn with ``plot_log``, by default
    ``log``) and ``estimate.mcap`` (``log`` + the estimate, its snapshots at
    most once per ``snapshot_every`` seconds). Returns the folder.
    The files are written into a new folder next to ``out_dir`` and swapped in
    (:func:`publish_folder`): a run killed at any moment leaves the old
    results or the new ones, not a mix."""
    out = Path(out_dir)
    new = new_folder_beside(out)
    try:
        (new / "metrics.json").write_text(json.dumps(record, indent=2) + "\n")
        save_plots(result, log if plot_log is None else plot_log, new)
        write_mcap(new / "estimate.mcap", log, result, snapshot_every=snapshot_every)
        return publish_folder(new, out, RUN_FILES)
    finally:
        if new.exists():
            shutil.rmtree(new)


def _gtsam_rows(path: Path, key: str) -> dict[tuple[int, str], float | None]:
    if not path.is_file():
        return {}
    data = json.loads(path.read_text())
    return {
        (int(r["robot"]), "gtsam"): r.get(key)
        for r in data.get("results", [])
        if r.get("dataset") == "MRCLAM_Dataset6"
    }


def write_mrclam_figures(
    runs: Mapping[tuple[int, str], MrclamRun], out_dir: str | os.PathLike[str]
) -> list[Path]:
    """The figures of Dataset 6's evaluation (``runs``: every method of
    :data:`~bearing_slam.vocabulary.MRCLAM_METHODS` on each robot, from
    :func:`bearing_slam.mrclam.evaluate_robots`). Writes into ``out_dir`` the MTE
    plots of each robot (``dataset6_robotN_mte_{trajectory,pose_errors,nees}.png``),
    ``dataset6_trajectories.png`` and ``dataset6_ate.png`` (with GTSAM from
    ``out_dir/gtsam.json`` when there); returns the paths."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    written: list[Path] = []
    for robot in sorted({r for r, _ in runs}):
        mte = runs[(robot, "mte")]
        for name, make in (
            ("trajectory", plot_trajectory),
            ("pose_errors", plot_pose_errors),
            ("nees", plot_nees),
        ):
            fig = make(mte.result, plot_log(mte))
            written.append(save_figure(fig, out / f"dataset6_robot{robot}_mte_{name}.png", 80))
    written.append(save_figure(comparison_figure(runs), out / "dataset6_trajectories.png", 90))
    ate: dict[tuple[int, str], float | None] = {
        key: run.metrics["ate_rmse_m"] for key, run in runs.items()
    }
    ate.update(_gtsam_rows(out / "gtsam.json", "ate_rmse_m"))
    methods = [*MRCLAM_METHODS, "gtsam"] if any(m == "gtsam" for _, m in ate) else MRCLAM_METHODS
    written.append(save_figure(ate_figure(ate, methods), out / "dataset6_ate.png", 90))
    return written
