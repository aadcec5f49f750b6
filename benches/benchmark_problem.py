"""THE benchmark problem of the EKF step, defined here and generated once, in numpy.

Every implementation timed by ``compare_peers.py`` (the numpy peers, filterpy,
GTSAM and ours through ``bearing_slam.EkfBenchmark``) gets its initial state,
controls and measurements from here.

* State ``[x, y, θ, l1x, l1y, …, lnx, lny]``, ``N = 3 + 2n``.
* ``rng = default_rng([7, n])``: landmarks ``uniform(-20, 20, (n, 2))``, then
  ``A = standard_normal((N, N))``, ``P0 = A Aᵀ / N + 1e-3 I``, symmetrised.
  Robot at the origin, heading 0; landmark means = true positions.
* Observed every step: ids ``(arange(10) * n) // 10``.
* Unicycle (Euler), ``u = (1 m/s, 0.1 rad/s)``, ``dt = 0.1 s``; noise std on
  ``(v, ω)`` of (0.1 m/s, 5°/s), mapped by ``V = ∂(motion)/∂(v, ω)``.
* Bearings ``atan2(ly − y, lx − x) − θ`` with std 1°, wrapped to (−π, π].
* Measurements: the noise-free trajectory plus noise from ``default_rng([7, n, 1])``;
  step k (1-based) uses ``z[k − 1]``, taken at the true pose after k steps.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

F64 = NDArray[np.float64]

M = 10
V = 1.0
W = 0.1
DT = 0.1
SIGMA_V = 0.1
SIGMA_W = float(np.deg2rad(5.0))
SIGMA_BEARING = float(np.deg2rad(1.0))


@dataclass(frozen=True)
class Problem:
    """The benchmark problem at one map size ``n``."""

    n: int
    landmarks: F64  # (n, 2)
    x0: F64  # (N,)
    P0: F64  # (N, N)
    ids: NDArray[np.int64]  # (M,)
    u: tuple[float, float] = (V, W)
    dt: float = DT
    sigma_v: float = SIGMA_V
    sigma_w: float = SIGMA_W
    sigma_bearing: float = SIGMA_BEARING

    @property
    def dim(self) -> int:
        return 3 + 2 * self.n

    @property
    def offsets(self) -> NDArray[np.int64]:
        """State index of each observed landmark's x."""
        return 3 + 2 * self.ids


def wrap(a: F64 | float) -> F64:
    """Angles wrapped to (−π, π]."""
    w = np.asarray(np.mod(np.asarray(a) + np.pi, 2.0 * np.pi) - np.pi)
    return np.where(w == -np.pi, np.pi, w)


def make_problem(n: int) -> Problem:
    """The problem at ``n`` landmarks (BENCHMARK.md)."""
    dim = 3 + 2 * n
    rng = np.random.default_rng([7, n])
    landmarks = rng.uniform(-20.0, 20.0, (n, 2))
    a = rng.standard_normal((dim, dim))
    p0 = a @ a.T / dim + 1e-3 * np.eye(dim)
    p0 = 0.5 * (p0 + p0.T)
    x0 = np.zeros(dim)
    x0[3:] = landmarks.ravel()
    ids = (np.arange(M) * n) // M
    return Problem(n=n, landmarks=landmarks, x0=x0, P0=p0, ids=ids.astype(np.int64))


def unicycle(pose: F64, u: tuple[float, float], dt: float) -> F64:
    """One Euler step of the unicycle."""
    v, w = u
    x, y, th = pose
    return np.array([x + v * dt * np.cos(th), y + v * dt * np.sin(th), th + w * dt])


def true_poses(prob: Problem, k: int) -> F64:
    """True poses after steps 1..k from the origin, noise-free controls (k, 3)."""
    poses = np.empty((k, 3))
    pose = np.zeros(3)
    for i in range(k):
        pose = unicycle(pose, prob.u, prob.dt)
        poses[i] = pose
    return poses


def bearings(prob: Problem, poses: F64, ids: NDArray[np.int64], noise: F64) -> F64:
    """Bearings from each pose (k, 3) to landmarks ``ids`` (k, M) plus ``noise`` (k, M)."""
    lm = prob.landmarks[ids]  # (k, M, 2) or (M, 2)
    dx = lm[..., 0] - poses[:, 0:1]
    dy = lm[..., 1] - poses[:, 1:2]
    return wrap(np.arctan2(dy, dx) - poses[:, 2:3] + noise)


def measurement_noise(prob: Problem, k: int) -> F64:
    """The bearing noise of steps 1..k, from ``default_rng([7, n, 1])`` (k, M)."""
    rng = np.random.default_rng([7, prob.n, 1])
    return prob.sigma_bearing * rng.standard_normal((k, M))


def make_stream(prob: Problem, k: int) -> tuple[F64, F64]:
    """``(poses, z)``: true poses after steps 1..k (k, 3), bearings to ``prob.ids`` (k, M)."""
    poses = true_poses(prob, k)
    return poses, bearings(prob, poses, prob.ids, measurement_noise(prob, k))


def round_robin_stream(prob: Problem, k: int) -> tuple[NDArray[np.int64], F64]:
    """GTSAM 'round-robin': step j (1-based) observes ``(10 (j − 1) + i) mod n``;
    returns ``(ids (k, M), z (k, M))`` with the same noise as ``make_stream``."""
    poses = true_poses(prob, k)
    ids = (M * np.arange(k)[:, None] + np.arange(M)[None, :]) % prob.n
    return ids, bearings(prob, poses, ids, measurement_noise(prob, k))


def controls(prob: Problem, k: int) -> F64:
    """The (noise-free) controls of k steps (k, 2)."""
    return np.tile(np.asarray(prob.u, dtype=float), (k, 1))
