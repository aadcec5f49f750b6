"""The heading Gaussian sum against the EKF: mean pose NEES over time (issue 13).

The consistency experiment's scene (``paper_fig4``, with and without its far landmark,
the default ``auto`` initializer), ``RUNS`` seeded runs from ``FIRST_SEED`` for the EKF
(``estimator="filter"``) and the heading Gaussian sum (``estimator="gaussian-sum"``):
the mean NEES of the runs at each time against its two-sided χ² 95 % band, one panel
per scene, written to ``OUT`` (default ``docs/results/gaussian_sum_nees.png``), and the
fraction of the time inside the band printed per row (docs/results/filter-consistency.md,
"A Gaussian sum over the heading").

    make develop
    python benches/gaussian_sum_nees.py [RUNS [FIRST_SEED [OUT]]]   # default 200, 0
"""

from __future__ import annotations

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

from bearing_slam.monte_carlo import montecarlo

ESTIMATORS = (("filter", "EKF (filter)", "tab:red"), ("gaussian-sum", "Gaussian sum", "tab:blue"))


def main(runs: int, first: int, out: Path) -> None:
    fig, axes = plt.subplots(1, 2, figsize=(11, 4), sharey=True)
    for ax, far in zip(axes, (True, False), strict=True):
        band = None
        for estimator, label, colour in ESTIMATORS:
            result = montecarlo(
                "paper_fig4",
                "auto",
                runs,
                seed0=first,
                far_landmark=far,
                estimator=estimator,
                progress=False,
            )["auto"]
            inside = result.nees_fraction_inside
            print(
                f"paper_fig4{'' if far else ' (no far landmark)'} {estimator}: "
                f"inside the band {100 * (inside or 0.0):.1f} % of the time, "
                f"mean ATE {result.report['all_finite']['ate_rmse_m']:.3f} m"
            )
            ax.plot(result.time, result.nees_mean, color=colour, lw=1.2, label=label)
            band = result
        assert band is not None
        ax.fill_between(
            band.time, band.nees_lower, band.nees_upper, color="0.85", label="95 % band"
        )
        ax.set_title(f"paper_fig4{'' if far else ', no far landmark'}, {runs} runs")
        ax.set_xlabel("time (s)")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("mean pose NEES")
    axes[0].legend(loc="upper right")
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)
    print(f"wrote {out}")


if __name__ == "__main__":
    main(
        int(sys.argv[1]) if len(sys.argv) > 1 else 200,
        int(sys.argv[2]) if len(sys.argv) > 2 else 0,
        Path(sys.argv[3]) if len(sys.argv) > 3 else Path("docs/results/gaussian_sum_nees.png"),
    )
