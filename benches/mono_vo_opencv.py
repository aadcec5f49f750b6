"""OpenCV five-point monocular visual odometry: the yardstick for bearing-slam's
monocular SLAM on the KITTI clips (issue 17).

Frame to frame: Shi-Tomasi corners (``goodFeaturesToTrack``) tracked by pyramidal
Lucas-Kanade into the next frame, the essential matrix by the five-point algorithm in
RANSAC (``findEssentialMat``, threshold 1 px, confidence 0.999), the relative pose by
``recoverPose``. Two scales for the translation:

- ``truth`` (the issue's yardstick, as in the usual monocular VO demos): every step's
  length from the ground truth;
- ``first_step``: the first step's length from the ground truth (what ``bearing-slam
  mono`` is given: the first two poses), every later one carried by the points:
  the points tracked through three frames are triangulated from both frame pairs and
  the step's scale is the median ratio of their distances from the shared camera
  (Scaramuzza & Fraundorfer 2011's relative scale), over the points with at least 1°
  of parallax in both pairs; a step with fewer than 10 such points keeps the previous
  length (counted).

Scores the frames 1 … N−1 as ``bearing-slam mono`` does: ATE after a Sim(3) (Umeyama)
alignment and unaligned.

    pip install -e '.[bench]'   # opencv-python-headless
    python benches/mono_vo_opencv.py ../shared/datasets/kitti-clips/KITTI_sequence_1 \
        ../shared/datasets/kitti-clips/KITTI_sequence_2
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any

import cv2 as _cv2
import numpy as np

# OpenCV's stubs (when installed) are stricter than its runtime (None for an
# output array); the script uses it untyped, as it does without the stubs.
cv2: Any = _cv2


def read_calib(path: Path) -> np.ndarray:
    """The 3×3 intrinsics from ``P0`` (the first line) of a KITTI calib.txt."""
    first = path.read_text().splitlines()[0].split()
    values = [float(v) for v in first if not v.endswith(":")]
    return np.array(values, dtype=float).reshape(3, 4)[:, :3]


def read_poses(path: Path) -> np.ndarray:
    """``(n, 3, 4)`` camera-to-world poses."""
    rows = [
        list(map(float, line.split())) for line in path.read_text().splitlines() if line.strip()
    ]
    return np.array(rows, dtype=float).reshape(-1, 3, 4)


def umeyama(src: np.ndarray, dst: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """Least-squares similarity ``dst ≈ s R src + t``."""
    mu_s, mu_d = src.mean(axis=0), dst.mean(axis=0)
    xs, xd = src - mu_s, dst - mu_d
    cov = xd.T @ xs / len(src)
    u, d, vt = np.linalg.svd(cov)
    sign = np.eye(3)
    if np.linalg.det(u) * np.linalg.det(vt) < 0:
        sign[2, 2] = -1
    r = u @ sign @ vt
    s = float(np.trace(np.diag(d) @ sign) / (xs**2).sum(axis=1).mean())
    return s, r, mu_d - s * r @ mu_s


#: Corners detected per frame, and the fewest tracked before detecting again.
MAX_CORNERS, MIN_TRACKED = 2000, 1000
#: Fewest points seen from both frame pairs for a relative scale.
MIN_SCALE_POINTS = 10
#: Least parallax of a point (the angle between its rays from the two cameras) for its
#: distance to enter a relative scale; farther points' triangulations are noise.
MIN_PARALLAX_RAD = np.deg2rad(1.0)


def parallax(points: np.ndarray, baseline: np.ndarray) -> np.ndarray:
    """The angle at each point between the rays from the origin and from ``baseline``."""
    first = points / np.linalg.norm(points, axis=1, keepdims=True)
    second = points - baseline
    second = second / np.linalg.norm(second, axis=1, keepdims=True)
    cosines: np.ndarray = np.clip((first * second).sum(axis=1), -1.0, 1.0)
    angles: np.ndarray = np.arccos(cosines)
    return angles


def triangulate(
    k: np.ndarray, r: np.ndarray, t: np.ndarray, a: np.ndarray, b: np.ndarray
) -> np.ndarray:
    """Points seen at pixels ``a`` (frame i−1) and ``b`` (frame i), frame i's pose in
    frame i−1 being ``[r | t]``; returns them in frame i−1's coordinates."""
    first = k @ np.hstack([np.eye(3), np.zeros((3, 1))])
    second = k @ np.hstack([r.T, -r.T @ t.reshape(3, 1)])
    h: np.ndarray = cv2.triangulatePoints(first, second, a.T.astype(float), b.T.astype(float))
    points: np.ndarray = (h[:3] / h[3]).T
    return points


def five_point_vo(clip: Path, scale: str = "truth") -> dict[str, Any]:
    """Runs the VO on one clip with the given scale (``truth`` or ``first_step``);
    returns its scores."""
    k = read_calib(clip / "calib.txt")
    truth = read_poses(clip / "poses.txt")
    images = sorted((clip / "image_l").glob("*.png"))
    if len(images) != len(truth):
        raise SystemExit(f"{clip}: {len(images)} images, {len(truth)} poses")
    rotation, position = truth[0][:, :3].copy(), truth[0][:, 3].copy()
    estimate = [position.copy()]
    prev = cv2.imread(str(images[0]), cv2.IMREAD_GRAYSCALE)
    # The points carried from the previous step: pixels in the previous frame and,
    # where known, their position in its camera frame (metres at the running scale).
    carried = np.zeros((0, 2), dtype=np.float32)
    carried_xyz = np.zeros((0, 3))  # NaN where unknown or too far to carry the scale
    step = float(np.linalg.norm(truth[1][:, 3] - truth[0][:, 3]))
    lost = held = 0
    start = time.perf_counter()
    for i in range(1, len(images)):
        cur = cv2.imread(str(images[i]), cv2.IMREAD_GRAYSCALE)
        p0, xyz0 = carried, carried_xyz
        if len(p0) < MIN_TRACKED:
            fresh = cv2.goodFeaturesToTrack(
                prev, maxCorners=MAX_CORNERS, qualityLevel=0.01, minDistance=7
            ).reshape(-1, 2)
            p0 = np.vstack([p0, fresh]).astype(np.float32)
            xyz0 = np.vstack([xyz0, np.full((len(fresh), 3), np.nan)])
        p1, status, _ = cv2.calcOpticalFlowPyrLK(prev, cur, p0, None, winSize=(21, 21), maxLevel=3)
        good = status.ravel() == 1
        a, b, xyz_a = p0[good], p1[good], xyz0[good]
        e, mask = cv2.findEssentialMat(b, a, k, method=cv2.RANSAC, prob=0.999, threshold=1.0)
        if scale == "truth" or i == 1:
            step = float(np.linalg.norm(truth[i][:, 3] - truth[i - 1][:, 3]))
        if e is None or e.shape != (3, 3):
            lost += 1
            position = position + rotation @ np.array([0.0, 0.0, step])
            carried, carried_xyz = np.zeros((0, 2), dtype=np.float32), np.zeros((0, 3))
        else:
            # recoverPose(E, b, a): x_a = R x_b + t, i.e. [R | t] is frame i's pose
            # in frame i-1 (the points of the current frame come first).
            _, r, t, pose_mask = cv2.recoverPose(e, b, a, k, mask=mask)
            t = t.ravel() / np.linalg.norm(t)
            inlier = pose_mask.ravel() > 0
            unit = triangulate(k, r, t, a, b)  # frame i-1, unit baseline
            if scale == "first_step" and i > 1:
                both = inlier & np.isfinite(xyz_a).all(axis=1) & (unit[:, 2] > 0)
                both &= (xyz_a[:, 2] > 0) & (parallax(unit, t) >= MIN_PARALLAX_RAD)
                if both.sum() >= MIN_SCALE_POINTS:
                    ratios = np.linalg.norm(xyz_a[both], axis=1) / np.linalg.norm(
                        unit[both], axis=1
                    )
                    step = float(np.median(ratios))
                else:
                    held += 1
            position = position + step * (rotation @ t)
            rotation = rotation @ r
            metric = unit[inlier] * step
            carried = b[inlier].reshape(-1, 2).astype(np.float32)
            carried_xyz = (r.T @ (metric - step * t).T).T  # into frame i
            carried_xyz[parallax(unit[inlier], t) < MIN_PARALLAX_RAD] = np.nan
        estimate.append(position.copy())
        prev = cur
    seconds = time.perf_counter() - start
    est = np.array(estimate)[1:]
    gt = truth[1:, :, 3]
    s, r, t = umeyama(est, gt)
    aligned = (s * (r @ est.T)).T + t
    sim3 = float(np.sqrt(((aligned - gt) ** 2).sum(axis=1).mean()))
    metric_ate = float(np.sqrt(((est - gt) ** 2).sum(axis=1).mean()))
    path = float(np.linalg.norm(np.diff(gt, axis=0), axis=1).sum())
    return {
        "clip": clip.name,
        "scale": scale,
        "frames_scored": len(gt),
        "path_length_m": path,
        "ate_sim3_m": sim3,
        "ate_sim3_percent_of_path": 100.0 * sim3 / path,
        "sim3_scale": s,
        "ate_metric_m": metric_ate,
        "frames_without_essential_matrix": lost,
        "steps_scale_held": held,
        "fps": (len(images) - 1) / seconds,
    }


def main(argv: list[str] | None = None) -> int:
    """Entry point: one JSON line per clip."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("clips", nargs="+", type=Path, help="KITTI clip directories")
    parser.add_argument(
        "--scale",
        choices=["truth", "first_step", "both"],
        default="both",
        help="every step's length from the ground truth, only the first one, or both runs "
        "(default: %(default)s)",
    )
    args = parser.parse_args(argv)
    scales = ["truth", "first_step"] if args.scale == "both" else [args.scale]
    for clip in args.clips:
        for scale in scales:
            print(json.dumps(five_point_vo(clip, scale)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
