"""The ``bearing-slam`` command line: simulate, run, demo, montecarlo,
experiment, mrclam, mrclam-figures.

Every subcommand's ``--help`` says what it does and what it writes. User
errors (missing file, corrupt MCAP, unknown scenario, bad parameter) print one
line ``bearing-slam: error: ...`` and exit with status 2; nothing prints a
traceback for them.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import shutil
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any, NoReturn

from tqdm import tqdm

from bearing_slam._native import (
    BearingSlamError,
    Config,
    RunResult,
    SensorLog,
    __version__,
    load_mrclam,
    read_mcap,
    run,
    scenario_names,
    simulate,
    write_mcap,
)
from bearing_slam.arg_types import (
    UserError,
    angle_deg,
    non_negative_float,
    non_negative_int,
    output_file,
    positive_float,
    positive_named,
    robot_number,
    seed,
)
from bearing_slam.association_options import (
    add_association_option,
    add_hidden_id_options,
    with_hidden_id_options,
)
from bearing_slam.cli_batch import add_batch_parsers
from bearing_slam.estimators import (
    add_estimator_options,
    add_online_smoother_options,
    estimator_problem,
    with_estimator,
)
from bearing_slam.filter_options import add_filter_options, filter_options, filter_problem
from bearing_slam.live import add_live_arguments, stream_if_asked  # --live
from bearing_slam.outputs import (
    metrics_record,
    mrclam_record,
    new_folder_beside,
    publish_folder,
    write_outputs,
)
from bearing_slam.tum import write_tum
from bearing_slam.vocabulary import (
    DEFAULT_INIT,
    DEFAULT_PRIOR,
    FAR_PRIOR,
    HISTORY_CORRELATIONS,
    MRCLAM_METHODS,
    MTE_HISTORY,
    PRIOR_INITS,
    RUN_INITS,
    config_init,
)

__all__ = ["DEMO_RUNS", "DEMO_SCENARIOS", "main"]

#: Scenarios of ``bearing-slam demo``: the paper's Fig. 4 straight run and a
#: room with a slippery floor patch (physics simulation).
DEMO_SCENARIOS = ("paper_fig4", "slip_patch")

#: Runs of ``bearing-slam demo``: (folder label, init of :data:`RUN_INITS`,
#: extra Config parameters): the library's default first, then the paper's
#: methods.
DEMO_RUNS: tuple[tuple[str, str, dict[str, float]], ...] = (
    (DEFAULT_INIT, DEFAULT_INIT, {}),
    ("mte", "mte", {}),
    ("mte-clone", "mte-clone", {}),
    ("mte-history", "mte-history", {}),
    (f"pi-sr_{FAR_PRIOR['rho_ini']:g}_{FAR_PRIOR['sigma_rho']:g}", "pi-sr", dict(FAR_PRIOR)),
)

#: The initializers of ``bearing-slam mrclam --init``: the bearing-only
#: methods of the MRCLAM evaluation (the range-bearing EKF is ``--use-range``).
MRCLAM_INITS = tuple(m for m in MRCLAM_METHODS if m in RUN_INITS)

#: Columns of the metrics table.
_TABLE = (
    ("ATE [m]", "ate_rmse_m", "{:.3f}"),
    ("final pos [m]", "final_position_error_m", "{:.3f}"),
    ("final θ [deg]", "final_heading_error_deg", "{:.2f}"),
    ("map RMSE [m]", "landmark_rmse_m", "{:.3f}"),
    ("NEES", "mean_nees_pose", "{:.2f}"),
    ("landmarks", "n_landmarks_initialized", "{}"),
    ("DR ATE [m]", "dead_reckoning_ate_rmse_m", "{:.3f}"),
)


def _format_table(rows: list[tuple[str, str, dict[str, Any]]]) -> str:
    header = ["scenario", "method", *[c[0] for c in _TABLE]]
    body = []
    for scenario, label, rec in rows:
        cells = [scenario, label]
        for _, key, fmt in _TABLE:
            v = rec.get(key)
            cells.append("n/a" if v is None else fmt.format(v))
        body.append(cells)
    widths = [max(len(r[i]) for r in [header, *body]) for i in range(len(header))]
    line = "  ".join(h.ljust(w) for h, w in zip(header, widths, strict=True))
    sep = "  ".join("-" * w for w in widths)
    rows_txt = [
        "  ".join(
            c.ljust(w) if i < 2 else c.rjust(w)
            for i, (c, w) in enumerate(zip(r, widths, strict=True))
        )
        for r in body
    ]
    return "\n".join([line, sep, *rows_txt])


def _config(log: SensorLog, args: argparse.Namespace) -> Config:
    overrides: dict[str, Any] = {}
    if args.rho_ini is not None:
        overrides["rho_ini"] = args.rho_ini
    if args.sigma_rho is not None:
        overrides["sigma_rho"] = args.sigma_rho
    if args.alpha_min_deg is not None:
        overrides["alpha_min"] = math.radians(args.alpha_min_deg)
    if args.bearing_sigma_deg is not None:
        overrides["bearing_sigma"] = math.radians(args.bearing_sigma_deg)
    if args.use_range:
        overrides["use_range"] = True
    if args.history_correlation is not None:
        overrides["history_correlation"] = args.history_correlation
    return _run_config(log, args.init, **overrides, **filter_options(args))


def _run_config(log: SensorLog, init: str, **overrides: Any) -> Config:
    """``Config.for_log`` for an initializer of :data:`RUN_INITS`."""
    config_name, extra = config_init(init)
    return Config.for_log(log, init=config_name, **extra, **overrides)


def _demo_entries() -> list[str]:
    """What ``demo`` writes into its folder."""
    return [f"{s}_{label}" for s in DEMO_SCENARIOS for label, _, _ in DEMO_RUNS] + [
        "metrics_table.txt"
    ]


def _write_tum(path: str | Path | None, result: RunResult, quiet: bool = False) -> None:
    """``--tum FILE``: the estimate (and the truth beside it) in the TUM format."""
    if path is None:
        return
    try:
        estimate, truth = write_tum(path, result)
    except ValueError as e:
        raise UserError(str(e)) from None
    if not quiet:
        print(f"wrote {estimate}" + (f" and {truth} (TUM)" if truth else " (TUM; no ground truth)"))


#: Help of ``--tum`` (run, mrclam).
_TUM_HELP = (
    "also write the estimate in the TUM format (timestamp x y z qx qy qz qw) to FILE and "
    "the ground truth at the same times beside it (run.tum -> run.truth.tum): "
    "`evo_ape tum run.truth.tum run.tum` (no --align) gives ate_rmse_m"
)


def _wrote(out: Path) -> str:
    """What a run wrote into ``out`` (``particles.png`` too for FastSLAM)."""
    return f"wrote {out}/" + ", ".join(sorted(p.name for p in out.iterdir()))


def _cmd_demo(args: argparse.Namespace) -> int:
    out = Path(args.out)
    entries = _demo_entries()
    if out.exists() and not out.is_dir():
        raise UserError(f"--out {out} is a file; give a folder")
    if out.is_dir():
        foreign = sorted(p.name for p in out.iterdir() if p.name not in entries)
        if foreign:
            raise UserError(
                f"--out {out} holds files demo does not write ({', '.join(foreign[:5])}); "
                "give a new or empty folder, or a folder of an earlier demo"
            )
    rows: list[tuple[str, str, dict[str, Any]]] = []
    total = len(DEMO_SCENARIOS) * (1 + len(DEMO_RUNS))
    # Everything goes into a new folder, swapped in at the end: a demo killed
    # at any moment leaves the old results or the new ones, never a mix.
    new = new_folder_beside(out)
    try:
        with tqdm(total=total, desc="demo", unit="step", disable=args.quiet) as bar:
            for scenario in DEMO_SCENARIOS:
                bar.set_postfix_str(f"simulating {scenario}")
                log = simulate(scenario, seed=args.seed)
                bar.update()
                for label, init, extra in DEMO_RUNS:
                    bar.set_postfix_str(f"{scenario} / {label}")
                    config = _run_config(log, init, **extra)
                    live = _rerun_logger(args, log, label=f"{scenario}_{label}")
                    t0 = time.perf_counter()
                    result = run(log, config, on_scan=live)
                    seconds = time.perf_counter() - t0
                    rec = metrics_record(result, log, seconds)
                    write_outputs(
                        new / f"{scenario}_{label}",
                        rec,
                        result,
                        log,
                        snapshot_every=args.snapshot_every,
                    )
                    if args.tum is not None:
                        _write_tum(new / f"{scenario}_{label}" / args.tum, result, quiet=True)
                    _log_rerun(args, live, result, label=f"{scenario}_{label}")
                    rows.append((scenario, label, rec))
                    bar.update()
        table = _format_table(rows)
        (new / "metrics_table.txt").write_text(table + "\n")
        publish_folder(new, out, entries)
    finally:
        if new.exists():
            shutil.rmtree(new)
    print(table)
    print(f"\nwrote {len(rows)} runs into {out}/ (metrics.json, PNG plots, estimate.mcap each)")
    return 0


def _cmd_simulate(args: argparse.Namespace) -> int:
    options: dict[str, Any] = {}
    if args.landmark_count is not None:
        options["landmark_count"] = args.landmark_count
    if args.no_far_landmark:
        options["far_landmark"] = False
    if args.slip:
        options["slip"] = True
    if args.bearing_sigma_deg is not None:
        options["bearing_sigma"] = math.radians(args.bearing_sigma_deg)
    if args.duration is not None:
        options["duration"] = args.duration
    if args.clutter is not None:
        options["clutter"] = args.clutter
    if args.descriptor_sigma is not None:
        options["descriptor_sigma"] = args.descriptor_sigma
        options["descriptor_confusion"] = args.descriptor_confusion
    elif args.descriptor_confusion != 0.0:
        raise UserError("--descriptor-confusion needs --descriptor-sigma")
    scenario = args.scenario
    is_file = scenario.lower().endswith((".toml", ".json"))
    if not is_file and scenario not in scenario_names():
        raise UserError(
            f"unknown scenario {scenario!r}; known: {', '.join(scenario_names())} "
            "(or a .toml/.json scenario file)"
        )
    log = simulate(scenario, seed=args.seed, **options)
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    write_mcap(out, log)
    print(f"{log!r}\nwrote {out}")
    return 0


def _add_robustness_options(parser: argparse.ArgumentParser) -> None:
    """Adds ``--robust-gate`` and ``--bearing-offset`` (issue 13 item 3):
    robust gating with re-admission and the camera-yaw offset state, both
    off by default."""
    parser.add_argument(
        "--robust-gate",
        action="store_true",
        help="robust chi-square gate: a landmark's bearings gated 3 times in a row are "
        "re-admitted with their noise inflated onto the gate, and bearings inside the gate "
        "with sqrt(NIS) > 2 are Huber down-weighted; each one is an event in the trace",
    )
    parser.add_argument(
        "--bearing-offset",
        type=positive_float,
        metavar="SIGMA_RW",
        help="estimate a camera yaw offset online as one more state, a random walk of "
        "SIGMA_RW rad/sqrt(s) (Dataset 6's ground truth gives 0.00082)",
    )


def _with_robustness(config: Config, args: argparse.Namespace) -> Config:
    """``config`` with the options of :func:`_add_robustness_options`."""
    if args.robust_gate:
        config = config.replace(readmit_after=3, huber_threshold=2.0)
    if args.bearing_offset is not None:
        config = config.replace(bearing_offset_sigma=args.bearing_offset)
    return config


def _cmd_run(args: argparse.Namespace) -> int:
    if args.init not in PRIOR_INITS and (args.rho_ini is not None or args.sigma_rho is not None):
        raise UserError(
            f"--rho-ini and --sigma-rho apply to --init {' and '.join(PRIOR_INITS)} only "
            "(PI-SR's prior), not to --init " + args.init
        )
    if args.init in PRIOR_INITS and args.alpha_min_deg is not None:
        raise UserError("--alpha-min-deg applies to the MTE initializers only, not to PI-SR")
    if args.init != "mte-history" and args.history_correlation is not None:
        raise UserError("--history-correlation applies to --init mte-history only")
    init = "range-bearing" if args.use_range else args.init
    if problem := filter_problem(args, init):
        raise UserError(problem)
    path = Path(args.log)
    if not path.is_file():
        raise UserError(f"no such file: {path}")
    log, _, warnings = read_mcap(path)
    for w in warnings:
        print(f"bearing-slam: warning: {w}", file=sys.stderr)
    if problem := estimator_problem(args):
        raise UserError(problem)
    config = with_estimator(_config(log, args), args).replace(association=args.association)
    config = with_hidden_id_options(config, args)
    config = _with_robustness(config, args)
    live = _rerun_logger(args, log)
    with tqdm(total=1, desc=f"run {args.init}", unit="run", disable=args.quiet) as bar:
        t0 = time.perf_counter()
        result = run(log, config, on_scan=live)
        seconds = time.perf_counter() - t0
        bar.update()
    out = Path(args.out)
    rec = metrics_record(result, log, seconds)
    write_outputs(out, rec, result, log, snapshot_every=args.snapshot_every)
    _log_rerun(args, live, result)
    print(_format_table([(str(log.info.get("source") or path.name), args.init, rec)]))
    print("\n" + _wrote(out))
    _write_tum(args.tum, result)
    stream_if_asked(args, log, result)  # --live
    return 0


def _cmd_mrclam(args: argparse.Namespace) -> int:
    from bearing_slam import mrclam

    dataset = Path(args.dataset)
    if not dataset.is_dir():
        hint = ""
        if dataset.parent.is_dir():
            found = sorted(p.name for p in dataset.parent.glob("MRCLAM_Dataset*") if p.is_dir())
            if found:
                hint = f" (found there: {', '.join(found)})"
        raise UserError(f"no such MRCLAM dataset directory: {dataset}{hint}")
    if not 1 <= args.robot <= 5:
        raise UserError(
            f"robot number {args.robot} is out of range: MRCLAM robots are numbered 1 to 5"
        )
    if args.start is not None and args.end is not None and args.end <= args.start:
        raise UserError(f"--end ({args.end:g} s) must be greater than --start ({args.start:g} s)")
    method = "range-bearing" if args.use_range else args.init
    if problem := estimator_problem(args) or filter_problem(args, method):
        raise UserError(problem)
    out = Path(args.out)
    with tqdm(total=2, desc=f"robot {args.robot} {method}", unit="step", disable=args.quiet) as bar:
        bar.set_postfix_str("load + filter")
        live = _rerun_logger(args, scene=(dataset, args.robot, args.start, args.end))
        run_ = mrclam.evaluate(
            dataset,
            args.robot,
            method,
            args.start,
            args.end,
            args.estimator,
            args.particles,
            on_scan=live,
            association=args.association,
            online_window=args.online_window,
            landmark_chart=args.landmark_chart,
            **filter_options(args),
        )
        bar.update()
        bar.set_postfix_str("metrics.json, plots, estimate.mcap")
        rec = mrclam_record(run_)
        write_outputs(
            out,
            rec,
            run_.result,
            run_.log,
            mrclam.plot_log(run_),
            snapshot_every=args.snapshot_every,
        )
        _log_rerun(args, live, run_.result, landmarks=mrclam.plot_log(run_).landmarks)
        bar.update()
    _write_tum(args.tum, run_.result)
    stream_if_asked(args, run_.log, run_.result)  # --live

    def f(key: str) -> str:
        v = rec.get(key)
        return "n/a" if v is None else f"{v:.3f} m"

    print(
        f"{rec['source']} {method} {args.estimator}: ATE {f('ate_rmse_m')} "
        f"(dead reckoning {f('odometry_ate_rmse_m')}), "
        f"landmark RMSE {f('landmark_rmse_m')} "
        f"({'Vicon frame' if rec['has_ground_truth'] else 'SE(2)-aligned'}; "
        f"aligned {f('landmark_rmse_aligned_m')}), "
        f"{rec['n_landmarks_mapped']}/{rec['n_landmarks_truth']} landmarks mapped, "
        f"{rec['n_measurements_used']}/{rec['n_measurements']} bearings used, "
        f"{rec['n_dropped']} landmark rows dropped by the loader as unusable "
        f"(other robots, unknown barcodes, outside the log, duplicates), "
        f"{rec['n_outside_window']} outside the --start/--end window"
    )
    print(_wrote(out))
    return 0


def _cmd_mrclam_figures(args: argparse.Namespace) -> int:
    from bearing_slam import mrclam
    from bearing_slam.outputs import write_mrclam_figures

    d6 = mrclam.data_dir(args.data) / "MRCLAM_Dataset6"
    total = 5 * len(MRCLAM_METHODS)
    with tqdm(total=total, desc="Dataset 6", disable=args.quiet) as bar:

        def progress(robot: int, method: str) -> None:
            bar.set_postfix_str(f"robot {robot} {method}")
            bar.update()

        runs = mrclam.evaluate_robots(d6, progress=progress)
    if not args.quiet:
        summary = {
            f"robot{r}_{m}": {
                "ate_rmse_m": run_.metrics["ate_rmse_m"],
                "landmark_rmse_m": run_.metrics["landmark_rmse_m"],
                "n_landmarks_mapped": run_.metrics["n_landmarks_mapped"],
            }
            for (r, m), run_ in sorted(runs.items())
        }
        print(json.dumps(summary, indent=1))
    for path in write_mrclam_figures(runs, Path(args.out)):
        print(f"wrote {path} ({path.stat().st_size // 1024} KB)")
    return 0


class _Parser(argparse.ArgumentParser):
    """argparse with the command's one-line errors: ``bearing-slam: error:
    argument --seed: ... (see bearing-slam simulate --help)``, exit status 2.
    Sub-command parsers are of this class too."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"bearing-slam: error: {message} (see `{self.prog} --help`)\n")


def _parser() -> argparse.ArgumentParser:
    p = _Parser(
        prog="bearing-slam",
        description="Bearing-only EKF SLAM (Munguía & Grau's stochastic triangulation, 'MTE'): "
        "simulate logs, run the filter on them, and plot and score the results.",
    )
    p.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    sub = p.add_subparsers(dest="command", required=True, metavar="COMMAND")

    demo = sub.add_parser(
        "demo",
        help="simulate paper_fig4 and slip_patch, compare MTE, MTE-clone, MTE-history and PI-SR",
        description="Simulates the paper's Fig. 4 run and the slippery-room scenario "
        "(physics), runs MTE, MTE with pose cloning, MTE-history (cloning, with the bearings "
        f"seen while waiting kept: history={MTE_HISTORY}) and PI-SR "
        f"(rho_ini={FAR_PRIOR['rho_ini']:g}, sigma_rho={FAR_PRIOR['sigma_rho']:g}) "
        "on each, prints a table of metrics and writes one folder per run into --out with "
        "metrics.json, trajectory.png, pose_errors.png, nees.png and estimate.mcap "
        "(log + estimate, opens in Foxglove), plus metrics_table.txt.",
    )
    demo.add_argument("--out", default="demo_output", help="output folder (default: %(default)s)")
    demo.add_argument("--seed", type=seed, default=0, help="simulation seed (default: %(default)s)")
    demo.add_argument("--quiet", action="store_true", help="no progress bar")
    _add_view_flags(demo, demo=True)
    demo.add_argument(
        "--tum",
        metavar="NAME",
        help="also write each run's estimate in the TUM format to OUT/SCENARIO_METHOD/NAME "
        "and its ground truth beside it (run.tum -> run.truth.tum), for evo",
    )
    demo.set_defaults(func=_cmd_demo)

    simp = sub.add_parser(
        "simulate",
        help="simulate a scenario into an MCAP log",
        description="Simulates SCENARIO (a built-in name: "
        + ", ".join(scenario_names())
        + "; or a .toml/.json scenario file) and writes its sensor log (odometry, bearings, "
        "ground truth, landmark truth) to an MCAP file that opens in Foxglove.",
    )
    simp.add_argument("scenario", metavar="SCENARIO", help="scenario name or .toml/.json file")
    simp.add_argument("--seed", type=seed, default=None, help="seed (default: 0, or the file's)")
    simp.add_argument("--out", required=True, type=output_file, help="output MCAP file")
    simp.add_argument("--landmark-count", type=non_negative_int, help="number of random landmarks")
    simp.add_argument("--no-far-landmark", action="store_true", help="drop the far landmark")
    simp.add_argument("--slip", action="store_true", help="add the scenario's slip patches")
    simp.add_argument("--bearing-sigma-deg", type=positive_float, help="bearing noise σ, degrees")
    simp.add_argument("--duration", type=positive_float, help="duration, seconds")
    simp.add_argument(
        "--clutter", type=non_negative_float, help="mean false bearings per scan (clutter)"
    )
    simp.add_argument(
        "--descriptor-sigma",
        type=positive_float,
        help="give every sighting an appearance descriptor with this noise σ per component",
    )
    simp.add_argument(
        "--descriptor-confusion",
        type=non_negative_float,
        default=0.0,
        help="probability a sighting shows another landmark's appearance (default: 0)",
    )
    simp.set_defaults(func=_cmd_simulate)

    runp = sub.add_parser(
        "run",
        help="run the filter on an MCAP log and write metrics, plots and the estimate",
        description="Runs bearing-only SLAM on LOG (an MCAP file from `bearing-slam simulate` "
        "or the Rust tools) and writes into --out: metrics.json (ate_rmse_m, "
        "final_position_error_m, final_heading_error_deg, landmark_rmse_m, mean_nees_pose, "
        "median_nees_pose, nees_within_95 (fraction under the one-sided χ²(3) 95 % bound), "
        "n_landmarks_initialized, dead-reckoning numbers, counts, config), trajectory.png "
        "(with landmark 2σ ellipses), pose_errors.png (±3σ), nees.png (χ² 95 % bound) and "
        "estimate.mcap (log + estimate, opens in Foxglove).",
    )
    runp.add_argument("log", metavar="LOG.mcap", help="input MCAP log")
    runp.add_argument(
        "--init",
        choices=RUN_INITS,
        default=DEFAULT_INIT,
        help="landmark initializer (default: %(default)s; mte-history: mte-clone keeping "
        f"up to {MTE_HISTORY} bearings seen while a landmark waits)",
    )
    add_filter_options(runp)
    runp.add_argument(
        "--rho-ini", type=positive_named("rho_ini"), help="PI-SR initial inverse depth, 1/m"
    )
    runp.add_argument(
        "--sigma-rho", type=positive_named("sigma_rho"), help="PI-SR inverse-depth σ, 1/m"
    )
    runp.add_argument(
        "--alpha-min-deg", type=angle_deg(0.0, 180.0), help="MTE minimum parallax, degrees"
    )
    runp.add_argument("--bearing-sigma-deg", type=positive_float, help="bearing noise σ, degrees")
    runp.add_argument("--use-range", action="store_true", help="use ranges too (reference)")
    runp.add_argument(
        "--history-correlation",
        choices=HISTORY_CORRELATIONS,
        help="mte-history: how the replay treats the correlated errors of a landmark's "
        "consecutive bearings (default none; whiten: AR(1) whitening, decimate: one per "
        "visit, visit-mean: each visit's mean with its AR(1) variance; phi 0.64)",
    )
    runp.add_argument("--out", required=True, help="output folder")
    runp.add_argument("--tum", metavar="FILE", help=_TUM_HELP)
    runp.add_argument("--quiet", action="store_true", help="no progress bar")
    _add_view_flags(runp)
    add_estimator_options(runp)
    add_online_smoother_options(runp)
    add_association_option(runp)
    add_hidden_id_options(runp)
    _add_robustness_options(runp)
    add_live_arguments(runp)  # --live
    runp.set_defaults(func=_cmd_run)

    names = sub.add_parser(
        "scenarios",
        help="list the built-in scenarios",
        description="Prints the names of the built-in scenarios, one per line.",
    )
    names.set_defaults(func=lambda _args: print("\n".join(scenario_names())) or 0)
    add_batch_parsers(sub)

    mr = sub.add_parser(
        "mrclam",
        help="run the filter on a real UTIAS MRCLAM robot and score it",
        description="Runs bearing-only SLAM on robot --robot of an MRCLAM dataset directory "
        "(MRCLAM_Dataset6/ with Vicon ground truth, MRCLAM_Dataset1/ without) with the noise "
        "parameters and command-model correction (0.25 s delay, speed v*max(0, 1.04 - "
        "1.11 s/rad*|omega|): faster than commanded straight ahead, slower in turns) calibrated on "
        "Dataset 6, and writes into --out: metrics.json, trajectory.png, pose_errors.png, "
        "nees.png and estimate.mcap (the corrected log + estimate, opens in Foxglove). "
        "metrics.json has landmark_rmse_m against Landmark_Groundtruth.dat: with robot ground "
        "truth (Dataset 6) the filter starts at the Vicon pose and the map is scored raw in the "
        "Vicon frame (landmark_rmse_aligned_m after the best SE(2) alignment too); without it "
        "(Dataset 1) the map is in the robot's start frame and landmark_rmse_m is SE(2)-aligned "
        "(landmark_frame says which). With ground truth also ate_rmse_m and "
        "odometry_ate_rmse_m (dead reckoning on the same corrected commands), otherwise null. "
        "Also mean_nees_pose, median_nees_pose and nees_within_95 (fraction of the scored "
        "times under the one-sided chi2(3) 95 % bound, the number in nees.png's title), "
        "n_measurements_used, n_gated, n_dropped (landmark rows the loader dropped as "
        "unusable: other robots' barcodes, unknown barcodes, outside the log, duplicates), "
        "n_outside_window (rows outside --start/--end) and the parameters. The plots of a "
        "run without ground truth show no truth line, the true landmarks aligned onto the "
        "map and no NEES.",
    )
    mr.add_argument("dataset", metavar="DATASET_DIR", help="an MRCLAM_DatasetN directory")
    mr.add_argument("--robot", type=robot_number, required=True, help="robot number, 1 to 5")
    mr.add_argument(
        "--init",
        choices=MRCLAM_INITS,
        default=DEFAULT_INIT,
        help="landmark initializer (default: %(default)s; PI-SR with the prior "
        f"{DEFAULT_PRIOR['rho_ini']:g}, {DEFAULT_PRIOR['sigma_rho']:g})",
    )
    add_filter_options(mr)
    mr.add_argument(
        "--use-range",
        action="store_true",
        help="run the classic range-bearing EKF instead (uses the ranges; a reference)",
    )
    mr.add_argument(
        "--start", type=non_negative_float, help="window start, s since the robot's first command"
    )
    mr.add_argument(
        "--end", type=positive_float, help="window end, s since the robot's first command"
    )
    mr.add_argument("--out", required=True, help="output folder")
    mr.add_argument("--tum", metavar="FILE", help=_TUM_HELP)
    mr.add_argument("--quiet", action="store_true", help="no progress bar")
    _add_view_flags(mr)
    add_estimator_options(mr)
    add_online_smoother_options(mr)
    add_association_option(mr)
    add_live_arguments(mr)  # --live
    mr.set_defaults(func=_cmd_mrclam)

    figs = sub.add_parser(
        "mrclam-figures",
        help="every method on the five robots of MRCLAM Dataset 6: the figures of the results",
        description="Runs every method ("
        + ", ".join(MRCLAM_METHODS)
        + ") on the five robots of DATA_DIR/MRCLAM_Dataset6 (whole runs, the same numbers as "
        "the Rust MRCLAM evaluation) and writes into --out: dataset6_trajectories.png "
        "(truth, dead reckoning, MTE, PI-SR, range-bearing per robot), dataset6_ate.png (ATE "
        "bars, with GTSAM from OUT/gtsam.json when there) and, for MTE on each robot, "
        "dataset6_robotN_mte_trajectory.png, _pose_errors.png and _nees.png; prints the ATE "
        "and landmark RMSE of every run as JSON.",
    )
    figs.add_argument(
        "data",
        metavar="DATA_DIR",
        nargs="?",
        help="the folder holding MRCLAM_Dataset6/ (default: $BEARING_SLAM_DATA)",
    )
    figs.add_argument(
        "--out", default="docs/results/mrclam", help="output folder (default: %(default)s)"
    )
    figs.add_argument("--quiet", action="store_true", help="no progress bar and no JSON")
    figs.set_defaults(func=_cmd_mrclam_figures)

    # issue 17: monocular SLAM on a frames directory (KITTI clip layout).
    from bearing_slam.cli_mono import add_mono_parser

    add_mono_parser(sub)
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``bearing-slam``; returns the exit status."""
    parser = _parser()
    args = parser.parse_args(argv)
    try:
        status: int = args.func(args)
    except BrokenPipeError:
        # The reader of stdout left (`bearing-slam ... | head -1`): every
        # output file is written by then; only the printing stops. Python's
        # own advice: point stdout at devnull so the exit flush stays quiet.
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 1
    except (UserError, BearingSlamError, OSError) as e:
        print(f"bearing-slam: error: {e}", file=sys.stderr)
        return 2
    return status


# ---------------------------------------------------------------- Rerun, snapshots, acoustics


def _non_negative_seconds(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not (v >= 0 and math.isfinite(v)):
        raise argparse.ArgumentTypeError(f"must be a finite number of seconds >= 0, got {text}")
    return v


def _add_view_flags(p: argparse.ArgumentParser, demo: bool = False) -> None:
    """``--rerun``, ``--rerun-spawn`` and ``--snapshot-every`` of run, mrclam, demo."""
    p.add_argument(
        "--rerun",
        metavar="FILE.rrd",
        help="also log the run to this Rerun recording (needs the rerun extra)"
        + ("; demo writes FILE_SCENARIO_METHOD.rrd per run" if demo else ""),
    )
    p.add_argument(
        "--rerun-spawn",
        action="store_true",
        help="also send the run to a Rerun viewer it starts (needs the rerun extra)",
    )
    p.add_argument(
        "--snapshot-every",
        type=_non_negative_seconds,
        default=0.0,
        metavar="S",
        help="write the estimate snapshots (map and landmarks) of estimate.mcap and the "
        "Rerun recording at most once per S seconds of log time, and the last "
        "(default: %(default)s, every snapshot); the sensor data stay whole",
    )


def _rerun_path(args: argparse.Namespace, label: str | None) -> str | None:
    """The ``.rrd`` file of ``--rerun`` (demo: one per run, named by ``label``)."""
    path: str | None = args.rerun
    if path and label is not None:
        from bearing_slam.rerun import rerun_paths

        path = rerun_paths(path, [label])[0]
    return path


def _rerun_logger(
    args: argparse.Namespace,
    log: SensorLog | None = None,
    label: str | None = None,
    scene: tuple[Path, int, float | None, float | None] | None = None,
) -> Any:
    """The live Rerun logger of ``--rerun``/``--rerun-spawn`` (None without
    them), its recording opened; the run is given it as ``on_scan``.
    ``scene``: an MRCLAM run's (dataset, robot, start, end), loaded to size
    the view (its true landmarks are drawn at the end, in the map's frame)."""
    if not (args.rerun or args.rerun_spawn):
        return None
    try:
        from bearing_slam.rerun import RerunLogger, open_recording, scene_size_of
    except ImportError as e:  # pragma: no cover - the dev venv has it
        raise UserError(str(e)) from None
    path = _rerun_path(args, label)
    if path:
        Path(path).parent.mkdir(parents=True, exist_ok=True)
    source = log.info.get("source") if log is not None else None
    rec = open_recording(
        path=path, spawn=args.rerun_spawn, recording_name=label or (str(source) if source else None)
    )
    size = None if scene is None else scene_size_of(load_mrclam(*scene)[0])
    return RerunLogger(rec, log, scene_size=size, snapshot_every=args.snapshot_every)


def _log_rerun(
    args: argparse.Namespace,
    live: Any,
    result: Any,
    label: str | None = None,
    landmarks: Any = None,
) -> None:
    """Finishes the live Rerun recording of ``--rerun`` (the tail of the run)."""
    if live is None:
        return
    live.finish(result, landmarks=landmarks)
    live.recording.disconnect()  # closes the file (its footer) or the viewer's connection
    path = _rerun_path(args, label)
    if path and not getattr(args, "quiet", False):
        print(f"wrote {path}")


if __name__ == "__main__":
    sys.exit(main())
