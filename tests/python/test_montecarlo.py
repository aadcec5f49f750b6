"""Monte Carlo from Python: the local (rayon) path, executors (threads, a real
Dask cluster) giving the same report bit for bit, the classification, errors,
the CLI and the experiment writers."""

from __future__ import annotations

import json
import math
import pickle
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import bearing_slam as bs
from bearing_slam._native import montecarlo_report, montecarlo_run_one
from bearing_slam.monte_carlo import CLASSES, METRICS, MonteCarloResult, make_spec, run_spec
from conftest import cli

FIG4_MTE = make_spec("paper_fig4", "mte", 4, seed0=10)


def canonical(report: dict[str, Any]) -> str:
    """The report as text with every float in its exact shortest repr."""
    return json.dumps(report, sort_keys=True)


@pytest.fixture(scope="module")
def local_mte() -> MonteCarloResult:
    return run_spec(FIG4_MTE, progress=False)


def test_local_equals_thread_executor(local_mte: MonteCarloResult) -> None:
    with ThreadPoolExecutor(max_workers=2) as pool:
        remote = run_spec(FIG4_MTE, executor=pool, progress=False)
    assert remote.report == local_mte.report
    assert canonical(remote.report) == canonical(local_mte.report)
    assert remote.report["error_over_time"]["slam_mean_m"]  # series were aggregated
    assert np.array_equal(remote.metrics["ate_rmse_m"], local_mte.metrics["ate_rmse_m"])


def test_records_in_any_order_and_pickled(local_mte: MonteCarloResult) -> None:
    spec_json = json.dumps(FIG4_MTE)
    records = [montecarlo_run_one(spec_json, i) for i in range(FIG4_MTE["runs"])]
    records = [pickle.loads(pickle.dumps(r)) for r in reversed(records)]
    json.dumps(records)  # plain JSON-able objects
    assert canonical(montecarlo_report(spec_json, records)) == canonical(local_mte.report)


def test_dask_local_cluster_same_report(local_mte: MonteCarloResult, dask_client: Any) -> None:
    # Worker processes (conftest's dask_client): the task and its record
    # really cross a process boundary by pickling, as on a remote cluster.
    remote = run_spec(FIG4_MTE, executor=dask_client.get_executor(), progress=False)
    assert canonical(remote.report) == canonical(local_mte.report)


def test_classes_and_fractions() -> None:
    pisr_far = {"method": "pi-sr", "rho_ini": 0.01, "sigma_rho": 0.005}
    results = bs.montecarlo("paper_fig4", ["mte", pisr_far], runs=4, seed0=10, progress=False)
    assert list(results) == ["mte", "PI-SR (0.01, 0.005)"]
    for r in results.values():
        assert math.isclose(sum(r.fractions.values()), 1.0)
        assert set(r.classes) <= set(CLASSES)
        assert r.classes.shape == (4,)
        for key in METRICS:
            assert r.metrics[key].shape == (4,)
        assert r.time.shape == r.nees_mean.shape == r.nees_lower.shape == r.nees_upper.shape
        back = MonteCarloResult.from_json(r.to_json())
        assert back.report == r.report
    mte, pisr = results["mte"], results["PI-SR (0.01, 0.005)"]
    assert mte.converged_fraction == 1.0, mte.reasons
    assert mte.mean_nees is not None
    assert 0.5 < mte.mean_nees < 15.0
    finite = np.isfinite(mte.nees_mean)
    assert np.all(mte.nees_lower[finite] < 3.0)
    assert np.all(mte.nees_upper[finite] > 3.0)
    assert np.all(mte.metrics["ate_rmse_m"] < mte.metrics["dead_reckoning_ate_rmse_m"])
    # The far prior puts the near landmarks at 100 m: no run converges.
    assert pisr.converged_fraction == 0.0
    assert np.all(pisr.metrics["near_landmark_rmse_m"] > 5.0)


def test_history_and_scaled_scene() -> None:
    """MTE-history on a scene scaled down: the spec carries the scale to the
    simulator (the map error follows the smaller scene) and the waiting
    bearings are used (a more accurate start than MTE-clone on the same seeds)."""
    results = bs.montecarlo(
        "paper_fig4", ["mte-clone", "mte-history"], runs=6, landmark_scale=0.5, progress=False
    )
    clone, history = results["mte-clone"], results["mte-history"]
    assert history.report["spec"]["scenario"]["landmark_scale"] == 0.5
    assert history.report["spec"]["initializer"] == {"method": "mte-history"}
    assert history.converged_fraction == 1.0, history.reasons
    assert np.mean(history.metrics["ate_rmse_m"]) < np.mean(clone.metrics["ate_rmse_m"])
    # The near landmarks at half their distance are mapped to a few centimetres.
    assert np.all(history.metrics["near_landmark_rmse_m"] < 0.15)
    with pytest.raises(bs.SimulationError, match="landmark_scale"):
        bs.montecarlo("paper_fig4", "mte", runs=1, landmark_scale=-1.0, progress=False)


def test_progress_callback_counts_every_run() -> None:
    seen: list[tuple[int, int]] = []
    spec = make_spec("paper_fig4", "mte-clone", 3)
    run_spec(spec, progress=lambda done, total: seen.append((done, total)))
    assert seen
    assert seen[-1] == (3, 3)
    assert [d for d, _ in seen] == sorted(d for d, _ in seen)


@pytest.mark.parametrize(
    ("spec", "error", "match"),
    [
        (make_spec("no_such_scenario", "mte", 2), bs.SimulationError, "no_such_scenario"),
        (
            make_spec("paper_fig4", {"method": "pi-sr", "rho_ini": 0.5, "sigma_rho": -1.0}, 2),
            bs.InvalidNoiseError,
            "sigma_rho",
        ),
        (make_spec("paper_fig4", {"method": "magic"}, 2), bs.InvalidParameterError, "magic"),
        (
            make_spec("paper_fig4", "mte", 2, thresholds={"drift_position_m": -1.0}),
            bs.InvalidParameterError,
            "drift_position_m",
        ),
        ({**make_spec("paper_fig4", "mte", 2), "extra": 1}, bs.InvalidParameterError, "extra"),
        # Refused up front, not counted as two diverged runs.
        (
            make_spec("paper_fig4", "mte", 2, estimator="fastslam1", particles=10**12),
            bs.InvalidParameterError,
            "more particles than a run can hold",
        ),
    ],
)
def test_bad_spec_raises(spec: dict[str, Any], error: type[Exception], match: str) -> None:
    with pytest.raises(error, match=match):
        run_spec(spec, progress=False)
    with ThreadPoolExecutor(max_workers=1) as pool, pytest.raises(error, match=match):
        run_spec(spec, executor=pool, progress=False)
    with pytest.raises(error, match=match):
        montecarlo_run_one(json.dumps(spec), 0)


def test_bad_records_and_inputs() -> None:
    spec_json = json.dumps(make_spec("paper_fig4", "mte", 2))
    with pytest.raises(bs.InvalidParameterError, match="Monte Carlo spec"):
        montecarlo_run_one("{not json", 0)
    with pytest.raises(bs.InvalidParameterError, match="out of range"):
        montecarlo_run_one(spec_json, 2)
    with pytest.raises(bs.InvalidParameterError, match="missing key"):
        montecarlo_report(spec_json, [{"series": {}}])
    with pytest.raises(bs.InvalidParameterError, match="run_index"):
        montecarlo_report(spec_json, [{"metrics": {}, "series": {}, "init_events": []}])
    record = montecarlo_run_one(spec_json, 0)
    with pytest.raises(bs.InvalidParameterError, match="twice"):
        montecarlo_report(spec_json, [record, record])
    with pytest.raises(ValueError, match="unknown initializer"):
        bs.montecarlo("paper_fig4", "ekf", runs=2, progress=False)
    with pytest.raises(ValueError, match="at least 1"):
        bs.montecarlo("paper_fig4", "mte", runs=0, progress=False)


def test_cli_montecarlo_writes_json(tmp_path: Path) -> None:
    out = tmp_path / "mc" / "pisr.json"
    r = cli("montecarlo", "paper_fig4", "--runs", "3", "--init", "pi-sr", "--rho-ini", "0.5",
            "--sigma-rho", "0.25", "--seed0", "5", "--json", out, "--quiet")  # fmt: skip
    assert r.returncode == 0, r.stderr
    assert "converged" in r.stdout
    assert "drift" in r.stdout
    assert "diverged" in r.stdout
    report = json.loads(out.read_text())
    for key in (
        "spec", "label", "runs", "converged_fraction", "drift_fraction", "diverged_fraction",
        "all_finite", "converged", "mean_nees", "nees_over_time", "error_over_time",
    ):  # fmt: skip
        assert key in report, key
    assert report["spec"]["initializer"] == {"method": "pi-sr", "rho_ini": 0.5, "sigma_rho": 0.25}
    assert report["spec"]["scenario"]["seed0"] == 5
    assert [run["seed"] for run in report["runs"]] == [5, 6, 7]
    assert math.isclose(
        report["converged_fraction"] + report["drift_fraction"] + report["diverged_fraction"], 1.0
    )
    bad = cli("montecarlo", "nowhere", "--runs", "2", "--json", tmp_path / "x.json")
    assert bad.returncode == 2
    assert "unknown scenario" in bad.stderr
    assert "Traceback" not in bad.stderr


def test_association_is_scored_over_the_runs(tmp_path: Path) -> None:
    result = bs.montecarlo(
        "paper_fig4", "mte", 3, association="jcbb", clutter=1.0, descriptor_sigma=0.1,
        progress=False,
    )["mte"]  # fmt: skip
    spec = result.spec["scenario"]
    assert spec["clutter_per_scan"] == 1.0
    assert spec["appearance"] == {"sigma": 0.1, "confusion_rate": 0.0}
    precision = result.metrics["association_precision"]
    assert precision.shape == (3,)
    assert np.all(precision >= 0.99)
    assert np.all(result.metrics["spurious_at_end"] == 0)
    means = result.report["all_finite"]
    assert means["association_precision"] == pytest.approx(float(precision.mean()))
    assert "association precision" in result.summary_line()
    # Known ids: nothing to score.
    assert np.isnan(run_spec(FIG4_MTE, progress=False).metrics["association_precision"]).all()
    with pytest.raises(ValueError, match="descriptor_confusion needs descriptor_sigma"):
        make_spec("paper_fig4", "mte", 2, descriptor_confusion=0.1)
    out = tmp_path / "jcbb.json"
    r = cli("montecarlo", "paper_fig4", "--runs", "2", "--association", "jcbb", "--clutter", "1",
            "--descriptor-sigma", "0.1", "--json", out, "--quiet")  # fmt: skip
    assert r.returncode == 0, r.stderr
    assert "association precision" in r.stdout
    assert json.loads(out.read_text())["spec"]["association"] == "jcbb"


@pytest.mark.parametrize("command", [["montecarlo"], ["experiment"]])
def test_cli_help(command: list[str]) -> None:
    r = cli(*command, "--help")
    assert r.returncode == 0, r.stderr
    text = " ".join(r.stdout.split())
    if command == ["experiment"]:
        for name in ("fig4.png", "fig5", "fig8.png", "fig10.png", "consistency.png", "NAME.md"):
            assert name in text, name
    else:
        assert "converged_fraction" in text


def test_cli_experiment_fig5(tmp_path: Path) -> None:
    r = cli("experiment", "fig5", "--out", tmp_path, "--quiet")
    assert r.returncode == 0, r.stderr
    assert "parallax" in r.stdout
    assert (tmp_path / "fig5.png").read_bytes().startswith(b"\x89PNG")
    data = json.loads((tmp_path / "fig5.json").read_text())
    sigma_d = [p["sigma_depth_m"] for p in data["points"]]
    assert sigma_d == sorted(sigma_d, reverse=True)  # more parallax, less depth uncertainty
    assert "| parallax" in (tmp_path / "fig5.md").read_text()


def test_experiment_plots_on_a_small_fig4(tmp_path: Path) -> None:
    from bearing_slam.experiments import run_experiments

    written = run_experiments(["fig4", "consistency"], tmp_path, runs=2, progress=False)
    assert set(written) == {"fig4", "consistency"}
    for paths in written.values():
        for p in paths:
            assert p.stat().st_size > 500, p
    fig4 = json.loads((tmp_path / "fig4.json").read_text())
    assert len(fig4["with_far"]) == len(fig4["without_far"]) == 6
    assert [r["label"] for r in fig4["across_scales"]] == [r["label"] for r in fig4["with_far"]]
    for row in fig4["across_scales"]:
        assert [c["scale"] for c in row["cells"]] == [0.2, 0.5, 1.0, 2.0, 4.0]
    assert "worst ATE / best" in (tmp_path / "fig4.md").read_text()
    assert "consistency" not in fig4
    curves = json.loads((tmp_path / "consistency.json").read_text())["curves"]
    assert len(curves) == 12
    assert all(len(c["nees"]["time"]) <= 401 for c in curves)
