"""Type stubs of the native module (pyo3). Arrays are float64 unless noted."""

import os
from collections.abc import Callable, Iterable, Sequence
from typing import Any, final

import numpy as np
from numpy.typing import ArrayLike, NDArray

_F64 = NDArray[np.float64]
_U64 = NDArray[np.uint64]
_Path = str | os.PathLike[str]
_LandmarkArrays = tuple[NDArray[np.uint64], NDArray[np.float64], NDArray[np.float64]]
_MotionOut = tuple[
    NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]
]

__all__ = [
    "BearingSlamError",
    "Config",
    "DatasetError",
    "DegenerateGeometryError",
    "DimensionMismatchError",
    "DivergedError",
    "DuplicateMeasurementError",
    "EkfBenchmark",
    "InvalidNoiseError",
    "InvalidParameterError",
    "LandmarkAtInfinityError",
    "McapError",
    "MismatchError",
    "NonFiniteError",
    "NotPositiveDefiniteError",
    "RunResult",
    "SensorLog",
    "SimulationError",
    "SlamFilter",
    "TimeOrderError",
    "Trace",
    "UnknownLandmarkError",
    "UpdateReport",
    "__version__",
    "association_oracle",
    "ate",
    "bearing_to_inverse_depth",
    "bearing_to_point",
    "chi2_interval",
    "chi2_quantile",
    "diff_drive",
    "evaluate_mrclam",
    "inverse_depth_to_point",
    "inverse_range_bearing",
    "linearity_index",
    "load_mrclam",
    "nees",
    "nees_summary",
    "nis",
    "odometry",
    "odometry_increment",
    "pi_sr_init",
    "pose_nees",
    "range_bearing",
    "read_mcap",
    "rpe",
    "run",
    "scenario_names",
    "scenario_toml",
    "simulate",
    "smooth",
    "triangulate",
    "triangulation_init",
    "velocity",
    "wrap_angle",
    "write_mcap",
]

__version__: str

class BearingSlamError(Exception): ...
class NonFiniteError(BearingSlamError, ValueError): ...
class InvalidNoiseError(BearingSlamError, ValueError): ...
class InvalidParameterError(BearingSlamError, ValueError): ...
class DimensionMismatchError(BearingSlamError, ValueError): ...
class UnknownLandmarkError(BearingSlamError, KeyError): ...
class DuplicateMeasurementError(BearingSlamError, ValueError): ...
class NotPositiveDefiniteError(BearingSlamError, ValueError): ...
class LandmarkAtInfinityError(BearingSlamError): ...
class DegenerateGeometryError(BearingSlamError, ValueError): ...
class DivergedError(BearingSlamError): ...
class TimeOrderError(BearingSlamError, ValueError): ...
class MismatchError(BearingSlamError, ValueError): ...
class SimulationError(BearingSlamError): ...
class McapError(BearingSlamError): ...
class DatasetError(BearingSlamError): ...

@final
class Config:
    init: str
    bearing_sigma: float
    range_sigma: float
    initial_pose: tuple[float, float, float]
    initial_pose_sigma: tuple[float, float, float]
    gate_probability: float | None
    conversion_threshold: float | None
    conversion_depth_linearity: bool
    covariance_update: str
    update: str
    consistency: str
    update_iterations: int
    second_order: bool
    alpha_min: float
    baseline_min: float
    beta_min: float
    candidate_timeout: float
    min_depth: float
    history: int
    # The waiting bearings' correlation (issue 13 item 2): "none", "whiten",
    # "decimate", "visit-mean"; AR(1) φ, σ (None: bearing_sigma), decimation.
    history_correlation: str
    history_phi: float
    history_sigma: float | None
    history_decimate_every: int
    auto_visits: int
    auto_max_wait: float | None
    auto_stalled_parallax: bool
    auto_insignificant_parallax: bool
    auto_keep_first_ray: bool
    rho_ini: float
    sigma_rho: float
    per_landmark_priors: dict[int, tuple[float, float]]
    odometry: str
    wheel_base: float
    wheel_floor_sigma: float
    wheel_scale_sqrt: float
    velocity_alpha: tuple[float, float, float, float, float, float]
    velocity_sigma_v_min: float
    velocity_sigma_omega_min: float
    use_range: bool
    # The estimator (issues 13, 14, 15): "filter", "smoother", "filter+smoother",
    # "fastslam1", "fastslam2", "gaussian-sum"; particles of FastSLAM; the
    # heading Gaussian sum's split threshold (degrees) and size.
    estimator: str
    particles: int
    gaussian_sum_split_deg: float
    gaussian_sum_components: int
    # The online smoother ("filter+smoother" only): its window ("keyframes",
    # the default, or "scans") and landmark chart ("inverse-depth", "point").
    online_window: str
    landmark_chart: str
    # Data association (issue 16): "known", "nn", "jcbb", "ransac" (1-point
    # RANSAC) (ids hidden: the filter takes all three, FastSLAM "nn" only,
    # per-particle maximum likelihood; the smoothers all three, the EKF as
    # their front end); the appearance descriptors'
    # noise σ (None: descriptors ignored; hidden ids only); the EKF's
    # moving-object removal (windowed NIS factor, pairing ratio, and
    # whether the removed movers are remembered; off by default).
    association: str
    descriptor_sigma: float | None
    moving_object_nis_factor: float | None
    moving_object_pair_ratio: float | None
    remember_movers: bool
    # Robustness on a real camera (issue 13 item 3): robust gating and the
    # bearing-offset state, all off (None) by default.
    readmit_after: int | None
    huber_threshold: float | None
    bearing_offset_sigma: float | None
    bearing_offset_initial_sigma: float
    def __new__(cls, init: str | None = None, **kwargs: Any) -> Config: ...
    @staticmethod
    def for_log(log: SensorLog, init: str | None = None, **kwargs: Any) -> Config: ...
    def replace(self, **kwargs: Any) -> Config: ...
    def validate(self) -> None: ...
    def to_dict(self) -> dict[str, Any]: ...
    def __eq__(self, other: object, /) -> bool: ...
    def __copy__(self) -> Config: ...
    def __deepcopy__(self, memo: Any, /) -> Config: ...
    def __getstate__(self) -> dict[str, Any]: ...
    def __setstate__(self, state: dict[str, Any], /) -> None: ...

@final
class SensorLog:
    @staticmethod
    def from_arrays(
        *,
        wheels: ArrayLike | None = None,
        velocity: ArrayLike | None = None,
        bearings: ArrayLike | None = None,
        ranges: ArrayLike | None = None,
        truth: ArrayLike | None = None,
        landmarks: ArrayLike | None = None,
        info: dict[str, Any] | None = None,
    ) -> SensorLog: ...
    def __len__(self) -> int: ...
    def __eq__(self, other: object, /) -> bool: ...
    @property
    def duration(self) -> float: ...
    @property
    def times(self) -> _F64: ...
    @property
    def wheels(self) -> _F64: ...
    @property
    def velocity(self) -> _F64: ...
    @property
    def bearings(self) -> _F64: ...
    @property
    def ranges(self) -> _F64: ...
    @property
    def bearing_ids(self) -> _U64: ...
    @property
    def descriptors(self) -> _F64: ...
    @property
    def truth(self) -> _F64: ...
    @property
    def landmarks(self) -> _F64: ...
    @property
    def info(self) -> dict[str, Any]: ...
    def to_json(self) -> str: ...
    @staticmethod
    def from_json(text: str) -> SensorLog: ...
    def head(self, seconds: float) -> SensorLog: ...
    def __reduce__(self) -> tuple[Callable[[bytes], SensorLog], tuple[bytes]]: ...

@final
class UpdateReport:
    @property
    def used(self) -> int: ...
    @property
    def rejected(self) -> int: ...
    @property
    def initialized(self) -> int: ...
    @property
    def nis(self) -> float: ...

@final
class SlamFilter:
    def __new__(cls, config: Config | None = None) -> SlamFilter: ...
    @property
    def config(self) -> Config: ...
    def predict_wheels(self, time: float, left_m: float, right_m: float) -> None: ...
    def predict_velocity(self, time: float, v: float, omega: float, dt: float) -> None: ...
    def update_bearings(self, time: float, ids: ArrayLike, bearings: ArrayLike) -> UpdateReport: ...
    def update_range_bearings(
        self, time: float, ids: ArrayLike, ranges: ArrayLike, bearings: ArrayLike
    ) -> UpdateReport: ...
    @property
    def time(self) -> float | None: ...
    @property
    def pose(self) -> _F64: ...
    @property
    def pose_covariance(self) -> _F64: ...
    @property
    def state(self) -> _F64: ...
    @property
    def covariance(self) -> _F64: ...
    @property
    def landmark_ids(self) -> _U64: ...
    @property
    def candidate_count(self) -> int: ...
    def landmark(self, id: int) -> tuple[_F64, _F64, str, str]: ...
    def landmarks(self) -> _LandmarkArrays: ...
    @property
    def events(self) -> list[dict[str, Any]]: ...
    def snapshot(self) -> dict[str, Any]: ...
    def remove_landmark(self, id: int) -> None: ...
    def copy(self) -> SlamFilter: ...
    def __copy__(self) -> SlamFilter: ...
    def __deepcopy__(self, memo: Any, /) -> SlamFilter: ...

@final
class EkfBenchmark:
    """THE benchmark problem's EKF step (BENCHMARK.md) on the library's Ekf."""

    def __new__(
        cls,
        x0: ArrayLike,
        p0: ArrayLike,
        ids: ArrayLike,
        sigma_v: float,
        sigma_w: float,
        dt: float,
        sigma_bearing: float,
        symmetric: bool = False,
        update: str = "full",
    ) -> EkfBenchmark: ...
    def observe(self, ids: ArrayLike) -> None: ...
    def step(self, u: tuple[float, float], z: ArrayLike) -> None: ...
    def run(self, controls: ArrayLike, z: ArrayLike) -> None: ...
    @property
    def mean(self) -> _F64: ...
    @property
    def covariance(self) -> _F64: ...
    @property
    def symmetric(self) -> bool: ...
    @property
    def update(self) -> str: ...
    @property
    def dim(self) -> int: ...

@final
class Trace:
    def __len__(self) -> int: ...
    @property
    def times(self) -> _F64: ...
    @property
    def poses(self) -> _F64: ...
    @property
    def pose_covariances(self) -> _F64: ...
    @property
    def events(self) -> list[dict[str, Any]]: ...
    def snapshot(self, index: int) -> dict[str, Any]: ...
    def final_landmarks(self) -> _LandmarkArrays: ...
    # Issue 15: FastSLAM's recorded clouds.
    def particle_clouds(self) -> list[dict[str, Any]]: ...
    def __reduce__(self) -> tuple[Callable[[bytes], Trace], tuple[bytes]]: ...

@final
class RunResult:
    @property
    def summary(self) -> dict[str, Any] | None: ...
    @property
    def config(self) -> Config: ...
    @property
    def time(self) -> _F64: ...
    @property
    def estimate(self) -> _F64: ...
    @property
    def covariance(self) -> _F64: ...
    @property
    def truth(self) -> _F64: ...
    @property
    def dead_reckoning(self) -> _F64: ...
    @property
    def nees(self) -> _F64: ...
    def landmarks(self) -> _LandmarkArrays: ...
    @property
    def events(self) -> list[dict[str, Any]]: ...
    @property
    def counts(self) -> dict[str, int]: ...
    @property
    def association(self) -> dict[str, Any] | None: ...
    def __reduce__(
        self,
    ) -> tuple[Callable[[bytes, Config], RunResult], tuple[bytes, Config]]: ...
    @property
    def trace(self) -> Trace: ...

def run(
    log: SensorLog,
    config: Config | None = None,
    *,
    on_scan: Callable[[dict[str, Any]], object] | None = None,
) -> RunResult: ...
def smooth(log: SensorLog, config: Config | None = None) -> RunResult: ...
def scenario_names() -> list[str]: ...
def simulate(
    scenario: _Path,
    seed: int | None = None,
    *,
    landmark_count: int | None = None,
    far_landmark: bool = True,
    slip: bool | None = None,
    bearing_sigma: float | None = None,
    fov: float | None = None,
    encoder_noise: float | None = None,
    duration: float | None = None,
    clutter: float | None = None,
    descriptor_sigma: float | None = None,
    descriptor_confusion: float = 0.0,
) -> SensorLog: ...
def scenario_toml(scenario: _Path, seed: int | None = None) -> str: ...
def write_mcap(
    path: _Path,
    log: SensorLog,
    result: RunResult | Trace | None = None,
    *,
    snapshot_every: float = 0.0,
    compression: str = "zstd",
) -> None: ...
def read_mcap(path: _Path) -> tuple[SensorLog, Trace | None, list[str]]: ...
def load_mrclam(
    dataset_dir: _Path, robot: int, start: float | None = None, end: float | None = None
) -> tuple[SensorLog, dict[str, Any]]: ...
def evaluate_mrclam(
    dataset_dir: _Path,
    robot: int,
    method: str | None = None,
    start: float | None = None,
    end: float | None = None,
    estimator: str = "filter",
    particles: int | None = None,
    *,
    on_scan: Callable[[dict[str, Any]], object] | None = None,
    association: str = "known",
    online_window: str | None = None,
    landmark_chart: str | None = None,
    auto_visits: int | None = None,
    auto_max_wait: float | None = None,
    auto_stalled_parallax: bool | None = None,
    auto_insignificant_parallax: bool | None = None,
    auto_keep_first_ray: bool | None = None,
    second_order: bool | None = None,
    conversion_depth_linearity: bool | None = None,
) -> tuple[RunResult, dict[str, Any], SensorLog]: ...
def vocabulary() -> dict[str, Any]: ...

# issue 17: monocular SLAM on image sequences (wrapped by bearing_slam.mono).
def mono_run(
    frames_dir: _Path,
    calib: _Path | None = None,
    config_json: str | None = None,
    mcap: _Path | None = None,
) -> dict[str, Any]: ...
def mono_render(out_dir: _Path, config_json: str | None = None) -> int: ...
def mono_motion_noise(
    frames_dir: _Path, velocity_frame_json: str, calib: _Path | None = None
) -> tuple[float, float]: ...
def ate(estimate: ArrayLike, truth: ArrayLike, align: bool = False) -> dict[str, Any]: ...
def rpe(estimate: ArrayLike, truth: ArrayLike, delta: int = 1) -> dict[str, Any]: ...
def nees(error: ArrayLike, covariance: ArrayLike) -> float: ...
def pose_nees(estimate: ArrayLike, covariance: ArrayLike, truth: ArrayLike) -> float: ...
def nis(innovation: ArrayLike, s: ArrayLike) -> float: ...
def nees_summary(series: ArrayLike) -> dict[str, Any]: ...
def association_oracle(
    log: SensorLog,
    bearing_sigma: float | None = None,
    recall: float = 0.95,
    precision: float = 0.99,
    blind: bool = False,
) -> dict[str, Any]: ...
def chi2_quantile(dof: float, p: float) -> float: ...
def chi2_interval(dof: float, runs: int = 1, confidence: float = 0.95) -> tuple[float, float]: ...
def diff_drive(
    state: ArrayLike,
    left: float,
    right: float,
    wheel_base: float = 0.2,
    floor_sigma: float = 1e-4,
    scale_sqrt: float = 0.01,
) -> _MotionOut: ...
def velocity(
    state: ArrayLike,
    v: float,
    omega: float,
    dt: float,
    alpha: tuple[
        float, float, float, float, float, float
    ] = ...,  # (0.05, 0.001, 0.05, 0.05, 0.001, 0.001)
    sigma_v_min: float = 0.01,
    sigma_omega_min: float = 0.02,
) -> _MotionOut: ...
def odometry(
    state: ArrayLike,
    rot1: float,
    trans: float,
    rot2: float,
    alpha: tuple[float, float, float, float] = ...,  # (0.05, 0.001, 0.05, 0.01)
    sigma_rot_min: float = 0.001,
    sigma_trans_min: float = 0.001,
) -> _MotionOut: ...
def odometry_increment(previous: ArrayLike, current: ArrayLike) -> tuple[float, float, float]: ...
def bearing_to_point(pose: ArrayLike, landmark: ArrayLike) -> tuple[float, _F64, _F64]: ...
def bearing_to_inverse_depth(pose: ArrayLike, landmark: ArrayLike) -> tuple[float, _F64, _F64]: ...
def range_bearing(pose: ArrayLike, landmark: ArrayLike) -> tuple[_F64, _F64, _F64]: ...
def inverse_range_bearing(
    pose: ArrayLike, range: float, bearing: float
) -> tuple[_F64, _F64, _F64]: ...
def pi_sr_init(pose: ArrayLike, bearing: float, rho_ini: float) -> tuple[_F64, _F64, _F64]: ...
def triangulation_init(
    first_pose: ArrayLike, first_bearing: float, pose: ArrayLike, bearing: float
) -> tuple[_F64, _F64, _F64, _F64, _F64, dict[str, float]]: ...
def triangulate(
    pose1: ArrayLike, z1: float, pose2: ArrayLike, z2: float
) -> tuple[_F64, _F64, _F64, _F64, _F64]: ...
def inverse_depth_to_point(landmark: ArrayLike) -> tuple[_F64, _F64]: ...
def linearity_index(landmark: ArrayLike, rho_variance: float, sensor: ArrayLike) -> float: ...
def wrap_angle(angle: float) -> float: ...

# Monte Carlo and experiments (crates/bearing-slam-py/src/montecarlo.rs).
__all__ += [
    "experiment_consistency",
    "experiment_fig4",
    "experiment_fig5",
    "experiment_fig8",
    "experiment_fig10",
    "montecarlo_report",
    "montecarlo_run_many",
    "montecarlo_run_one",
]

# The names and defaults shared with Python (crates/bearing-slam-py/src/vocabulary.rs).
__all__ += ["vocabulary"]

def montecarlo_run_one(spec_json: str, index: int) -> dict[str, Any]: ...
def montecarlo_report(spec_json: str, records: Iterable[dict[str, Any]]) -> dict[str, Any]: ...
def montecarlo_run_many(
    spec_json: str, progress: Callable[[int], object] | None = None
) -> dict[str, Any]: ...
def experiment_fig4(
    runs: int = 200, seed0: int = 0, progress: Callable[[str, int, int], object] | None = None
) -> dict[str, Any]: ...
def experiment_consistency(
    runs: int = 200, seed0: int = 0, progress: Callable[[str, int, int], object] | None = None
) -> dict[str, Any]: ...
def experiment_fig5(
    sigma_deg: float = 1.0,
    distance_m: float = 5.0,
    parallax_deg: Sequence[float] | None = None,
    samples: int = 20000,
    seed: int = 0,
) -> dict[str, Any]: ...
def experiment_fig8(
    runs: int = 50,
    seed0: int = 0,
    counts: Sequence[int] | None = None,
    progress: Callable[[str, int, int], object] | None = None,
) -> dict[str, Any]: ...
def experiment_fig10(
    runs: int = 50, seed0: int = 0, progress: Callable[[str, int, int], object] | None = None
) -> dict[str, Any]: ...

# The live Foxglove server of `--live` (bearing_slam.live).
__all__ += ["LiveServer"]

@final
class LiveServer:
    def __new__(cls, port: int = 8765, host: str = "127.0.0.1") -> LiveServer: ...
    @property
    def port(self) -> int: ...
    @property
    def url(self) -> str: ...
    def has_subscribers(self) -> bool: ...
    def wait_for_subscriber(self, timeout: float | None = None) -> bool: ...
    def stream(
        self,
        log: SensorLog,
        result: RunResult | Trace | None = None,
        *,
        speed: float = 1.0,
        snapshot_every: float = 0.0,
    ) -> dict[str, Any]: ...
    def stop(self) -> None: ...

# issue 17: monocular SLAM on image sequences (crates/bearing-slam-py/src/mono.rs).
__all__ += ["mono_motion_noise", "mono_render", "mono_run"]
