"""The replay treatments of MTE-history's correlated waiting bearings
(issue 13 item 2): the Config kwargs, their checks, a run with each, and
the CLI flag."""

from __future__ import annotations

from pathlib import Path

import pytest

import bearing_slam as bs
from bearing_slam.vocabulary import HISTORY_CORRELATIONS
from conftest import cli


def test_names_and_defaults() -> None:
    assert HISTORY_CORRELATIONS == ("none", "whiten", "decimate", "visit-mean")
    c = bs.Config(init="mte-history")
    assert c.history_correlation == "none"
    assert c.history_phi == pytest.approx(0.64)
    assert c.history_sigma is None
    assert c.history_decimate_every == 0


def test_each_treatment_runs_and_reports_what_it_leaves_out(fig4_log: bs.SensorLog) -> None:
    for treatment in HISTORY_CORRELATIONS:
        config = bs.Config.for_log(
            fig4_log, init="mte-history", history_correlation=treatment, history_sigma=0.02
        )
        assert config.to_dict()["history_correlation"] == treatment
        result = bs.run(fig4_log, config)
        kinds = {e["kind"] for e in result.trace.events}
        assert "landmark_initialized" in kinds, treatment
        if treatment == "decimate":
            assert "bearings_discarded" in kinds


def test_bad_values_are_refused() -> None:
    with pytest.raises(ValueError, match="history correlation treatment"):
        bs.Config(init="mte-history", history_correlation="bleach")
    with pytest.raises(bs.InvalidParameterError, match="phi"):
        bs.Config(init="mte-history", history_phi=1.0)
    with pytest.raises(bs.InvalidParameterError, match="history_correlation is not used"):
        bs.Config(init="mte", history_correlation="whiten")


def test_cli_flag_needs_mte_history(tmp_path: Path) -> None:
    log = tmp_path / "fig4.mcap"
    assert cli("simulate", "paper_fig4", "--seed", "3", "--out", log).returncode == 0
    bad = cli("run", log, "--init", "mte", "--history-correlation", "whiten", "--out", tmp_path)
    assert bad.returncode != 0
    assert "--history-correlation applies to --init mte-history" in bad.stderr
