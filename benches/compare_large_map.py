# Matrix names (P, H, S) follow the Kalman-filter notation.
# ruff: noqa: N806
"""Large maps: the compressed EKF against the full EKF and the peers, one run.

The benchmark problem of ``benchmark_problem.py`` (BENCHMARK.md) extended to a
large map (issue 19): n landmarks uniform in [−20, 20]²; a dense SPD
``P0 = B Bᵀ / 32 + 1e-3 I`` with ``B`` (N×32) standard normal from
``default_rng([7, n, 2])`` (BENCHMARK.md's ``A Aᵀ / N`` costs O(N³), 10¹² flops
at n = 5,000); the BENCHMARK.md unicycle and bearing noise; each step 10
bearings to the landmarks of the current region, ids ``(10 r + i) mod n``,
the region ``r = k // R`` changing every ``R = 100`` steps (noise from
``default_rng([7, n, 3])``).

Timed, mean time per step (single-threaded BLAS):

* ours compressed (``EkfBenchmark(update="compressed", symmetric=True)``,
  stepped from Python): six whole region cycles (6R steps) after one untimed
  cycle: at the default cap of 64 active states a local phase spans three
  regions, so the timed steps hold two global updates, the amortized rate;
* ours full Symmetric and Joseph, numpy block-aware + in-place dgemm: a few
  steady-state steps (a full EKF step costs the same in any region);
* GTSAM iSAM2 (if installed, the ``bench`` extra): priors on the pose and all
  n landmarks at step 0, then per step a Pose2, a ``BetweenFactorPose2`` and
  10 ``BearingFactor2D``; ``isam.update()`` timed over the second cycle.

Memory: the growth of the resident set while each method's state is alive
(glibc's mmap threshold fixed so freed matrices leave the resident set).

``.venv/bin/python benches/compare_large_map.py`` (``--sizes 200,1000``,
``--full-steps 5``). Writes ``benches/LARGE_MAP.md`` and
``benches/large_map.png``.
"""

from __future__ import annotations

import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import contextlib  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from collections.abc import Callable  # noqa: E402
from functools import partial  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bearing_slam  # noqa: E402
import benchmark_problem as bp  # noqa: E402
from compare_peers import bearing_jacobians, cpu_model, load, motion  # noqa: E402

HERE = Path(__file__).resolve().parent
SIZES = [200, 500, 1000, 2000, 5000]
R = 100
RANK = 32
# Region cycles timed for the compressed EKF: two whole local phases.
COMPRESSED_CYCLES = 6


def make_large(n: int) -> bp.Problem:
    """The large-map problem at ``n`` landmarks (see the module docstring)."""
    dim = 3 + 2 * n
    rng = np.random.default_rng([7, n, 2])
    landmarks = rng.uniform(-20.0, 20.0, (n, 2))
    b = rng.standard_normal((dim, RANK))
    p0 = b @ b.T / RANK
    p0[np.diag_indices(dim)] += 1e-3
    x0 = np.zeros(dim)
    x0[3:] = landmarks.ravel()
    return bp.Problem(n=n, landmarks=landmarks, x0=x0, P0=p0, ids=region_ids(n, 0))


def region_ids(n: int, k: int) -> np.ndarray:
    """The landmarks observed at step k (0-based)."""
    return ((bp.M * (k // R) + np.arange(bp.M)) % n).astype(np.int64)


def stream(prob: bp.Problem, k: int) -> tuple[np.ndarray, np.ndarray]:
    """``(ids (k, M), z (k, M))`` of steps 0..k−1."""
    poses = bp.true_poses(prob, k)
    ids = np.stack([region_ids(prob.n, j) for j in range(k)])
    noise = prob.sigma_bearing * np.random.default_rng([7, prob.n, 3]).standard_normal((k, bp.M))
    return ids, bp.bearings(prob, poses, ids, noise)


class NumpyBlockDgemm:
    """Block-aware numpy with the in-place dgemm (compare_peers' peer 3),
    with the observed landmarks changing by region."""

    def __init__(self, prob: bp.Problem) -> None:
        from scipy.linalg.blas import dgemm

        self.prob, self.dgemm = prob, dgemm
        self.x = prob.x0.copy()
        self.P = prob.P0.copy()
        self.m = np.diag([prob.sigma_v**2, prob.sigma_w**2])
        self.R = prob.sigma_bearing**2 * np.eye(bp.M)
        self.lcols = 3 + 2 * np.arange(bp.M)
        self.rows = np.arange(bp.M)

    def step(self, ids: np.ndarray, z: np.ndarray) -> None:
        p, P = self.prob, self.P
        offsets = 3 + 2 * ids
        idx = np.concatenate([np.arange(3), np.stack([offsets, offsets + 1], 1).ravel()])
        pose, f, vj = motion(self.x, p.u, p.dt)
        self.x[:3] = pose
        P[:3, :] = f @ P[:3, :]
        P[:, :3] = P[:, :3] @ f.T
        P[:3, :3] += vj @ self.m @ vj.T
        h, jv, jl = bearing_jacobians(self.x, offsets)
        Hb = np.zeros((bp.M, 3 + 2 * bp.M))
        Hb[:, :3] = jv
        Hb[self.rows, self.lcols] = jl[:, 0]
        Hb[self.rows, self.lcols + 1] = jl[:, 1]
        PHt = P[:, idx] @ Hb.T
        S = Hb @ PHt[idx] + self.R
        Wt = np.linalg.solve(S, PHt.T)
        self.x += Wt.T @ bp.wrap(z - h)
        self.dgemm(-1.0, PHt, Wt, beta=1.0, c=P.T, overwrite_c=1)


def numpy_step(prob: bp.Problem) -> Callable[[np.ndarray, np.ndarray], None]:
    """The step function of a new :class:`NumpyBlockDgemm`."""
    return NumpyBlockDgemm(prob).step


def ours(
    prob: bp.Problem, symmetric: bool, update: str
) -> Callable[[np.ndarray, np.ndarray], None]:
    """A step function of ``bearing_slam.EkfBenchmark``."""
    ekf = bearing_slam.EkfBenchmark(
        prob.x0,
        prob.P0,
        prob.ids,
        prob.sigma_v,
        prob.sigma_w,
        prob.dt,
        prob.sigma_bearing,
        symmetric=symmetric,
        update=update,
    )
    last = [prob.ids]

    def step(ids: np.ndarray, z: np.ndarray) -> None:
        if ids[0] != last[0][0]:
            ekf.observe(ids)
            last[0] = ids
        ekf.step(prob.u, z)

    return step


def time_steps(
    step: Callable[[np.ndarray, np.ndarray], None],
    ids: np.ndarray,
    z: np.ndarray,
    skip: int,
    timed: int,
) -> float:
    """Mean seconds per step of steps ``skip .. skip + timed`` (the first untimed)."""
    for k in range(skip):
        step(ids[k], z[k])
    t0 = time.perf_counter()
    for k in range(skip, skip + timed):
        step(ids[k], z[k])
    return (time.perf_counter() - t0) / timed


def gtsam_mean(prob: bp.Problem, ids: np.ndarray, z: np.ndarray, held: list[int]) -> float | None:
    """Mean ``isam.update()`` time over steps R+1 .. 2R, or None without GTSAM;
    appends the resident set at the end (iSAM2 still alive) to ``held``."""
    try:
        import gtsam
        from gtsam.symbol_shorthand import L, X
    except ImportError:
        return None
    isam = gtsam.ISAM2(gtsam.ISAM2Params())
    graph = gtsam.NonlinearFactorGraph()
    values = gtsam.Values()
    sd = np.sqrt(np.diag(prob.P0))
    origin = gtsam.Pose2(0.0, 0.0, 0.0)
    graph.add(gtsam.PriorFactorPose2(X(0), origin, gtsam.noiseModel.Diagonal.Sigmas(sd[:3])))
    values.insert(X(0), origin)
    for j in range(prob.n):
        sigmas = gtsam.noiseModel.Diagonal.Sigmas(sd[3 + 2 * j : 5 + 2 * j])
        graph.add(gtsam.PriorFactorPoint2(L(j), prob.landmarks[j], sigmas))
        values.insert(L(j), prob.landmarks[j])
    isam.update(graph, values)
    v, w = prob.u
    odom = gtsam.Pose2(v * prob.dt, 0.0, w * prob.dt)
    odom_noise = gtsam.noiseModel.Diagonal.Sigmas(
        np.array([prob.sigma_v * prob.dt, 0.01, prob.sigma_w * prob.dt])
    )
    bearing_noise = gtsam.noiseModel.Isotropic.Sigma(1, prob.sigma_bearing)
    estimate, total = origin, 0.0
    for k in range(1, 2 * R + 1):
        graph = gtsam.NonlinearFactorGraph()
        values = gtsam.Values()
        values.insert(X(k), estimate.compose(odom))
        graph.add(gtsam.BetweenFactorPose2(X(k - 1), X(k), odom, odom_noise))
        for i in range(bp.M):
            rot = gtsam.Rot2(float(z[k - 1, i]))
            graph.add(gtsam.BearingFactor2D(X(k), L(int(ids[k - 1, i])), rot, bearing_noise))
        t0 = time.perf_counter()
        isam.update(graph, values)
        if k > R:
            total += time.perf_counter() - t0
        estimate = isam.calculateEstimatePose2(X(k))
    held.append(rss())
    return total / R


def _fixed_mmap_threshold() -> None:
    """Makes glibc serve every block of 128 KiB or more by ``mmap`` and
    give it back on free (no dynamic threshold), so that the resident set
    follows what the live objects hold, numpy's and the Rust extension's
    alike (both allocate through glibc's malloc)."""
    import ctypes

    with contextlib.suppress(OSError, AttributeError):
        ctypes.CDLL("libc.so.6").mallopt(-3, 128 * 1024)  # M_MMAP_THRESHOLD


def rss() -> int:
    """Resident set size of this process, bytes (Linux ``/proc``)."""
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


def measured(
    make: Callable[[], Callable[[np.ndarray, np.ndarray], None]],
    ids: np.ndarray,
    z: np.ndarray,
    skip: int,
    timed: int,
) -> tuple[float, int]:
    """``time_steps`` of the step function ``make`` builds, and the growth of
    the resident set from before ``make`` to the end of the timed steps (the
    method's state: its covariance and workspace), bytes."""
    before = rss()
    step = make()
    t = time_steps(step, ids, z, skip, timed)
    held = rss() - before
    del step
    return t, held


def fmt(t: float | None) -> str:
    if t is None:
        return "—"
    return f"{t * 1e3:.2f} ms" if t >= 1e-3 else f"{t * 1e6:.1f} µs"


def slope(ns: list[int], ts: list[float]) -> float:
    return float(np.polyfit(np.log(ns), np.log(ts), 1)[0])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default=",".join(map(str, SIZES)))
    ap.add_argument("--full-steps", type=int, default=10, help="timed steps of a full EKF")
    args = ap.parse_args()
    sizes = [int(s) for s in args.sizes.split(",")]
    names = [
        "ours compressed",
        "ours full Symmetric",
        "ours full Joseph",
        "numpy block+dgemm",
        "GTSAM iSAM2",
    ]
    results: dict[str, list[float | None]] = {name: [] for name in names}
    memory: dict[str, list[int | None]] = {name: [] for name in names}
    gtsam_rss: list[int] = []
    _fixed_mmap_threshold()
    for n in sizes:
        prob = make_large(n)
        ids, z = stream(prob, (1 + COMPRESSED_CYCLES) * R)
        full = min(args.full_steps, 3 if n >= 5000 else args.full_steps)
        makers = {
            "ours compressed": (partial(ours, prob, True, "compressed"), R, COMPRESSED_CYCLES * R),
            "ours full Symmetric": (partial(ours, prob, True, "full"), 2, full),
            "ours full Joseph": (partial(ours, prob, False, "full"), 2, full),
            "numpy block+dgemm": (partial(numpy_step, prob), 2, full),
        }
        res: dict[str, float | None] = {}
        for name, (make, skip, timed) in makers.items():
            res[name], grown = measured(make, ids, z, skip, timed)
            memory[name].append(grown)
        before = rss()
        res["GTSAM iSAM2"] = gtsam_mean(prob, ids, z, gtsam_rss)
        memory["GTSAM iSAM2"].append(gtsam_rss[0] - before if gtsam_rss else None)
        gtsam_rss.clear()
        del makers
        for name in names:
            results[name].append(res[name])
        print(f"n = {n}: " + ", ".join(f"{k} {fmt(v)}" for k, v in res.items()), flush=True)
        del prob
    report(sizes, results, memory, args.full_steps)
    plot(sizes, results)


def report(
    sizes: list[int],
    results: dict[str, list[float | None]],
    memory: dict[str, list[int | None]],
    full_steps: int,
) -> None:
    head = "| method | " + " | ".join(f"n = {n}" for n in sizes) + " |"
    rule = "|---|" + "---|" * len(sizes)
    lines = [
        "# Large maps: compressed EKF vs full EKF and peers",
        "",
        "Generated by `benches/compare_large_map.py`; do not edit by hand.",
        "",
        f"* Machine: **{cpu_model()}**; load average at the end: {load()}. BLAS single-threaded.",
        f"* Problem: the module docstring (10 bearings per step, region change every R = {R}).",
        f"* Compressed: mean over {COMPRESSED_CYCLES} whole cycles ({COMPRESSED_CYCLES}R steps, "
        "two local phases of three regions); full EKFs and numpy: "
        f"{full_steps} steady-state steps (3 at n = 5,000); GTSAM: `isam.update()`, steps R+1..2R.",
        "",
        "Mean time per step:",
        "",
        head,
        rule,
    ]
    for name, ts in results.items():
        lines.append(f"| {name} | " + " | ".join(fmt(t) for t in ts) + " |")
    lines += ["", "Ratios, method / ours compressed (> 1: compressed is faster):", "", head, rule]
    comp = results["ours compressed"]
    for name, ts in results.items():
        if name == "ours compressed":
            continue
        cells = [
            "—" if t is None or c is None else f"{t / c:.1f}×"
            for t, c in zip(ts, comp, strict=True)
        ]
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    lines += [
        "",
        "Memory: growth of the resident set while the method's state is alive (its "
        "covariance, auxiliaries and workspace; the problem's own P0 is not counted), MB:",
        "",
        head,
        rule,
    ]
    for name, ms in memory.items():
        cells = ["—" if m is None else f"{m / 1e6:.1f}" for m in ms]
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    big = [(n, t) for n, t in zip(sizes, comp, strict=True) if n >= 500 and t is not None]
    if len(big) >= 2:
        s = slope([n for n, _ in big], [t for _, t in big])
        lines += [
            "",
            f"Log-log slope of the compressed step in n, n = 500 … {big[-1][0]}: **{s:.2f}**",
        ]
    lines.append("")
    (HERE / "LARGE_MAP.md").write_text("\n".join(lines))
    print("\n".join(lines))


def plot(sizes: list[int], results: dict[str, list[float | None]]) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4.5))
    for name, ts in results.items():
        pts = [(n, t) for n, t in zip(sizes, ts, strict=True) if t is not None]
        if pts:
            style = "-o" if name.startswith("ours") else "--s"
            ax.loglog([n for n, _ in pts], [t * 1e3 for _, t in pts], style, label=name)
    ax.set_xlabel("landmarks n")
    ax.set_ylabel("mean time per step (ms)")
    ax.set_title(f"Large map, 10 bearings per step, region change every {R} steps")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(HERE / "large_map.png", dpi=120)


if __name__ == "__main__":
    main()
