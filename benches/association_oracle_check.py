"""An independent check of the association oracle's ``paper_fig8`` row (issue 16).

``cargo run --release -p bearing-slam --example association -- oracle 20`` reports that
even an oracle knowing the true pose and map pairs only about 80 % of ``paper_fig8``'s
bearings with their own landmark. This script rebuilds that geometry without the
library: ten landmarks uniform by area in the 2–9 m annulus, the robot on the 5 m
circle facing along it, every landmark seen with 5° Gaussian bearing noise, and pairs
each scan's bearings with the landmarks by the most probable one-to-one assignment
(``scipy.optimize.linear_sum_assignment`` on the squared wrapped bearing errors). It
prints the fraction paired right.

    python benches/association_oracle_check.py [LAYOUTS [SCANS_PER_LAYOUT]]  # default 30 200
"""

from __future__ import annotations

import sys

import numpy as np
from scipy.optimize import linear_sum_assignment

LANDMARKS = 10
R_MIN, R_MAX = 2.0, 9.0
CIRCLE_RADIUS = 5.0
SIGMA = np.radians(5.0)


def fraction_paired_right(layouts: int, scans: int, seed: int = 0) -> float:
    """The share of bearings the maximum-likelihood assignment gives their own landmark."""
    rng = np.random.default_rng(seed)
    right = 0
    for _ in range(layouts):
        radius = np.sqrt(rng.uniform(R_MIN**2, R_MAX**2, LANDMARKS))
        angle = rng.uniform(0.0, 2.0 * np.pi, LANDMARKS)
        landmarks = np.c_[radius * np.cos(angle), radius * np.sin(angle)]
        for _ in range(scans):
            phi = rng.uniform(0.0, 2.0 * np.pi)
            position = CIRCLE_RADIUS * np.array([np.cos(phi), np.sin(phi)])
            heading = phi + np.pi / 2.0
            offset = landmarks - position
            predicted = np.arctan2(offset[:, 1], offset[:, 0]) - heading
            measured = predicted + rng.normal(0.0, SIGMA, LANDMARKS)
            error = np.angle(np.exp(1j * (measured[:, None] - predicted[None, :])))
            _, assigned = linear_sum_assignment(error**2)
            right += int(np.sum(assigned == np.arange(LANDMARKS)))
    return right / (layouts * scans * LANDMARKS)


def main() -> None:
    layouts = int(sys.argv[1]) if len(sys.argv) > 1 else 30
    scans = int(sys.argv[2]) if len(sys.argv) > 2 else 200
    share = fraction_paired_right(layouts, scans)
    print(f"paper_fig8 geometry, {layouts} layouts x {scans} scans:", end=" ")
    print(f"{100 * share:.1f} % paired right")


if __name__ == "__main__":
    main()
