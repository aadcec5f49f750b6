"""Dataset 1: aligned landmark RMSE of the final maps with Landmark_Groundtruth.dat as given
and with subjects 11 and 17 exchanged (Procrustes without scale, as align_landmarks_se2).

    .venv/bin/python docs/results/mrclam/check_swap_11_17.py [DATA_DIR]

DATA_DIR holds MRCLAM_Dataset1/ (default: $BEARING_SLAM_DATA).
"""

from __future__ import annotations

import argparse

import numpy as np
from numpy.typing import NDArray

from bearing_slam import mrclam

F64 = NDArray[np.float64]


def aligned_rmse(est: F64, tru: F64) -> tuple[float, F64]:
    """RMSE of ``est`` after its best rigid motion onto ``tru``, and the residual per point."""
    me, mt = est.mean(0), tru.mean(0)
    cross = (est - me).T @ (tru - mt)
    u, _, vt = np.linalg.svd(cross)
    rot = vt.T @ u.T
    if np.linalg.det(rot) < 0:
        vt[1] *= -1
        rot = vt.T @ u.T
    r = (rot @ (est - me).T).T + mt - tru
    per_point: F64 = np.sqrt((r**2).sum(1))
    return float(np.sqrt((r**2).sum(1).mean())), per_point


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("data", nargs="?", metavar="DATA_DIR", help="default: $BEARING_SLAM_DATA")
    args = ap.parse_args(argv)
    d1 = mrclam.data_dir(args.data) / "MRCLAM_Dataset1"
    for robot in range(1, 6):
        for m in ["range-bearing", "pi-sr"]:
            run = mrclam.evaluate(d1, robot, m)
            ids, pos, _ = run.result.landmarks()
            truth = {int(r[0]): r[1:] for r in run.log.landmarks}
            tru = np.array([truth[int(i)] for i in ids])
            a, per = aligned_rmse(pos, tru)
            sw = {**truth, 11: truth[17], 17: truth[11]}
            b, per2 = aligned_rmse(pos, np.array([sw[int(i)] for i in ids]))
            print(
                robot,
                m,
                f"as given {a:.2f}  with 11<->17 swapped {b:.2f}  worst ids as given",
                [int(ids[k]) for k in np.argsort(per)[-2:]],
                f"max resid swapped {per2.max():.2f}",
            )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
