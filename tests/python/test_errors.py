"""Every error kind raises its own class, with the Rust message; bad shapes
and dtypes raise TypeError/ValueError, never crash."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import bearing_slam as bs


@pytest.fixture
def filt() -> bs.SlamFilter:
    f = bs.SlamFilter(bs.Config(initial_pose_sigma=(0.01, 0.01, 0.01)))
    f.predict_wheels(0.1, 0.05, 0.05)
    return f


def test_hierarchy() -> None:
    for name in [
        "NonFiniteError",
        "InvalidNoiseError",
        "InvalidParameterError",
        "DimensionMismatchError",
        "UnknownLandmarkError",
        "DuplicateMeasurementError",
        "NotPositiveDefiniteError",
        "LandmarkAtInfinityError",
        "DegenerateGeometryError",
        "DivergedError",
        "TimeOrderError",
        "MismatchError",
        "SimulationError",
        "McapError",
        "DatasetError",
    ]:
        cls = getattr(bs, name)
        assert issubclass(cls, bs.BearingSlamError), name
        assert cls.__module__ == "bearing_slam"
    assert issubclass(bs.UnknownLandmarkError, KeyError)
    assert issubclass(bs.TimeOrderError, ValueError)
    assert issubclass(bs.NonFiniteError, ValueError)


def test_nan_bearing(filt: bs.SlamFilter) -> None:
    with pytest.raises(bs.NonFiniteError, match="non-finite bearing"):
        filt.update_bearings(0.2, [1], [np.nan])


def test_unknown_landmark(filt: bs.SlamFilter) -> None:
    with pytest.raises(bs.UnknownLandmarkError, match="unknown landmark id 42") as e:
        filt.landmark(42)
    assert str(e.value) == "unknown landmark id 42"  # no KeyError quoting
    with pytest.raises(KeyError):
        filt.remove_landmark(42)


def test_time_backwards(filt: bs.SlamFilter) -> None:
    with pytest.raises(bs.TimeOrderError, match="time went backwards"):
        filt.predict_wheels(0.05, 0.01, 0.01)
    with pytest.raises(ValueError, match="backwards"):
        filt.update_bearings(0.0, [1], [0.1])


def test_duplicate_measurement(filt: bs.SlamFilter) -> None:
    with pytest.raises(bs.DuplicateMeasurementError):
        filt.update_bearings(0.2, [3, 3], [0.1, 0.2])


def test_diverged(filt: bs.SlamFilter) -> None:
    with pytest.raises(bs.DivergedError):
        filt.predict_wheels(0.2, 1e300, 1e300)


def test_invalid_config() -> None:
    with pytest.raises(bs.InvalidNoiseError):
        bs.Config(bearing_sigma=-1.0)
    with pytest.raises(bs.InvalidParameterError):
        bs.Config(init="pi-sr", rho_ini=0.0)
    with pytest.raises(bs.InvalidParameterError):
        bs.Config(alpha_min=0.0)
    with pytest.raises(bs.InvalidParameterError, match="history"):
        bs.Config(init="mte", history=8)
    assert bs.Config(init="mte-clone", history=8).history == 8
    with pytest.raises(bs.InvalidParameterError):
        bs.Config(wheel_base=-0.2)
    with pytest.raises(ValueError, match="unknown initializer"):
        bs.Config(init="ekf")
    with pytest.raises(ValueError, match="unknown odometry"):
        bs.Config(odometry="legs")
    with pytest.raises(ValueError, match="unknown covariance update"):
        bs.Config(covariance_update="cholesky")


def test_metrics_errors() -> None:
    with pytest.raises(bs.NotPositiveDefiniteError):
        bs.nees([1.0, 0.0], [[-1.0, 0.0], [0.0, 1.0]])
    with pytest.raises(bs.DimensionMismatchError):
        bs.ate(np.zeros((3, 3)), np.zeros((4, 3)))
    with pytest.raises(bs.InvalidParameterError):
        bs.chi2_quantile(3.0, 1.5)
    with pytest.raises(ValueError, match="shape"):
        bs.nees([1.0, 0.0], np.eye(3))


def test_degenerate_and_infinity() -> None:
    with pytest.raises(bs.DegenerateGeometryError):
        bs.models.bearing_to_point([1.0, 2.0, 0.0], [1.0, 2.0])
    with pytest.raises(bs.DegenerateGeometryError):
        bs.models.inverse_depth_to_point([0.0, 0.0, 0.0, -1.0])


def test_no_ground_truth_is_a_mismatch() -> None:
    log = bs.SensorLog.from_arrays(
        wheels=[[0.1, 0.01, 0.01]], bearings=[[0.1, 1, 0.2]], info={"wheel_base_m": 0.2}
    )
    result = bs.run(log)
    assert result.summary is None
    with pytest.raises(bs.MismatchError):
        bs.Config.for_log(bs.SensorLog.from_arrays(wheels=[[0.1, 0.01, 0.01]]))


def test_bad_landmark_truth_and_head() -> None:
    wheels = [[0.0, 0.0, 0.0], [0.1, 0.01, 0.01]]
    with pytest.raises(bs.NonFiniteError, match="landmark truth x"):
        bs.SensorLog.from_arrays(wheels=wheels, landmarks=[[1, np.nan, 0.0]])
    with pytest.raises(bs.InvalidParameterError, match="landmark truth id = 1"):
        bs.SensorLog.from_arrays(wheels=wheels, landmarks=[[1, 0.0, 0.0], [1, 2.0, 1.0]])
    log = bs.SensorLog.from_arrays(wheels=wheels, landmarks=[[1, 0.0, 0.0], [2, 2.0, 1.0]])
    assert len(log.head(0.05)) == 1
    for seconds in (float("nan"), -1.0, float("inf")):
        with pytest.raises(bs.InvalidParameterError, match="head"):
            log.head(seconds)


def test_bad_shapes_and_dtypes(filt: bs.SlamFilter) -> None:
    with pytest.raises(ValueError, match="differ in length"):
        filt.update_bearings(0.2, [1, 2], [0.1])
    with pytest.raises(TypeError, match="integers"):
        filt.update_bearings(0.2, [1.5], [0.1])
    with pytest.raises(TypeError):
        filt.update_bearings(0.2, ["a"], [0.1])
    with pytest.raises(ValueError, match="non-negative"):
        filt.update_bearings(0.2, np.array([-1]), [0.1])
    with pytest.raises(ValueError, match="one-dimensional"):
        filt.update_bearings(0.2, np.array([[1]]), [0.1])
    with pytest.raises((TypeError, ValueError)):
        filt.update_bearings(0.2, [1], [[0.1]])
    with pytest.raises(ValueError, match=r"shape \(3,\)"):
        bs.models.bearing_to_point([0.0, 0.0], [1.0, 1.0])
    with pytest.raises((TypeError, ValueError)):
        bs.models.bearing_to_point("abc", [1.0, 1.0])
    with pytest.raises(ValueError, match=r"\(n, 3\)"):
        bs.ate(np.zeros((3, 2)), np.zeros((3, 2)))
    with pytest.raises(TypeError):
        bs.SlamFilter(bs.Config()).predict_wheels("now", 0.1, 0.1)  # type: ignore[arg-type]
    # Accepted: uint64, int32 and lists of ints.
    filt.update_bearings(0.2, np.array([1], dtype=np.uint64), [0.1])
    filt.update_bearings(0.3, np.array([1], dtype=np.int32), np.array([0.1], dtype=np.float32))


def test_unknown_scenario() -> None:
    with pytest.raises(bs.SimulationError, match="unknown scenario"):
        bs.simulate("no_such_scenario")
    with pytest.raises(bs.SimulationError):
        bs.simulate("missing_file.toml")
    with pytest.raises(bs.SimulationError, match="no random landmarks"):
        bs.simulate("paper_fig4", landmark_count=3)


def test_corrupt_and_missing_mcap(tmp_path: Path) -> None:
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(b"this is not an mcap file at all")
    with pytest.raises(bs.McapError):
        bs.read_mcap(bad)
    with pytest.raises(bs.McapError):
        bs.read_mcap(tmp_path / "missing.mcap")


def test_missing_dataset(tmp_path: Path) -> None:
    with pytest.raises(bs.DatasetError, match="does not exist"):
        bs.load_mrclam(tmp_path / "nope", 1)
    with pytest.raises(bs.DatasetError, match="robot number"):
        bs.load_mrclam(tmp_path, 9)
