"""The ``auto`` initializer's options in simulation (issue 13, the default's evidence).

``auto`` is MTE whose landmarks enter undelayed after a visit that ended without the
parallax, or within the visit once their parallax has stalled (the stalled-parallax
rule, on by default since 2026-11-29; ``auto_stalled_parallax=False`` turns it off),
and whose candidates keep their first ray across visits (``auto_keep_first_ray``, on
by default since 2026-11-29: triangulated against at the next visit, or applied once
the depth is bounded).
An opt-in wait budget (``auto_max_wait=T``) makes them enter earlier still. On MRCLAM
they help (docs/results/filter-consistency.md); this script shows what they cost where
the paper's MTE works, on the built-in scenarios: mean ATE and mean pose NEES over the
seeds, one row per configuration, as a markdown table.

    make develop
    python benches/auto_init_sim.py [SEEDS] [FIRST]  # default 20 seeds from 0 (held out: 1000)
"""

from __future__ import annotations

import sys
from typing import Any

import numpy as np

import bearing_slam as bs

SCENARIOS = ("paper_fig4", "slip_patch", "paper_fig8")
CONFIGS: tuple[tuple[str, dict[str, Any]], ...] = (
    ("mte", {"init": "mte"}),
    (
        "auto, no stalled-parallax rule, first rays dropped",
        {"init": "auto", "auto_stalled_parallax": False, "auto_keep_first_ray": False},
    ),
    ("auto, first rays dropped", {"init": "auto", "auto_keep_first_ray": False}),
    ("auto without the stalled-parallax rule", {"init": "auto", "auto_stalled_parallax": False}),
    ("auto (default: stalled-parallax rule, kept first ray)", {"init": "auto"}),
    ("auto + 1 s budget", {"init": "auto", "auto_max_wait": 1.0}),
    ("auto + 2 s budget", {"init": "auto", "auto_max_wait": 2.0}),
)


def main(seeds: int, first: int = 0) -> None:
    print("| scenario | initializer | mean ATE m | mean pose NEES |")
    print("|---|---|---|---|")
    for scenario in SCENARIOS:
        logs = [bs.simulate(scenario, seed) for seed in range(first, first + seeds)]
        for label, kwargs in CONFIGS:
            ate, nees = [], []
            for log in logs:
                summary = bs.run(log, bs.Config.for_log(log, **kwargs)).summary
                assert summary is not None
                ate.append(summary["ate_rmse_m"])
                nees.append(summary["mean_nees_pose"])
            print(f"| {scenario} | {label} | {np.mean(ate):.3f} | {np.mean(nees):.2f} |")


if __name__ == "__main__":
    main(
        int(sys.argv[1]) if len(sys.argv) > 1 else 20,
        int(sys.argv[2]) if len(sys.argv) > 2 else 0,
    )
