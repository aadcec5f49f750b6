"""What logging a run to Rerun *as it goes* costs, and by which mechanism
(issue 18). Not part of ``make test``; run it by hand (release build)::

    nice -n 10 .venv/bin/python benches/rerun_live.py [--mrclam DIR] [--repeat N]

On paper_fig4 (seed 3, 21 s) and on MRCLAM Dataset 6 robot 3 (its whole
25 minutes, the log ``evaluate_mrclam`` gives the filter), the best of N
wall times of:

* ``run``: ``bs.run(log, config)``, the filter alone (Rust, GIL released);
* ``run + on_scan no-op``: the runner's per-scan callback into Python
  (``bs.run(..., on_scan=...)``), doing nothing: the mechanism's own cost;
* ``Python loop over SlamFilter``: the other mechanism, the runner's loop
  written in Python over the step API (odometry, velocity commands held
  between events, dead reckoning, the track at every ground-truth time),
  logging nothing; whether its final estimate equals ``bs.run``'s is printed;
* ``live .rrd``: ``run_with_rerun`` to a file (the callback logging every
  scan); ``run + log_rerun``: the old way, the recording made after the run.
"""

from __future__ import annotations

import argparse
import math
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

import bearing_slam as bs
from bearing_slam import models

ROOT = Path(__file__).resolve().parents[1]


def best_of(repeat: int, fn: Callable[[], object]) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def python_loop(log: bs.SensorLog, config: bs.Config) -> NDArray[np.float64]:
    """The runner's loop (crates/bearing-slam-core/src/runner.rs) in Python
    over ``bs.SlamFilter``; returns the estimate at every track time."""
    start = log.info.get("initial_pose")
    if start is not None:
        config = config.replace(initial_pose=(start["x"], start["y"], start["theta"]))
    f = bs.SlamFilter(config)
    dr = np.array(config.initial_pose, dtype=np.float64)
    wheels = config.odometry == "wheels"
    # (time, rank at equal time: wheels, truth, bearings, velocity, kind, payload)
    events: list[tuple[float, int, int, Any]] = []
    for row in log.wheels:
        events.append((row[0], 0, 0, row))
    for row in log.truth:
        events.append((row[0], 1, 1, row))
    b = log.bearings
    if len(b):
        times, starts = np.unique(b[:, 0], return_index=True)
        bounds = [*starts.tolist(), len(b)]
        for k, t in enumerate(times):
            events.append((float(t), 2, 2, b[bounds[k] : bounds[k + 1]]))
    for row in log.velocity:
        events.append((row[0], 3, 3, row))
    events.sort(key=lambda e: (e[0], e[1]))
    has_truth = len(log.truth) > 0
    command: tuple[NDArray[np.float64], float, float] | None = None
    track: list[NDArray[np.float64]] = []
    started = False
    alpha = config.velocity_alpha
    for t, _, kind, payload in events:
        if not wheels and command is not None:
            cmd, start, applied = command
            until = min(t, start + cmd[3])
            dt = until - applied
            if dt > 1e-9:
                f.predict_velocity(until, cmd[1], cmd[2], dt)
                dr = models.velocity(
                    dr,
                    cmd[1],
                    cmd[2],
                    dt,
                    alpha,
                    config.velocity_sigma_v_min,
                    config.velocity_sigma_omega_min,
                )[0]
                command = (cmd, start, until)
        if kind == 0:
            started = True
            if wheels:
                f.predict_wheels(t, payload[1], payload[2])
                dr = models.diff_drive(
                    dr,
                    payload[1],
                    payload[2],
                    config.wheel_base,
                    config.wheel_floor_sigma,
                    config.wheel_scale_sqrt,
                )[0]
        elif kind == 3:
            started = True
            command = (payload, t, t)
        elif kind == 2:
            started = True
            f.update_bearings(t, payload[:, 1].astype(np.uint64), payload[:, 2])
            if not has_truth:
                track.append(f.pose)
        elif started or t <= 0.0:
            track.append(f.pose)
            _ = f.pose_covariance, dr
    return np.array(track)


def measure(name: str, log: bs.SensorLog, config: bs.Config, repeat: int) -> None:
    plain = bs.run(log, config)
    scans = len(plain.trace)
    print(f"\n{name}: {log.duration:.0f} s of log, {scans} scans, {len(plain.time)} track points")
    t_run = best_of(repeat, lambda: bs.run(log, config))
    calls = 0

    def noop(step: dict[str, Any]) -> None:
        nonlocal calls
        calls += 1

    t_noop = best_of(repeat, lambda: bs.run(log, config, on_scan=noop))
    same = bs.run(log, config, on_scan=noop)
    assert np.array_equal(same.estimate, plain.estimate)
    t_loop = best_of(repeat, lambda: python_loop(log, config))
    loop_est = python_loop(log, config)
    exact = loop_est.shape == plain.estimate.shape and np.array_equal(loop_est, plain.estimate)
    err = (
        float(np.abs(loop_est - plain.estimate).max())
        if loop_est.shape == plain.estimate.shape
        else math.nan
    )
    with tempfile.TemporaryDirectory() as tmp:
        rrd = Path(tmp) / "live.rrd"
        t_live = best_of(
            repeat, lambda: bs.run_with_rerun(log, config, path=rrd, recording_name="bench")
        )
        size_live = rrd.stat().st_size
        rrd2 = Path(tmp) / "after.rrd"

        def after() -> None:
            bs.log_rerun(bs.run(log, config), log, path=rrd2)

        t_after = best_of(repeat, after)
        t_live5 = best_of(
            repeat,
            lambda: bs.run_with_rerun(log, config, path=rrd, snapshot_every=5.0),
        )
    ms = 1e3
    print(f"  run                              {t_run * ms:9.1f} ms")
    print(
        f"  run + on_scan no-op              {t_noop * ms:9.1f} ms"
        f"  (+{(t_noop - t_run) * ms:.1f} ms, {(t_noop - t_run) / scans * 1e6:.1f} µs/scan)"
    )
    print(
        f"  Python loop over SlamFilter      {t_loop * ms:9.1f} ms"
        f"  (+{(t_loop - t_run) * ms:.1f} ms; final estimate "
        f"{'bit-identical' if exact else f'differs by up to {err:.3g}'})"
    )
    print(
        f"  live .rrd (run_with_rerun)       {t_live * ms:9.1f} ms"
        f"  ({(t_live - t_run) / scans * 1e6:.0f} µs/scan, {size_live / 1e6:.1f} MB)"
    )
    print(f"  live .rrd, --snapshot-every 5    {t_live5 * ms:9.1f} ms")
    print(f"  run + log_rerun (after the run)  {t_after * ms:9.1f} ms")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument(
        "--mrclam",
        type=Path,
        default=Path(__file__).resolve().parents[2] / "shared/datasets/mrclam/MRCLAM_Dataset6",
        help="MRCLAM Dataset 6 (default: ../shared beside the checkout)",
    )
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    log = bs.simulate("paper_fig4", seed=3)
    measure("paper_fig4 seed 3", log, bs.Config.for_log(log, init="mte"), args.repeat)
    result, _, flog = bs.evaluate_mrclam(args.mrclam, 3, "mte")
    measure("MRCLAM Dataset 6 robot 3 (whole run)", flog, result.config, args.repeat)


if __name__ == "__main__":
    main()
