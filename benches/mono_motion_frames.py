"""Monocular SLAM on KITTI: the constant-velocity model's frame and its noise (issue 17).

The paper's model (25) keeps the velocity in the world frame, for a hand-held camera. A
camera on a car moves along its own axis: in a curve its world velocity turns, and the
world model needs an acceleration of ``|v||ω|`` (about 5 m/s² on KITTI clip 2) to
follow it. ``velocity_frame = "body"`` keeps the velocity in the camera frame instead.

This script runs both frames, with the filter and search configurations of
``mono.md``, under two noise rules stated before the runs:

- ``paper``: the hand-held defaults (σ_a = 2 m/s², σ_α = 3 rad/s²);
- ``held-out``: the noise fitted by ``bs.mono.motion_noise`` to the ground truth of
  the *other* clip (clip 1's for clip 2, clip 2's for clip 1), in the same frame, so
  no clip is scored with noise taken from its own ground truth.

    make develop
    python benches/mono_motion_frames.py ../shared/datasets/kitti-clips/KITTI_sequence_1 \\
        ../shared/datasets/kitti-clips/KITTI_sequence_2
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import bearing_slam as bs
from kitti_clips import clips_have_poses
from mono_ransac_seeds import CONFIGS, ate_percent

#: The hand-held defaults of ``MonoRunConfig`` (the paper's setting).
PAPER_NOISE = {"linear_accel_sigma": 2.0, "angular_accel_sigma": 3.0}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("clips", nargs=2, type=Path, help="the two frames directories")
    args = parser.parse_args(argv)
    clips: list[Path] = args.clips
    if not clips_have_poses(clips):
        return 2
    print("| clip | velocity frame | noise rule | σ_a, σ_α | " + " | ".join(CONFIGS) + " |")
    print("|---" * (4 + len(CONFIGS)) + "|")
    for index, clip in enumerate(clips):
        other = clips[1 - index]
        for frame in ("world", "body"):
            fitted = bs.mono.motion_noise(other, frame)
            rules = {
                "paper": PAPER_NOISE,
                f"held-out ({other.name})": {
                    "linear_accel_sigma": fitted["linear_accel_sigma"],
                    "angular_accel_sigma": fitted["angular_accel_sigma"],
                },
            }
            for rule, noise in rules.items():
                cells = [
                    f"{ate_percent(clip, {**config, **noise, 'velocity_frame': frame}):.2f}"
                    for config in CONFIGS.values()
                ]
                sigmas = f"{noise['linear_accel_sigma']:.2f}, {noise['angular_accel_sigma']:.2f}"
                print(f"| {clip.name} | {frame} | {rule} | {sigmas} | " + " | ".join(cells) + " |")
                sys.stdout.flush()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
