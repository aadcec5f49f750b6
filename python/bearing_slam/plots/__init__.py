"""Figures (matplotlib, Agg backend: files only, no window).

* :mod:`bearing_slam.plots.run`: the plots of one run (trajectory and map,
  pose errors with ±3σ, NEES under its χ² 95 % bound) and :func:`save_plots`;
* :mod:`bearing_slam.plots.experiments`: the figures of the paper's experiments;
* :mod:`bearing_slam.plots.mrclam`: the figures of the MRCLAM evaluation.

The names below are re-exported, so ``from bearing_slam.plots import save_plots`` works.
"""

from bearing_slam.plots.experiments import (
    PLOTS,
    plot_consistency,
    plot_fig4,
    plot_fig5,
    plot_fig8,
    plot_fig10,
    save_experiment_figure,
)
from bearing_slam.plots.mrclam import ate_figure, comparison_figure
from bearing_slam.plots.run import (
    covariance_ellipse,
    nees_caption,
    plot_nees,
    plot_pose_errors,
    plot_trajectory,
    save_figure,
    save_plots,
)

__all__ = [
    "PLOTS",
    "ate_figure",
    "comparison_figure",
    "covariance_ellipse",
    "nees_caption",
    "plot_consistency",
    "plot_fig4",
    "plot_fig5",
    "plot_fig8",
    "plot_fig10",
    "plot_nees",
    "plot_pose_errors",
    "plot_trajectory",
    "save_experiment_figure",
    "save_figure",
    "save_plots",
]
