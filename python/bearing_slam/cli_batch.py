"""The batch commands of ``bearing-slam``: ``montecarlo`` (many seeded runs of
one scenario) and ``experiment`` (the paper's figures, with Gaussian or
acoustic bearings). :func:`bearing_slam.cli.main` adds them with
:func:`add_batch_parsers`.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from tqdm import tqdm

from bearing_slam._native import scenario_names
from bearing_slam.arg_types import (
    UserError,
    non_negative_float,
    output_file,
    positive_float,
    seed,
)
from bearing_slam.arg_types import positive_int as _positive_int
from bearing_slam.estimators import add_estimator_options, estimator_problem, estimator_spec
from bearing_slam.outputs import write_text_atomic
from bearing_slam.vocabulary import (
    ASSOCIATIONS,
    DEFAULT_INIT,
    DEFAULT_PRIOR,
    DEFAULT_THRESHOLDS,
    EXPERIMENT_DEFAULT_RUNS,
    EXPERIMENTS,
    FAR_PRIOR,
    INIT_NAMES,
    PRIOR_INITS,
)

__all__ = ["add_batch_parsers"]


def _cmd_montecarlo(args: argparse.Namespace) -> int:
    from bearing_slam.monte_carlo import make_spec, run_spec

    if args.scenario not in scenario_names():
        raise UserError(f"unknown scenario {args.scenario!r}; known: {', '.join(scenario_names())}")
    if args.init not in PRIOR_INITS and (args.rho_ini is not None or args.sigma_rho is not None):
        raise UserError(
            f"--rho-ini and --sigma-rho apply to --init {' and '.join(PRIOR_INITS)} only"
        )
    if problem := estimator_problem(args):
        raise UserError(problem)
    if args.descriptor_sigma is None and args.descriptor_confusion != 0.0:
        raise UserError("--descriptor-confusion needs --descriptor-sigma")
    spec = make_spec(
        args.scenario,
        args.init,
        args.runs,
        seed0=args.seed0,
        landmark_count=args.landmarks,
        far_landmark=not args.no_far,
        slip=None if args.slip is None else args.slip == "on",
        landmark_scale=args.scale,
        rho_ini=DEFAULT_PRIOR["rho_ini"] if args.rho_ini is None else args.rho_ini,
        sigma_rho=DEFAULT_PRIOR["sigma_rho"] if args.sigma_rho is None else args.sigma_rho,
        association=args.association,
        clutter=args.clutter,
        descriptor_sigma=args.descriptor_sigma,
        descriptor_confusion=args.descriptor_confusion,
        **estimator_spec(args),
    )
    result = run_spec(spec, progress=not args.quiet)

    def f(v: float | None, digits: int = 3) -> str:
        return "n/a" if v is None else f"{v:.{digits}f}"

    a = result.report["all_finite"]
    inside = result.nees_fraction_inside
    print(f"{args.scenario} / {result.summary_line()}")
    print(
        f"ATE {f(a['ate_rmse_m'])} m (dead reckoning {f(a['dead_reckoning_ate_rmse_m'])} m), "
        f"final position {f(a['final_position_error_m'])} m, "
        f"heading {f(a['final_heading_error_deg'], 2)}°, mean NEES {f(result.mean_nees, 2)}, "
        f"NEES in 95 % band {f(inside and 100 * inside, 1)} % of the time"
    )
    out = Path(args.json)
    out.parent.mkdir(parents=True, exist_ok=True)
    write_text_atomic(out, result.to_json() + "\n")
    print(f"wrote {out}")
    return 0


def _cmd_experiment(args: argparse.Namespace) -> int:
    from bearing_slam.experiments import EXPERIMENTS, run_experiments

    if args.bearings == "acoustic":
        return _cmd_experiment_acoustic(args)
    if args.name == "particles":
        return _cmd_experiment_particles(args)
    if args.name == "smoother":
        return _cmd_experiment_smoother(args)
    particle_only = [args.estimator, args.particles, args.scenario, args.long_only]
    if any(particle_only) or args.long_s is not None or args.long_runs is not None:
        raise UserError(
            "--estimator, --particles, --scenario, --long-only, --long-s and --long-runs apply "
            "to experiment particles only (--scenario also to experiment smoother)"
        )
    names = list(EXPERIMENTS) if args.name == "all" else [args.name]
    command = "bearing-slam experiment " + " ".join(
        [args.name]
        + ([f"--runs {args.runs}"] if args.runs is not None else [])
        + ([f"--seed0 {args.seed0}"] if args.seed0 else [])
        + [f"--out {args.out}"]
    )
    written = run_experiments(
        names,
        args.out,
        runs=args.runs,
        seed0=args.seed0,
        progress=not args.quiet,
        command=command,
        echo=print,
    )
    files = [p.name for paths in written.values() for p in paths]
    print(f"wrote {', '.join(files)} into {args.out}/")
    return 0


def add_batch_parsers(sub: Any) -> None:
    """Adds the ``montecarlo`` and ``experiment`` commands to ``sub`` (the
    subparsers of :func:`bearing_slam.cli.main`'s parser)."""
    t = DEFAULT_THRESHOLDS
    mc = sub.add_parser(
        "montecarlo",
        help="many seeded runs of a scenario with one initializer: class fractions, NEES",
        description="Runs SCENARIO --runs times (seeds --seed0, --seed0+1, ...) with one "
        "landmark initializer on all local cores, classifies every run as converged, drift "
        f"(final heading error > {t['drift_heading_deg']:g}°, final position error > "
        f"{t['drift_position_m']:g} m or near-landmark RMSE > {t['drift_landmark_rmse_m']:g} m) "
        "or diverged (failure, non-finite or non-PSD covariance, or final position "
        f"error > {t['diverged_position_m']:g} m), prints the class fractions and writes --json: "
        "the spec, "
        "converged_fraction, drift_fraction, diverged_fraction, per-run metrics (runs), "
        "means (all_finite, converged), mean_nees, nees_over_time (mean with the 95 % band) "
        "and error_over_time. From Python, bearing_slam.montecarlo(...) also runs on any "
        "concurrent.futures executor, e.g. a Dask cluster.",
    )
    mc.add_argument("scenario", metavar="SCENARIO", help="built-in scenario name")
    mc.add_argument("--runs", type=_positive_int, default=20, help="runs (default: %(default)s)")
    mc.add_argument(
        "--init",
        choices=INIT_NAMES,
        default=DEFAULT_INIT,
        help="landmark initializer (default: %(default)s)",
    )
    mc.add_argument(
        "--rho-ini",
        type=positive_float,
        help=f"PI-SR initial inverse depth, 1/m (default {DEFAULT_PRIOR['rho_ini']:g}; "
        f"pi-sr-mixed: near landmarks, the far ones get {FAR_PRIOR['rho_ini']:g})",
    )
    mc.add_argument(
        "--sigma-rho",
        type=positive_float,
        help=f"its σ, 1/m (default {DEFAULT_PRIOR['sigma_rho']:g}; "
        f"far: {FAR_PRIOR['sigma_rho']:g})",
    )
    mc.add_argument("--seed0", type=seed, default=0, help="seed of run 0 (default: %(default)s)")
    mc.add_argument("--no-far", action="store_true", help="remove the scenario's far landmarks")
    mc.add_argument("--landmarks", type=_positive_int, help="number of random landmarks")
    mc.add_argument("--slip", choices=["on", "off"], help="slippery patches (default: scenario's)")
    mc.add_argument(
        "--scale",
        type=positive_float,
        help="multiply the near landmarks' positions by this factor (the far ones stay; the "
        f"{t['drift_landmark_rmse_m']:g} m near-landmark drift threshold does not scale, as it "
        "does in `experiment fig4`)",
    )
    mc.add_argument(
        "--json", required=True, type=output_file, metavar="OUT.json", help="report file to write"
    )
    mc.add_argument(
        "--association",
        choices=ASSOCIATIONS,
        default="known",
        help="data association (default: %(default)s, the log's ids; nn/jcbb/ransac: hidden "
        "from the filter and used to score it: precision, recall, duplicates in the report)",
    )
    mc.add_argument("--clutter", type=non_negative_float, help="mean false bearings per scan")
    mc.add_argument(
        "--descriptor-sigma",
        type=positive_float,
        help="give every sighting an appearance descriptor with this noise σ (also the "
        "association's descriptor model)",
    )
    mc.add_argument(
        "--descriptor-confusion",
        type=non_negative_float,
        default=0.0,
        help="probability a sighting shows another landmark's appearance (default: 0)",
    )
    mc.add_argument("--quiet", action="store_true", help="no progress bar")
    add_estimator_options(mc)
    mc.set_defaults(func=_cmd_montecarlo)

    ex = sub.add_parser(
        "experiment",
        help="reproduce the paper's figures: markdown tables, JSON and PNG plots",
        description="Runs one of the paper's experiments (or all) and writes into --out, for "
        "each: NAME.md (the table, as printed), NAME.json (the numbers behind it) and "
        "NAME.png. fig4: paper_fig4 with PI-SR (0.01, 0.005), PI-SR (0.5, 0.25), PI-SR mixed, "
        "MTE, MTE-clone and MTE-history, with and without the far landmark (default "
        f"{EXPERIMENT_DEFAULT_RUNS['fig4']} runs each), then every initializer with the near "
        "landmarks scaled x0.2 to x4; fig4.png: "
        "class fractions per method and ATE against scale. consistency: the same runs' "
        "mean pose NEES over time with the 95 % band per method (consistency.png; reuses "
        "fig4's runs under all). "
        "fig5: σ_d and σ_ρ of a triangulation against parallax, first order and sampled "
        "(fig5.png, log y). fig8: paper_fig8 with 5, 10, 20, 40 landmarks, MTE (default "
        f"{EXPERIMENT_DEFAULT_RUNS['fig8']} runs); fig8.png: ATE of dead reckoning and SLAM "
        "against landmark count. fig10: single-source oval and figure-eight, slip off and on, "
        f"MTE (default {EXPERIMENT_DEFAULT_RUNS['fig10']} runs); "
        "fig10.png: position error over time, dead reckoning and SLAM.",
    )
    ex.add_argument(
        "name",
        choices=[*EXPERIMENTS, "particles", "smoother", "all"],
        metavar="|".join([*EXPERIMENTS, "particles", "smoother", "all"]),
        help="which experiment (particles: FastSLAM against the EKF, issue 15; smoother: the "
        "batch and fixed-lag smoothers against the EKF, issue 14; neither is part of all)",
    )
    ex.add_argument(
        "--runs",
        type=_positive_int,
        help="runs per configuration (default: "
        + ", ".join(f"{n} for {name}" for name, n in EXPERIMENT_DEFAULT_RUNS.items())
        + ")",
    )
    ex.add_argument("--seed0", type=seed, default=0, help="seed of run 0 (default: %(default)s)")
    ex.add_argument("--out", default="docs/results", help="output folder (default: %(default)s)")
    ex.add_argument("--quiet", action="store_true", help="no progress bars")
    ex.add_argument(
        "--bearings",
        choices=["gaussian", "acoustic"],
        default="gaussian",
        help="fig10 only: 'acoustic' runs Fig. 10 with the bearings of a simulated "
        "microphone array (SRP-PHAT, MUSIC, NormMUSIC; needs the acoustics extra) beside the "
        "Gaussian ones and writes fig10_acoustic.md/.json/.png and acoustics.md (the DOA "
        "error distribution); --runs defaults to 2 there (default: %(default)s)",
    )
    _add_particle_options(ex)
    ex.set_defaults(func=_cmd_experiment)


# --- Issue 15: `bearing-slam experiment particles`, FastSLAM against the EKF.


def _add_particle_options(ex: argparse.ArgumentParser) -> None:
    from bearing_slam.estimator_study import (
        DEFAULT_ESTIMATORS,
        DEFAULT_LONG_RUNS,
        DEFAULT_LONG_S,
        DEFAULT_PARTICLE_COUNTS,
        DEFAULT_RUNS,
        LONG_SCENARIO,
        SCENARIOS,
    )
    from bearing_slam.estimators import PARTICLE_ESTIMATORS

    ex.add_argument(
        "--estimator",
        action="append",
        choices=PARTICLE_ESTIMATORS,
        help="particles only, repeatable: the FastSLAM estimators run beside the EKF on "
        f"{', '.join(SCENARIOS)} (default: {' and '.join(DEFAULT_ESTIMATORS)}; "
        f"{DEFAULT_RUNS} runs each unless --runs)",
    )
    ex.add_argument(
        "--particles",
        action="append",
        type=_positive_int,
        help="particles only, repeatable: the particle counts "
        f"(default: {', '.join(map(str, DEFAULT_PARTICLE_COUNTS))})",
    )
    ex.add_argument(
        "--scenario",
        action="append",
        choices=SCENARIOS,
        help=f"particles and smoother, repeatable: the Monte Carlo scenarios (default: all of "
        f"{', '.join(SCENARIOS)})",
    )
    ex.add_argument(
        "--long-only",
        action="store_true",
        help="particles only: the long run alone, no Monte Carlo",
    )
    ex.add_argument(
        "--long-s",
        type=positive_float,
        help=f"particles only: length of the long run on {LONG_SCENARIO}, s "
        f"(default: {DEFAULT_LONG_S:g})",
    )
    ex.add_argument(
        "--long-runs",
        type=int,
        help=f"particles only: seeds of the long run, 0 skips it (default: {DEFAULT_LONG_RUNS})",
    )


def _cmd_experiment_particles(args: argparse.Namespace) -> int:
    from bearing_slam.estimator_study import (
        DEFAULT_ESTIMATORS,
        DEFAULT_LONG_RUNS,
        DEFAULT_LONG_S,
        DEFAULT_PARTICLE_COUNTS,
        DEFAULT_RUNS,
        SCENARIOS,
        run_estimator_study,
        write_estimator_study,
    )

    if args.long_runs is not None and args.long_runs < 0:
        raise UserError(f"--long-runs must be 0 or more, got {args.long_runs}")
    estimators = args.estimator or list(DEFAULT_ESTIMATORS)
    counts = args.particles or list(DEFAULT_PARTICLE_COUNTS)
    command = "bearing-slam experiment particles " + " ".join(
        [f"--estimator {e}" for e in (args.estimator or [])]
        + [f"--particles {m}" for m in (args.particles or [])]
        + [f"--scenario {n}" for n in (args.scenario or [])]
        + (["--long-only"] if args.long_only else [])
        + ([f"--runs {args.runs}"] if args.runs is not None else [])
        + ([f"--seed0 {args.seed0}"] if args.seed0 else [])
        + ([f"--long-s {args.long_s:g}"] if args.long_s is not None else [])
        + ([f"--long-runs {args.long_runs}"] if args.long_runs is not None else [])
        + [f"--out {args.out}"]
    )
    study = run_estimator_study(
        runs=args.runs if args.runs is not None else DEFAULT_RUNS,
        seed0=args.seed0,
        estimators=estimators,
        particle_counts=counts,
        scenarios=[] if args.long_only else (args.scenario or list(SCENARIOS)),
        long_s=args.long_s if args.long_s is not None else DEFAULT_LONG_S,
        long_runs=args.long_runs if args.long_runs is not None else DEFAULT_LONG_RUNS,
        progress=not args.quiet,
        echo=print,
    )
    paths = write_estimator_study(study, args.out, command, "particles")
    print(study["table"])
    print(f"wrote {', '.join(p.name for p in paths)} into {args.out}/")
    return 0


def _cmd_experiment_smoother(args: argparse.Namespace) -> int:
    """``experiment smoother``: the Monte Carlo part of the estimator study
    with the batch and fixed-lag smoothers beside the EKF (no long run)."""
    from bearing_slam.estimator_study import (
        DEFAULT_RUNS,
        SCENARIOS,
        SMOOTHER_ESTIMATORS,
        run_estimator_study,
        write_estimator_study,
    )

    particle_only = [args.estimator, args.particles, args.long_only]
    if any(particle_only) or args.long_s is not None or args.long_runs is not None:
        raise UserError(
            "--estimator, --particles, --long-only, --long-s and --long-runs apply to "
            "experiment particles only"
        )
    command = "bearing-slam experiment smoother " + " ".join(
        [f"--scenario {n}" for n in (args.scenario or [])]
        + ([f"--runs {args.runs}"] if args.runs is not None else [])
        + ([f"--seed0 {args.seed0}"] if args.seed0 else [])
        + [f"--out {args.out}"]
    )
    study = run_estimator_study(
        runs=args.runs if args.runs is not None else DEFAULT_RUNS,
        seed0=args.seed0,
        estimators=SMOOTHER_ESTIMATORS,
        particle_counts=(),
        scenarios=args.scenario or list(SCENARIOS),
        long_runs=0,
        progress=not args.quiet,
        echo=print,
    )
    paths = write_estimator_study(study, args.out, command, "smoother")
    print(study["table"])
    print(f"wrote {', '.join(p.name for p in paths)} into {args.out}/")
    return 0


def _cmd_experiment_acoustic(args: argparse.Namespace) -> int:
    if args.name != "fig10":
        raise UserError("--bearings acoustic applies to the fig10 experiment only")
    try:
        from bearing_slam.fig10_acoustic import (
            DEFAULT_RUNS,
            run_fig10_acoustic,
            write_fig10_acoustic,
        )
    except ImportError as e:  # pragma: no cover - the dev venv has it
        raise UserError(f"{e} (pip install 'bearing-slam[acoustics]')") from None
    runs = args.runs if args.runs is not None else DEFAULT_RUNS
    command = "bearing-slam experiment fig10 --bearings acoustic " + " ".join(
        ([f"--runs {args.runs}"] if args.runs is not None else [])
        + ([f"--seed0 {args.seed0}"] if args.seed0 else [])
        + [f"--out {args.out}"]
    )
    with tqdm(total=4 * runs, desc="fig10 acoustic", unit="run", disable=args.quiet) as bar:

        def progress(what: str, done: int, total: int) -> None:
            bar.set_postfix_str(what)
            bar.update(done - bar.n)

        result = run_fig10_acoustic(runs, args.seed0, progress=progress)
    paths = write_fig10_acoustic(result, args.out, command)
    print(result["table"])
    from bearing_slam.acoustics import error_table

    print(error_table(result["doa"]))
    print(f"wrote {', '.join(p.name for p in paths)} into {args.out}/")
    return 0
