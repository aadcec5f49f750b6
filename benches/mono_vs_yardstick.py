"""Monocular SLAM on the KITTI clips against OpenCV's five-point VO, like for like (issue 17).

Two pairs, each given the same information about scale:

- **the true step length at every frame**: OpenCV's five-point VO scaling each unit
  translation by the ground truth's step (the issue's yardstick), against our filter
  reading the same step lengths as a speed at every frame (``speed_readings``,
  as a car's wheel odometry would give, σ by the stated rule ``σ_a·Δt/2``);
- **the first step only**: the VO carrying its scale by triangulation from the first
  step, against our filter started from the first two ground-truth poses.

Our filter runs in the car configuration of ``docs/results/mono.md`` (undelayed
inverse depth, velocity in the camera frame, features out of view forgotten) with the
motion noise fitted to the *other* clip's ground truth (``bs.mono.motion_noise``), so no
clip is scored with noise from its own truth. ATE after Sim(3) alignment, % of the
path, frames 1 … N−1 on both sides; the metric ATE (no alignment) beside it.

    make develop && .venv/bin/pip install opencv-python-headless
    python benches/mono_vs_yardstick.py ../shared/datasets/kitti-clips/KITTI_sequence_1 \\
        ../shared/datasets/kitti-clips/KITTI_sequence_2
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

import bearing_slam as bs
from kitti_clips import clips_have_poses
from mono_vo_opencv import five_point_vo

#: The car configuration of docs/results/mono.md, besides the motion noise.
CAR: dict[str, Any] = {
    "filter": "undelayed",
    "velocity_frame": "body",
    "forget_out_of_view": True,
}


def ours(clip: Path, noise_clip: Path, speed: bool) -> tuple[float, float]:
    """Our filter's ATE after Sim(3) (% of path) and metric ATE (m) on ``clip``."""
    fitted = bs.mono.motion_noise(noise_clip, "body")
    config = {
        **CAR,
        "linear_accel_sigma": fitted["linear_accel_sigma"],
        "angular_accel_sigma": fitted["angular_accel_sigma"],
        "speed_readings": "ground_truth" if speed else "none",
    }
    metrics = bs.mono.run(clip, config=config).metrics
    return float(metrics["ate_sim3_percent_of_path"]), float(metrics["ate_metric"]["rmse_m"])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("clips", nargs=2, type=Path, help="the two KITTI clip directories")
    args = parser.parse_args(argv)
    clips: list[Path] = args.clips
    if not clips_have_poses(clips):
        return 2
    print(
        "| clip | scale given | ours: ATE Sim(3) % (metric m) | OpenCV VO: ATE Sim(3) % "
        "(metric m) | ours / VO |"
    )
    print("|---|---|---|---|---|")
    for index, clip in enumerate(clips):
        other = clips[1 - index]
        for speed, scale, label in (
            (True, "truth", "true step length, every frame"),
            (False, "first_step", "first step only"),
        ):
            ate, metric = ours(clip, other, speed)
            vo = five_point_vo(clip, scale)
            vo_ate = float(vo["ate_sim3_percent_of_path"])
            print(
                f"| {clip.name} | {label} | {ate:.3f} ({metric:.2f}) | "
                f"{vo_ate:.3f} ({float(vo['ate_metric_m']):.2f}) | {ate / vo_ate:.2f} |"
            )
            sys.stdout.flush()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
