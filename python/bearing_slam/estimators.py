"""The estimator options of the command line (issues 14 and 15).

``bearing-slam run``, ``mrclam`` and ``montecarlo`` take ``--estimator`` (the
names of :data:`~bearing_slam.vocabulary.ESTIMATORS`, read from Rust's
``EstimatorKind``): ``filter`` (the EKF, the default), ``smoother`` (the
batch graph smoother, started from the online keyframe window run after
the filter), ``filter+smoother`` (the online fixed-lag smoother run with
the filter), ``fastslam1`` and ``fastslam2`` (with ``--particles``),
``gaussian-sum`` (the EKF as a Gaussian sum over the heading: split in
three while a component's heading σ exceeds 3°, at most 9 components,
weighted by the bearings; ``Config(gaussian_sum_split_deg=...,
gaussian_sum_components=...)`` in Python);
``filter+smoother`` takes ``--online-window`` (``keyframes``, the default:
every scan's pose, the window spanning 50 keyframes by motion and solved at
each, with its own triangulation; or ``scans``: the last 50 scans, solved at
every scan) and ``--landmark-chart`` (``inverse-depth``, the default, or
``point``) on ``run`` and ``mrclam``. Every estimator's result
has the shape of the filter's, so ``metrics.json``, the plots and
``estimate.mcap`` (the smoothed trajectory and map, or the particle cloud's
pose with the best particle's map) are written the same way.
"""

from __future__ import annotations

import argparse
from typing import Any

from bearing_slam._native import Config
from bearing_slam.arg_types import positive_int
from bearing_slam.vocabulary import ESTIMATORS, LANDMARK_CHARTS, ONLINE_WINDOWS

__all__ = [
    "DEFAULT_ESTIMATOR",
    "DEFAULT_LANDMARK_CHART",
    "DEFAULT_ONLINE_WINDOW",
    "DEFAULT_PARTICLES",
    "PARTICLE_ESTIMATORS",
    "add_estimator_options",
    "add_online_smoother_options",
    "estimator_problem",
    "estimator_spec",
    "with_estimator",
]

#: The estimator used unless one is given (Rust: ``EstimatorKind::default``).
DEFAULT_ESTIMATOR: str = Config().estimator

#: FastSLAM's particle count unless given (Rust: ``EstimatorConfig::default``).
DEFAULT_PARTICLES: int = Config().particles

#: The online smoother's window and landmark chart unless given (Rust:
#: ``OnlineWindow::default``, ``SmootherConfig::default().landmark_chart``).
DEFAULT_ONLINE_WINDOW: str = Config().online_window
DEFAULT_LANDMARK_CHART: str = Config().landmark_chart

#: The estimators that take ``--particles``.
PARTICLE_ESTIMATORS: tuple[str, ...] = tuple(e for e in ESTIMATORS if e.startswith("fastslam"))


def add_estimator_options(parser: argparse.ArgumentParser) -> None:
    """Adds ``--estimator`` and ``--particles`` to a subcommand."""
    parser.add_argument(
        "--estimator",
        choices=ESTIMATORS,
        default=DEFAULT_ESTIMATOR,
        help="the estimator (default: %(default)s, the EKF; smoother: the batch graph "
        "smoother, started from the online keyframe window; filter+smoother: the online fixed-lag "
        "smoother; fastslam1/fastslam2: FastSLAM 1.0/2.0; gaussian-sum: the EKF as a Gaussian "
        "sum over the heading, split while its σ exceeds 3°)",
    )
    parser.add_argument(
        "--particles",
        type=positive_int,
        help=f"FastSLAM's particle count (default: {DEFAULT_PARTICLES})",
    )


def add_online_smoother_options(parser: argparse.ArgumentParser) -> None:
    """Adds ``--online-window`` and ``--landmark-chart`` (``filter+smoother``)."""
    parser.add_argument(
        "--online-window",
        choices=ONLINE_WINDOWS,
        help=f"filter+smoother only: keyframes (a window of 50 keyframes by motion, "
        f"0.5 m / 0.5 rad / 20 scans, every scan's pose inside, the landmarks the "
        f"filter has not initialized triangulated in the window) or scans (the last "
        f"50 scans) (default: {DEFAULT_ONLINE_WINDOW})",
    )
    parser.add_argument(
        "--landmark-chart",
        choices=LANDMARK_CHARTS,
        help="filter+smoother only: the chart of the landmarks' increments "
        f"(default: {DEFAULT_LANDMARK_CHART})",
    )


def estimator_problem(args: argparse.Namespace) -> str | None:
    """Why the estimator options cannot be used as given, or None."""
    if args.particles is not None and args.estimator not in PARTICLE_ESTIMATORS:
        return (
            f"--particles applies to --estimator {' and '.join(PARTICLE_ESTIMATORS)} only, "
            f"not to --estimator {args.estimator}"
        )
    online = [getattr(args, "online_window", None), getattr(args, "landmark_chart", None)]
    if any(o is not None for o in online) and args.estimator != "filter+smoother":
        return (
            "--online-window and --landmark-chart apply to --estimator filter+smoother only, "
            f"not to --estimator {args.estimator}"
        )
    live = getattr(args, "rerun", None) or getattr(args, "rerun_spawn", False)
    if live and args.estimator != "filter":
        return (
            "--rerun and --rerun-spawn show the filter's run as it goes; "
            f"--estimator {args.estimator} has no live view"
        )
    return None


def with_estimator(config: Config, args: argparse.Namespace) -> Config:
    """``config`` with the estimator (particle count, online window and
    landmark chart) of the command line."""
    given: dict[str, Any] = {"estimator": args.estimator}
    if args.particles is not None:
        given["particles"] = args.particles
    for field in ("online_window", "landmark_chart"):
        if getattr(args, field, None) is not None:
            given[field] = getattr(args, field)
    return config.replace(**given)


def estimator_spec(args: argparse.Namespace) -> dict[str, Any]:
    """The estimator part of a Monte Carlo spec (``make_spec``'s keywords)."""
    particles = DEFAULT_PARTICLES if args.particles is None else args.particles
    return {"estimator": args.estimator, "particles": particles}
