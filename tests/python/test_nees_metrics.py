"""One definition of a run's NEES numbers (issue 13, item 5).

``metrics.json``'s ``mean_nees_pose``, ``median_nees_pose`` and
``nees_within_95`` and the title of ``nees.png`` are the same computation:
the Rust ``NeesSummary`` of the Rust pose-NEES series (``RunResult.nees``),
whose scoring starts at the first covariance above the documented floor.
The MRCLAM case needs the data (see ``test_mrclam.py``); it fails without it.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np

import bearing_slam as bs
from bearing_slam import mrclam
from bearing_slam._native import nees_summary
from bearing_slam.outputs import metrics_record, mrclam_record
from bearing_slam.plots.run import nees_caption, plot_nees
from bearing_slam.vocabulary import POSE_NEES

ROOT = Path(__file__).resolve().parents[2]
DATA = Path(os.environ.get("BEARING_SLAM_DATA") or ROOT.parent / "shared" / "datasets" / "mrclam")


def _title_percent(result: bs.RunResult) -> str:
    """The percentage the NEES plot prints in its title."""
    import matplotlib.pyplot as plt

    fig = plot_nees(result)
    title = fig.axes[0].get_title()
    plt.close(fig)
    assert nees_caption(result) in title
    return title.split(" % under")[0].rsplit(" ", 1)[1]


def test_the_bound_is_the_one_sided_chi2_quantile() -> None:
    assert POSE_NEES["dof"] == 3.0
    assert POSE_NEES["probability"] == 0.95
    assert POSE_NEES["bound"] == bs.chi2_quantile(3.0, 0.95)
    s = nees_summary(np.array([1.0, np.nan, 2.0, 3.0, 10.0]))
    assert s["n_scored"] == 4
    assert s["median"] == 2.5
    assert s["fraction_within_bound"] == 0.75


def test_simulated_run_metrics_json_and_plot_agree() -> None:
    log = bs.simulate("paper_fig4", 3)
    result = bs.run(log, bs.Config(init="pi-sr"))
    record = metrics_record(result, log, 0.0)
    s = nees_summary(result.nees)
    assert s["n_scored"] > 100
    assert record["nees_within_95"] == s["fraction_within_bound"]
    assert record["mean_nees_pose"] == s["mean"]
    assert record["median_nees_pose"] == s["median"]
    assert record["n_nees_scored"] == s["n_scored"]
    assert _title_percent(result) == f"{100 * record['nees_within_95']:.0f}"
    # The start is known exactly: its zero covariance is never scored.
    assert math.isnan(result.nees[0])


def test_mrclam_metrics_json_and_plot_agree() -> None:
    # Robot 5 from the log start: the command delay leaves the covariance
    # near zero for its first 0.25 s while the robot moves (the samples that
    # gave a mean NEES of 3e10 before the scoring rule).
    run = mrclam.evaluate(DATA / "MRCLAM_Dataset6", 5, "mte", start=0.0, end=60.0)
    record = mrclam_record(run)
    s = nees_summary(run.result.nees)
    assert record["nees_within_95"] == s["fraction_within_bound"]
    assert record["mean_nees_pose"] == s["mean"]
    assert record["median_nees_pose"] == s["median"]
    assert _title_percent(run.result) == f"{100 * record['nees_within_95']:.0f}"
    assert record["mean_nees_pose"] < 1e3
    # Nothing scored before the covariance reached the floor.
    first = int(np.flatnonzero(np.isfinite(run.result.nees))[0])
    cov = run.result.covariance[first]
    assert math.sqrt(cov[2, 2]) >= POSE_NEES["min_heading_sigma_rad"]
    assert record["n_outside_window"] > 0
