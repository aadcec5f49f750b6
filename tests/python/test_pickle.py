"""Config, SensorLog, Trace and RunResult travel: pickle, copy and a Dask worker process."""

from __future__ import annotations

import copy
import pickle
from typing import Any

import numpy as np
import pytest

import bearing_slam as bs


def same_result(a: bs.RunResult, b: bs.RunResult) -> None:
    assert repr(a.summary) == repr(b.summary)  # NaN prints as nan on both sides
    assert a.config == b.config
    for name in ("time", "estimate", "covariance", "truth", "dead_reckoning", "nees"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
    for x, y in zip(a.landmarks(), b.landmarks(), strict=True):
        np.testing.assert_array_equal(x, y)
    assert a.events == b.events
    assert a.counts == b.counts
    assert len(a.trace) == len(b.trace)
    np.testing.assert_array_equal(a.trace.poses, b.trace.poses)


def test_config_pickles() -> None:
    config = bs.Config(
        "pi-sr-mixed",
        rho_ini=0.2,
        per_landmark_priors={7: (0.01, 0.005)},
        gate_probability=None,
        initial_pose=(1.0, -2.0, 0.3),
    )
    for protocol in range(2, pickle.HIGHEST_PROTOCOL + 1):
        back = pickle.loads(pickle.dumps(config, protocol=protocol))
        assert back == config
        assert back.to_dict() == config.to_dict()
    assert copy.deepcopy(config) == config
    assert pickle.loads(pickle.dumps(config)) != config.replace(rho_ini=0.3)


def test_log_pickles_exactly(fig4_log: bs.SensorLog) -> None:
    back = pickle.loads(pickle.dumps(fig4_log))
    assert back == fig4_log
    assert back.info == fig4_log.info
    np.testing.assert_array_equal(back.bearings, fig4_log.bearings)
    np.testing.assert_array_equal(back.truth, fig4_log.truth)


def test_run_result_and_trace_pickle(fig4_result: bs.RunResult) -> None:
    data = pickle.dumps(fig4_result)
    same_result(pickle.loads(data), fig4_result)
    trace = pickle.loads(pickle.dumps(fig4_result.trace))
    np.testing.assert_array_equal(trace.times, fig4_result.trace.times)
    np.testing.assert_array_equal(trace.pose_covariances, fig4_result.trace.pose_covariances)
    assert trace.events == fig4_result.trace.events


def test_nan_survives(fig4_log: bs.SensorLog) -> None:
    # A run without ground truth has NaN NEES everywhere and no summary (NaN is
    # what JSON would lose): both come back as they were.
    bare = bs.SensorLog.from_arrays(
        wheels=fig4_log.wheels,
        bearings=fig4_log.bearings,
        info={"wheel_base_m": fig4_log.info["wheel_base_m"]},
    )
    no_truth = bs.run(bare)
    assert no_truth.summary is None
    assert np.isnan(no_truth.nees).all()
    back = pickle.loads(pickle.dumps(no_truth))
    assert np.isnan(back.nees).all()
    same_result(back, no_truth)
    assert pickle.loads(pickle.dumps(bare)) == bare


def test_corrupt_pickle_is_a_clear_error(fig4_log: bs.SensorLog) -> None:
    with pytest.raises(ValueError, match="invalid pickled sensor log"):
        bs.SensorLog._from_pickle(b"not cbor")  # type: ignore[attr-defined]


def test_slam_filter_does_not_pickle() -> None:
    # The step-by-step filter has no serialized form (candidates, clones):
    # pickling it fails loudly rather than losing state.
    with pytest.raises(TypeError):
        pickle.dumps(bs.SlamFilter(bs.Config()))


def _ate_on_worker(log: bs.SensorLog, config: bs.Config) -> tuple[bs.RunResult, dict[str, Any]]:
    result = bs.run(log, config)
    assert result.summary is not None
    return result, result.summary


@pytest.mark.slow
def test_through_a_dask_worker_process(
    fig4_log: bs.SensorLog, fig4_result: bs.RunResult, dask_client: Any
) -> None:
    # The log and config go to a worker process (conftest's dask_client), the
    # result comes back: every object crosses the process boundary twice by
    # pickling.
    log_future = dask_client.scatter(fig4_log)
    remote, summary = dask_client.submit(_ate_on_worker, log_future, fig4_result.config).result()
    echoed = dask_client.submit(lambda r: r, fig4_result).result()
    same_result(remote, fig4_result)
    same_result(echoed, fig4_result)
    assert summary["ate_rmse_m"] == fig4_result.summary["ate_rmse_m"]  # type: ignore[index]
