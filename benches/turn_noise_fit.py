"""How MRCLAM's heading error grows with the turn rate (issue 13: the filter's
motion noise on real robots).

The calibrated velocity noise (``FilterParameters::velocity_noise``) has one
floor for the turn rate, ``sigma_omega_min``, matched to the heading drift over
the median blind stretch (27 s); its ``alpha`` terms are zero. This script
measures, on Dataset 6's five robots (Vicon against the corrected commands):

* the RMS heading error of 1 s windows binned by the mean commanded ``|omega|``;
* at windows of 1, 4 and 27 s, the least-squares variance components of
  ``e_theta^2 = sigma_min^2 T + alpha4 * sum(omega^2 dt)`` (Thrun's alpha4 with
  the floor), against the uniform fit ``e_theta^2 = sigma^2 T``.

    make develop
    python benches/turn_noise_fit.py [MRCLAM_Dataset6 directory]

Only windows in which the robot was commanded to move (more than 1 cm) count.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

import bearing_slam.mrclam as mrclam

DEFAULT = Path(__file__).resolve().parents[1] / ".." / "shared/datasets/mrclam/MRCLAM_Dataset6"


def windows(dataset: Path, window_s: float) -> NDArray[np.float64]:
    """Rows ``(T, sum(omega^2 dt), mean |omega|, e_theta^2)`` of every moving window."""
    rows = []
    for robot in range(1, 6):
        run = mrclam.evaluate(dataset, robot, "dead-reckoning")
        commands = run.log.velocity  # t, v, omega, dt (the corrected commands)
        times, truth = run.result.time, run.result.truth
        start = commands[0, 0]
        while start + window_s < min(commands[-1, 0], times[-1]):
            inside = (commands[:, 0] >= start) & (commands[:, 0] < start + window_s)
            c = commands[inside]
            first, last = np.searchsorted(times, [start, start + window_s])
            if last < len(times) and np.sum(np.abs(c[:, 1]) * c[:, 3]) > 0.01:
                heading = np.unwrap(truth[first : last + 1, 2])
                error = (heading[-1] - heading[0]) - np.sum(c[:, 2] * c[:, 3])
                rows.append(
                    (
                        window_s,
                        np.sum(c[:, 2] ** 2 * c[:, 3]),
                        np.sum(np.abs(c[:, 2]) * c[:, 3]) / window_s,
                        error**2,
                    )
                )
            start += window_s
    return np.array(rows)


def main(dataset: Path) -> None:
    one = windows(dataset, 1.0)
    print("| mean commanded turn rate, abs (rad/s) | 1 s windows | RMS heading error (rad) |")
    print("|---|---|---|")
    for low, high in ((0.0, 0.02), (0.02, 0.1), (0.1, 0.2), (0.2, 0.3), (0.3, 0.5), (0.5, 2.0)):
        chosen = (one[:, 2] >= low) & (one[:, 2] < high)
        if chosen.any():
            rms = np.sqrt(np.mean(one[chosen, 3]))
            print(f"| {low}–{high} | {int(chosen.sum())} | {rms:.4f} |")
    print()
    print("| window (s) | windows | sigma_omega_min (rad/s) | alpha4 | uniform sigma (rad/s) |")
    print("|---|---|---|---|---|")
    for window_s in (1.0, 4.0, 27.0):
        rows = one if window_s == 1.0 else windows(dataset, window_s)
        (variance, alpha4), *_ = np.linalg.lstsq(rows[:, :2], rows[:, 3], rcond=None)
        uniform = np.sqrt(rows[:, 3].sum() / rows[:, 0].sum())
        floor = np.sqrt(max(variance, 0.0))
        print(f"| {window_s:g} | {len(rows)} | {floor:.4f} | {alpha4:.4f} | {uniform:.4f} |")


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else DEFAULT)
