"""The names and defaults the Python package shares with the Rust crates.

Every method name, initializer name, classification threshold and default
prior that Python needs is written here once; the CLI's ``choices=``, the
Monte Carlo specs, the MRCLAM tables and the plots take them from this
module. Each constant says which Rust item it mirrors, so that replacing
them with values exported by the extension module is one edit here.
"""

from __future__ import annotations

from typing import Any

__all__ = [
    "CLASSES",
    "CONFIG_INITS",
    "DEFAULT_PRIOR",
    "DEFAULT_THRESHOLDS",
    "EXPERIMENTS",
    "EXPERIMENT_DEFAULT_RUNS",
    "FAR_PRIOR",
    "INIT_NAMES",
    "METRICS",
    "MRCLAM_METHODS",
    "MRCLAM_METHOD_LABELS",
    "MTE_HISTORY",
    "PRIOR_INITS",
    "RUN_INITS",
    "config_init",
    "init_name",
]

#: The initializers ``Config(init=...)`` accepts (Rust: ``bearing-slam-py``
#: ``config::INITS``, ``InitializerConfig``).
CONFIG_INITS = ("mte", "mte-clone", "pi-sr")

#: The initializers of a Monte Carlo spec, by name (Rust:
#: ``montecarlo::InitializerSpec``).
INIT_NAMES = ("mte", "mte-clone", "mte-history", "pi-sr", "pi-sr-mixed")

#: The initializers of one run on one log (``bearing-slam run --init``):
#: :data:`CONFIG_INITS` plus ``mte-history`` (see :func:`config_init`).
#: ``pi-sr-mixed`` needs to know which landmarks are far, which a log does not say.
RUN_INITS = ("mte", "mte-clone", "mte-history", "pi-sr")

#: The initializers that take an inverse-depth prior (``rho_ini``, ``sigma_rho``).
PRIOR_INITS = ("pi-sr", "pi-sr-mixed")

#: Waiting bearings kept per candidate by ``mte-history`` (Rust:
#: ``montecarlo::MTE_HISTORY``).
MTE_HISTORY = 32

#: The PI-SR inverse-depth prior of the Monte Carlo runs and the MRCLAM
#: evaluation, 1/m (Rust: ``InitializerSpec`` defaults, ``real_data::Method::PiSr``).
DEFAULT_PRIOR: dict[str, float] = {"rho_ini": 0.5, "sigma_rho": 0.25}

#: The far-landmark prior of ``pi-sr-mixed`` (the paper's Fig. 4d), 1/m
#: (Rust: ``montecarlo::InitializerSpec::PiSrMixed``).
FAR_PRIOR: dict[str, float] = {"rho_ini": 0.01, "sigma_rho": 0.005}

#: The classification thresholds used unless a spec gives its own (Rust:
#: ``montecarlo::Thresholds::default``).
DEFAULT_THRESHOLDS: dict[str, float] = {
    "diverged_position_m": 5.0,
    "drift_position_m": 0.5,
    "drift_heading_deg": 5.0,
    "drift_landmark_rmse_m": 0.5,
}

#: The run classes, in the order of the fractions (Rust: ``montecarlo::RunClass``).
CLASSES = ("converged", "drift", "diverged")

#: The per-run metrics of a Monte Carlo report (Rust: ``montecarlo::RunMetrics``).
METRICS = (
    "ate_rmse_m",
    "final_position_error_m",
    "final_heading_error_deg",
    "landmark_rmse_m",
    "near_landmark_rmse_m",
    "mean_nees",
    "n_landmarks",
    "dead_reckoning_ate_rmse_m",
    "dead_reckoning_final_position_error_m",
    "dead_reckoning_final_heading_error_deg",
    "measurements_rejected",
)

#: The methods of the MRCLAM evaluation, in table order (Rust: ``real_data::Method::ALL``).
MRCLAM_METHODS = ("dead-reckoning", "mte", "mte-clone", "pi-sr", "range-bearing")

#: Labels of the MRCLAM methods (and of the GTSAM yardstick) in tables and figures.
MRCLAM_METHOD_LABELS = {
    "dead-reckoning": "dead reckoning",
    "mte": "MTE",
    "mte-clone": "MTE-clone",
    "pi-sr": "PI-SR (0.5, 0.25)",
    "range-bearing": "range-bearing EKF",
    "gtsam": "GTSAM batch",
}

#: The paper's experiments, in the order ``all`` runs them (Rust: ``experiments``).
EXPERIMENTS = ("fig4", "consistency", "fig5", "fig8", "fig10")

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
