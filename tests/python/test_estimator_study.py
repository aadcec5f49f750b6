"""``bearing-slam experiment smoother`` (issue 14): the batch and fixed-lag
smoothers beside the EKF on the simulator, written as smoother.md/.json/.png;
particle-only options refused."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from bearing_slam.estimator_study import _configs, run_estimator_study


def _cli(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "bearing_slam", *args],
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )


def test_configs_give_particle_counts_to_fastslam_only() -> None:
    assert _configs(["smoother", "fastslam2"], [10, 100]) == [
        ("filter", None),
        ("smoother", None),
        ("fastslam2", 10),
        ("fastslam2", 100),
    ]


def test_the_smoothers_are_scored_beside_the_filter() -> None:
    study = run_estimator_study(
        runs=2,
        estimators=("smoother",),
        particle_counts=(),
        scenarios=("paper_fig4",),
        long_runs=0,
        progress=False,
    )
    rows = {r["estimator"]: r for r in study["montecarlo"]}
    assert set(rows) == {"filter", "smoother"}
    assert rows["smoother"]["label"] == "batch smoother"
    for r in rows.values():
        assert r["runs"] == 2
        assert r["ate_mean_m"] is not None
        assert 0.0 < r["ate_mean_m"] < 1.0
        assert r["mean_nees"] is not None
        assert r["mean_nees"] > 0.0
    # Smoothing the same runs relinearizes the past: never worse on average.
    assert rows["smoother"]["ate_mean_m"] <= rows["filter"]["ate_mean_m"]
    assert "| paper_fig4 | batch smoother |" in study["table"]


def test_cli_writes_the_three_files_and_refuses_particle_options(tmp_path: Path) -> None:
    r = _cli(
        "experiment",
        "smoother",
        "--scenario",
        "paper_fig4",
        "--runs",
        "1",
        "--quiet",
        "--out",
        str(tmp_path),
    )
    assert r.returncode == 0, r.stderr
    for name in ("smoother.md", "smoother.json", "smoother.png"):
        assert (tmp_path / name).stat().st_size > 0
    md = (tmp_path / "smoother.md").read_text()
    assert "bearing-slam experiment smoother --scenario paper_fig4 --runs 1" in md
    assert "fixed-lag smoother (filter+smoother)" in md
    labels = {
        row["label"] for row in json.loads((tmp_path / "smoother.json").read_text())["montecarlo"]
    }
    assert labels == {"EKF (filter)", "batch smoother", "fixed-lag smoother (filter+smoother)"}
    r = _cli("experiment", "smoother", "--particles", "10", "--out", str(tmp_path))
    assert r.returncode != 0
    assert "apply to experiment particles only" in r.stderr
