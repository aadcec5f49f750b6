"""Acoustic bearings (bearing_slam.acoustics, pyroomacoustics): DOA within a
stated error in a clean room, the log they make, and Fig. 10 with them
beating dead reckoning."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import bearing_slam as bs
from bearing_slam import acoustics, cli
from bearing_slam.acoustics import DOA_METHODS, AcousticSetup
from bearing_slam.fig10_acoustic import run_fig10_acoustic, write_fig10_acoustic

#: In a clean room (almost anechoic, high SNR) every method's bearing is within
#: this of the truth (the grid is 1°).
CLEAN_ROOM_MAX_ERROR_DEG = 3.0


@pytest.fixture(scope="module")
def oval_log() -> bs.SensorLog:
    return bs.simulate("single_source_oval", seed=1, duration=12.0)


def test_doa_is_accurate_in_a_clean_room(oval_log: bs.SensorLog) -> None:
    setup = AcousticSetup(absorption=0.95, max_order=1, snr_db=30.0, every=10)
    doa = acoustics.simulate_doa(oval_log, setup)
    assert len(doa.times) >= 10
    for method in DOA_METHODS:
        err = np.degrees(np.abs(doa.errors(method)))
        assert err.max() < CLEAN_ROOM_MAX_ERROR_DEG, (method, err.max())
        stats = acoustics.doa_error_stats(doa.errors(method))
        assert stats["outlier_rate"] == 0.0
        assert abs(stats["bias_deg"]) < 1.5


def test_true_bearings_match_the_simulator(oval_log: bs.SensorLog) -> None:
    b = oval_log.bearings
    truth = acoustics.true_bearings(oval_log, b[:, 0], b[:, 1].astype(np.int64))
    # The simulator's bearings are the truth plus σ = 7.5° noise.
    err = np.degrees(np.angle(np.exp(1j * (b[:, 2] - truth))))
    assert abs(err.mean()) < 2.0
    assert 5.0 < err.std() < 10.0


def test_acoustic_log_replaces_only_the_bearings(oval_log: bs.SensorLog) -> None:
    setup = AcousticSetup(every=20)
    doa = acoustics.simulate_doa(oval_log, setup, methods=["SRP"])
    log = acoustics.acoustic_log(oval_log, doa, "SRP")
    np.testing.assert_array_equal(log.truth, oval_log.truth)
    np.testing.assert_array_equal(log.wheels, oval_log.wheels)
    np.testing.assert_array_equal(log.bearings[:, 2], doa.bearings["SRP"])
    assert len(log.bearings) == len(np.unique(oval_log.bearings[:, 0])[::20])
    assert log.info["bearing_sigma_rad"] == setup.bearing_sigma_rad
    assert bs.Config.for_log(log).bearing_sigma == setup.bearing_sigma_rad
    with pytest.raises(ValueError, match="no 'MUSIC' bearings"):
        acoustics.acoustic_log(oval_log, doa, "MUSIC")


def test_bad_setups_are_refused(oval_log: bs.SensorLog) -> None:
    with pytest.raises(ValueError, match="n_mics"):
        acoustics.simulate_doa(oval_log, AcousticSetup(n_mics=2))
    with pytest.raises(ValueError, match="unknown DOA method"):
        acoustics.simulate_doa(oval_log, AcousticSetup(), methods=["ESPRIT"])
    with pytest.raises(ValueError, match="ground truth"):
        acoustics.simulate_doa(bs.SensorLog.from_arrays(), AcousticSetup())


def test_error_stats_count_outliers_and_front_back() -> None:
    e = np.radians([1.0, -1.0, 3.0, 179.0, 45.0])
    s = acoustics.doa_error_stats(e)
    assert s["n"] == 5
    assert s["outlier_rate"] == pytest.approx(0.4)
    assert s["front_back_rate"] == pytest.approx(0.2)
    assert s["bias_deg"] == pytest.approx(1.0)
    assert math.isnan(acoustics.doa_error_stats(np.zeros(0))["bias_deg"])


@pytest.mark.slow
def test_fig10_with_acoustic_bearings_beats_dead_reckoning(tmp_path: Path) -> None:
    result = run_fig10_acoustic(
        1,
        seed0=2,
        methods=["NormMUSIC"],
        scenarios=["single_source_oval"],
        slips=[True],
        duration=50.0,
    )
    (config,) = result["configs"]
    ate = {k: v["ate_m"] for k, v in config["methods"].items()}
    assert ate["MTE acoustic NormMUSIC"] < ate["dead reckoning"], ate
    paths = write_fig10_acoustic(result, tmp_path)
    assert [p.name for p in paths] == [
        "fig10_acoustic.md",
        "fig10_acoustic.json",
        "fig10_acoustic.png",
        "acoustics.md",
    ]
    assert "| NormMUSIC |" in (tmp_path / "acoustics.md").read_text()


def test_cli_acoustic_bearings_need_fig10(capsys: pytest.CaptureFixture[str]) -> None:
    assert cli.main(["experiment", "fig5", "--bearings", "acoustic", "--quiet"]) == 2
    assert "fig10 experiment only" in capsys.readouterr().err
