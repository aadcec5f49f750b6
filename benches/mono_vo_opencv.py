"""OpenCV five-point monocular visual odometry: the yardstick for bearing-slam's
monocular SLAM on the KITTI clips (issue 17).

Frame to frame: Shi-Tomasi corners (``goodFeaturesToTrack``) tracked by pyramidal
Lucas-Kanade into the next frame, the essential matrix by the five-point algorithm in
RANSAC (``findEssentialMat``, threshold 1 px, confidence 0.999), the relative pose by
``recoverPose``; the translation's scale from the ground truth (the length of the
true step), as in the usual monocular VO demos. Scores the frames 1 … N−1 as
``bearing-slam mono`` does: ATE after a Sim(3) (Umeyama) alignment and unaligned.

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


def five_point_vo(clip: Path) -> dict[str, Any]:
    """Runs the VO on one clip; returns its scores."""
    k = read_calib(clip / "calib.txt")
    truth = read_poses(clip / "poses.txt")
    images = sorted((clip / "image_l").glob("*.png"))
    if len(images) != len(truth):
        raise SystemExit(f"{clip}: {len(images)} images, {len(truth)} poses")
    rotation, position = truth[0][:, :3].copy(), truth[0][:, 3].copy()
    estimate = [position.copy()]
    prev = cv2.imread(str(images[0]), cv2.IMREAD_GRAYSCALE)
    lost = 0
    start = time.perf_counter()
    for i in range(1, len(images)):
        cur = cv2.imread(str(images[i]), cv2.IMREAD_GRAYSCALE)
        p0 = cv2.goodFeaturesToTrack(prev, maxCorners=2000, qualityLevel=0.01, minDistance=7)
        p1, status, _ = cv2.calcOpticalFlowPyrLK(prev, cur, p0, None, winSize=(21, 21), maxLevel=3)
        good = status.ravel() == 1
        a, b = p0[good].reshape(-1, 2), p1[good].reshape(-1, 2)
        e, mask = cv2.findEssentialMat(b, a, k, method=cv2.RANSAC, prob=0.999, threshold=1.0)
        step = float(np.linalg.norm(truth[i][:, 3] - truth[i - 1][:, 3]))
        if e is None or e.shape != (3, 3):
            lost += 1
            position = position + rotation @ np.array([0.0, 0.0, step])
        else:
            # recoverPose(E, b, a): x_a = R x_b + t, i.e. [R | t] is frame i's pose
            # in frame i-1 (the points of the current frame come first).
            _, r, t, _ = cv2.recoverPose(e, b, a, k, mask=mask)
            position = position + step * (rotation @ (t.ravel() / np.linalg.norm(t)))
            rotation = rotation @ r
        estimate.append(position.copy())
        prev = cur
    seconds = time.perf_counter() - start
    est = np.array(estimate)[1:]
    gt = truth[1:, :, 3]
    s, r, t = umeyama(est, gt)
    aligned = (s * (r @ est.T)).T + t
    sim3 = float(np.sqrt(((aligned - gt) ** 2).sum(axis=1).mean()))
    metric = float(np.sqrt(((est - gt) ** 2).sum(axis=1).mean()))
    path = float(np.linalg.norm(np.diff(gt, axis=0), axis=1).sum())
    return {
        "clip": clip.name,
        "frames_scored": len(gt),
        "path_length_m": path,
        "ate_sim3_m": sim3,
        "ate_sim3_percent_of_path": 100.0 * sim3 / path,
        "ate_metric_m": metric,
        "frames_without_essential_matrix": lost,
        "fps": (len(images) - 1) / seconds,
    }


def main(argv: list[str] | None = None) -> int:
    """Entry point: one JSON line per clip."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("clips", nargs="+", type=Path, help="KITTI clip directories")
    args = parser.parse_args(argv)
    for clip in args.clips:
        print(json.dumps(five_point_vo(clip)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
