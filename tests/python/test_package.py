"""The package's shape: modules not shadowed, the vocabulary accepted by the
Rust side, records, one CLI parser per command, no data path from the install."""

from __future__ import annotations

import argparse
import json
import math
import os
import pkgutil
import subprocess
import sys
import tomllib
import types
from pathlib import Path

import pytest

import bearing_slam as bs
from bearing_slam import cli, mrclam, outputs, vocabulary
from bearing_slam._native import montecarlo_report
from bearing_slam.monte_carlo import make_spec


def test_no_module_is_shadowed_by_a_function() -> None:
    names = [m.name for m in pkgutil.iter_modules(bs.__path__) if m.name != "__main__"]
    assert "monte_carlo" in names
    assert "outputs" in names
    for name in names:
        __import__(f"bearing_slam.{name}")
        attr = getattr(bs, name)
        assert isinstance(attr, types.ModuleType), f"bearing_slam.{name} is a {type(attr)}"


def test_the_vocabulary_is_the_rust_enums() -> None:
    """Python restates no name or default: every one is the Rust enum's `ALL`
    or constant, exported by ``_native.vocabulary()``, and the CLI offers
    exactly those names."""
    rust = bs._native.vocabulary()
    assert tuple(rust["initializers"]) == vocabulary.INIT_NAMES
    assert set(vocabulary.RUN_INITS) == set(rust["initializers"]) - {"pi-sr-mixed"}
    assert tuple(rust["prior_initializers"]) == vocabulary.PRIOR_INITS
    assert tuple(rust["covariance_updates"]) == vocabulary.COVARIANCE_UPDATES
    assert tuple(rust["update_modes"]) == vocabulary.UPDATE_MODES == ("full", "compressed")
    assert tuple(rust["odometries"]) == vocabulary.ODOMETRIES
    assert tuple(rust["mrclam_methods"]) == vocabulary.MRCLAM_METHODS
    assert tuple(rust["run_classes"]) == vocabulary.CLASSES
    assert tuple(rust["experiments"]) == vocabulary.EXPERIMENTS
    assert tuple(rust["run_metrics"]) == vocabulary.METRICS
    assert rust["thresholds"] == vocabulary.DEFAULT_THRESHOLDS
    assert rust["paper_near_prior"] == vocabulary.DEFAULT_PRIOR
    assert rust["paper_far_prior"] == vocabulary.FAR_PRIOR
    assert rust["mte_history"] == vocabulary.MTE_HISTORY
    # The defaults a Config starts from are the Rust defaults.
    config = bs.Config()
    assert (config.rho_ini, config.sigma_rho) == (
        rust["paper_near_prior"]["rho_ini"],
        rust["paper_near_prior"]["sigma_rho"],
    )
    # Every name Rust lists is one its parsers accept, and nothing else is.
    for form in vocabulary.COVARIANCE_UPDATES:
        assert bs.Config(covariance_update=form).covariance_update == form
    for odometry in vocabulary.ODOMETRIES:
        assert bs.Config(odometry=odometry).odometry == odometry
    with pytest.raises(ValueError, match="unknown covariance update"):
        bs.Config(covariance_update="kalman")
    for mode in vocabulary.UPDATE_MODES:
        assert bs.Config(update=mode).update == mode
    assert bs.Config().update == "full"
    with pytest.raises(ValueError, match="unknown update mode"):
        bs.Config(update="partial")
    # The command line's choices are these lists.
    inits = [
        tuple(a.choices)
        for action in cli._parser()._actions
        if isinstance(action, argparse._SubParsersAction)
        for sub in action.choices.values()
        for a in sub._actions
        if a.dest == "init" and a.choices is not None
    ]
    assert len(inits) >= 3, "the run, mrclam and montecarlo commands each have --init"
    for names in inits:
        assert set(names) <= set(vocabulary.INIT_NAMES) | set(vocabulary.MRCLAM_METHODS)
    assert vocabulary.INIT_NAMES in inits


def test_every_config_init_is_accepted(fig4_log: bs.SensorLog) -> None:
    for init in vocabulary.CONFIG_INITS:
        assert bs.Config.for_log(fig4_log, init=init).init == init
    with pytest.raises(ValueError, match="unknown initializer"):
        bs.Config(init="no-such-init")


def test_every_run_init_builds_a_config(fig4_log: bs.SensorLog) -> None:
    for init in vocabulary.RUN_INITS:
        name, extra = vocabulary.config_init(init)
        config = bs.Config.for_log(fig4_log, init=name, **extra)
        assert vocabulary.init_name(config.init, config.history) == init
    assert vocabulary.config_init("mte-history") == (
        "mte-clone",
        {"history": vocabulary.MTE_HISTORY},
    )


@pytest.mark.parametrize("init", vocabulary.INIT_NAMES)
def test_every_monte_carlo_init_is_accepted(init: str) -> None:
    spec = make_spec("paper_fig4", init, 1)
    report = montecarlo_report(json.dumps(spec), [])
    assert report["spec"]["initializer"]["method"] == init
    assert report["spec"]["thresholds"] == vocabulary.DEFAULT_THRESHOLDS


def test_finite_or_none() -> None:
    assert outputs.finite_or_none(math.nan) is None
    assert outputs.finite_or_none(math.inf) is None
    assert outputs.finite_or_none(1.5) == 1.5
    assert outputs.finite_or_none("x") == "x"


def test_metrics_record_names_mte_history(fig4_log: bs.SensorLog) -> None:
    name, extra = vocabulary.config_init("mte-history")
    result = bs.run(fig4_log, bs.Config.for_log(fig4_log, init=name, **extra))
    record = outputs.metrics_record(result, fig4_log, 0.1)
    assert record["init"] == "mte-history"
    assert record["config"]["history"] == vocabulary.MTE_HISTORY
    json.dumps(record, allow_nan=False)


def test_data_dir_needs_an_argument_or_the_env(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.delenv(mrclam.DATA_ENV, raising=False)
    with pytest.raises(FileNotFoundError, match=mrclam.DATA_ENV):
        mrclam.data_dir()
    assert mrclam.data_dir(tmp_path) == tmp_path
    with pytest.raises(FileNotFoundError, match="no such MRCLAM data directory"):
        mrclam.data_dir(tmp_path / "nope")
    monkeypatch.setenv(mrclam.DATA_ENV, str(tmp_path / "missing"))
    with pytest.raises(FileNotFoundError, match=f"from {mrclam.DATA_ENV}"):
        mrclam.data_dir()
    monkeypatch.setenv(mrclam.DATA_ENV, str(tmp_path))
    assert mrclam.data_dir() == tmp_path


def run_module(*args: str, env: dict[str, str] | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", *args],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
        env=env,
    )


def test_mrclam_module_help_is_help() -> None:
    r = run_module("bearing_slam.mrclam", "--help")
    assert r.returncode == 0, r.stderr
    assert "usage: bearing-slam mrclam-figures" in r.stdout
    assert "DATA_DIR" in r.stdout


def test_mrclam_figures_without_data_is_one_line(tmp_path: Path) -> None:
    env = {k: v for k, v in os.environ.items() if k != mrclam.DATA_ENV}
    r = run_module("bearing_slam", "mrclam-figures", "--out", str(tmp_path), env=env)
    assert r.returncode == 2
    lines = [line for line in r.stderr.splitlines() if line.strip()]
    assert len(lines) == 1, r.stderr
    assert lines[0].startswith("bearing-slam: error: no MRCLAM data directory")
    assert mrclam.DATA_ENV in lines[0]
    assert not any(tmp_path.iterdir())


ROOT = Path(__file__).resolve().parents[2]


def repository_python_files() -> list[Path]:
    """Every ``.py`` file of the repository outside hidden, build and worktree folders."""
    skip = {"target", "__pycache__"}
    return [
        p
        for p in ROOT.rglob("*.py")
        if not any(
            part.startswith(".") or part in skip or part.startswith("wt-")
            for part in p.relative_to(ROOT).parts[:-1]
        )
    ]


def test_every_python_file_is_type_checked() -> None:
    files = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["mypy"]["files"]
    roots = [ROOT / f for f in files]
    scripts = repository_python_files()
    assert any(p.parent.name == "benches" for p in scripts)
    missed = [p for p in scripts if not any(p.is_relative_to(r) for r in roots)]
    assert not missed, f"not in [tool.mypy] files of pyproject.toml: {missed}"
