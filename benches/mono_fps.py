"""Frames per second of the monocular loop on one core (issue 17's speed target).

The issue asks for at least 100 fps on one core, front end and filter, at 424×240 and
at full KITTI size, with 30 and 100 map features. This script runs the release build of
the whole loop (``mono_run``: PNG decoding, FAST, active search by NCC, the EKF) once
per configuration and prints, per row:

- **CPU fps**: frames over the process's CPU time (user + system, from
  ``getrusage``), decoding and set-up included: what one core does, whatever else the
  machine runs;
- **loop fps**: the run's own ``fps_loop`` (front end and filter, decoding excluded,
  wall clock: lower when the machine is loaded);
- the map features searched per frame (mean): the map holds the target after each
  frame's additions, and those that leave the view by the next frame are not
  searched (on KITTI, a quarter of them at 100);
- the ATE after Sim(3) in percent of the path, to show what the speed buys.

Rows: the rendered room (``render_synthetic``, 150 frames at 424×240) with both filters
at their defaults; both KITTI clips with the defaults (the delayed filter, which matches
almost no landmark there: ``mono.md``), with the undelayed filter and the paper's
world-frame model and noise (features out of view forgotten), and with the car
configuration of ``mono.md`` (undelayed, body-frame velocity, features out of view
forgotten, the motion noise fitted on the *other* clip's ground truth by
``bs.mono.motion_noise``).

    make mono-fps    # or, by hand:
    cargo build --release -p bearing-slam-vision --examples
    make develop
    python benches/mono_fps.py ../shared/datasets/kitti-clips
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

import bearing_slam as bs
from kitti_clips import clips_have_poses

ROOT = Path(__file__).resolve().parent.parent
EXAMPLES = ROOT / "target" / "release" / "examples"
CLIPS = ("KITTI_sequence_1", "KITTI_sequence_2")


def cpu_seconds_of_children() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def run(frames_dir: Path, config: dict[str, Any]) -> tuple[float, dict[str, Any]]:
    """CPU seconds and metrics of one ``mono_run``."""
    before = cpu_seconds_of_children()
    done = subprocess.run(
        [str(EXAMPLES / "mono_run"), str(frames_dir), json.dumps(config)],
        capture_output=True,
        text=True,
        check=False,
    )
    cpu = cpu_seconds_of_children() - before
    if done.returncode != 0:
        raise RuntimeError(f"mono_run {frames_dir}: {done.stderr.strip()}")
    # The metrics are the JSON object that closes the output.
    metrics: dict[str, Any] = json.loads(done.stdout[done.stdout.index("\n{") + 1 :])
    return cpu, metrics


def frame_count(frames_dir: Path) -> int:
    return len(list((frames_dir / "image_l").glob("*.png")))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("kitti", type=Path, help="the kitti-clips directory")
    args = parser.parse_args(argv)
    kitti: Path = args.kitti
    for name in ("mono_run", "render_synthetic"):
        if not (EXAMPLES / name).is_file():
            print(
                f"error: {EXAMPLES / name} is missing: run "
                "`cargo build --release -p bearing-slam-vision --examples`",
                file=sys.stderr,
            )
            return 2
    clips = [kitti / clip for clip in CLIPS]
    if not clips_have_poses(clips):
        return 2
    with tempfile.TemporaryDirectory() as tmp:
        room = Path(tmp) / "room"
        subprocess.run(
            [str(EXAMPLES / "render_synthetic"), str(room), "--frames", "150"],
            check=True,
            capture_output=True,
        )
        rows: list[tuple[str, Path, dict[str, Any]]] = []
        for features in (30, 100):
            front_end = {"front_end": {"target_features": features}}
            for filter_kind in ("delayed", "undelayed"):
                label = f"room 424×240, {filter_kind}, {features}"
                rows.append((label, room, {"filter": filter_kind, **front_end}))
            for index, clip in enumerate(clips):
                noise = bs.mono.motion_noise(clips[1 - index], "body")
                car = {
                    "filter": "undelayed",
                    "velocity_frame": "body",
                    "forget_out_of_view": True,
                    "linear_accel_sigma": noise["linear_accel_sigma"],
                    "angular_accel_sigma": noise["angular_accel_sigma"],
                }
                name = f"KITTI {index + 1}"
                rows.append((f"{name}, defaults (delayed), {features}", clip, front_end))
                paper = {"filter": "undelayed", "forget_out_of_view": True}
                rows.append(
                    (f"{name}, undelayed, paper's model, {features}", clip, {**paper, **front_end})
                )
                rows.append((f"{name}, car configuration, {features}", clip, {**car, **front_end}))
        print(
            "| data, filter, map features | CPU fps | loop fps | searched / frame "
            "| ATE (% of path) |"
        )
        print("|---|---|---|---|---|")
        for label, frames_dir, config in rows:
            cpu, metrics = run(frames_dir, config)
            fps = frame_count(frames_dir) / cpu
            print(
                f"| {label} | {fps:.0f} | {metrics['fps_loop']:.0f} | "
                f"{metrics['mean_regions']:.0f} | {metrics['ate_sim3_percent_of_path']:.2f} |",
                flush=True,
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())
