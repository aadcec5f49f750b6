"""The paper's figures, reproduced: run the Rust experiment drivers, write
each figure's markdown table, JSON and PNG plot.

>>> from bearing_slam.experiments import run_experiments
>>> run_experiments(["fig5"], out="docs/results")  # doctest: +SKIP

The figures are drawn by :mod:`bearing_slam.plots.experiments`.

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
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from tqdm import tqdm

from bearing_slam._native import (
    experiment_consistency,
    experiment_fig4,
    experiment_fig5,
    experiment_fig8,
    experiment_fig10,
)
from bearing_slam.outputs import write_text_atomic
from bearing_slam.plots.experiments import save_experiment_figure
from bearing_slam.vocabulary import EXPERIMENT_DEFAULT_RUNS, EXPERIMENTS

__all__ = [
    "DEFAULT_RUNS",
    "EXPERIMENTS",
    "MAX_SERIES_POINTS",
    "SIGNIFICANT_DIGITS",
    "compact",
    "run_experiment",
    "run_experiments",
    "write_experiment",
]

#: Runs per configuration unless ``runs`` is given (Fig. 5 samples instead).
DEFAULT_RUNS = EXPERIMENT_DEFAULT_RUNS

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

#: ``callback(what, done, total)`` of the Rust drivers.
ExperimentProgress = Callable[[str, int, int], object]


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
    write_text_atomic(md, _markdown(name, str(result["table"]), command))
    js = out / f"{name}.json"
    write_text_atomic(js, json.dumps(compact(result), separators=(",", ":")) + "\n")
    png = out / f"{name}.png"
    save_experiment_figure(name, result, png)
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
