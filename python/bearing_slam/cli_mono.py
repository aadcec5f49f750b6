"""``bearing-slam mono DIR --out OUT`` and ``bearing-slam mono-render OUT`` (issue 17)."""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

__all__ = ["add_mono_parser"]


def _cmd_mono(args: argparse.Namespace) -> int:
    from bearing_slam import mono

    config: dict[str, Any] = json.loads(args.config) if args.config else {}
    if args.filter:
        config["filter"] = args.filter
    if args.velocity_frame:
        config["velocity_frame"] = args.velocity_frame
    if args.forget_out_of_view:
        config["forget_out_of_view"] = True
    if args.metric_reference:
        config["metric_reference"] = True
    if args.max_frames is not None:
        config["max_frames"] = args.max_frames
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    mcap = None if args.no_mcap else out / "mono.mcap"
    result = mono.run(Path(args.frames_dir), args.calib, config, mcap=mcap)
    metrics = mono.write_outputs(result, out)
    if not args.quiet:
        summary = {
            "ate_sim3_m": metrics["ate_sim3"]["rmse_m"],
            "ate_sim3_percent_of_path": metrics["ate_sim3_percent_of_path"],
            "ate_metric_m": metrics["ate_metric"]["rmse_m"],
            "path_length_m": metrics["path_length_m"],
            "fps_loop": metrics["fps_loop"],
            "mean_found": metrics["mean_found"],
        }
        print(json.dumps(summary, indent=2))
    return 0


def _cmd_mono_noise(args: argparse.Namespace) -> int:
    from bearing_slam import mono

    noise = mono.motion_noise(Path(args.frames_dir), args.velocity_frame, args.calib)
    print(json.dumps(noise, indent=2))
    return 0


def _cmd_mono_render(args: argparse.Namespace) -> int:
    from bearing_slam import mono

    config: dict[str, Any] = {"frames": args.frames, "seed": args.seed}
    if args.reference_sheet:
        config["reference_sheet"] = True
    if args.size:
        width, _, height = args.size.partition("x")
        config["width"], config["height"] = int(width), int(height)
    n = mono.render(args.out, config)
    print(f"{n} frames written to {args.out}")
    return 0


def add_mono_parser(sub: Any) -> None:
    """Adds the ``mono`` and ``mono-render`` subcommands to the CLI's subparsers."""
    p = sub.add_parser(
        "mono",
        help="6-DOF monocular SLAM on a frames directory (KITTI clip layout)",
        description="Runs the monocular loop (FAST features, active search by NCC inside "
        "the ellipse of S, the inverse-depth EKF) on DIR (image_l/*.png, calib.txt, "
        "poses.txt) from frame 1, started from the first two ground-truth poses, and "
        "writes OUT/metrics.json (ATE after Sim(3) and unaligned, path length, fps), "
        "OUT/trajectory.png (X-Y and X-Z views), OUT/frames.png (ellipses and matches) and "
        "OUT/mono.mcap for Foxglove (the images with the search ellipses and matches, the "
        "estimated and true camera paths, the map's 2σ ellipsoids after every frame).",
    )
    p.add_argument("frames_dir", metavar="DIR", help="the frames directory")
    p.add_argument("--out", required=True, help="output folder")
    p.add_argument("--calib", help="calibration file (default: DIR/calib.txt)")
    p.add_argument(
        "--filter",
        choices=["delayed", "delayed_clone", "undelayed", "oracle"],
        help="the filter (default: delayed; oracle = ground truth, rendered data only)",
    )
    p.add_argument(
        "--velocity-frame",
        choices=["world", "body"],
        help="the constant-velocity model's frame (default: world, the paper's (25), a "
        "hand-held camera; body: constant velocity along the camera, a camera on a car)",
    )
    p.add_argument(
        "--forget-out-of-view",
        action="store_true",
        help="features out of view count as misses and leave the map (a camera that does "
        "not come back, e.g. on a car: the state stays bounded)",
    )
    p.add_argument(
        "--metric-reference",
        action="store_true",
        help="hold the scale with the paper's metric reference: DIR/known_points.txt (x y z "
        "per line, world frame) enter the map as exact landmarks at the start",
    )
    p.add_argument("--max-frames", type=int, help="run at most this many frames")
    p.add_argument("--config", help="more settings as JSON (see bearing_slam.mono.run)")
    p.add_argument("--quiet", action="store_true", help="no summary on stdout")
    p.add_argument("--no-mcap", action="store_true", help="do not write OUT/mono.mcap")
    p.set_defaults(func=_cmd_mono)

    n = sub.add_parser(
        "mono-noise",
        help="the constant-velocity model's acceleration noise fitted to DIR's ground truth",
        description="Prints, as JSON for `mono --config`, the acceleration noise "
        "(linear_accel_sigma, angular_accel_sigma) the ground-truth path of DIR needs: the "
        "per-axis root mean square of its accelerations between frames. Fit it on one "
        "sequence and run on another.",
    )
    n.add_argument("frames_dir", metavar="DIR", help="the frames directory (poses.txt)")
    n.add_argument("--calib", help="calibration file (default: DIR/calib.txt)")
    n.add_argument(
        "--velocity-frame",
        choices=["world", "body"],
        default="world",
        help="the frame of the model's velocity (default: %(default)s)",
    )
    n.set_defaults(func=_cmd_mono_noise)

    r = sub.add_parser(
        "mono-render",
        help="render the synthetic room sequence (exact ground truth) in the KITTI layout",
    )
    r.add_argument("out", metavar="OUT", help="output folder")
    r.add_argument("--frames", type=int, default=150, help="frames (default: %(default)s)")
    r.add_argument("--size", help="WIDTHxHEIGHT (default: 424x240, the paper's camera)")
    r.add_argument("--seed", type=int, default=1, help="texture seed (default: %(default)s)")
    r.add_argument(
        "--reference-sheet",
        action="store_true",
        help="hang the paper's metric reference (a 30 × 20 cm black rectangle on a white "
        "sheet) in the room and write its corners to OUT/known_points.txt",
    )
    r.set_defaults(func=_cmd_mono_render)
