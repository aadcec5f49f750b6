"""The estimator options of the command line (issues 14 and 15).

``bearing-slam run``, ``mrclam`` and ``montecarlo`` take ``--estimator`` (the
names of :data:`~bearing_slam.vocabulary.ESTIMATORS`, read from Rust's
``EstimatorKind``): ``filter`` (the EKF, the default), ``smoother`` (the
batch graph smoother started from the filter's run), ``filter+smoother``
(the online fixed-lag smoother run with the filter), ``fastslam1`` and
``fastslam2`` (with ``--particles``). Every estimator's result has the shape
of the filter's, so ``metrics.json``, the plots and ``estimate.mcap`` (the
smoothed trajectory and map, or the particle cloud's pose with the best
particle's map) are written the same way.
"""

from __future__ import annotations

import argparse
from typing import Any

from bearing_slam._native import Config
from bearing_slam.arg_types import positive_int
from bearing_slam.vocabulary import ESTIMATORS

__all__ = [
    "DEFAULT_ESTIMATOR",
    "DEFAULT_PARTICLES",
    "PARTICLE_ESTIMATORS",
    "add_estimator_options",
    "estimator_problem",
    "estimator_spec",
    "with_estimator",
]

#: The estimator used unless one is given (Rust: ``EstimatorKind::default``).
DEFAULT_ESTIMATOR: str = Config().estimator

#: FastSLAM's particle count unless given (Rust: ``EstimatorConfig::default``).
DEFAULT_PARTICLES: int = Config().particles

#: The estimators that take ``--particles``.
PARTICLE_ESTIMATORS: tuple[str, ...] = tuple(e for e in ESTIMATORS if e.startswith("fastslam"))


def add_estimator_options(parser: argparse.ArgumentParser) -> None:
    """Adds ``--estimator`` and ``--particles`` to a subcommand."""
    parser.add_argument(
        "--estimator",
        choices=ESTIMATORS,
        default=DEFAULT_ESTIMATOR,
        help="the estimator (default: %(default)s, the EKF; smoother: the batch graph "
        "smoother started from the filter's run; filter+smoother: the online fixed-lag "
        "smoother; fastslam1/fastslam2: FastSLAM 1.0/2.0)",
    )
    parser.add_argument(
        "--particles",
        type=positive_int,
        help=f"FastSLAM's particle count (default: {DEFAULT_PARTICLES})",
    )


def estimator_problem(args: argparse.Namespace) -> str | None:
    """Why the estimator options cannot be used as given, or None."""
    if args.particles is not None and args.estimator not in PARTICLE_ESTIMATORS:
        return (
            f"--particles applies to --estimator {' and '.join(PARTICLE_ESTIMATORS)} only, "
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
    """``config`` with the estimator (and particle count) of the command line."""
    if args.particles is None:
        return config.replace(estimator=args.estimator)
    return config.replace(estimator=args.estimator, particles=args.particles)


def estimator_spec(args: argparse.Namespace) -> dict[str, Any]:
    """The estimator part of a Monte Carlo spec (``make_spec``'s keywords)."""
    particles = DEFAULT_PARTICLES if args.particles is None else args.particles
    return {"estimator": args.estimator, "particles": particles}
