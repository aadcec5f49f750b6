"""The ``bearing-slam`` CLI, run as a user would (subprocess)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest
from mcap.reader import make_reader

import bearing_slam as bs
from conftest import cli

ROOT = Path(__file__).resolve().parents[2]
EXAMPLE_SCENARIO = ROOT / "crates" / "bearing-slam-sim" / "scenarios" / "example.toml"
KEYS = [
    "ate_rmse_m",
    "final_position_error_m",
    "final_heading_error_deg",
    "landmark_rmse_m",
    "mean_nees_pose",
    "n_landmarks_initialized",
]
PLOTS = ["trajectory.png", "pose_errors.png", "nees.png"]


def check_outputs(folder: Path) -> dict[str, object]:
    metrics = json.loads((folder / "metrics.json").read_text())
    for key in KEYS:
        assert key in metrics, key
        assert metrics[key] is not None, key
        assert math.isfinite(metrics[key]), key
    for png in PLOTS:
        data = (folder / png).read_bytes()
        assert data.startswith(b"\x89PNG"), png
        assert len(data) > 20_000, png
    with (folder / "estimate.mcap").open("rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None
    assert any(c.topic == "/slam/estimate" for c in summary.channels.values())
    return dict(metrics)


@pytest.mark.parametrize(
    "command",
    [
        [],
        ["demo"],
        ["simulate"],
        ["run"],
        ["scenarios"],
        ["montecarlo"],
        ["experiment"],
        ["mrclam"],
        ["mrclam-figures"],
    ],
)
def test_help(command: list[str]) -> None:
    r = cli(*command, "--help")
    assert r.returncode == 0, r.stderr
    assert "usage: bearing-slam" in r.stdout
    if command in (["demo"], ["run"]):
        assert "metrics.json" in r.stdout
        assert "estimate.mcap" in r.stdout


def test_simulate_then_run(tmp_path: Path) -> None:
    log = tmp_path / "fig4.mcap"
    r = cli("simulate", "paper_fig4", "--seed", "3", "--out", log)
    assert r.returncode == 0, r.stderr
    assert log.stat().st_size > 10_000
    out = tmp_path / "mte"
    r = cli("run", log, "--init", "mte", "--out", out, "--quiet")
    assert r.returncode == 0, r.stderr
    m = check_outputs(out)
    assert m["n_landmarks_initialized"] == 5
    assert m["ate_rmse_m"] < m["dead_reckoning_ate_rmse_m"]  # type: ignore[operator]
    assert 0.0 < m["mean_nees_pose"] < 20.0  # type: ignore[operator]
    assert m["init"] == "mte"
    r = cli(
        "run", log, "--init", "pi-sr", "--rho-ini", "0.5", "--sigma-rho", "0.25", "--out",
        tmp_path / "pisr", "--quiet",
    )  # fmt: skip
    assert r.returncode == 0, r.stderr
    m = check_outputs(tmp_path / "pisr")
    assert m["config"]["rho_ini"] == 0.5  # type: ignore[index]
    assert m["init"] == "pi-sr"


def test_run_mte_history(tmp_path: Path) -> None:
    log = tmp_path / "fig4.mcap"
    assert cli("simulate", "paper_fig4", "--seed", "3", "--out", log).returncode == 0
    out = tmp_path / "history"
    r = cli("run", log, "--init", "mte-history", "--out", out, "--quiet")
    assert r.returncode == 0, r.stderr
    assert "mte-history" in r.stdout
    m = check_outputs(out)
    assert m["init"] == "mte-history"
    assert m["config"]["init"] == "mte-clone"  # type: ignore[index]
    assert m["config"]["history"] == 32  # type: ignore[index]
    assert m["n_landmarks_initialized"] == 5
    assert m["ate_rmse_m"] < m["dead_reckoning_ate_rmse_m"]  # type: ignore[operator]


def test_simulate_with_clutter_and_descriptors_then_associate(tmp_path: Path) -> None:
    log = tmp_path / "fig4.mcap"
    r = cli(
        "simulate", "paper_fig4", "--seed", "3", "--duration", "25", "--clutter", "1",
        "--descriptor-sigma", "0.1", "--out", log,
    )  # fmt: skip
    assert r.returncode == 0, r.stderr
    out = tmp_path / "jcbb"
    r = cli(
        "run", log, "--association", "jcbb", "--descriptor-sigma", "0.1", "--out", out, "--quiet"
    )
    assert r.returncode == 0, r.stderr
    m = check_outputs(out)
    assert m["config"]["descriptor_sigma"] == 0.1  # type: ignore[index]
    score = m["association"]
    assert score["precision"] >= 0.99  # type: ignore[index]
    assert score["spurious"] == 0  # type: ignore[index]
    r = cli("run", log, "--descriptor-sigma", "0.1", "--out", tmp_path / "known", "--quiet")
    assert r.returncode != 0
    assert "--descriptor-sigma: for --association nn, jcbb or ransac only" in r.stderr
    r = cli("simulate", "paper_fig4", "--descriptor-confusion", "0.1", "--out", log)
    assert r.returncode != 0
    assert "--descriptor-confusion needs --descriptor-sigma" in r.stderr


def test_simulate_scenario_file(tmp_path: Path) -> None:
    out = tmp_path / "example.mcap"
    r = cli("simulate", EXAMPLE_SCENARIO, "--seed", "1", "--duration", "5", "--out", out)
    assert r.returncode == 0, r.stderr
    assert out.exists()


def test_demo(tmp_path: Path) -> None:
    out = tmp_path / "demo"
    r = cli("demo", "--out", out, "--quiet")
    assert r.returncode == 0, r.stderr
    assert "paper_fig4" in r.stdout
    assert "slip_patch" in r.stdout
    assert "ATE [m]" in r.stdout
    folders = sorted(p.name for p in out.iterdir() if p.is_dir())
    assert len(folders) == 10  # 2 scenarios x (the default, MTE, MTE-clone, MTE-history, PI-SR)
    for scenario in ("paper_fig4", "slip_patch"):
        default = check_outputs(out / f"{scenario}_{bs.vocabulary.DEFAULT_INIT}")
        assert default["init"] == bs.vocabulary.DEFAULT_INIT
        assert default["ate_rmse_m"] < default["dead_reckoning_ate_rmse_m"]  # type: ignore[operator]
        m = check_outputs(out / f"{scenario}_mte")
        assert m["ate_rmse_m"] < m["dead_reckoning_ate_rmse_m"]  # type: ignore[operator]
        check_outputs(out / f"{scenario}_mte-clone")
        h = check_outputs(out / f"{scenario}_mte-history")
        assert h["ate_rmse_m"] < h["dead_reckoning_ate_rmse_m"]  # type: ignore[operator]
        check_outputs(out / f"{scenario}_pi-sr_0.01_0.005")
    assert check_outputs(out / "paper_fig4_mte")["n_landmarks_initialized"] == 5


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["simulate", "nowhere", "--out", "x.mcap"], "unknown scenario"),
        (["simulate", "missing.toml", "--out", "x.mcap"], "cannot read scenario file"),
        (["run", "missing.mcap", "--out", "o"], "no such file"),
        (["run", "CORRUPT", "--out", "o"], "not an MCAP file"),
        (["run", "LOG", "--init", "pi-sr", "--rho-ini", "-1", "--out", "o"], "rho_ini"),
    ],
)
def test_user_errors_are_one_line(tmp_path: Path, args: list[str], message: str) -> None:
    corrupt = tmp_path / "corrupt.mcap"
    corrupt.write_bytes(b"garbage" * 20)
    log = tmp_path / "log.mcap"
    if "LOG" in args:
        assert cli("simulate", "paper_fig4", "--out", log).returncode == 0
    args = [
        str(corrupt) if a == "CORRUPT" else str(log) if a == "LOG" else
        str(tmp_path / a) if a.endswith((".mcap", ".toml")) or a == "o" else a
        for a in args
    ]  # fmt: skip
    r = cli(*args)
    assert r.returncode == 2
    assert "Traceback" not in r.stderr
    lines = [line for line in r.stderr.splitlines() if line.strip()]
    assert len(lines) == 1, r.stderr
    assert lines[0].startswith("bearing-slam: error:")
    assert message in lines[0]


def test_fastslam_and_the_smoother_with_hidden_ids_write_the_association_block(
    tmp_path: Path,
) -> None:
    log = tmp_path / "fig4.mcap"
    assert cli("simulate", "paper_fig4", "--seed", "3", "--out", log).returncode == 0
    out = tmp_path / "fastslam_nn"
    r = cli(
        "run", log, "--estimator", "fastslam2", "--particles", "20",
        "--association", "nn", "--out", out, "--quiet",
    )  # fmt: skip
    assert r.returncode == 0, r.stderr
    metrics = json.loads((out / "metrics.json").read_text())
    association = metrics["association"]
    assert association is not None
    assert association["mapped"] > 0
    assert association["spurious_at_end"] == 0
    smoothed = tmp_path / "smoother_nn"
    r = cli(
        "run", log, "--estimator", "smoother", "--association", "nn", "--out", smoothed, "--quiet",
    )  # fmt: skip
    assert r.returncode == 0, r.stderr
    given = tmp_path / "smoother_known"
    r = cli("run", log, "--estimator", "smoother", "--out", given, "--quiet")
    assert r.returncode == 0, r.stderr
    hidden_metrics = json.loads((smoothed / "metrics.json").read_text())
    known_metrics = json.loads((given / "metrics.json").read_text())
    assert hidden_metrics["association"]["spurious_at_end"] == 0
    assert known_metrics["association"] is None
    # The batch re-associates against its smoothed estimate: it ends where
    # it does given the ids.
    assert hidden_metrics["ate_rmse_m"] <= 1.2 * known_metrics["ate_rmse_m"]
