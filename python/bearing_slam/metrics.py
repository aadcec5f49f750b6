"""Trajectory and consistency metrics: ATE, RPE, NEES, NIS and χ² bounds."""

from bearing_slam._native import (
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
    "ate",
    "chi2_interval",
    "chi2_quantile",
    "nees",
    "nees_summary",
    "nis",
    "pose_nees",
    "rpe",
]
