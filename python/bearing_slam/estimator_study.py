"""Estimators against the EKF on the simulator: ``bearing-slam experiment
particles`` (FastSLAM, issue 15) and ``bearing-slam experiment smoother``
(the batch and fixed-lag smoothers, issue 14).

>>> from bearing_slam.estimator_study import run_estimator_study
>>> study = run_estimator_study(runs=20)  # doctest: +SKIP

Two parts, both written into ``STEM.md``, ``STEM.json`` and ``STEM.png``
(``particles`` or ``smoother``, :data:`STUDIES`):

* **Monte Carlo** on ``paper_fig4``, ``paper_fig8`` and ``slip_patch``
  (:data:`SCENARIOS`): ``runs`` seeded runs (MTE; FastSLAM triangulates per
  particle and is seeded with the run's seed) of the EKF (``filter``, the
  reference) and of each other estimator (each FastSLAM estimator at each
  particle count; the smoothers score the NEES of their marginal
  covariances). Per configuration: the class fractions (converged, drift,
  diverged, as ``bearing-slam montecarlo``), ATE, final position and heading
  errors, the mean pose NEES and the fraction of the time the mean NEES lies
  in its 95 % band, and the wall time; the NEES over time goes into the plot.
* **The long run** (Bailey, Nieto & Nebot 2006: FastSLAM grows
  over-confident over time whatever M): ``long_runs`` seeds of
  :data:`LONG_SCENARIO` for ``long_s`` seconds, the mean pose NEES over time
  per configuration against the χ²(3) 95 % band of that mean, and the
  fraction of the time it lies above the band.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from bearing_slam._native import Config, chi2_interval, run, simulate
from bearing_slam.estimators import DEFAULT_PARTICLES
from bearing_slam.monte_carlo import MonteCarloResult, make_spec, run_spec

__all__ = [
    "DEFAULT_ESTIMATORS",
    "DEFAULT_PARTICLE_COUNTS",
    "DEFAULT_RUNS",
    "LONG_SCENARIO",
    "SCENARIOS",
    "SMOOTHER_ESTIMATORS",
    "STUDIES",
    "estimator_table",
    "run_estimator_study",
    "write_estimator_study",
]

#: The scenarios of the Monte Carlo part.
SCENARIOS: tuple[str, ...] = ("paper_fig4", "paper_fig8", "slip_patch")

#: FastSLAM estimators compared with the EKF unless given.
DEFAULT_ESTIMATORS: tuple[str, ...] = ("fastslam1", "fastslam2")

#: The smoothers ``experiment smoother`` compares with the EKF.
SMOOTHER_ESTIMATORS: tuple[str, ...] = ("smoother", "filter+smoother")

#: Each study's file stem and title.
STUDIES: dict[str, str] = {
    "particles": "FastSLAM against the EKF",
    "smoother": "The graph smoothers against the EKF",
}

#: How the estimators without particles are labelled.
_LABELS: dict[str, str] = {
    "filter": "EKF (filter)",
    "smoother": "batch smoother",
    "filter+smoother": "fixed-lag smoother (filter+smoother)",
}

#: Particle counts unless given.
DEFAULT_PARTICLE_COUNTS: tuple[int, ...] = (10, 100, 1000)

#: Runs per configuration unless given.
DEFAULT_RUNS = 20

#: The scenario of the long run, its length (s) and its number of seeds.
LONG_SCENARIO = "paper_fig8"
DEFAULT_LONG_S = 300.0
DEFAULT_LONG_RUNS = 5

#: ``echo(text)``: progress lines.
Echo = Callable[[str], object]


def _label(estimator: str, particles: int | None) -> str:
    return (
        _LABELS.get(estimator, estimator) if particles is None else f"{estimator}, M = {particles}"
    )


def _configs(
    estimators: Sequence[str], particle_counts: Sequence[int]
) -> list[tuple[str, int | None]]:
    """The EKF, then each FastSLAM estimator at each particle count and each
    other estimator once."""
    out: list[tuple[str, int | None]] = [("filter", None)]
    for e in estimators:
        if e.startswith("fastslam"):
            out += [(e, m) for m in particle_counts]
        elif e != "filter":
            out.append((e, None))
    return out


def _finite_median(a: NDArray[np.float64]) -> float | None:
    a = a[np.isfinite(a)]
    return float(np.median(a)) if len(a) else None


def _finite_mean(a: NDArray[np.float64]) -> float | None:
    a = a[np.isfinite(a)]
    return float(np.mean(a)) if len(a) else None


def _montecarlo_row(
    scenario: str, estimator: str, particles: int | None, runs: int, seed0: int, progress: bool
) -> dict[str, Any]:
    spec = make_spec(
        scenario,
        "mte",
        runs,
        seed0=seed0,
        estimator=estimator,
        particles=DEFAULT_PARTICLES if particles is None else particles,
    )
    started = time.perf_counter()
    result: MonteCarloResult = run_spec(spec, progress=progress)
    elapsed = time.perf_counter() - started
    m = result.metrics
    return {
        "scenario": scenario,
        "estimator": estimator,
        "particles": particles,
        "label": _label(estimator, particles),
        "runs": result.runs,
        "converged": result.converged_fraction,
        "drift": result.drift_fraction,
        "diverged": result.diverged_fraction,
        "ate_mean_m": _finite_mean(m["ate_rmse_m"]),
        "ate_median_m": _finite_median(m["ate_rmse_m"]),
        "final_position_median_m": _finite_median(m["final_position_error_m"]),
        "final_heading_median_deg": _finite_median(m["final_heading_error_deg"]),
        "mean_nees": result.mean_nees,
        "nees_inside": result.nees_fraction_inside,
        "seconds": elapsed,
        "nees_over_time": {
            "time": result.time.tolist(),
            "mean": result.nees_mean.tolist(),
            "lower": result.nees_lower.tolist(),
            "upper": result.nees_upper.tolist(),
        },
    }


def _long_run(
    estimator: str, particles: int | None, long_s: float, long_runs: int, seed0: int
) -> dict[str, Any]:
    """Mean pose NEES over ``long_runs`` seeds of :data:`LONG_SCENARIO`."""
    series: list[NDArray[np.float64]] = []
    grid: NDArray[np.float64] | None = None
    started = time.perf_counter()
    for seed in range(seed0, seed0 + long_runs):
        log = simulate(LONG_SCENARIO, seed, duration=long_s)
        kwargs: dict[str, Any] = {"estimator": estimator}
        if particles is not None:
            kwargs["particles"] = particles
        result = run(log, Config.for_log(log, **kwargs))
        t = np.asarray(result.time, dtype=np.float64)
        nees = np.asarray(result.nees, dtype=np.float64)
        if grid is None:
            grid = t
        series.append(np.interp(grid, t, nees))
    assert grid is not None
    stack = np.vstack(series)
    mean = np.nanmean(stack, axis=0)
    lower, upper = chi2_interval(3, long_runs, 0.95)
    ok = np.isfinite(mean)
    return {
        "estimator": estimator,
        "particles": particles,
        "label": _label(estimator, particles),
        "time": grid.tolist(),
        "mean": mean.tolist(),
        "lower": float(lower),
        "upper": float(upper),
        "fraction_above": float(np.mean(mean[ok] > upper)) if ok.any() else None,
        "fraction_inside": float(np.mean((mean[ok] >= lower) & (mean[ok] <= upper)))
        if ok.any()
        else None,
        "first_half_mean": _finite_mean(mean[: len(mean) // 2]),
        "second_half_mean": _finite_mean(mean[len(mean) // 2 :]),
        "first_half_median": _finite_median(mean[: len(mean) // 2]),
        "second_half_median": _finite_median(mean[len(mean) // 2 :]),
        "seconds": time.perf_counter() - started,
    }


def run_estimator_study(
    *,
    runs: int = DEFAULT_RUNS,
    seed0: int = 0,
    estimators: Sequence[str] = DEFAULT_ESTIMATORS,
    particle_counts: Sequence[int] = DEFAULT_PARTICLE_COUNTS,
    scenarios: Sequence[str] = SCENARIOS,
    long_s: float = DEFAULT_LONG_S,
    long_runs: int = DEFAULT_LONG_RUNS,
    progress: bool = True,
    echo: Echo | None = None,
) -> dict[str, Any]:
    """Runs both parts; returns ``{"montecarlo": [rows], "long": [rows],
    "table": markdown}``. ``long_runs = 0`` skips the long run."""
    if runs < 1:
        raise ValueError(f"runs must be at least 1, got {runs}")
    if not scenarios and long_runs < 1:
        raise ValueError("nothing to run: no scenario and no long run")
    configs = _configs(estimators, particle_counts)
    rows = []
    for scenario in scenarios:
        for estimator, particles in configs:
            row = _montecarlo_row(scenario, estimator, particles, runs, seed0, progress)
            rows.append(row)
            if echo is not None:
                echo(f"{scenario} / {row['label']}: {_row_cells(row)}")
    long_rows = []
    if long_runs > 0:
        for estimator, particles in configs:
            row = _long_run(estimator, particles, long_s, long_runs, seed0)
            long_rows.append(row)
            if echo is not None:
                echo(f"long {LONG_SCENARIO} {long_s:g} s / {row['label']}: {_long_cells(row)}")
    study = {
        "runs": runs,
        "seed0": seed0,
        "long_scenario": LONG_SCENARIO,
        "long_s": long_s,
        "long_runs": long_runs,
        "montecarlo": rows,
        "long": long_rows,
    }
    study["table"] = estimator_table(study)
    return study


def _f(v: float | None, digits: int = 3) -> str:
    return "n/a" if v is None or not math.isfinite(v) else f"{v:.{digits}f}"


def _sig(v: float | None) -> str:
    """Three significant digits (FastSLAM's NEES reaches 1e20)."""
    return "n/a" if v is None or not math.isfinite(v) else f"{v:.3g}"


def _pct(v: float | None) -> str:
    return "n/a" if v is None else f"{100 * v:.0f} %"


def _row_cells(row: dict[str, Any]) -> str:
    return " | ".join(
        [
            f"{_pct(row['converged'])} / {_pct(row['drift'])} / {_pct(row['diverged'])}",
            f"{_f(row['ate_mean_m'])} / {_f(row['ate_median_m'])}",
            _f(row["final_position_median_m"]),
            _f(row["final_heading_median_deg"], 2),
            _sig(row["mean_nees"]),
            _pct(row["nees_inside"]),
            f"{row['seconds']:.1f}",
        ]
    )


def _long_cells(row: dict[str, Any]) -> str:
    return " | ".join(
        [
            f"{_sig(row['first_half_median'])} / {_sig(row['second_half_median'])}",
            f"{_sig(row['first_half_mean'])} / {_sig(row['second_half_mean'])}",
            _pct(row["fraction_inside"]),
            _pct(row["fraction_above"]),
            f"{row['seconds']:.1f}",
        ]
    )


def estimator_table(study: dict[str, Any]) -> str:
    """The study's markdown tables."""
    lines: list[str] = []
    if study["montecarlo"]:
        lines += _montecarlo_lines(study)
    if study["long"]:
        lines += _long_lines(study)
    return "\n".join(lines) + "\n"


def _montecarlo_lines(study: dict[str, Any]) -> list[str]:
    lines = [
        f"### Monte Carlo: {study['runs']} seeded runs per configuration (MTE)",
        "",
        "| scenario | estimator | converged / drift / diverged | ATE mean / median (m) "
        "| final position median (m) | final heading median (°) | mean NEES "
        "| mean NEES in 95 % band | time (s) |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for row in study["montecarlo"]:
        lines.append(f"| {row['scenario']} | {row['label']} | {_row_cells(row)} |")
    return lines


def _long_lines(study: dict[str, Any]) -> list[str]:
    lines = [
        "",
        f"### The long run: {study['long_scenario']}, {study['long_s']:g} s, "
        f"{study['long_runs']} seeds",
        "",
        "Mean pose NEES (3 dof) over the seeds; its 95 % band is "
        f"[{_f(study['long'][0]['lower'], 2)}, {_f(study['long'][0]['upper'], 2)}].",
        "",
        "| estimator | its median over time, first / second half "
        "| its mean over time, first / second half "
        "| time in band | time above band | time (s) |",
        "|---|---|---|---|---|---|",
    ]
    for row in study["long"]:
        lines.append(f"| {row['label']} | {_long_cells(row)} |")
    return lines


def _plot(study: dict[str, Any], path: Path, title: str) -> Path:
    import matplotlib.pyplot as plt

    from bearing_slam.plots.run import save_figure

    panels = list(dict.fromkeys(r["scenario"] for r in study["montecarlo"]))
    n = len(panels) + (1 if study["long"] else 0)
    cols = 1 if n == 1 else 2
    fig, axes = plt.subplots(
        math.ceil(n / cols),
        cols,
        figsize=(6.5 * cols + 2.5, 4.2 * math.ceil(n / cols)),
        layout="constrained",
    )
    flat = list(np.atleast_1d(axes).ravel())
    colours = plt.get_cmap("tab10")
    labels = list(dict.fromkeys(r["label"] for r in [*study["montecarlo"], *study["long"]]))

    def draw(ax: Any, t: list[float], mean: list[float], label: str) -> None:
        ax.plot(t, mean, lw=1.3, color=colours(labels.index(label) % 10), label=label)

    for ax, scenario in zip(flat, panels, strict=False):
        rows = [r for r in study["montecarlo"] if r["scenario"] == scenario]
        for r in rows:
            s = r["nees_over_time"]
            draw(ax, s["time"], s["mean"], r["label"])
        s0 = rows[0]["nees_over_time"]
        ax.fill_between(s0["time"], s0["lower"], s0["upper"], color="grey", alpha=0.25)
        ax.set_title(f"{scenario}: mean pose NEES, {study['runs']} runs (grey: 95 % band)")
    if study["long"]:
        ax = flat[len(panels)]
        for r in study["long"]:
            draw(ax, r["time"], r["mean"], r["label"])
        lo, hi = study["long"][0]["lower"], study["long"][0]["upper"]
        ax.axhspan(lo, hi, color="grey", alpha=0.25)
        ax.set_title(
            f"long run: {study['long_scenario']} {study['long_s']:g} s, "
            f"{study['long_runs']} seeds (Bailey et al. 2006)"
        )
    for ax in flat[:n]:
        ax.set_yscale("log")
        ax.set_xlabel("time [s]")
        ax.set_ylabel("mean pose NEES")
        ax.grid(True, which="both", alpha=0.3)
    for ax in flat[n:]:
        ax.set_visible(False)
    handles, names = flat[0].get_legend_handles_labels()
    fig.legend(handles, names, loc="outside right center", fontsize=8)
    fig.suptitle(f"{title}: pose NEES over time")
    return save_figure(fig, path, dpi=100)


def write_estimator_study(
    study: dict[str, Any], out: str | Path, command: str, stem: str = "particles"
) -> list[Path]:
    """Writes ``STEM.md``, ``STEM.json`` (time series thinned) and
    ``STEM.png`` into ``out`` (``stem`` one of :data:`STUDIES`); returns the
    paths."""
    import json

    from bearing_slam.experiments import compact
    from bearing_slam.outputs import write_text_atomic

    title = STUDIES[stem]
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    md = out / f"{stem}.md"
    write_text_atomic(
        md,
        f"# {title}\n\n"
        f"Made by `{command}`; the plot is [`{stem}.png`]({stem}.png), the numbers "
        f"[`{stem}.json`]({stem}.json).\n\n{study['table'].strip()}\n\n"
        f"![{stem}]({stem}.png)\n",
    )
    js = out / f"{stem}.json"
    write_text_atomic(js, json.dumps(compact(study), separators=(",", ":")) + "\n")
    png = _plot(study, out / f"{stem}.png", title)
    return [md, js, png]
