"""Monte Carlo runs of the simulator and the filter, on local cores or a cluster.

>>> import bearing_slam as bs
>>> results = bs.montecarlo("paper_fig4", ["mte", "pi-sr"], runs=20)  # doctest: +SKIP
>>> results["mte"].converged_fraction  # doctest: +SKIP

Run ``i`` simulates the scenario with seed ``seed0 + i`` and runs the filter
on it; runs share nothing, so they can go anywhere:

* without an executor, every run goes to the Rust runner, which spreads them
  over all local cores (rayon) with the GIL released;
* with any :class:`concurrent.futures.Executor` (a thread or process pool, or
  a Dask ``distributed.Client(...).get_executor()``), each run is one task
  ``run_one(spec_json, i)``: a module-level function with a string and an int
  as arguments, returning a plain dict of floats, lists and strings. The
  records are gathered and aggregated in Rust, and the report is the same,
  bit for bit, as without an executor.

Each run is classified (thresholds in :data:`DEFAULT_THRESHOLDS`, the
definitions in the Rust module ``bearing_slam::eval::montecarlo``):

* **diverged**: the run failed, a pose or its covariance was not finite or
  not positive semi-definite, or the final position error exceeds
  ``diverged_position_m`` (5 m);
* **drift**: otherwise, if the final heading error exceeds
  ``drift_heading_deg`` (5°), the final position error ``drift_position_m``
  (0.5 m), or the near landmarks' RMSE ``drift_landmark_rmse_m`` (0.5 m);
* **converged**: the rest.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import Executor, as_completed
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray
from tqdm import tqdm

from bearing_slam._native import (
    montecarlo_report,
    montecarlo_run_many,
    montecarlo_run_one,
)
from bearing_slam.estimators import DEFAULT_ESTIMATOR, DEFAULT_PARTICLES
from bearing_slam.vocabulary import (
    CLASSES,
    DEFAULT_PRIOR,
    DEFAULT_THRESHOLDS,
    FAR_PRIOR,
    INIT_NAMES,
    METRICS,
)

__all__ = [
    "CLASSES",
    "DEFAULT_THRESHOLDS",
    "INIT_NAMES",
    "METRICS",
    "MonteCarloResult",
    "initializer_spec",
    "make_spec",
    "montecarlo",
    "run_one",
    "run_spec",
]

#: Progress: ``True`` (a tqdm bar), ``False`` (none) or ``callback(done, total)``.
Progress = bool | Callable[[int, int], object]


def initializer_spec(
    init: str | Mapping[str, Any],
    *,
    rho_ini: float = DEFAULT_PRIOR["rho_ini"],
    sigma_rho: float = DEFAULT_PRIOR["sigma_rho"],
) -> dict[str, Any]:
    """The initializer part of a spec: ``"mte"``, ``"mte-clone"``,
    ``"mte-history"`` (MTE-clone keeping the bearings seen while waiting), ``"auto"``
    (MTE, then undelayed after a visit without parallax), ``"pi-sr"``
    (prior ``rho_ini``, ``sigma_rho``), ``"pi-sr-mixed"`` (that prior for the
    near landmarks, (0.01, 0.005) for the scenario's far ones), or a dict such
    as ``{"method": "pi-sr", "rho_ini": 0.01, "sigma_rho": 0.005}`` (kept as is)."""
    if isinstance(init, Mapping):
        return dict(init)
    if init in ("mte", "mte-clone", "mte-history", "auto"):
        return {"method": init}
    if init == "pi-sr":
        return {"method": "pi-sr", "rho_ini": rho_ini, "sigma_rho": sigma_rho}
    if init == "pi-sr-mixed":
        return {
            "method": "pi-sr-mixed",
            "near": {"rho_ini": rho_ini, "sigma_rho": sigma_rho},
            "far": dict(FAR_PRIOR),
        }
    raise ValueError(f"unknown initializer {init!r}; known: {', '.join(INIT_NAMES)} or a dict")


def make_spec(
    scenario: str,
    init: str | Mapping[str, Any],
    runs: int,
    *,
    seed0: int = 0,
    landmark_count: int | None = None,
    far_landmark: bool = True,
    slip: bool | None = None,
    landmark_scale: float | None = None,
    thresholds: Mapping[str, float] | None = None,
    rho_ini: float = DEFAULT_PRIOR["rho_ini"],
    sigma_rho: float = DEFAULT_PRIOR["sigma_rho"],
    estimator: str = DEFAULT_ESTIMATOR,
    particles: int = DEFAULT_PARTICLES,
    association: str = "known",
    clutter: float | None = None,
    descriptor_sigma: float | None = None,
    descriptor_confusion: float = 0.0,
) -> dict[str, Any]:
    """A Monte Carlo spec (the JSON of the Rust ``MonteCarloSpec``) as a dict.
    ``landmark_scale`` multiplies the positions of the scenario's near
    landmarks (all but its far ones) about the world origin; ``estimator``
    (:data:`~bearing_slam.vocabulary.ESTIMATORS`) runs another estimator
    than the EKF (``particles`` for FastSLAM, seeded with each run's seed).
    ``association`` (:data:`~bearing_slam.vocabulary.ASSOCIATIONS`) hides the
    ids from the estimator (``"nn"``, ``"jcbb"``, ``"ransac"``) and scores it against them;
    ``clutter`` adds false bearings per scan; ``descriptor_sigma`` gives every
    sighting an appearance descriptor of that noise (also the association's
    descriptor model), ``descriptor_confusion`` the probability a sighting
    shows another landmark's appearance."""
    if runs < 1:
        raise ValueError(f"runs must be at least 1, got {runs}")
    if descriptor_sigma is None and descriptor_confusion != 0.0:
        raise ValueError(
            "descriptor_confusion needs descriptor_sigma (the descriptors it confuses)"
        )
    appearance = (
        None
        if descriptor_sigma is None
        else {"sigma": descriptor_sigma, "confusion_rate": descriptor_confusion}
    )
    return {
        "scenario": {
            "name": scenario,
            "seed0": seed0,
            "landmark_count": landmark_count,
            "far_landmark": far_landmark,
            "slip": slip,
            "landmark_scale": landmark_scale,
            "clutter_per_scan": clutter,
            "appearance": appearance,
        },
        "initializer": initializer_spec(init, rho_ini=rho_ini, sigma_rho=sigma_rho),
        "runs": runs,
        "thresholds": {**DEFAULT_THRESHOLDS, **(thresholds or {})},
        "estimator": estimator,
        "particles": particles,
        "association": association,
    }


def run_one(spec_json: str, index: int) -> dict[str, Any]:
    """Run ``index`` of a spec (JSON): the task an executor runs. Returns
    ``{"metrics": {...}, "series": {...}, "init_events": [...]}``, plain
    Python objects. Importable on a worker as ``bearing_slam.monte_carlo.run_one``."""
    return montecarlo_run_one(spec_json, index)


def _nan_array(values: Sequence[float | int | None]) -> NDArray[np.float64]:
    return np.array([math.nan if v is None else float(v) for v in values], dtype=np.float64)


@dataclass(frozen=True)
class MonteCarloResult:
    """The aggregate of a Monte Carlo experiment.

    ``report`` is the Rust report as a dict (what :meth:`to_json` writes);
    the attributes are views of it as numbers and numpy arrays."""

    report: dict[str, Any] = field(repr=False)
    #: Short label of the initializer (``MTE``, ``PI-SR (0.5, 0.25)``, …).
    label: str
    #: Number of runs.
    runs: int
    converged_fraction: float
    drift_fraction: float
    diverged_fraction: float
    #: Mean pose NEES over the runs that did not diverge and over time.
    mean_nees: float | None
    #: Per-run class names (``converged``, ``drift``, ``diverged``), by run index.
    classes: NDArray[np.str_] = field(repr=False)
    #: Per-run metrics (:data:`METRICS`), NaN where a run has none.
    metrics: dict[str, NDArray[np.float64]] = field(repr=False)
    #: Why each run drifted or diverged (``None`` for a converged run).
    reasons: list[str | None] = field(repr=False)
    #: The common time grid of the series, s.
    time: NDArray[np.float64] = field(repr=False)
    #: Mean pose NEES (3 dof) over the non-diverged runs at each time (NaN: none).
    nees_mean: NDArray[np.float64] = field(repr=False)
    #: The 95 % band of that mean, ``chi2_interval(3, n, 0.95)``.
    nees_lower: NDArray[np.float64] = field(repr=False)
    nees_upper: NDArray[np.float64] = field(repr=False)
    #: Fraction of the times with a mean that lie inside the band.
    nees_fraction_inside: float | None
    #: Mean position error over time, SLAM and dead reckoning, m.
    slam_error_mean: NDArray[np.float64] = field(repr=False)
    dead_reckoning_error_mean: NDArray[np.float64] = field(repr=False)

    @classmethod
    def from_report(cls, report: dict[str, Any]) -> MonteCarloResult:
        """Wraps a report dict (``montecarlo_report``, ``montecarlo_run_many``)."""
        runs = report["runs"]
        nees = report["nees_over_time"]
        err = report["error_over_time"]
        return cls(
            report=report,
            label=report["label"],
            runs=len(runs),
            converged_fraction=report["converged_fraction"],
            drift_fraction=report["drift_fraction"],
            diverged_fraction=report["diverged_fraction"],
            mean_nees=report["mean_nees"],
            classes=np.array([r["class"] for r in runs], dtype=np.str_),
            metrics={k: _nan_array([r[k] for r in runs]) for k in METRICS},
            reasons=[r["reason"] for r in runs],
            time=_nan_array(nees["time"]),
            nees_mean=_nan_array(nees["mean"]),
            nees_lower=_nan_array(nees["lower"]),
            nees_upper=_nan_array(nees["upper"]),
            nees_fraction_inside=nees["fraction_inside"],
            slam_error_mean=_nan_array(err["slam_mean_m"]),
            dead_reckoning_error_mean=_nan_array(err["dead_reckoning_mean_m"]),
        )

    @classmethod
    def from_json(cls, text: str) -> MonteCarloResult:
        """Reads what :meth:`to_json` wrote."""
        return cls.from_report(json.loads(text))

    @property
    def spec(self) -> dict[str, Any]:
        """The spec that was run."""
        spec: dict[str, Any] = self.report["spec"]
        return spec

    @property
    def fractions(self) -> dict[str, float]:
        """``{"converged": …, "drift": …, "diverged": …}``."""
        return {
            "converged": self.converged_fraction,
            "drift": self.drift_fraction,
            "diverged": self.diverged_fraction,
        }

    def to_json(self, indent: int | None = 2) -> str:
        """The whole report as JSON (spec, fractions, per-run metrics, means,
        NEES and errors over time; missing numbers are ``null``)."""
        return json.dumps(self.report, indent=indent)

    def summary_line(self) -> str:
        """One line: label, runs and class fractions (and, with the ids
        hidden, the mean association precision, recall and duplicates)."""
        line = (
            f"{self.label}: {self.runs} runs: converged {100 * self.converged_fraction:.1f} %, "
            f"drift {100 * self.drift_fraction:.1f} %, "
            f"diverged {100 * self.diverged_fraction:.1f} %"
        )
        means = self.report["all_finite"]
        if means.get("association_precision") is not None:
            line += (
                f"; association precision {100 * means['association_precision']:.1f} %, "
                f"recall {100 * means['association_recall']:.1f} %, "
                f"{means['duplicates_at_end']:.2f} duplicate and "
                f"{means['spurious_at_end']:.2f} spurious landmarks per run"
            )
        return line


def _bar(
    progress: Progress, total: int, desc: str
) -> tuple[Callable[[int], None], Callable[[], None]]:
    """An ``update(done)`` and a ``close()`` for a progress setting."""
    if progress is True:
        bar = tqdm(total=total, desc=desc, unit="run")

        def update(done: int) -> None:
            bar.update(done - bar.n)

        return update, bar.close
    if callable(progress):
        cb = progress

        def call(done: int) -> None:
            cb(done, total)

        return call, (lambda: None)
    return (lambda _done: None), (lambda: None)


def run_spec(
    spec: Mapping[str, Any],
    *,
    executor: Executor | None = None,
    progress: Progress = True,
) -> MonteCarloResult:
    """Runs a whole spec (:func:`make_spec`): on the local cores through the
    Rust runner, or one task per run on ``executor``."""
    spec_json = json.dumps(spec)
    total = int(spec["runs"])
    desc = f"{spec['scenario']['name']} / {spec['initializer']['method']}"
    update, close = _bar(progress, total, desc)
    try:
        if executor is None:
            report = montecarlo_run_many(spec_json, update)
        else:
            # Check the spec here, not on every worker: a bad one raises now.
            montecarlo_report(spec_json, [])
            futures = [executor.submit(run_one, spec_json, i) for i in range(total)]
            records = []
            try:
                for done, fut in enumerate(as_completed(futures), start=1):
                    records.append(fut.result())
                    update(done)
            except BaseException:
                for f in futures:
                    f.cancel()
                raise
            report = montecarlo_report(spec_json, records)
    finally:
        close()
    return MonteCarloResult.from_report(report)


def montecarlo(
    scenario: str,
    inits: str | Mapping[str, Any] | Sequence[str | Mapping[str, Any]],
    runs: int,
    *,
    executor: Executor | None = None,
    seed0: int = 0,
    landmark_count: int | None = None,
    far_landmark: bool = True,
    slip: bool | None = None,
    landmark_scale: float | None = None,
    thresholds: Mapping[str, float] | None = None,
    progress: Progress = True,
    rho_ini: float = DEFAULT_PRIOR["rho_ini"],
    sigma_rho: float = DEFAULT_PRIOR["sigma_rho"],
    estimator: str = DEFAULT_ESTIMATOR,
    particles: int = DEFAULT_PARTICLES,
    association: str = "known",
    clutter: float | None = None,
    descriptor_sigma: float | None = None,
    descriptor_confusion: float = 0.0,
) -> dict[str, MonteCarloResult]:
    """``runs`` runs of ``scenario`` (seeds ``seed0 …``) for each initializer.

    ``inits``: one or several of ``"mte"``, ``"mte-clone"``,
    ``"mte-history"``, ``"pi-sr"`` (prior ``rho_ini``, ``sigma_rho``),
    ``"pi-sr-mixed"``, or initializer dicts (:func:`initializer_spec`).
    ``landmark_count``, ``far_landmark``, ``slip`` and ``landmark_scale``
    change the scenario (``None``: its own); ``thresholds``
    override :data:`DEFAULT_THRESHOLDS`; ``estimator`` and ``particles``
    choose the estimator, ``association``, ``clutter``, ``descriptor_sigma``
    and ``descriptor_confusion`` the data association and what makes it hard
    (:func:`make_spec`). Without ``executor`` the runs use
    every local core; with one (e.g. ``distributed.Client().get_executor()``)
    each run is a task, with the same result.

    Returns one :class:`MonteCarloResult` per initializer, keyed by its name
    (a string init) or its report label (a dict init), in the given order.
    Raises :class:`bearing_slam.BearingSlamError` for a bad scenario or initializer."""
    items: Sequence[str | Mapping[str, Any]] = (
        [inits] if isinstance(inits, str | Mapping) else list(inits)
    )
    out: dict[str, MonteCarloResult] = {}
    for init in items:
        spec = make_spec(
            scenario,
            init,
            runs,
            seed0=seed0,
            landmark_count=landmark_count,
            far_landmark=far_landmark,
            slip=slip,
            landmark_scale=landmark_scale,
            thresholds=thresholds,
            rho_ini=rho_ini,
            sigma_rho=sigma_rho,
            estimator=estimator,
            particles=particles,
            association=association,
            clutter=clutter,
            descriptor_sigma=descriptor_sigma,
            descriptor_confusion=descriptor_confusion,
        )
        result = run_spec(spec, executor=executor, progress=progress)
        key = init if isinstance(init, str) else result.label
        if key in out:
            key = f"{key} #{len(out)}"
        out[key] = result
    return out
