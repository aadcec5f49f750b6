"""Small things a new user trips on: help texts, ``--version``, ``make help``,
the README's API lines, labels and legends of the plots, the θ band."""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

import matplotlib as mpl
import numpy as np
import pytest

import bearing_slam as bs
from bearing_slam.plots.run import (
    landmark_clusters,
    plot_pose_errors,
    plot_trajectory,
    scan_gaps,
)
from conftest import cli

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("command", ["run", "montecarlo", "experiment", "demo", "mrclam"])
def test_help_prints_no_doubled_percent(command: str) -> None:
    r = cli(command, "--help")
    assert r.returncode == 0, r.stderr
    assert "%%" not in r.stdout
    if command in ("run", "montecarlo", "experiment"):
        assert "95 %" in r.stdout


def test_version() -> None:
    r = cli("--version")
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == f"bearing-slam {bs.__version__}"


def test_make_help_lists_every_target() -> None:
    makefile = (ROOT / "Makefile").read_text()
    targets = set(re.findall(r"^([a-z][a-z0-9-]*):", makefile, flags=re.M))
    r = subprocess.run(
        ["make", "--no-print-directory", "-s", "help"],
        cwd=ROOT,
        capture_output=True,
        text=True,
        check=False,
        timeout=60,
    )
    assert r.returncode == 0, r.stderr
    listed = set(re.findall(r"^make ([a-z][a-z0-9-]*) ", r.stdout, flags=re.M))
    assert targets - {"help"} <= listed, f"make help misses {sorted(targets - listed - {'help'})}"
    assert listed <= targets, f"make help lists unknown {sorted(listed - targets)}"


def test_readme_says_what_read_mcap_returns() -> None:
    text = (ROOT / "README.md").read_text()
    assert "read_mcap(path) -> (log, trace, warnings)" in text
    quickstart = text.split("## Python quickstart", 1)[1].split("\n## ", 1)[0]
    assert "init=init, rho_ini" not in quickstart  # PI-SR's prior is not MTE's


def test_landmark_clusters() -> None:
    points = np.array([[0.0, 0.0], [0.1, 0.0], [5.0, 5.0], [0.2, 0.05], [5.05, 5.0], [9.0, 0.0]])
    assert landmark_clusters(points, 0.15) == [[0, 1, 3], [2, 4], [5]]
    assert landmark_clusters(points, 0.01) == [[0], [1], [2], [3], [4], [5]]
    assert landmark_clusters(np.zeros((0, 2)), 1.0) == []


def test_trajectory_legend_outside_and_one_label_per_group(
    fig4_log: bs.SensorLog, fig4_result: bs.RunResult
) -> None:
    fig = plot_trajectory(fig4_result, fig4_log)
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()  # type: ignore[attr-defined]
    assert len(fig.legends) == 1
    legend_box = fig.legends[0].get_window_extent(renderer)
    fig_box = fig.bbox
    assert legend_box.x1 <= fig_box.x1 + 0.5, "the legend is cut off"
    for ax in fig.axes:
        assert not ax.get_window_extent(renderer).overlaps(legend_box), "the legend covers the map"
        texts = [t.get_text() for t in ax.texts]
        labelled = [int(i) for t in texts for i in t.split(", ")]
        assert sorted(labelled) == sorted(int(i) for i in fig4_log.landmarks[:, 0])
    mpl.pyplot.close(fig)


def test_theta_band_is_three_sigma_of_the_covariance(fig4_result: bs.RunResult) -> None:
    # The θ band is 3σ of the covariance (not wrapped): its saw-tooth is the
    # filter's prediction growing it and updates shrinking it.
    fig = plot_pose_errors(fig4_result)
    theta_axes = fig.axes[2]
    band = np.asarray(theta_axes.lines[0].get_ydata(), dtype=np.float64)
    sigma_deg = np.degrees(np.sqrt(np.clip(fig4_result.covariance[:, 2, 2], 0.0, None)))
    np.testing.assert_allclose(band, 3.0 * sigma_deg, rtol=1e-12)
    mpl.pyplot.close(fig)


def test_scan_gaps_are_shaded() -> None:
    log = bs.simulate("paper_fig4", seed=3)
    times = log.bearings[:, 0]
    keep = (times < 5.0) | (times > 12.0)  # a 7 s pause in the scans
    paused = bs.SensorLog.from_arrays(
        wheels=log.wheels,
        bearings=log.bearings[keep],
        truth=log.truth,
        landmarks=log.landmarks,
        info={"wheel_base_m": log.info["wheel_base_m"]},
    )
    result = bs.run(paused)
    gaps = scan_gaps(result)
    assert len(gaps) == 1
    start, end = gaps[0]
    assert 4.5 < start <= 5.0
    assert 12.0 < end < 12.5
    fig = plot_pose_errors(result)
    for ax in fig.axes:
        assert len(ax.patches) == 1  # the gap
    mpl.pyplot.close(fig)
