"""The 6-hour soak through the command line (issue 20), run by ``make soak``.

``bearing-slam simulate single_source_oval --duration HOURS·3600`` writes a
log, ``bearing-slam run`` runs the filter on it, and this script then checks
every output the run wrote: ``metrics.json`` finite and not diverged, the
three PNGs decodable images, ``estimate.mcap`` read back without warnings
with its log equal to the simulated one and its trace reaching the end of
the run. It prints the wall time and peak resident memory of each command.

Usage: ``python benches/soak_cli.py [HOURS] [--keep DIR]``.
"""

from __future__ import annotations

import argparse
import json
import math
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from matplotlib.image import imread

import bearing_slam as bs

SCENARIO = "single_source_oval"


def _cli(*args: str) -> tuple[float, float]:
    """Runs ``bearing-slam ARGS`` (this interpreter's package) and returns
    its wall time in seconds and the peak resident memory of the children
    so far in MiB; a failing command ends the soak."""
    start = time.monotonic()
    done = subprocess.run([sys.executable, "-m", "bearing_slam", *args], check=False)
    wall = time.monotonic() - start
    if done.returncode != 0:
        raise SystemExit(f"soak: `bearing-slam {' '.join(args)}` exited {done.returncode}")
    peak_mib = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024.0
    return wall, peak_mib


def _check_metrics(path: Path) -> dict[str, float]:
    """The run's summary: present, finite where it must be, not diverged."""
    record = json.loads(path.read_text())
    wanted = ("ate_rmse_m", "final_position_error_m", "mean_nees_pose", "landmark_rmse_m")
    numbers = {key: record.get(key) for key in wanted}
    for key, value in numbers.items():
        if not isinstance(value, (int, float)) or not math.isfinite(value):
            raise SystemExit(f"soak: metrics.json {key} = {value!r}, not a finite number")
    if record.get("finite") is not True or record.get("diverged") is not False:
        raise SystemExit(
            f"soak: metrics.json says finite = {record.get('finite')!r}, "
            f"diverged = {record.get('diverged')!r} (at {record.get('diverged_at_s')!r} s)"
        )
    return {key: float(value) for key, value in numbers.items() if value is not None}


def _check_png(path: Path) -> tuple[int, int]:
    """A complete PNG: it decodes, and is not a blank canvas."""
    pixels = imread(path)
    colours = np.unique(pixels.reshape(-1, pixels.shape[-1]), axis=0)
    if len(colours) < 3:
        raise SystemExit(f"soak: {path.name} has {len(colours)} colours: a blank plot")
    return int(pixels.shape[1]), int(pixels.shape[0])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("hours", nargs="?", type=float, default=6.0, help="simulated hours")
    parser.add_argument("--keep", type=Path, help="keep the files in this folder")
    args = parser.parse_args()
    work = args.keep or Path(tempfile.mkdtemp(prefix="bearing-slam-soak-cli-"))
    work.mkdir(parents=True, exist_ok=True)
    log_path, out = work / "log.mcap", work / "run"
    seconds = args.hours * 3600.0
    try:
        t_sim, rss_sim = _cli(
            "simulate", SCENARIO, "--duration", f"{seconds}", "--out", str(log_path)
        )
        t_run, rss_run = _cli("run", str(log_path), "--out", str(out), "--quiet")

        metrics = _check_metrics(out / "metrics.json")
        plots = ("trajectory.png", "pose_errors.png", "nees.png")
        sizes = {name: _check_png(out / name) for name in plots}
        simulated, _, log_warnings = bs.read_mcap(log_path)
        estimate_log, trace, warnings = bs.read_mcap(out / "estimate.mcap")
        if log_warnings or warnings:
            raise SystemExit(f"soak: MCAP warnings {log_warnings + warnings}")
        if estimate_log != simulated:
            raise SystemExit("soak: the log inside estimate.mcap differs from the simulated one")
        if trace is None or len(trace) == 0:
            raise SystemExit("soak: estimate.mcap holds no estimate")
        last = float(trace.times[-1])
        if simulated.duration < 0.99 * seconds or last < simulated.duration - 1.0:
            raise SystemExit(
                f"soak: the log covers {simulated.duration:.0f} s and the estimate ends at "
                f"{last:.0f} s, of {seconds:.0f} s asked"
            )
    finally:
        if args.keep is None:
            shutil.rmtree(work, ignore_errors=True)
    print(
        f"soak cli: {simulated.duration / 3600:.2f} h of {SCENARIO} ({len(simulated)} events); "
        f"simulate {t_sim:.0f} s, run {t_run:.0f} s; peak RSS {max(rss_sim, rss_run):.0f} MiB; "
        f"estimate ends at {last:.1f} s with {len(trace)} poses; plots "
        + ", ".join(f"{name} {w}×{h}" for name, (w, h) in sizes.items())
        + "; "
        + ", ".join(f"{key} {value:.3f}" for key, value in metrics.items())
    )


if __name__ == "__main__":
    main()
