"""FastSLAM's particle clouds (issue 15): recorded in the run's trace, drawn
in ``particles.png``, carried through MCAP; ``experiment particles`` refuses
bad options."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import bearing_slam as bs
from bearing_slam.plots.particles import has_particle_clouds, plot_particle_cloud
from bearing_slam.plots.run import save_plots


@pytest.fixture(scope="module")
def fastslam_run() -> tuple[bs.SensorLog, bs.RunResult]:
    log = bs.simulate("paper_fig4", seed=3).head(10.0)
    config = bs.Config.for_log(log, estimator="fastslam2", particles=10)
    return log, bs.run(log, config)


def test_the_clouds_are_recorded(fastslam_run: tuple[bs.SensorLog, bs.RunResult]) -> None:
    _, result = fastslam_run
    clouds = result.trace.particle_clouds()
    assert 2 <= len(clouds) <= 101
    times = [c["time"] for c in clouds]
    assert times == sorted(times)
    assert times[-1] == result.trace.times[-1]
    for c in clouds:
        assert c["poses"].shape == (10, 3)
        assert c["weights"].shape == (10,)
        assert abs(float(c["weights"].sum()) - 1.0) < 1e-9
        assert 0 <= c["best"] < 10
    assert has_particle_clouds(result)


def test_the_ekf_records_none(fastslam_run: tuple[bs.SensorLog, bs.RunResult]) -> None:
    log, _ = fastslam_run
    ekf = bs.run(log, bs.Config.for_log(log))
    assert ekf.trace.particle_clouds() == []
    assert not has_particle_clouds(ekf)
    with pytest.raises(ValueError, match="no particle cloud"):
        plot_particle_cloud(ekf, log)


def test_plots_and_mcap_carry_the_clouds(
    fastslam_run: tuple[bs.SensorLog, bs.RunResult], tmp_path: Path
) -> None:
    log, result = fastslam_run
    names = [p.name for p in save_plots(result, log, tmp_path)]
    assert "particles.png" in names
    assert (tmp_path / "particles.png").stat().st_size > 10_000
    path = tmp_path / "run.mcap"
    bs.write_mcap(path, log, result)
    _, trace, _ = bs.read_mcap(path)
    assert trace is not None
    back = trace.particle_clouds()
    ours = result.trace.particle_clouds()
    assert len(back) == len(ours)
    for a, b in zip(back, ours, strict=True):
        assert a["time"] == b["time"]
        assert a["best"] == b["best"]
        np.testing.assert_array_equal(a["poses"], b["poses"])
        np.testing.assert_array_equal(a["weights"], b["weights"])


def test_experiment_particle_options_are_checked(tmp_path: Path) -> None:
    def cli(*args: str) -> subprocess.CompletedProcess[str]:
        return subprocess.run(
            [sys.executable, "-m", "bearing_slam", *args],
            capture_output=True,
            text=True,
            timeout=120,
            check=False,
        )

    r = cli("experiment", "fig5", "--estimator", "fastslam2", "--out", str(tmp_path))
    assert r.returncode != 0
    assert "apply to experiment particles only" in r.stderr
    r = cli("experiment", "particles", "--estimator", "filter", "--out", str(tmp_path))
    assert r.returncode != 0
    assert "invalid choice: 'filter'" in r.stderr
    r = cli("experiment", "particles", "--long-runs", "-1", "--out", str(tmp_path))
    assert r.returncode != 0
    assert "--long-runs must be 0 or more" in r.stderr
