"""The command line's data-association options (issue 16), shared by the
``run`` and ``mrclam`` subcommands: ``--association`` and, for ``run``, the
appearance descriptors' noise and the EKF's moving-object removal."""

from __future__ import annotations

import argparse

from bearing_slam._native import Config
from bearing_slam.arg_types import UserError, positive_float
from bearing_slam.vocabulary import ASSOCIATIONS


def add_association_option(parser: argparse.ArgumentParser) -> None:
    """Adds ``--association``: the log's ids, or hidden from the filter,
    which then pairs bearings with landmarks itself."""
    parser.add_argument(
        "--association",
        choices=ASSOCIATIONS,
        default="known",
        help="data association (default: %(default)s, the log's ids; nn/jcbb/ransac: the ids "
        "are hidden from the estimator, which pairs bearings with landmarks itself; they then "
        "only score it, in metrics.json; ransac is 1-point RANSAC; the filter takes nn, jcbb "
        "and ransac, fastslam1/fastslam2 take nn (per-particle maximum likelihood); the "
        "smoothers take nn, jcbb and ransac with the filter as their front end (the batch then "
        "re-associates every bearing against its smoothed estimate)",
    )


def add_hidden_id_options(parser: argparse.ArgumentParser) -> None:
    """Adds the options of the association with the ids hidden:
    ``--descriptor-sigma`` and the moving-object removal
    (``--moving-object-nis-factor``, ``--moving-object-pair-ratio``,
    ``--remember-movers``), all off by default."""
    parser.add_argument(
        "--descriptor-sigma",
        type=positive_float,
        help="with --association nn/jcbb/ransac: the noise σ of the log's appearance "
        "descriptors; a bearing that carries one is then paired only with a landmark that "
        "looks alike",
    )
    parser.add_argument(
        "--moving-object-nis-factor",
        type=positive_float,
        metavar="F",
        help="with --association nn/jcbb/ransac (the filter): a mapped landmark whose last "
        "10 pairings' NIS sums beyond chi2_10(0.999) and beyond F (> 1) times the other "
        "landmarks' median leaves the map as a moving object (it also evicts static "
        "landmarks where the robot slips; 3 in docs/results/association.md)",
    )
    parser.add_argument(
        "--moving-object-pair-ratio",
        type=positive_float,
        metavar="R",
        help="with --association nn/jcbb/ransac (the filter): a mapped landmark paired in "
        "fewer than the fraction R of its last 20 scans leaves the map (MonoSLAM's rule; "
        "only for a sensor that keeps every landmark in view)",
    )
    parser.add_argument(
        "--remember-movers",
        action="store_true",
        help="with --moving-object-nis-factor: remember where each landmark it removed "
        "stood, and do not map a track that such a mover explains",
    )


def with_hidden_id_options(config: Config, args: argparse.Namespace) -> Config:
    """``config`` with the options of :func:`add_hidden_id_options` that
    were given; a :class:`UserError` names an option given where it has
    no effect."""
    options: dict[str, object] = {}
    if args.descriptor_sigma is not None:
        options["descriptor_sigma"] = args.descriptor_sigma
    if args.moving_object_nis_factor is not None:
        options["moving_object_nis_factor"] = args.moving_object_nis_factor
    if args.moving_object_pair_ratio is not None:
        options["moving_object_pair_ratio"] = args.moving_object_pair_ratio
    if args.remember_movers:
        if args.moving_object_nis_factor is None:
            raise UserError("--remember-movers needs --moving-object-nis-factor")
        options["remember_movers"] = True
    given = ", ".join("--" + name.replace("_", "-") for name in options)
    if options and args.association == "known":
        raise UserError(f"{given}: for --association nn, jcbb or ransac only")
    moving = [name for name in options if name != "descriptor_sigma"]
    if moving and getattr(args, "estimator", None) in ("fastslam1", "fastslam2"):
        raise UserError(
            f"{given}: the moving-object rules are the filter's (FastSLAM associates per particle)"
        )
    return config.replace(**options) if options else config
