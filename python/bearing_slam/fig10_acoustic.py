"""Fig. 10 with acoustic bearings: the single-source oval and figure-eight
(slip off and on), each run with the simulator's Gaussian bearings and with
the bearings of a simulated microphone array (:mod:`bearing_slam.acoustics`,
one per DOA method), beside dead reckoning; and the DOA error distribution.

``bearing-slam experiment fig10 --bearings acoustic`` runs
:func:`run_fig10_acoustic` and :func:`write_fig10_acoustic`: it writes
``fig10_acoustic.md`` (the table), ``fig10_acoustic.json`` (the numbers, rounded as by
:func:`bearing_slam.experiments.compact`),
``fig10_acoustic.png`` (mean position error over time) and ``acoustics.md``
(the DOA error distribution per method, with the command).
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from bearing_slam._native import Config, RunResult, SensorLog, run, simulate
from bearing_slam.acoustics import (
    DOA_METHODS,
    OUTLIER_DEG,
    AcousticSetup,
    acoustic_log,
    doa_error_stats,
    error_table,
    simulate_doa,
)
from bearing_slam.experiments import compact

__all__ = [
    "DEFAULT_RUNS",
    "SCENARIOS",
    "position_error",
    "run_fig10_acoustic",
    "summary_lines",
    "table",
    "write_fig10_acoustic",
]

#: The scenarios of Fig. 10.
SCENARIOS = ("single_source_oval", "single_source_figure8")

#: Runs per configuration unless told: the room simulation costs about
#: 0.3 s per scan window and method.
DEFAULT_RUNS = 2

#: Points of the mean-error curves in the JSON and the plot.
_CURVE_POINTS = 200


def position_error(result: RunResult, which: str = "estimate") -> NDArray[np.float64]:
    """|estimate − truth| (``which``: ``"estimate"`` or ``"dead_reckoning"``)
    over ``result.time``, m."""
    est = result.estimate if which == "estimate" else result.dead_reckoning
    err: NDArray[np.float64] = np.hypot(*(est[:, :2] - result.truth[:, :2]).T)
    return err


def _ate(err: NDArray[np.float64]) -> float:
    return float(np.sqrt(np.mean(err**2))) if len(err) else math.nan


def _run_mte(log: SensorLog) -> RunResult:
    return run(log, Config.for_log(log, init="mte"))


def run_fig10_acoustic(
    runs: int = DEFAULT_RUNS,
    seed0: int = 0,
    *,
    setup: AcousticSetup | None = None,
    methods: Sequence[str] = DOA_METHODS,
    scenarios: Sequence[str] = SCENARIOS,
    slips: Sequence[bool] = (False, True),
    duration: float | None = None,
    progress: Callable[[str, int, int], object] | None = None,
) -> dict[str, Any]:
    """Runs the experiment: for each scenario, slip setting and seed
    ``seed0 … seed0 + runs − 1``, dead reckoning, MTE on the Gaussian
    bearings and MTE on each method's acoustic bearings. Returns a dict with
    ``configs`` (per configuration: per-method ATE, final error and the mean
    error curve), ``doa`` (:func:`~bearing_slam.acoustics.doa_error_stats`
    per method, pooled), ``setup`` and the markdown ``table``."""
    setup = setup or AcousticSetup()
    setup.validate()
    labels = ["dead reckoning", "MTE gaussian", *[f"MTE acoustic {m}" for m in methods]]
    configs: list[dict[str, Any]] = []
    errors: dict[str, list[NDArray[np.float64]]] = {m: [] for m in methods}
    total = len(scenarios) * len(slips) * runs
    done = 0
    for name in scenarios:
        for slip in slips:
            per: dict[str, dict[str, list[float]]] = {
                lab: {"ate_m": [], "final_m": []} for lab in labels
            }
            curves: dict[str, list[NDArray[np.float64]]] = {lab: [] for lab in labels}
            grid: NDArray[np.float64] | None = None
            for r in range(runs):
                log = simulate(name, seed=seed0 + r, slip=slip, duration=duration)
                doa = simulate_doa(log, replace_seed(setup, seed0 + r), methods)
                gauss = _run_mte(log)
                results: dict[str, tuple[RunResult, str]] = {
                    "dead reckoning": (gauss, "dead_reckoning"),
                    "MTE gaussian": (gauss, "estimate"),
                }
                for m in methods:
                    errors[m].append(doa.errors(m))
                    results[f"MTE acoustic {m}"] = (_run_mte(acoustic_log(log, doa, m)), "estimate")
                for lab, (res, which) in results.items():
                    err = position_error(res, which)
                    if grid is None:
                        grid = np.linspace(0.0, float(res.time[-1]), _CURVE_POINTS)
                    per[lab]["ate_m"].append(_ate(err))
                    per[lab]["final_m"].append(float(err[-1]))
                    curves[lab].append(np.interp(grid, res.time, err))
                done += 1
                if progress is not None:
                    progress(f"fig10 acoustic {name} slip {'on' if slip else 'off'}", done, total)
            configs.append(
                {
                    "scenario": name,
                    "slip": slip,
                    "runs": runs,
                    "methods": {
                        lab: {
                            "ate_m": float(np.mean(v["ate_m"])),
                            "final_m": float(np.mean(v["final_m"])),
                            "per_run_ate_m": v["ate_m"],
                        }
                        for lab, v in per.items()
                    },
                    "error_over_time": {
                        "time": [] if grid is None else grid.tolist(),
                        **{lab: np.mean(c, axis=0).tolist() for lab, c in curves.items()},
                    },
                }
            )
    doa_stats = {m: doa_error_stats(np.concatenate(errors[m])) for m in methods}
    result: dict[str, Any] = {
        "labels": labels,
        "configs": configs,
        "doa": doa_stats,
        "setup": {k: v for k, v in vars(setup).items()},
        "outlier_deg": OUTLIER_DEG,
        "seed0": seed0,
        "runs": runs,
    }
    result["table"] = table(result)
    return result


def replace_seed(setup: AcousticSetup, seed: int) -> AcousticSetup:
    """``setup`` with the signal seed of run ``seed`` (a fresh noise per run)."""
    from dataclasses import replace

    return replace(setup, seed=setup.seed * 1_000_003 + seed)


def table(result: dict[str, Any]) -> str:
    labels: list[str] = result["labels"]
    head = "| scenario | slip | runs | " + " | ".join(f"{lab} ATE m" for lab in labels) + " |"
    rows = [head, "|" + "---|" * (3 + len(labels))]
    for c in result["configs"]:
        cells = [f"{c['methods'][lab]['ate_m']:.3f}" for lab in labels]
        rows.append(
            f"| {c['scenario']} | {'on' if c['slip'] else 'off'} | {c['runs']} | "
            + " | ".join(cells)
            + " |"
        )
    rows += ["", "Final position error, m:", ""]
    rows += [
        "| scenario | slip | " + " | ".join(labels) + " |",
        "|" + "---|" * (2 + len(labels)),
    ]
    for c in result["configs"]:
        cells = [f"{c['methods'][lab]['final_m']:.3f}" for lab in labels]
        rows.append(
            f"| {c['scenario']} | {'on' if c['slip'] else 'off'} | " + " | ".join(cells) + " |"
        )
    return "\n".join(rows) + "\n"


def summary_lines(result: dict[str, Any]) -> list[str]:
    """One line per SLAM variant: in how many configurations its mean ATE is
    below dead reckoning's, and its mean ATE as a fraction of it."""
    configs = result["configs"]
    lines = []
    for lab in result["labels"][1:]:
        ratios = [
            c["methods"][lab]["ate_m"] / c["methods"]["dead reckoning"]["ate_m"] for c in configs
        ]
        better = sum(r < 1.0 for r in ratios)
        lines.append(
            f"- {lab}: below dead reckoning in {better} of {len(configs)} configurations, "
            f"mean ATE {100 * float(np.mean(ratios)):.0f} % of dead reckoning's"
        )
    return lines


def _setup_text(setup: dict[str, Any]) -> str:
    return (
        f"shoebox room {setup['margin_m']:g} m around the run, wall absorption "
        f"{setup['absorption']:g}, image sources up to order {setup['max_order']}, "
        f"{setup['n_mics']}-microphone circular array of radius {100 * setup['array_radius_m']:g} "
        f"cm on the robot, a {1000 * setup['window_s']:g} ms white-noise burst at "
        f"{setup['fs']} Hz per window, SNR {setup['snr_db']:g} dB, STFT {setup['nfft']} "
        f"points, band {setup['freq_range'][0]:g}–{setup['freq_range'][1]:g} Hz, one "
        f"window per {setup['every']} scans ({10 / setup['every']:g} Hz at the simulator's 10 Hz "
        f"scans), filter σ {math.degrees(setup['bearing_sigma_rad']):g}°"
    )


def _plot(result: dict[str, Any], path: Path) -> Path:
    import matplotlib as mpl

    mpl.use("Agg")
    import matplotlib.pyplot as plt

    configs = result["configs"]
    fig, axes = plt.subplots(
        len(configs), 1, figsize=(9, 2.6 * len(configs)), sharex=True, squeeze=False
    )
    styles = {"dead reckoning": ("#7f7f7f", "--"), "MTE gaussian": ("#1f77b4", "-")}
    palette = ["#d62728", "#ff7f0e", "#9467bd", "#8c564b"]
    for ax, c in zip(axes[:, 0], configs, strict=True):
        e = c["error_over_time"]
        for i, lab in enumerate(result["labels"]):
            color, ls = styles.get(lab, (palette[i % len(palette)], "-"))
            ax.plot(e["time"], e[lab], color=color, ls=ls, lw=1.3, label=lab)
        ax.set_title(
            f"{c['scenario']}, slip {'on' if c['slip'] else 'off'} ({c['runs']} runs)", fontsize=9
        )
        ax.set_ylabel("position error [m]")
        ax.grid(True, alpha=0.3)
    axes[0, 0].legend(fontsize=7, ncol=3)
    axes[-1, 0].set_xlabel("time [s]")
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)
    return path


def write_fig10_acoustic(result: dict[str, Any], out: str | Path, command: str = "") -> list[Path]:
    """Writes ``fig10_acoustic.md``, ``.json``, ``.png`` and ``acoustics.md``
    into ``out``; returns the paths."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    command = command or "bearing-slam experiment fig10 --bearings acoustic"
    setup = _setup_text(result["setup"])
    md = out / "fig10_acoustic.md"
    md.write_text(
        "# Fig. 10 with acoustic bearings: position error, single source (MTE)\n\n"
        f"Made by `{command}`; the plot is [`fig10_acoustic.png`](fig10_acoustic.png), the "
        "numbers [`fig10_acoustic.json`](fig10_acoustic.json); the DOA errors "
        "[`acoustics.md`](acoustics.md).\n\nMean ATE over the runs (each run: the same "
        "simulated log with its Gaussian bearings, σ 7.5° at 10 Hz, and with the "
        f"acoustic bearings of each DOA method: {setup}).\n\n"
        f"{result['table'].strip()}\n\n" + "\n".join(summary_lines(result)) + "\n\n"
        "![fig10_acoustic](fig10_acoustic.png)\n"
    )
    js = out / "fig10_acoustic.json"
    slim = json.loads(json.dumps(result, default=_json_default))
    js.write_text(json.dumps(compact(slim), separators=(",", ":")) + "\n")
    png = _plot(result, out / "fig10_acoustic.png")
    doa = out / "acoustics.md"
    doa.write_text(
        "# Acoustic bearings: DOA error distribution\n\n"
        f"Made by `{command}` (module `bearing_slam.acoustics`, the `acoustics` extra: "
        "pyroomacoustics). Setup: "
        f"{setup}. Error = estimated − true bearing (robot frame), pooled over every scan "
        f"window of the {result['runs']} runs × {len(result['configs'])} configurations of "
        "[`fig10_acoustic.md`](fig10_acoustic.md). Bias and spread are the mean and standard "
        f"deviation of the inliers (|error| ≤ {result['outlier_deg']:g}°); outliers are "
        "beyond that; front-back counts errors within 30° of the mirror direction.\n\n"
        f"{error_table(result['doa']).strip()}\n"
    )
    return [md, js, png, doa]


def _json_default(obj: Any) -> Any:
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, tuple):
        return list(obj)
    raise TypeError(f"not JSON serializable: {type(obj).__name__}")
