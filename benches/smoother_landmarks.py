"""How well the data pin down the smoother's raw landmark positions (issue 14).

Issue 14 asks the batch smoother for a raw (unaligned) landmark RMSE ≤ 0.25 m on
every MRCLAM Dataset 6 robot. This script runs the default smoother
(``bs.evaluate_mrclam(..., estimator="smoother")``) on each robot and scores its final
map against the landmark truth: the raw RMSE, each landmark's NEES against its marginal
covariance (the fraction inside the χ²(2) 95 % bound, mean and median), the worst
landmark with its marginal's standard deviations, and the RMSE the marginals predict,
``√(mean tr C)``. Where the marginals are consistent and predict more than 0.25 m, the
data do not pin the landmarks down that well.

    make develop
    python benches/smoother_landmarks.py [DATASET_DIR]   # default: ../shared/.../MRCLAM_Dataset6
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from scipy.stats import chi2

import bearing_slam as bs

DEFAULT_DIR = (
    Path(__file__).resolve().parents[2] / "shared" / "datasets" / "mrclam" / "MRCLAM_Dataset6"
)
BOUND = float(chi2.ppf(0.95, 2))


def main(dataset: Path) -> None:
    print(
        "| robot | ATE m | raw landmark RMSE m | predicted by the marginals m "
        "| landmark NEES mean / median | inside the 95 % bound | worst landmark: error m, "
        "NEES, marginal σ m |"
    )
    print("|---|---|---|---|---|---|---|")
    for robot in range(1, 6):
        result, metrics, log = bs.evaluate_mrclam(dataset, robot, estimator="smoother")
        ids, positions, covariances = result.trace.final_landmarks()
        truth = {int(i): np.array([x, y]) for i, x, y in np.asarray(log.landmarks).tolist()}
        errors = np.array([p - truth[int(i)] for i, p in zip(ids, positions, strict=True)])
        nees = np.array(
            [e @ np.linalg.solve(c, e) for e, c in zip(errors, covariances, strict=True)]
        )
        distance = np.hypot(errors[:, 0], errors[:, 1])
        predicted = np.sqrt(np.mean([np.trace(c) for c in covariances]))
        w = int(np.argmax(distance))
        sigmas = np.sqrt(np.linalg.eigvalsh(covariances[w]))
        print(
            f"| {robot} | {metrics['ate_rmse_m']:.3f} | {np.sqrt(np.mean(distance**2)):.3f} "
            f"| {predicted:.3f} | {nees.mean():.1f} / {np.median(nees):.1f} "
            f"| {100 * np.mean(nees <= BOUND):.0f} % "
            f"| landmark {int(ids[w])}: {distance[w]:.2f}, {nees[w]:.1f}, "
            f"{sigmas[0]:.2f} × {sigmas[1]:.2f} |"
        )


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else DEFAULT_DIR)
