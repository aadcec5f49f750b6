"""Trajectory and consistency metrics: ATE, RPE, NEES, NIS and χ² bounds, and the
association oracle (the best pairing any method could reach on a log)."""

from bearing_slam._native import (
    association_oracle,
    ate,
    chi2_interval,
    chi2_quantile,
    nees,
    nees_summary,
    nis,
    pose_nees,
    rpe,
)

__all__ = [
    "association_oracle",
    "ate",
    "chi2_interval",
    "chi2_quantile",
    "nees",
    "nees_summary",
    "nis",
    "pose_nees",
    "rpe",
]
