"""The paper's figures, reproduced: run the Rust experiment drivers, write
each figure's markdown table, JSON and PNG plot.

>>> from bearing_slam.experiments import run_experiments
>>> run_experiments(["fig5"], out="docs/results")  # doctest: +SKIP

=============  ==============================================================
name           what it runs and plots
=============  ==============================================================
``fig4``       ``paper_fig4``, six initializers, with and without the far
               landmark: class fractions per method; then every initializer
               on the scene scaled ×0.2 … ×4: ATE per scale (``fig4.png``)
``fig5``       depth σ_d and inverse-depth σ_ρ of a triangulation against
               parallax, first order and sampled, log y (``fig5.png``)
``fig8``       ``paper_fig8`` with 5, 10, 20, 40 landmarks (MTE): ATE of dead
               reckoning and SLAM against landmark count (``fig8.png``)
``fig10``      single-source oval and figure-eight, slip off and on (MTE):
               position error over time, dead reckoning and SLAM (``fig10.png``)
``consistency``  Fig. 4's runs: mean pose NEES over time with the 95 % band,
               per method (``consistency.png``)
=============  ==============================================================

Each writes ``NAME.md`` (the table), ``NAME.json`` (the numbers behind the
table and the plot; the time series thinned to at most
:data:`MAX_SERIES_POINTS` points, numbers to :data:`SIGNIFICANT_DIGITS`
significant digits) and ``NAME.png``.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import Any

import matplotlib as mpl

mpl.use("Agg")

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure
from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter
from numpy.typing import NDArray
from tqdm import tqdm

from bearing_slam._native import (
    experiment_consistency,
    experiment_fig4,
    experiment_fig5,
    experiment_fig8,
    experiment_fig10,
)

__all__ = [
    "DEFAULT_RUNS",
    "EXPERIMENTS",
    "MAX_SERIES_POINTS",
    "PLOTS",
    "SIGNIFICANT_DIGITS",
    "compact",
    "plot_consistency",
    "plot_fig4",
    "plot_fig5",
    "plot_fig8",
    "plot_fig10",
    "run_experiment",
    "run_experiments",
    "write_experiment",
]

#: The experiments, in the order ``all`` runs them.
EXPERIMENTS = ("fig4", "consistency", "fig5", "fig8", "fig10")

#: Runs per configuration unless ``runs`` is given (Fig. 5 samples instead).
DEFAULT_RUNS = {"fig4": 200, "consistency": 200, "fig8": 50, "fig10": 50}

#: Time series in the written JSON are thinned to at most this many points.
MAX_SERIES_POINTS = 400

#: Significant digits of the numbers in the written JSON.
SIGNIFICANT_DIGITS = 6

#: What each experiment is, for titles and markdown headings.
TITLES = {
    "fig4": "Fig. 4: convergence of the initializers on paper_fig4",
    "consistency": "Consistency: pose NEES over time (paper_fig4, 3 dof)",
    "fig5": "Fig. 5: triangulation uncertainty against parallax",
    "fig8": "Fig. 8: dead reckoning against SLAM (MTE) by landmark count",
    "fig10": "Fig. 10: position error over time, single source (MTE)",
}

_COLORS = {"converged": "#2ca02c", "drift": "#ff7f0e", "diverged": "#d62728"}
_DR = "#7f7f7f"
_SLAM = "#1f77b4"

#: ``callback(what, done, total)`` of the Rust drivers.
ExperimentProgress = Callable[[str, int, int], object]


def _nan(values: Iterable[float | None]) -> NDArray[np.float64]:
    return np.array([math.nan if v is None else v for v in values], dtype=np.float64)


# ---------------------------------------------------------------- plots


def plot_fig4(result: dict[str, Any]) -> Figure:
    """Class fractions (converged, drift, diverged) per method, with and
    without the far landmark: horizontal stacked bars; below them, when the
    result has the tuning study, each method's ATE against the scene scale."""
    scales = result.get("across_scales") or []
    fig = plt.figure(figsize=(13, 9.0 if scales else 4.2))
    grid = fig.add_gridspec(2 if scales else 1, 2, height_ratios=[1, 1] if scales else [1])
    axes = [fig.add_subplot(grid[0, 0])]
    axes.append(fig.add_subplot(grid[0, 1], sharey=axes[0]))
    plt.setp(axes[1].get_yticklabels(), visible=False)
    for ax, key, title in zip(
        axes,
        ("with_far", "without_far"),
        ("with the far landmark (75 m)", "without the far landmark"),
        strict=True,
    ):
        reports = result[key]
        labels = [r["label"].replace(" (near", "\n(near") for r in reports]
        y = np.arange(len(reports))[::-1]
        left = np.zeros(len(reports))
        for cls in ("converged", "drift", "diverged"):
            frac = np.array([r[f"{cls}_fraction"] for r in reports])
            ax.barh(y, frac, left=left, color=_COLORS[cls], label=cls, height=0.65)
            for yi, lo, f in zip(y, left, frac, strict=True):
                if f >= 0.06:
                    ax.text(lo + f / 2, yi, f"{100 * f:.1f} %", ha="center", va="center",
                            color="white", fontsize=9, fontweight="bold")  # fmt: skip
            left += frac
        ax.set_yticks(y, labels)
        ax.set_xlim(0, 1)
        ax.set_xlabel("fraction of runs")
        runs = reports[0]["spec"]["runs"] if reports else 0
        ax.set_title(f"paper_fig4, {title}, {runs} runs each")
        ax.grid(axis="x", alpha=0.3)
    handles, names = axes[0].get_legend_handles_labels()
    if scales:
        _plot_fig4_scales(fig.add_subplot(grid[1, :]), scales)
        fig.legend(handles, names, loc="center", bbox_to_anchor=(0.5, 0.505), ncol=3,
                   fontsize=9, frameon=False)  # fmt: skip
        fig.tight_layout(h_pad=3.0)
    else:
        fig.legend(handles, names, loc="lower center", ncol=3, fontsize=9, frameon=False)
        fig.tight_layout(rect=(0, 0.06, 1, 1))
    return fig


def _plot_fig4_scales(ax: Axes, rows: list[dict[str, Any]]) -> None:
    """ATE (mean over the runs that did not diverge) against the factor on
    the near landmarks' positions, one line per method; the marker is hollow
    where fewer than 95 % of the runs converged."""
    for row in rows:
        cells = row["cells"]
        x = np.array([c["scale"] for c in cells], dtype=np.float64)
        ate = _nan(c["ate_rmse_m"] for c in cells)
        ok = np.array([c["converged_fraction"] >= 0.95 for c in cells])
        mte = row["label"].startswith("MTE")
        style = "-" if mte else "--"
        # MTE and MTE-clone nearly coincide: MTE is drawn wider, beneath.
        width = 4.0 if row["label"] == "MTE" else 2.2 if mte else 1.4
        (line,) = ax.plot(x, ate, style, lw=width, label=row["label"], zorder=3 if mte else 2)
        color = line.get_color()
        ax.plot(x[ok], ate[ok], "o", color=color, ms=6, zorder=4)
        ax.plot(x[~ok], ate[~ok], "o", color=color, mfc="white", ms=6, zorder=4)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xticks(
        [c["scale"] for c in rows[0]["cells"]], [f"×{c['scale']:g}" for c in rows[0]["cells"]]
    )
    ax.minorticks_off()
    ax.set_yticks([0.03, 0.05, 0.1, 0.2, 0.5, 1.0])
    ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    ax.set_xlabel("near landmarks' positions × (first depths 2.5–8.2 m at ×1)")
    ax.set_ylabel("ATE [m] (mean, non-diverged runs)")
    ax.set_title(
        "paper_fig4 scaled: which initializer needs no tuning? "
        "(hollow marker: < 95 % of the runs converged)"
    )
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8, ncol=2, loc="upper left")


def plot_fig5(result: dict[str, Any]) -> Figure:
    """σ_d (depth) and σ_ρ (inverse depth) against parallax, first order
    (lines) and sampled (markers), log y."""
    pts = result["points"]
    a = _nan(p["parallax_deg"] for p in pts)
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(12, 4.5))
    ax1.semilogy(a, _nan(p["sigma_depth_m"] for p in pts), "-", color=_SLAM,
                 label="first order σ_ρ/ρ²")  # fmt: skip
    ax1.semilogy(a, _nan(p["sampled_sigma_depth_m"] for p in pts), "o", color="#d62728", ms=5,
                 label="sampled, rays meeting in front (half 16–84 % range)")  # fmt: skip
    ax1.set_ylabel("σ_d [m]")
    ax1.set_title(f"depth σ_d, landmark at {result['distance_m']:g} m")
    ax2.semilogy(a, _nan(p["sigma_rho"] for p in pts), "-", color=_SLAM, label="first order")
    ax2.semilogy(a, _nan(p["sampled_sigma_rho"] for p in pts), "o", color="#d62728", ms=5,
                 label="sampled (std)")  # fmt: skip
    ax2.set_ylabel("σ_ρ [1/m]")
    ax2.set_title("inverse depth σ_ρ")
    for ax in (ax1, ax2):
        ax.set_xlabel("parallax α [°]")
        ax.grid(which="both", alpha=0.3)
        ax.legend()
    fig.suptitle(
        f"Triangulation with σ = {result['sigma_deg']:g}° bearings, β = 90°, "
        f"{result['samples']} samples per angle"
    )
    fig.tight_layout()
    return fig


def plot_fig8(result: dict[str, Any]) -> Figure:
    """Per-run ATE of dead reckoning and SLAM (MTE) against the number of
    landmarks: boxes over runs, means as diamonds."""
    rows = result["rows"]
    fig, ax = plt.subplots(figsize=(8, 4.8))
    x = np.arange(len(rows))
    for offset, key, color, name in (
        (-0.18, "dead_reckoning_ate_rmse_m", _DR, "dead reckoning"),
        (0.18, "ate_rmse_m", _SLAM, "SLAM (MTE)"),
    ):
        data = []
        for row in rows:
            v = _nan(r[key] for r in row["report"]["runs"] if r["class"] != "diverged")
            data.append(v[np.isfinite(v)])
        bp = ax.boxplot(data, positions=x + offset, widths=0.3, patch_artist=True,
                        showfliers=True, flierprops={"ms": 3})  # fmt: skip
        for box in bp["boxes"]:
            box.set_facecolor(color)
            box.set_alpha(0.45)
        means = [float(np.mean(d)) if len(d) else math.nan for d in data]
        ax.plot(x + offset, means, "D-", color=color, ms=6, label=f"{name}, mean")
    ax.set_xticks(x, [str(r["landmarks"]) for r in rows])
    ax.set_xlabel("number of landmarks")
    ax.set_ylabel("ATE (position RMSE) [m]")
    ax.set_yscale("log")
    runs = rows[0]["report"]["spec"]["runs"] if rows else 0
    ax.set_title(f"paper_fig8: dead reckoning vs SLAM, {runs} runs per count")
    ax.grid(which="both", axis="y", alpha=0.3)
    ax.legend()
    fig.tight_layout()
    return fig


def plot_fig10(result: dict[str, Any]) -> Figure:
    """Mean position error over time (over the runs that did not diverge),
    dead reckoning against SLAM, per scenario and slip setting."""
    reports = result["reports"]
    fig, axes = plt.subplots(2, 2, figsize=(12, 7.5), sharex="row")
    for ax, rep in zip(axes.flat, reports, strict=False):
        e = rep["error_over_time"]
        t = _nan(e["time"])
        ax.plot(
            t, _nan(e["dead_reckoning_mean_m"]), color=_DR, lw=1.6, label="dead reckoning, mean"
        )
        ax.plot(
            t,
            _nan(e["dead_reckoning_rms_m"]),
            color=_DR,
            lw=0.9,
            ls="--",
            label="dead reckoning, RMS",
        )
        ax.plot(t, _nan(e["slam_mean_m"]), color=_SLAM, lw=1.6, label="SLAM (MTE), mean")
        ax.plot(t, _nan(e["slam_rms_m"]), color=_SLAM, lw=0.9, ls="--", label="SLAM (MTE), RMS")
        if len(t):
            for k in range(1, 6):
                ax.axvline(t[-1] * k / 6, color="k", lw=0.5, alpha=0.25)
        sc = rep["spec"]["scenario"]
        slip = "on" if sc["slip"] else "off"
        n = rep["all_finite"]["runs"]
        ax.set_title(f"{sc['name']}, slip {slip} ({n} runs)")
        ax.set_xlabel("time [s] (thin lines: laps)")
        ax.set_ylabel("position error [m]")
        ax.grid(alpha=0.3)
    axes.flat[0].legend(fontsize=8)
    fig.tight_layout()
    return fig


def plot_consistency(result: dict[str, Any]) -> Figure:
    """Mean pose NEES over time with its 95 % band, one panel per method,
    with (left) and without (right) the far landmark; log y."""
    curves = result["curves"]
    with_far = [c for c in curves if "no far" not in c["scenario"]]
    without = [c for c in curves if "no far" in c["scenario"]]
    n = max(len(with_far), len(without), 1)
    fig, axes = plt.subplots(n, 2, figsize=(12, 2.3 * n + 0.6), sharex=True, squeeze=False)
    for col, group, title in ((0, with_far, "with far landmark"), (1, without, "no far landmark")):
        for row in range(n):
            ax = axes[row, col]
            if row >= len(group):
                ax.set_visible(False)
                continue
            c = group[row]
            nees = c["nees"]
            t = _nan(nees["time"])
            ax.fill_between(t, _nan(nees["lower"]), _nan(nees["upper"]), color="#2ca02c",
                            alpha=0.25, lw=0, label="95 % band")  # fmt: skip
            ax.axhline(3.0, color="k", lw=0.7, ls=":", label="expected (3)")
            ax.plot(t, _nan(nees["mean"]), color=_SLAM, lw=1.2, label="mean NEES")
            ax.set_yscale("log")
            # The start is known exactly: the first NEES values are ~0; keep the band readable.
            ax.set_ylim(bottom=0.2)
            ax.yaxis.set_major_locator(LogLocator(base=10, subs=(1.0, 2.0, 5.0), numticks=8))
            ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _pos: f"{v:g}"))
            ax.yaxis.set_minor_formatter(NullFormatter())
            inside = nees.get("fraction_inside")
            frac = "" if inside is None else f", {100 * inside:.0f} % of the time in the band"
            label = c["label"].split(" (near")[0]
            ax.set_title(f"{label}, {title}{frac}", fontsize=9)
            ax.set_ylabel("NEES")
            ax.grid(which="both", alpha=0.25)
            if row == len(group) - 1:
                ax.set_xlabel("time [s]")
    axes[0, 0].legend(fontsize=8, loc="upper left")
    fig.tight_layout()
    return fig


PLOTS: dict[str, Callable[[dict[str, Any]], Figure]] = {
    "fig4": plot_fig4,
    "consistency": plot_consistency,
    "fig5": plot_fig5,
    "fig8": plot_fig8,
    "fig10": plot_fig10,
}


# ---------------------------------------------------------------- running and writing


def _thin(obj: Any, n_grid: int, step: int) -> Any:
    """Every list of length ``n_grid`` inside ``obj`` thinned to every ``step``-th
    element (keeping the last)."""
    if isinstance(obj, dict):
        return {k: _thin(v, n_grid, step) for k, v in obj.items()}
    if isinstance(obj, list):
        if len(obj) == n_grid and n_grid > 0:
            idx = list(range(0, n_grid, step))
            if idx[-1] != n_grid - 1:
                idx.append(n_grid - 1)
            return [obj[i] for i in idx]
        return [_thin(v, n_grid, step) for v in obj]
    return obj


def _grids(obj: Any) -> set[int]:
    """Lengths of the ``time`` lists inside ``obj``."""
    out: set[int] = set()
    if isinstance(obj, dict):
        t = obj.get("time")
        if isinstance(t, list):
            out.add(len(t))
        for v in obj.values():
            out |= _grids(v)
    elif isinstance(obj, list):
        for v in obj:
            out |= _grids(v)
    return out


def _round(obj: Any, digits: int) -> Any:
    """Every float inside ``obj`` rounded to ``digits`` significant digits."""
    if isinstance(obj, float):
        return float(f"{obj:.{digits}g}") if math.isfinite(obj) else obj
    if isinstance(obj, dict):
        return {k: _round(v, digits) for k, v in obj.items()}
    if isinstance(obj, list):
        return [_round(v, digits) for v in obj]
    return obj


def compact(result: dict[str, Any], max_points: int = MAX_SERIES_POINTS) -> dict[str, Any]:
    """``result`` without its markdown table (and, for Fig. 4, without the
    consistency part, written on its own), with every time series (NEES and
    errors over time) thinned to at most ``max_points`` points and every
    number rounded to :data:`SIGNIFICANT_DIGITS` significant digits; the
    per-run metrics stay. For the exact numbers run the experiment from Python."""
    out: Any = {k: v for k, v in result.items() if k not in ("table", "consistency")}
    for n in sorted(_grids(out)):
        if n > max_points:
            out = _thin(out, n, math.ceil(n / max_points))
    result_out: dict[str, Any] = _round(out, SIGNIFICANT_DIGITS)
    return result_out


def _progress_bars() -> tuple[ExperimentProgress, Callable[[], None]]:
    state: dict[str, Any] = {"what": None, "bar": None}

    def update(what: str, done: int, total: int) -> None:
        if state["what"] != what:
            if state["bar"] is not None:
                state["bar"].close()
            state["what"] = what
            state["bar"] = tqdm(total=total, desc=what, unit="run")
        bar = state["bar"]
        bar.update(done - bar.n)

    def close() -> None:
        if state["bar"] is not None:
            state["bar"].close()
            state["bar"] = None
            state["what"] = None

    return update, close


def run_experiment(
    name: str,
    *,
    runs: int | None = None,
    seed0: int = 0,
    progress: bool | ExperimentProgress = True,
) -> dict[str, Any]:
    """Runs one experiment (:data:`EXPERIMENTS`) and returns its plot-ready
    dict, with its markdown table under ``"table"``. ``runs`` defaults to
    :data:`DEFAULT_RUNS` (Fig. 5 ignores it). ``fig4`` also carries the
    ``consistency`` result of the same runs."""
    if progress is True:
        callback, close = _progress_bars()
    elif callable(progress):
        callback, close = progress, (lambda: None)
    else:
        callback, close = None, (lambda: None)
    n = runs if runs is not None else DEFAULT_RUNS.get(name, 0)
    try:
        if name == "fig4":
            return experiment_fig4(n, seed0, callback)
        if name == "consistency":
            return experiment_consistency(n, seed0, callback)
        if name == "fig5":
            return experiment_fig5(seed=seed0)
        if name == "fig8":
            return experiment_fig8(n, seed0, None, callback)
        if name == "fig10":
            return experiment_fig10(n, seed0, callback)
    finally:
        close()
    raise ValueError(f"unknown experiment {name!r}; known: {', '.join(EXPERIMENTS)}")


def _markdown(name: str, table: str, command: str) -> str:
    return (
        f"# {TITLES[name]}\n\nMade by `{command}`; the plot is [`{name}.png`]({name}.png), "
        f"the numbers [`{name}.json`]({name}.json).\n\n{table.strip()}\n\n![{name}]({name}.png)\n"
    )


def write_experiment(
    name: str, result: dict[str, Any], out: str | Path, command: str = ""
) -> list[Path]:
    """Writes ``NAME.md``, ``NAME.json`` (:func:`compact`) and ``NAME.png``
    into ``out``; returns the paths."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    command = command or f"bearing-slam experiment {name}"
    md = out / f"{name}.md"
    md.write_text(_markdown(name, str(result["table"]), command))
    js = out / f"{name}.json"
    js.write_text(json.dumps(compact(result), separators=(",", ":")) + "\n")
    png = out / f"{name}.png"
    fig = PLOTS[name](result)
    fig.savefig(png, dpi=110)
    plt.close(fig)
    return [md, js, png]


def run_experiments(
    names: Sequence[str],
    out: str | Path,
    *,
    runs: int | None = None,
    seed0: int = 0,
    progress: bool | ExperimentProgress = True,
    command: str = "",
    echo: Callable[[str], object] | None = None,
) -> dict[str, list[Path]]:
    """Runs and writes each experiment; ``consistency`` reuses the runs of
    ``fig4`` when both are asked for. ``echo(text)`` receives each table as
    it is done. Returns the written paths per experiment."""
    unknown = [n for n in names if n not in EXPERIMENTS]
    if unknown:
        raise ValueError(f"unknown experiment {unknown[0]!r}; known: {', '.join(EXPERIMENTS)}")
    written: dict[str, list[Path]] = {}
    fig4_result: dict[str, Any] | None = None
    for name in [n for n in EXPERIMENTS if n in names]:
        if name == "consistency" and fig4_result is not None:
            result = fig4_result["consistency"]
        else:
            result = run_experiment(name, runs=runs, seed0=seed0, progress=progress)
        if name == "fig4":
            fig4_result = result
        written[name] = write_experiment(name, result, out, command)
        if echo is not None:
            echo(f"## {TITLES[name]}\n\n{str(result['table']).strip()}\n")
    return written
