"""TUM trajectories (``bs.write_tum``, ``--tum``) scored by evo agree with our ATE."""

from __future__ import annotations

import json
import math
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import bearing_slam as bs
from bearing_slam.tum import truth_path, tum_lines
from conftest import cli

ROOT = Path(__file__).resolve().parents[2]


def evo_ape_rmse(truth: Path, estimate: Path, *options: str) -> float:
    """``evo_ape tum TRUTH ESTIMATE`` (the command line a user types), its RMSE."""
    exe = shutil.which("evo_ape") or str(Path(sys.executable).parent / "evo_ape")
    r = subprocess.run(
        [exe, "tum", str(truth), str(estimate), *options],
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )
    assert r.returncode == 0, r.stderr + r.stdout
    for line in r.stdout.splitlines():
        words = line.split()
        if words[:1] == ["rmse"]:
            return float(words[1])
    raise AssertionError(f"no rmse in evo_ape's output:\n{r.stdout}")


def test_tum_lines_planar_quaternion() -> None:
    times = np.array([0.0, 1.5])
    poses = np.array([[1.0, 2.0, 0.0], [3.0, -4.0, math.pi / 2]])
    first, second = (line.split() for line in tum_lines(times, poses))
    assert [float(v) for v in first] == [0.0, 1.0, 2.0, 0.0, 0.0, 0.0, 0.0, 1.0]
    values = [float(v) for v in second]
    assert values[:4] == [1.5, 3.0, -4.0, 0.0]
    assert values[4:6] == [0.0, 0.0]
    assert values[6] == pytest.approx(math.sqrt(0.5), abs=1e-15)
    assert values[7] == pytest.approx(math.sqrt(0.5), abs=1e-15)
    with pytest.raises(ValueError, match=r"\(n, 3\)"):
        tum_lines(times, poses[:, :2])


def test_truth_path() -> None:
    assert truth_path("out/run.tum") == Path("out/run.truth.tum")
    assert truth_path("est.txt") == Path("est.truth.txt")
    assert truth_path("traj") == Path("traj.truth")


@pytest.mark.slow
def test_evo_ape_equals_ate_rmse(
    tmp_path: Path, fig4_log: bs.SensorLog, fig4_result: bs.RunResult
) -> None:
    estimate, truth = bs.write_tum(tmp_path / "run.tum", fig4_result)
    assert truth == tmp_path / "run.truth.tum"
    summary = fig4_result.summary
    assert summary is not None
    n_truth = int(np.isfinite(fig4_result.truth).all(axis=1).sum())
    assert len(truth.read_text().splitlines()) == n_truth + 1
    assert evo_ape_rmse(truth, estimate) == pytest.approx(summary["ate_rmse_m"], abs=1e-6)


@pytest.mark.slow
def test_evo_python_api_equals_ate_rmse(tmp_path: Path, fig4_result: bs.RunResult) -> None:
    from evo.core import metrics, sync
    from evo.tools import file_interface

    estimate, truth = bs.write_tum(tmp_path / "est.txt", fig4_result, tmp_path / "gt.txt")
    assert truth == tmp_path / "gt.txt"
    ref = file_interface.read_tum_trajectory_file(str(truth))
    est = file_interface.read_tum_trajectory_file(str(estimate))
    ref, est = sync.associate_trajectories(ref, est)
    ape = metrics.APE(metrics.PoseRelation.translation_part)
    ape.process_data((ref, est))
    summary = fig4_result.summary
    assert summary is not None
    rmse = ape.get_statistic(metrics.StatisticsType.rmse)
    assert rmse == pytest.approx(summary["ate_rmse_m"], abs=1e-6)
    # The unaligned ATE is not the SE(2)-aligned one: the test would see a wrong convention.
    assert abs(summary["ate_rmse_m"] - summary["ate_aligned_rmse_m"]) > 1e-4


@pytest.mark.slow
def test_cli_run_tum(tmp_path: Path) -> None:
    log = tmp_path / "fig4.mcap"
    r = cli("simulate", "paper_fig4", "--seed", "4", "--out", log)
    assert r.returncode == 0, r.stderr
    tum = tmp_path / "tum" / "run.tum"
    r = cli("run", log, "--out", tmp_path / "run", "--quiet", "--tum", tum)
    assert r.returncode == 0, r.stderr
    assert f"wrote {tum}" in r.stdout
    metrics = json.loads((tmp_path / "run" / "metrics.json").read_text())
    rmse = evo_ape_rmse(tmp_path / "tum" / "run.truth.tum", tum)
    assert rmse == pytest.approx(metrics["ate_rmse_m"], abs=1e-6)


def test_write_tum_is_atomic(
    tmp_path: Path, fig4_result: bs.RunResult, monkeypatch: pytest.MonkeyPatch
) -> None:
    # A write torn half-way (a full disk, a kill) leaves the old files whole
    # and no temporary file beside them; a good write then replaces both.
    estimate = tmp_path / "run.tum"
    truth = truth_path(estimate)
    estimate.write_text("old estimate\n")
    truth.write_text("old truth\n")
    write_text = Path.write_text

    def torn(self: Path, data: str, *args: object, **kwargs: object) -> int:
        write_text(self, data[: len(data) // 2])
        raise OSError("no space left on device")

    monkeypatch.setattr(Path, "write_text", torn)
    with pytest.raises(OSError, match="no space"):
        bs.write_tum(estimate, fig4_result)
    monkeypatch.undo()
    assert estimate.read_text() == "old estimate\n"
    assert truth.read_text() == "old truth\n"
    assert sorted(tmp_path.iterdir()) == sorted([estimate, truth])
    bs.write_tum(estimate, fig4_result)
    assert len(estimate.read_text().splitlines()) == len(fig4_result.time) + 1
    assert truth.read_text().startswith("# timestamp")
    assert sorted(tmp_path.iterdir()) == sorted([estimate, truth])


def test_write_tum_without_truth(tmp_path: Path, fig4_log: bs.SensorLog) -> None:
    bare = fig4_log.head(20.0)
    log = bs.SensorLog.from_arrays(
        wheels=bare.wheels,
        bearings=bare.bearings,
        info={"wheel_base_m": fig4_log.info["wheel_base_m"]},
    )
    result = bs.run(log, bs.Config.for_log(log))
    estimate, truth = bs.write_tum(tmp_path / "run.tum", result)
    assert truth is None
    assert not truth_path(estimate).exists()
    assert len(estimate.read_text().splitlines()) == len(result.time) + 1


@pytest.mark.slow
def test_evo_agrees_on_mrclam(tmp_path: Path) -> None:
    # Real data (as tests/python/test_mrclam.py finds it): the Vicon truth at
    # 10 Hz and MRCLAM's own clock, a 150 s window of robot 3.
    from bearing_slam import mrclam

    data = Path(
        os.environ.get("BEARING_SLAM_DATA") or ROOT.parent / "shared" / "datasets" / "mrclam"
    )
    run = mrclam.evaluate(data / "MRCLAM_Dataset6", 3, "mte", start=100.0, end=250.0)
    estimate, truth = bs.write_tum(tmp_path / "r3.tum", run.result)
    assert truth is not None
    rmse = evo_ape_rmse(truth, estimate)
    assert rmse == pytest.approx(run.metrics["ate_rmse_m"], abs=1e-6)
