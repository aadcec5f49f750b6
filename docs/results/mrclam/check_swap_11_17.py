"""Dataset 1: aligned landmark RMSE of the final maps with Landmark_Groundtruth.dat as given
and with subjects 11 and 17 exchanged (Procrustes without scale, as align_landmarks_se2).

    .venv/bin/python docs/results/mrclam/check_swap_11_17.py
"""
import numpy as np
from bearing_slam import mrclam
d1 = mrclam.default_data_dir() / "MRCLAM_Dataset1"
def aligned_rmse(est, tru):
    me, mt = est.mean(0), tru.mean(0)
    H = (est-me).T @ (tru-mt)
    U,S,Vt = np.linalg.svd(H); R = Vt.T @ U.T
    if np.linalg.det(R) < 0: Vt[1]*=-1; R = Vt.T@U.T
    r = (R @ (est-me).T).T + mt - tru
    return float(np.sqrt((r**2).sum(1).mean())), np.sqrt((r**2).sum(1))
for robot in range(1,6):
  for m in ["range-bearing","pi-sr"]:
    run = mrclam.evaluate(d1, robot, m)
    ids, pos, _ = run.result.landmarks()
    truth = {int(r[0]): r[1:] for r in run.log.landmarks}
    tru = np.array([truth[int(i)] for i in ids])
    a, per = aligned_rmse(pos, tru)
    sw = {**truth, 11: truth[17], 17: truth[11]}
    b, per2 = aligned_rmse(pos, np.array([sw[int(i)] for i in ids]))
    print(robot, m, f"as given {a:.2f}  with 11<->17 swapped {b:.2f}  worst ids as given", [int(ids[k]) for k in np.argsort(per)[-2:]], "max resid swapped %.2f" % per2.max())
