"""The names and defaults the Python package shares with the Rust crates.

Every initializer, method, run class, experiment and metric name, the
classification thresholds and the paper's priors are defined once, in Rust
(``InitializerKind``, ``CovarianceUpdate``, ``OdometryKind``, ``EstimatorKind``,
``real_data::Method``, ``RunClass``, ``Experiment``, ``RunMetrics``,
``Thresholds``, ``InverseDepthPrior::PAPER_NEAR``/``PAPER_FAR``,
``MTE_HISTORY``), and read here from the extension module's
``vocabulary()``. The CLI's ``choices=``, the Monte Carlo specs, the MRCLAM
tables and the plots take them from this module.
"""

from __future__ import annotations

from typing import Any

from bearing_slam import _native

__all__ = [
    "ASSOCIATIONS",
    "CLASSES",
    "CONFIG_INITS",
    "COVARIANCE_UPDATES",
    "DEFAULT_INIT",
    "DEFAULT_PRIOR",
    "DEFAULT_THRESHOLDS",
    "ESTIMATORS",
    "EXPERIMENTS",
    "EXPERIMENT_DEFAULT_RUNS",
    "FAR_PRIOR",
    "HISTORY_CORRELATIONS",
    "INIT_NAMES",
    "LANDMARK_CHARTS",
    "METRICS",
    "MRCLAM_METHODS",
    "MRCLAM_METHOD_LABELS",
    "MTE_HISTORY",
    "ODOMETRIES",
    "ONLINE_WINDOWS",
    "POSE_NEES",
    "PRIOR_INITS",
    "RUN_INITS",
    "UPDATE_MODES",
    "config_init",
    "init_name",
]

_RUST = _native.vocabulary()

#: Every initializer by name (Rust: ``InitializerKind::ALL``).
INIT_NAMES: tuple[str, ...] = tuple(_RUST["initializers"])

#: The default initializer (Rust: ``SlamConfig::default()``'s): ``Config()``'s
#: and every command line's ``--init``.
DEFAULT_INIT: str = str(_RUST["default_initializer"])

#: The initializers of one run on one log (``Config(init=...)``,
#: ``bearing-slam run --init``): all but ``pi-sr-mixed``, which needs to know
#: which landmarks are far, which a log does not say.
RUN_INITS: tuple[str, ...] = tuple(n for n in INIT_NAMES if n != "pi-sr-mixed")

#: The initializers ``Config(init=...)`` accepts without per-landmark priors.
CONFIG_INITS: tuple[str, ...] = RUN_INITS

#: The initializers that take an inverse-depth prior (``rho_ini``, ``sigma_rho``).
PRIOR_INITS: tuple[str, ...] = tuple(_RUST["prior_initializers"])

#: The covariance-update forms (Rust: ``CovarianceUpdate::ALL``).
COVARIANCE_UPDATES: tuple[str, ...] = tuple(_RUST["covariance_updates"])

#: The update modes, full or compressed (Rust: ``UpdateMode::ALL``).
UPDATE_MODES: tuple[str, ...] = tuple(_RUST["update_modes"])

#: Where the filter's Jacobians are evaluated, ``Config(consistency=...)``:
#: standard, first estimates (FEJ), observability-constrained (OC) or the
#: right-invariant EKF (Rust: ``Consistency::ALL``).
CONSISTENCIES: tuple[str, ...] = tuple(_RUST["consistencies"])

#: The odometry models (Rust: ``OdometryKind::ALL``).
ODOMETRIES: tuple[str, ...] = tuple(_RUST["odometries"])

#: The estimators, the EKF first (Rust: ``estimator::EstimatorKind::ALL``):
#: ``Config(estimator=...)``, ``--estimator``.
ESTIMATORS: tuple[str, ...] = tuple(_RUST["estimators"])

#: The online smoother's windows (Rust: ``smoother::OnlineWindow::ALL``):
#: ``Config(online_window=...)``, ``--online-window``.
ONLINE_WINDOWS: tuple[str, ...] = tuple(_RUST["online_windows"])

#: The online smoother's landmark charts (Rust: ``smoother::LandmarkChart::ALL``):
#: ``Config(landmark_chart=...)``, ``--landmark-chart``.
LANDMARK_CHARTS: tuple[str, ...] = tuple(_RUST["landmark_charts"])

#: Data association (Rust: ``association::AssociationMethod::ALL``):
#: ``Config(association=...)``, ``--association``.
ASSOCIATIONS: tuple[str, ...] = tuple(_RUST["associations"])

#: Waiting bearings kept per candidate by ``mte-history`` (Rust: ``init::MTE_HISTORY``).
MTE_HISTORY: int = int(_RUST["mte_history"])

#: How ``mte-history`` replays correlated waiting bearings (Rust:
#: ``init::HistoryTreatment::ALL``): ``Config(history_correlation=...)``,
#: ``--history-correlation``.
HISTORY_CORRELATIONS: tuple[str, ...] = tuple(_RUST["history_correlations"])

#: The PI-SR inverse-depth prior of the Monte Carlo runs and the MRCLAM
#: evaluation, 1/m (Rust: ``InverseDepthPrior::PAPER_NEAR``).
DEFAULT_PRIOR: dict[str, float] = dict(_RUST["paper_near_prior"])

#: The far-landmark prior of ``pi-sr-mixed`` (the paper's Fig. 4d), 1/m
#: (Rust: ``InverseDepthPrior::PAPER_FAR``).
FAR_PRIOR: dict[str, float] = dict(_RUST["paper_far_prior"])

#: The classification thresholds used unless a spec gives its own (Rust:
#: ``montecarlo::Thresholds::default``).
DEFAULT_THRESHOLDS: dict[str, float] = dict(_RUST["thresholds"])

#: The run classes, in the order of the fractions (Rust: ``montecarlo::RunClass``).
CLASSES: tuple[str, ...] = tuple(_RUST["run_classes"])

#: The per-run metrics of a Monte Carlo report (Rust: ``RunMetrics::metric_names``).
METRICS: tuple[str, ...] = tuple(_RUST["run_metrics"])

#: The methods of the MRCLAM evaluation, in table order (Rust: ``real_data::Method::ALL``).
MRCLAM_METHODS: tuple[str, ...] = tuple(_RUST["mrclam_methods"])

#: Labels of the MRCLAM methods (Rust: ``Method::label``) and of the GTSAM
#: yardstick (a Python script's) in tables and figures.
MRCLAM_METHOD_LABELS: dict[str, str] = {**_RUST["mrclam_method_labels"], "gtsam": "GTSAM batch"}

#: The pose-NEES scoring rule of one run (Rust: ``metrics::pose_nees_bound``
#: and the ``NEES_*`` constants): ``dof``, ``probability``, the one-sided
#: ``bound`` (χ²(3) 95 % quantile, 7.81) a sample is "under", and the floor
#: (``min_position_sigma_m``, ``min_heading_sigma_rad``) the covariance must
#: first rise above before samples are scored.
POSE_NEES: dict[str, float] = dict(_RUST["pose_nees"])

#: The paper's experiments, in the order ``all`` runs them (Rust: ``Experiment::ALL``).
EXPERIMENTS: tuple[str, ...] = tuple(_RUST["experiments"])

#: Runs per configuration of each experiment unless given (Fig. 5 samples instead).
EXPERIMENT_DEFAULT_RUNS = {"fig4": 200, "consistency": 200, "fig8": 50, "fig10": 50}


def config_init(init: str) -> tuple[str, dict[str, Any]]:
    """The ``Config`` arguments of a run initializer (:data:`RUN_INITS`):
    ``(init, extra parameters)``. ``mte-history`` is MTE with pose cloning
    that keeps :data:`MTE_HISTORY` waiting bearings; the others pass as they are."""
    if init == "mte-history":
        return "mte-clone", {"history": MTE_HISTORY}
    return init, {}


def init_name(init: str, history: int) -> str:
    """The name of a ``Config``'s initializer as :data:`RUN_INITS` spells it
    (``mte-history`` for MTE-clone with a history)."""
    return "mte-history" if init == "mte-clone" and history > 0 else init
