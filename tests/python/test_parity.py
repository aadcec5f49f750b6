"""The bindings give the Rust numbers: the step-by-step filter driven from
Python agrees bit for bit with ``run()`` (the Rust loop), runs are
deterministic, and the summary matches the metrics recomputed from the arrays."""

from __future__ import annotations

import json

import numpy as np
import pytest

import bearing_slam as bs


def replay(log: bs.SensorLog, config: bs.Config) -> tuple[list[float], np.ndarray, np.ndarray]:
    """Runs a wheel-odometry log through ``SlamFilter`` the way the Rust runner
    does, event by event in log order: wheels predict, scans update, ground
    truth records the estimate."""
    start = log.info["initial_pose"]
    filt = bs.SlamFilter(config.replace(initial_pose=(start["x"], start["y"], start["theta"])))
    times: list[float] = []
    poses: list[np.ndarray] = []
    covs: list[np.ndarray] = []
    started = False
    for event in json.loads(log.to_json())["events"]:
        t, kind, data = event["time"], event["kind"]["kind"], event["kind"]["data"]
        if kind == "wheels":
            filt.predict_wheels(t, data["left_m"], data["right_m"])
            started = True
        elif kind == "bearings":
            ids = np.array([o["landmark_id"] for o in data], dtype=np.uint64)
            filt.update_bearings(t, ids, np.array([o["bearing"] for o in data]))
            started = True
        elif kind == "ground_truth" and (started or t <= 0.0):
            times.append(t)
            poses.append(filt.pose)
            covs.append(filt.pose_covariance)
    return times, np.array(poses), np.array(covs)


@pytest.mark.parametrize("init", ["mte", "mte-clone", "pi-sr"])
def test_step_by_step_filter_equals_run_bit_for_bit(fig4_log: bs.SensorLog, init: str) -> None:
    config = bs.Config.for_log(fig4_log, init=init)
    result = bs.run(fig4_log, config)
    times, poses, covs = replay(fig4_log, config)
    assert len(times) == len(result.time) > 100
    np.testing.assert_array_equal(np.array(times), result.time)
    np.testing.assert_array_equal(poses, result.estimate)
    np.testing.assert_array_equal(covs, result.covariance)


def test_simulation_and_run_are_deterministic(fig4_log: bs.SensorLog) -> None:
    again = bs.simulate("paper_fig4", seed=3)
    assert again == fig4_log
    assert bs.simulate("paper_fig4", seed=4) != fig4_log
    r1 = bs.run(fig4_log, bs.Config.for_log(fig4_log))
    r2 = bs.run(again, bs.Config.for_log(again))
    assert r1.summary == r2.summary
    np.testing.assert_array_equal(r1.estimate, r2.estimate)


def test_json_round_trip_is_exact(fig4_log: bs.SensorLog) -> None:
    back = bs.SensorLog.from_json(fig4_log.to_json())
    assert back == fig4_log
    np.testing.assert_array_equal(back.truth, fig4_log.truth)


def test_summary_matches_metrics_from_arrays(
    fig4_log: bs.SensorLog, fig4_result: bs.RunResult
) -> None:
    s = fig4_result.summary
    assert s is not None
    a = bs.ate(fig4_result.estimate, fig4_result.truth)
    assert a["rmse_m"] == s["ate_rmse_m"]
    assert a["final_position_m"] == s["final_position_error_m"]
    assert np.degrees(a["final_heading_rad"]) == pytest.approx(s["final_heading_error_deg"])
    dr = bs.ate(fig4_result.dead_reckoning, fig4_result.truth)
    assert dr["rmse_m"] == s["dead_reckoning_ate_rmse_m"]
    nees = fig4_result.nees
    assert np.nanmean(nees) == pytest.approx(s["mean_nees_pose"], rel=1e-12)
    ids, pos, cov = fig4_result.landmarks()
    truth = {int(r[0]): r[1:] for r in fig4_log.landmarks}
    err = np.array([pos[k] - truth[int(i)] for k, i in enumerate(ids)])
    assert np.sqrt(np.mean(np.sum(err**2, axis=1))) == pytest.approx(s["landmark_rmse_m"])
    assert s["n_landmarks_initialized"] == len(ids) == 5
    assert cov.shape == (5, 2, 2)


def test_mte_beats_dead_reckoning_on_fig4(fig4_result: bs.RunResult) -> None:
    s = fig4_result.summary
    assert s is not None
    assert s["finite"]
    assert s["diverged"] is False
    assert s["diverged_at_s"] is None
    assert s["ate_rmse_m"] < s["dead_reckoning_ate_rmse_m"]
    assert 0.0 < s["mean_nees_pose"] < 20.0
    assert fig4_result.counts["landmarks_initialized"] == 5


def test_log_arrays_have_documented_shapes(fig4_log: bs.SensorLog) -> None:
    assert fig4_log.wheels.shape[1] == 3
    assert fig4_log.velocity.shape[1] == 4
    assert fig4_log.bearings.shape[1] == 3
    assert fig4_log.ranges.shape == (fig4_log.bearings.shape[0],)
    assert fig4_log.truth.shape[1] == 4
    assert fig4_log.landmarks.shape == (5, 3)
    assert fig4_log.times.shape == (len(fig4_log),)
    assert np.all(np.diff(fig4_log.times) >= 0)
    assert fig4_log.wheels.dtype == np.float64
    assert fig4_log.bearing_ids.dtype == np.uint64
    np.testing.assert_array_equal(fig4_log.bearing_ids, fig4_log.bearings[:, 1])


def test_from_arrays_builds_a_runnable_log(fig4_log: bs.SensorLog) -> None:
    log = bs.SensorLog.from_arrays(
        wheels=fig4_log.wheels,
        bearings=fig4_log.bearings,
        truth=fig4_log.truth,
        landmarks=fig4_log.landmarks,
        info=fig4_log.info,
    )
    a = bs.run(log, bs.Config.for_log(log))
    b = bs.run(fig4_log, bs.Config.for_log(fig4_log))
    # Same streams in the simulator's order at equal times (velocity left out,
    # the wheel run ignores it): the same run, bit for bit.
    assert a.summary == b.summary
    np.testing.assert_array_equal(a.estimate, b.estimate)


def test_from_arrays_rows_at_one_time_form_one_scan_wherever_they_stand() -> None:
    rows = [[1.0, 1, 0.1], [2.0, 2, 0.2], [1.0, 3, 0.3]]
    log = bs.SensorLog.from_arrays(wheels=[[0.0, 0.0, 0.0]], bearings=rows, ranges=[1.0, 2.0, 3.0])
    assert len(log) == 3  # the wheels, the scan at 1 s (ids 1 and 3), the scan at 2 s
    np.testing.assert_array_equal(log.bearings, [[1.0, 1, 0.1], [1.0, 3, 0.3], [2.0, 2, 0.2]])
    np.testing.assert_array_equal(log.ranges, [1.0, 3.0, 2.0])
    with pytest.raises(bs.DuplicateMeasurementError, match="landmark id 1"):
        bs.run(
            bs.SensorLog.from_arrays(
                wheels=[[0.0, 0.0, 0.0]], bearings=[[1.0, 1, 0.1], [2.0, 2, 0.2], [1.0, 1, 0.3]]
            ),
            bs.Config(),
        )


def test_config_defaults_are_the_papers() -> None:
    """The default initializer is ``auto`` (the paper's MTE wherever no
    landmark's visit ends untriangulated), every parameter the paper's."""
    c = bs.Config()
    assert c.init == "auto" == bs.vocabulary.DEFAULT_INIT
    assert c.auto_visits == 1
    assert c.auto_stalled_parallax is True
    assert c.auto_insignificant_parallax is True
    assert c.conversion_depth_linearity is True
    assert c.auto_max_wait is None
    assert (c.rho_ini, c.sigma_rho) == (0.5, 0.25)
    assert c.alpha_min == pytest.approx(np.radians(10.0))
    assert c.beta_min == pytest.approx(np.radians(20.0))
    assert c.baseline_min == 1.0
    assert c.candidate_timeout == 5.0
    assert c.min_depth == 0.1
    assert c.bearing_sigma == pytest.approx(np.radians(1.0))
    assert c.gate_probability == 0.999
    d = c.to_dict()
    assert d["odometry"] == "wheels"
    assert bs.Config(**{k: v for k, v in d.items() if k != "init"}) == c
    assert c.replace(rho_ini=0.01).rho_ini == 0.01
    with pytest.raises(TypeError, match="no parameter"):
        bs.Config(bogus=1)


def test_symmetric_covariance_update_matches_joseph(fig4_log: bs.SensorLog) -> None:
    """The faster optimal-gain update runs the same filter to rounding."""
    joseph_config = bs.Config.for_log(fig4_log, init="mte")
    joseph_config.covariance_update = "joseph"
    joseph = bs.run(fig4_log, joseph_config)
    config = bs.Config.for_log(fig4_log, init="mte", covariance_update="symmetric")
    assert config.covariance_update == "symmetric"
    symmetric = bs.run(fig4_log, config)
    assert not np.array_equal(joseph.trace.pose_covariances, symmetric.trace.pose_covariances)
    np.testing.assert_allclose(symmetric.trace.poses, joseph.trace.poses, rtol=0, atol=1e-9)
    np.testing.assert_allclose(
        symmetric.trace.pose_covariances, joseph.trace.pose_covariances, rtol=1e-8, atol=1e-15
    )


def test_auto_enters_landmarks_undelayed_when_the_bearing_noise_decides_the_parallax() -> None:
    """On ``paper_fig8`` (σ_z = 5° > 10°/(3√2)) the default enters every landmark at
    its first sighting, undelayed; with the rule and the kept first ray off it is the
    paper's MTE to the bit, which triangulates some of them from noise at the very
    start."""
    log = bs.simulate("paper_fig8", 0, landmark_count=10)
    default = bs.run(log, bs.Config.for_log(log))
    entries = [e for e in default.events if e["kind"] == "landmark_initialized"]
    assert len(entries) == 10
    assert {e["method"] for e in entries} == {"pi_sr"}
    assert not [e for e in default.events if e["kind"] == "candidate_created"]
    off = bs.run(
        log,
        bs.Config.for_log(log, auto_insignificant_parallax=False, auto_keep_first_ray=False),
    )
    mte = bs.run(log, bs.Config.for_log(log, init="mte"))
    np.testing.assert_array_equal(off.estimate, mte.estimate)
    first = min(e["time"] for e in mte.events if e["kind"] == "landmark_initialized")
    assert first < 1.0
    assert default.summary is not None
    assert mte.summary is not None
    assert default.summary["ate_rmse_m"] < mte.summary["ate_rmse_m"]
    # A parameter of auto only: refused with another initializer.
    with pytest.raises(ValueError, match="auto_insignificant_parallax"):
        bs.Config(init="mte", auto_insignificant_parallax=False)
