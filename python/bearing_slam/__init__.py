"""bearing-slam: bearing-only EKF SLAM with the delayed stochastic-triangulation
initialization of Munguía & Grau ("MTE"), in Rust, with numpy in and out.

>>> import bearing_slam as bs
>>> log = bs.simulate("paper_fig4", seed=3)
>>> result = bs.run(log, bs.Config.for_log(log, init="mte"))
>>> result.summary["ate_rmse_m"]  # doctest: +SKIP

Step by step: :class:`SlamFilter`; models with Jacobians: :mod:`bearing_slam.models`;
metrics: :mod:`bearing_slam.metrics`; figures: :mod:`bearing_slam.plots`; Monte Carlo:
:func:`montecarlo` (module :mod:`bearing_slam.monte_carlo`); the paper's experiments:
:mod:`bearing_slam.experiments`; real robots: :mod:`bearing_slam.mrclam`; what the
commands write: :mod:`bearing_slam.outputs`; shared names and defaults:
:mod:`bearing_slam.vocabulary`; CLI: ``bearing-slam`` (:mod:`bearing_slam.cli`); Rerun
recordings, live: :func:`run_with_rerun`, of a finished run: :func:`log_rerun`
(:mod:`bearing_slam.rerun`); acoustic bearings:
:mod:`bearing_slam.acoustics`.
"""

from bearing_slam import metrics, models, mono
from bearing_slam._native import (
    BearingSlamError,
    Config,
    DatasetError,
    DegenerateGeometryError,
    DimensionMismatchError,
    DivergedError,
    DuplicateMeasurementError,
    EkfBenchmark,
    InvalidNoiseError,
    InvalidParameterError,
    LandmarkAtInfinityError,
    McapError,
    MismatchError,
    NonFiniteError,
    NotPositiveDefiniteError,
    RunResult,
    SensorLog,
    SimulationError,
    SlamFilter,
    TimeOrderError,
    Trace,
    UnknownLandmarkError,
    UpdateReport,
    __version__,
    ate,
    chi2_interval,
    chi2_quantile,
    evaluate_mrclam,
    load_mrclam,
    nees,
    nees_summary,
    nis,
    pose_nees,
    read_mcap,
    rpe,
    run,
    scenario_names,
    scenario_toml,
    simulate,
    smooth,
    write_mcap,
)

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
    "ate",
    "chi2_interval",
    "chi2_quantile",
    "evaluate_mrclam",
    "load_mrclam",
    "metrics",
    "models",
    "nees",
    "nees_summary",
    "nis",
    "pose_nees",
    "read_mcap",
    "rpe",
    "run",
    "scenario_names",
    "scenario_toml",
    "simulate",
    "smooth",
    "write_mcap",
]

# Monte Carlo on local cores or any concurrent.futures executor (e.g. Dask):
# the function `bs.montecarlo`; its module is `bearing_slam.monte_carlo`.
from bearing_slam.monte_carlo import MonteCarloResult, montecarlo

# Trajectories in the TUM format, for evo (module `bearing_slam.tum`).
from bearing_slam.tum import write_tum

__all__ += ["MonteCarloResult", "montecarlo"]
__all__ += ["write_tum"]
# issue 17: monocular SLAM on image sequences (bs.mono.run, bs.mono.render).
__all__ += ["mono"]

# A run as a Rerun recording (the `rerun` extra): `bs.run_with_rerun` (live),
# `bs.log_rerun` (a finished run); its module is
# `bearing_slam.rerun`. Acoustic bearings (the `acoustics` extra): `bearing_slam.acoustics`.
from bearing_slam.rerun import log_rerun, run_with_rerun  # noqa: E402

__all__ += ["log_rerun", "run_with_rerun"]

# A run streamed live to the Foxglove app (`--live`): `bs.stream_live` and the
# server `bs.LiveServer`; the module is `bearing_slam.live`.
from bearing_slam._native import LiveServer  # noqa: E402
from bearing_slam.live import stream_live  # noqa: E402

__all__ += ["LiveServer", "stream_live"]
