"""The filter's options on the command line (issue 13): the bearing update and
the ``auto`` initializer's rules.

``bearing-slam run`` and ``mrclam`` take ``--first-order`` (the paper's
first-order bearing update, ``Config(second_order=False)``, instead of the
second-order default) and, with ``--init auto`` (the default), the options
of Rust's ``UndelayedFallback`` under ``Config``'s names:
``--auto-visits N`` (expired visits before a landmark enters undelayed,
default 1), ``--auto-max-wait SECONDS`` (a wait budget: a candidate still
waiting for parallax after that long enters undelayed from its current
bearing; opt-in, its value from a sweep),
``--no-auto-stalled-parallax`` (it waits for its visit to expire even when
its parallax has stalled), ``--no-auto-insignificant-parallax`` (it waits
for parallax even where the bearing noise makes the parallax test
insignificant) and ``--no-auto-keep-first-ray`` (an expired candidate is
dropped with its first bearing, as in the paper, instead of keeping its first
ray for the next visit); docs/results/filter-consistency.md. ``--no-conversion-depth-linearity``
converts an inverse-depth landmark to a point by Civera et al.'s test alone,
as the paper does, without waiting for the conversion's own linearity.
"""

from __future__ import annotations

import argparse
from typing import Any

from bearing_slam.arg_types import positive_float, positive_int

__all__ = ["add_filter_options", "filter_options", "filter_problem"]

_AUTO_FLAGS = (
    "--auto-visits",
    "--auto-max-wait",
    "--no-auto-stalled-parallax",
    "--no-auto-insignificant-parallax",
    "--[no-]auto-keep-first-ray",
)


def add_filter_options(parser: argparse.ArgumentParser) -> None:
    """Adds ``--first-order``, ``--no-conversion-depth-linearity`` and the
    ``auto`` initializer's ``--auto-*`` options to a subcommand."""
    parser.add_argument(
        "--first-order",
        action="store_true",
        help="the paper's first-order (EKF) bearing update instead of the second-order "
        "default (which adds the bearing's curvature over the pose and landmark "
        "uncertainty to its mean and variance)",
    )
    parser.add_argument(
        "--auto-visits",
        type=positive_int,
        metavar="N",
        help="--init auto: visits that end without parallax before a landmark enters "
        "undelayed at its next sighting (default: 1)",
    )
    parser.add_argument(
        "--auto-max-wait",
        type=positive_float,
        metavar="SECONDS",
        help="--init auto: a wait budget; a landmark still waiting for parallax after "
        "SECONDS enters undelayed from its current bearing (default: none; better on "
        "MRCLAM, a higher ATE in simulation: docs/results/filter-consistency.md)",
    )
    parser.add_argument(
        "--no-auto-stalled-parallax",
        dest="auto_stalled_parallax",
        action="store_false",
        default=None,
        help="--init auto: a landmark whose parallax has stalled (it would not reach "
        "the minimum within the candidate timeout) waits for its visit to expire; by "
        "default it enters undelayed at once",
    )
    parser.add_argument(
        "--no-auto-insignificant-parallax",
        dest="auto_insignificant_parallax",
        action="store_false",
        default=None,
        help="--init auto: wait for parallax even when the bearing noise makes the "
        "parallax test insignificant (alpha_min < 3*sqrt(2)*sigma); by default such a "
        "landmark enters undelayed at once",
    )
    parser.add_argument(
        "--auto-keep-first-ray",
        dest="auto_keep_first_ray",
        action=argparse.BooleanOptionalAction,
        default=None,
        help="--init auto: a candidate whose visit ends without parallax keeps its "
        "first ray (its pose cloned into the state) for the landmark's next visit, "
        "which triangulates against it or applies it once the depth is bounded "
        "(default: the library's, Config().auto_keep_first_ray)",
    )
    parser.add_argument(
        "--no-conversion-depth-linearity",
        dest="conversion_depth_linearity",
        action="store_false",
        default=None,
        help="convert an inverse-depth landmark to a point by Civera et al.'s linearity "
        "test alone, as the paper does; by default the conversion also waits for its "
        "own linearity (2*sigma_rho/rho below the threshold)",
    )


def filter_options(args: argparse.Namespace) -> dict[str, Any]:
    """The options given, as ``Config``'s fields (``second_order``,
    ``conversion_depth_linearity``, ``auto_*``; empty when none was given)."""
    options: dict[str, Any] = {}
    if args.first_order:
        options["second_order"] = False
    if args.conversion_depth_linearity is not None:
        options["conversion_depth_linearity"] = args.conversion_depth_linearity
    if args.auto_visits is not None:
        options["auto_visits"] = args.auto_visits
    if args.auto_max_wait is not None:
        options["auto_max_wait"] = args.auto_max_wait
    if args.auto_stalled_parallax is not None:
        options["auto_stalled_parallax"] = args.auto_stalled_parallax
    if args.auto_insignificant_parallax is not None:
        options["auto_insignificant_parallax"] = args.auto_insignificant_parallax
    if args.auto_keep_first_ray is not None:
        options["auto_keep_first_ray"] = args.auto_keep_first_ray
    return options


def filter_problem(args: argparse.Namespace, init: str) -> str | None:
    """Why the options cannot be used with ``init`` (a ``--init`` name, or
    ``range-bearing`` for ``--use-range``), or None."""
    options = filter_options(args)
    if init == "range-bearing" and args.first_order:
        return "--first-order applies to the bearing-only update, not to --use-range"
    if init == "range-bearing" and args.conversion_depth_linearity is not None:
        return (
            "--no-conversion-depth-linearity applies to inverse-depth landmarks, "
            "not to --use-range (its landmarks are points from the start)"
        )
    if any(k.startswith("auto_") for k in options) and init != "auto":
        return f"{', '.join(_AUTO_FLAGS)} apply to --init auto only, not to --init {init}"
    return None
