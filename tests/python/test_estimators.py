"""The estimators' faces (issues 14, 15): ``Config(estimator=, particles=)``,
``bs.smooth``, ``bs.run`` with FastSLAM, the CLI's ``--estimator``."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import bearing_slam as bs
from bearing_slam.vocabulary import ESTIMATORS


@pytest.fixture(scope="module")
def short_log() -> bs.SensorLog:
    return bs.simulate("paper_fig4", seed=3).head(25.0)


def test_the_estimators_are_named_in_rust() -> None:
    assert ESTIMATORS == (
        "filter",
        "smoother",
        "filter+smoother",
        "fastslam1",
        "fastslam2",
        "gaussian-sum",
    )
    assert bs.Config().estimator == "filter"


def test_smooth_returns_a_run_result_with_marginals(short_log: bs.SensorLog) -> None:
    config = bs.Config.for_log(short_log)
    filtered = bs.run(short_log, config)
    smoothed = bs.smooth(short_log, config)
    assert smoothed.config.estimator == "smoother"
    assert smoothed.time.shape == filtered.time.shape
    assert smoothed.summary is not None
    assert np.isfinite(smoothed.summary["mean_nees_pose"])
    # Marginal covariances of the smoother, not the filter's.
    cov = smoothed.covariance[1:]
    assert np.all(np.linalg.eigvalsh(cov) > 0)
    assert not np.allclose(cov, filtered.covariance[1:])
    # The one NEES rule (metrics::pose_nees_series): scoring starts at the
    # first covariance above the floor, and every sample after it is scored.
    nees = smoothed.nees
    first = int(np.argmax(np.isfinite(nees)))
    assert first < 10, f"scoring starts only at sample {first}"
    assert np.isfinite(nees[first:]).all()
    ids, _, lm_cov = smoothed.landmarks()
    assert len(ids) == smoothed.summary["n_landmarks_initialized"] > 0
    assert np.all(np.linalg.eigvalsh(lm_cov) > 0)
    online = bs.smooth(short_log, config.replace(estimator="filter+smoother"))
    assert online.config.estimator == "filter+smoother"
    assert online.summary is not None
    assert np.isfinite(online.summary["ate_rmse_m"])
    with pytest.raises(ValueError, match="smooth\\(\\) runs a smoother"):
        bs.smooth(short_log, config.replace(estimator="fastslam2"))


def test_run_with_fastslam(short_log: bs.SensorLog) -> None:
    config = bs.Config.for_log(short_log, estimator="fastslam2", particles=10)
    result = bs.run(short_log, config)
    assert result.config.particles == 10
    assert result.summary is not None
    assert result.summary["finite"]
    assert result.summary["n_landmarks_initialized"] >= 4
    assert result.counts["measurements_used"] > 100


def test_run_with_the_heading_gaussian_sum(short_log: bs.SensorLog) -> None:
    config = bs.Config.for_log(
        short_log, estimator="gaussian-sum", gaussian_sum_split_deg=0.5, gaussian_sum_components=3
    )
    result = bs.run(short_log, config)
    assert result.config.gaussian_sum_components == 3
    assert result.summary is not None
    assert result.summary["finite"]
    assert np.all(np.linalg.eigvalsh(result.covariance) >= 0)
    one = bs.run(short_log, config.replace(gaussian_sum_components=1))
    filtered = bs.run(short_log, bs.Config.for_log(short_log))
    np.testing.assert_array_equal(one.estimate, filtered.estimate)
    with pytest.raises(bs.InvalidParameterError, match="max_components"):
        bs.Config(estimator="gaussian-sum", gaussian_sum_components=0)
    with pytest.raises(bs.InvalidParameterError, match="gaussian_sum_split_deg is not used here"):
        bs.Config(gaussian_sum_split_deg=2.0)
    with pytest.raises(ValueError, match="SlamFilter steps the EKF"):
        bs.SlamFilter(config)


def test_bad_estimator_parameters_are_refused() -> None:
    with pytest.raises(ValueError, match='unknown estimator "ekf2": expected one of filter'):
        bs.Config(estimator="ekf2")
    with pytest.raises(bs.InvalidParameterError, match="particles"):
        bs.Config(estimator="fastslam2", particles=0)
    # A mistyped count is refused, not an abort on its first allocation.
    with pytest.raises(bs.InvalidParameterError, match="more particles than a run can hold"):
        bs.Config(estimator="fastslam1", particles=10**12)
    with pytest.raises(bs.InvalidParameterError, match="particles is not used here"):
        bs.Config(particles=10)


def cli(*args: str | Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "bearing_slam", *map(str, args)],
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
    )


def test_cli_estimators_write_metrics(tmp_path: Path) -> None:
    log = tmp_path / "fig4.mcap"
    r = cli("simulate", "paper_fig4", "--seed", "3", "--duration", "25", "--out", log)
    assert r.returncode == 0, r.stderr
    for estimator, extra in [("smoother", []), ("fastslam2", ["--particles", "10"])]:
        out = tmp_path / estimator
        r = cli("run", log, "--estimator", estimator, *extra, "--out", out, "--quiet")
        assert r.returncode == 0, r.stderr
        m = json.loads((out / "metrics.json").read_text())
        assert m["config"]["estimator"] == estimator
        assert m["ate_rmse_m"] is not None
        assert m["mean_nees_pose"] is not None
        assert (out / "estimate.mcap").stat().st_size > 0
    r = cli("run", log, "--estimator", "filter", "--particles", "5", "--out", tmp_path / "x")
    assert r.returncode != 0
    assert "--particles applies to --estimator fastslam1 and fastslam2 only" in r.stderr
    r = cli("run", log, "--estimator", "ekf2", "--out", tmp_path / "y")
    assert r.returncode != 0
    assert "invalid choice: 'ekf2'" in r.stderr


def test_the_online_window_and_chart_reach_the_smoother(short_log: bs.SensorLog) -> None:
    # One definition each, in Rust: the names and the defaults.
    assert bs.vocabulary.ONLINE_WINDOWS == ("scans", "keyframes")
    assert bs.vocabulary.LANDMARK_CHARTS == ("point", "inverse-depth")
    assert (bs.Config().online_window, bs.Config().landmark_chart) == ("keyframes", "inverse-depth")
    base = bs.Config.for_log(short_log, estimator="filter+smoother")
    runs = {
        (window, chart): bs.smooth(
            short_log, base.replace(online_window=window, landmark_chart=chart)
        )
        for window in ("scans", "keyframes")
        for chart in ("point", "inverse-depth")
    }
    for (window, chart), result in runs.items():
        assert (result.config.online_window, result.config.landmark_chart) == (window, chart)
        assert result.summary is not None
        assert result.summary["finite"]
    # The options change the estimate (each reaches the Rust smoother).
    track = {k: r.estimate for k, r in runs.items()}
    assert not np.allclose(track["scans", "point"], track["keyframes", "point"])
    assert not np.allclose(track["scans", "point"], track["scans", "inverse-depth"])
    with pytest.raises(ValueError, match='unknown online window "frames"'):
        bs.Config(estimator="filter+smoother", online_window="frames")
    with pytest.raises(bs.InvalidParameterError, match="online_window is not used here"):
        bs.Config(online_window="scans")


def test_cli_online_window_options(tmp_path: Path) -> None:
    log = tmp_path / "fig4.mcap"
    r = cli("simulate", "paper_fig4", "--seed", "3", "--duration", "25", "--out", log)
    assert r.returncode == 0, r.stderr
    out = tmp_path / "online"
    r = cli(
        "run",
        log,
        "--estimator",
        "filter+smoother",
        "--online-window",
        "keyframes",
        "--landmark-chart",
        "point",
        "--out",
        out,
        "--quiet",
    )
    assert r.returncode == 0, r.stderr
    config = json.loads((out / "metrics.json").read_text())["config"]
    assert (config["online_window"], config["landmark_chart"]) == ("keyframes", "point")
    r = cli("run", log, "--online-window", "keyframes", "--out", tmp_path / "x")
    assert r.returncode != 0
    assert "--online-window and --landmark-chart apply to --estimator filter+smoother" in r.stderr
