"""A census of bad inputs through the Python API and the CLI (issue 20).

Tries each case for real and prints a markdown table of what it returns: the
exception class and the first line of its message, or what was accepted. The
table in docs/reliability.md ("Python API and CLI") is this script's output:

    .venv/bin/python tests/python/census.py > /tmp/census.md

Every case must end in a library error (``BearingSlamError`` or a built-in
``ValueError``/``TypeError``/``KeyError`` with a message naming the problem)
or an honest result; the last line counts what was not (a crash, a
traceback from the wrong layer such as ``OverflowError`` or pyo3's
``RuntimeError``, or a silent acceptance of a bad value), and the exit status
is 1 when any.
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

import bearing_slam as bs
import bearing_slam._native

ROOT = Path(__file__).resolve().parents[2]
DATA = Path(os.environ.get("BEARING_SLAM_DATA") or ROOT.parent / "shared" / "datasets" / "mrclam")

#: Exceptions that are a clear refusal (the message is shown in the table).
CLEAR: tuple[type[BaseException], ...] = (bs.BearingSlamError, ValueError, TypeError, KeyError)

Row = tuple[str, str, str, str, bool]


def _first_line(text: str, limit: int = 110) -> str:
    line = text.strip().splitlines()[0] if text.strip() else ""
    line = line.replace("|", "\\|")
    return line if len(line) <= limit else line[: limit - 1] + "…"


def attempt(fn: Callable[[], object], bad: bool = True) -> tuple[str, bool]:
    """(what happened, whether that is acceptable). ``bad``: the input is
    invalid, so acceptance is only fine when the result says so itself."""
    t0 = time.perf_counter()
    try:
        out = fn()
    except CLEAR as e:
        # pyo3's own errors are RuntimeError / OverflowError: not in CLEAR.
        return f"`{type(e).__name__}`: {_first_line(str(e))}", True
    except BaseException as e:
        return f"**`{type(e).__name__}`**: {_first_line(str(e))}", False
    seconds = time.perf_counter() - t0
    text = f"accepted: {_first_line(repr(out), 80)}" if out is not None else "accepted"
    if seconds > 5:
        text += f" ({seconds:.0f} s)"
    return text, not bad


def _accepted_ok(fn: Callable[[], object]) -> tuple[str, bool]:
    return attempt(fn, bad=False)


def cli(*args: str | Path) -> tuple[str, bool]:
    r = subprocess.run(
        [sys.executable, "-m", "bearing_slam", *map(str, args)],
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )
    lines = [line for line in r.stderr.splitlines() if line.strip()]
    last = _first_line(lines[-1]) if lines else ""
    ok = r.returncode == 2 and "Traceback" not in r.stderr
    return f"exit {r.returncode}: {last}", ok


def api_cases(
    tmp: Path, log: bs.SensorLog
) -> list[tuple[str, str, Callable[[], tuple[str, bool]]]]:
    nan, inf = math.nan, math.inf
    f = bs.SlamFilter(bs.Config(initial_pose_sigma=(0.01, 0.01, 0.01)))
    f.predict_wheels(0.1, 0.01, 0.01)

    def fresh() -> bs.SlamFilter:
        g = f.copy()
        return g

    empty = tmp / "empty.mcap"
    empty.write_bytes(b"")
    text = tmp / "text.mcap"
    text.write_text("time,x,y\n0,1,2\n")
    png = tmp / "plot.png"
    png.write_bytes(b"\x89PNG\r\n\x1a\n" + bytes(200))
    huge = tmp / "huge.mcap"
    with open(huge, "wb") as fh:
        fh.truncate(8 * 2**30)  # sparse: 8 GiB of zeros, no disk used
    mcap_ok = tmp / "ok.mcap"
    bs.write_mcap(mcap_ok, log)
    cut = tmp / "cut.mcap"
    cut.write_bytes(mcap_ok.read_bytes()[: mcap_ok.stat().st_size // 2])
    flipped = tmp / "flipped.mcap"
    raw = bytearray(mcap_ok.read_bytes())
    raw[len(raw) // 3] ^= 0x40
    flipped.write_bytes(bytes(raw))
    not_a_dataset = tmp / "not_mrclam"
    not_a_dataset.mkdir()
    (not_a_dataset / "Robot1_Odometry.dat").write_text("# no data\n")
    foreign_dataset = tmp / "foreign_mrclam"
    foreign_dataset.mkdir()
    for name in (
        "Barcodes.dat",
        "Landmark_Groundtruth.dat",
        "Robot1_Groundtruth.dat",
        "Robot1_Odometry.dat",
        "Robot1_Measurement.dat",
    ):
        (foreign_dataset / name).write_bytes(mcap_ok.read_bytes()[:4000])
    d6 = DATA / "MRCLAM_Dataset6"

    def arrays(**kw: Any) -> Callable[[], object]:
        return lambda: bs.SensorLog.from_arrays(**kw)

    cases: list[tuple[str, str, Callable[[], tuple[str, bool]]]] = [
        # NaN / Inf
        (
            "NaN/Inf",
            "`predict_wheels(t, nan, 0)`",
            lambda: attempt(lambda: fresh().predict_wheels(0.2, nan, 0.0)),
        ),
        (
            "NaN/Inf",
            "`predict_velocity(t, inf, 0, 0.1)`",
            lambda: attempt(lambda: fresh().predict_velocity(0.2, inf, 0.0, 0.1)),
        ),
        (
            "NaN/Inf",
            "`update_bearings(t, [1], [nan])`",
            lambda: attempt(lambda: fresh().update_bearings(0.2, [1], [nan])),
        ),
        (
            "NaN/Inf",
            "`update_bearings(nan, [1], [0.1])`",
            lambda: attempt(lambda: fresh().update_bearings(nan, [1], [0.1])),
        ),
        (
            "NaN/Inf",
            "`update_range_bearings(t, [1], [inf], [0.1])`",
            lambda: attempt(lambda: fresh().update_range_bearings(0.2, [1], [inf], [0.1])),
        ),
        (
            "NaN/Inf",
            "`from_arrays(wheels=[[0, nan, 0]])`",
            lambda: attempt(arrays(wheels=[[0.0, nan, 0.0]])),
        ),
        (
            "NaN/Inf",
            "`from_arrays(truth=[[0, inf, 0, 0]])`",
            lambda: attempt(arrays(truth=[[0.0, inf, 0.0, 0.0]])),
        ),
        (
            "NaN/Inf",
            "`from_arrays(bearings=[[0, 1, 1e300]])`",
            lambda: attempt(arrays(bearings=[[0.0, 1, 1e300]])),
        ),
        (
            "NaN/Inf",
            "`from_arrays(info={'wheel_base_m': nan})`",
            lambda: attempt(arrays(info={"wheel_base_m": nan})),
        ),
        (
            "NaN/Inf",
            "`from_arrays(wheels=..., landmarks=[[1, nan, 0]])`",
            lambda: attempt(arrays(wheels=[[0.0, 0.0, 0.0]], landmarks=[[1, nan, 0.0]])),
        ),
        (
            "NaN/Inf",
            "`log.head(nan)`",
            lambda: attempt(lambda: log.head(nan)),
        ),
        (
            "NaN/Inf",
            "`Config(bearing_sigma=nan)`",
            lambda: attempt(lambda: bs.Config(bearing_sigma=nan)),
        ),
        (
            "NaN/Inf",
            "`Config(initial_pose=(inf, 0, 0))`",
            lambda: attempt(lambda: bs.Config(initial_pose=(inf, 0.0, 0.0))),
        ),
        (
            "NaN/Inf",
            "`simulate('paper_fig4', duration=nan)`",
            lambda: attempt(lambda: bs.simulate("paper_fig4", duration=nan)),
        ),
        (
            "NaN/Inf",
            "`simulate('paper_fig4', bearing_sigma=inf)`",
            lambda: attempt(lambda: bs.simulate("paper_fig4", bearing_sigma=inf)),
        ),
        (
            "NaN/Inf",
            "`experiment_fig5(sigma_deg=nan)`",
            lambda: attempt(lambda: bs._native.experiment_fig5(sigma_deg=nan)),
        ),
        # shapes and dtypes
        (
            "shape/dtype",
            "`from_arrays(wheels=[[0, 1]])` (2 columns)",
            lambda: attempt(arrays(wheels=[[0.0, 1.0]])),
        ),
        (
            "shape/dtype",
            "`from_arrays(wheels=np.zeros((2, 3, 1)))`",
            lambda: attempt(arrays(wheels=np.zeros((2, 3, 1)))),
        ),
        (
            "shape/dtype",
            "`from_arrays(wheels=[['a', 'b', 'c']])`",
            lambda: attempt(arrays(wheels=[["a", "b", "c"]])),
        ),
        (
            "shape/dtype",
            "`from_arrays(bearings=..., ranges=[1, 2])` (length)",
            lambda: attempt(arrays(bearings=[[0.0, 1, 0.1]], ranges=[1.0, 2.0])),
        ),
        (
            "shape/dtype",
            "`from_arrays(bearings=[[0, 1.5, 0.1]])` (fractional id)",
            lambda: attempt(arrays(bearings=[[0.0, 1.5, 0.1]])),
        ),
        (
            "shape/dtype",
            "`from_arrays(wheels=..., landmarks=[[1, 0, 0], [1, 2, 1]])` (an id twice)",
            lambda: attempt(
                arrays(wheels=[[0.0, 0.0, 0.0]], landmarks=[[1, 0.0, 0.0], [1, 2.0, 1.0]])
            ),
        ),
        (
            "shape/dtype",
            "`Config(estimator='fastslam1', particles=10**12)`",
            lambda: attempt(lambda: bs.Config(estimator="fastslam1", particles=10**12)),
        ),
        (
            "shape/dtype",
            "`update_bearings(t, [1, 2], [0.1])`",
            lambda: attempt(lambda: fresh().update_bearings(0.2, [1, 2], [0.1])),
        ),
        (
            "shape/dtype",
            "`update_bearings(t, [1.5], [0.1])` (float ids)",
            lambda: attempt(lambda: fresh().update_bearings(0.2, [1.5], [0.1])),
        ),
        (
            "shape/dtype",
            "`update_bearings(t, [[1]], [[0.1]])` (2-D)",
            lambda: attempt(lambda: fresh().update_bearings(0.2, [[1]], [[0.1]])),
        ),
        (
            "shape/dtype",
            "`update_bearings(t, ['a'], [0.1])`",
            lambda: attempt(lambda: fresh().update_bearings(0.2, ["a"], [0.1])),
        ),
        (
            "shape/dtype",
            "`predict_wheels('now', 0, 0)`",
            lambda: attempt(lambda: fresh().predict_wheels(*_any(("now", 0.0, 0.0)))),
        ),
        (
            "shape/dtype",
            "`Config(initial_pose=(1, 2))`",
            lambda: attempt(lambda: bs.Config(**_any({"initial_pose": (1.0, 2.0)}))),
        ),
        (
            "shape/dtype",
            "`Config(history=-1)`",
            lambda: attempt(lambda: bs.Config(init="mte-clone", history=-1)),
        ),
        (
            "shape/dtype",
            "`ate(np.zeros((3, 2)), np.zeros((4, 2)))`",
            lambda: attempt(lambda: bs.ate(np.zeros((3, 2)), np.zeros((4, 2)))),
        ),
        # unknown ids and names
        (
            "unknown id/name",
            "`update_bearings(t, [-1], [0.1])`",
            lambda: attempt(lambda: fresh().update_bearings(0.2, [-1], [0.1])),
        ),
        (
            "unknown id/name",
            "`update_bearings(t, [3, 3], [0.1, 0.2])` (duplicate)",
            lambda: attempt(lambda: fresh().update_bearings(0.2, [3, 3], [0.1, 0.2])),
        ),
        (
            "unknown id/name",
            "`landmark(99)` (not in the map)",
            lambda: attempt(lambda: fresh().landmark(99)),
        ),
        (
            "unknown id/name",
            "`remove_landmark(99)`",
            lambda: attempt(lambda: fresh().remove_landmark(99)),
        ),
        ("unknown id/name", "`Config(init='ekf')`", lambda: attempt(lambda: bs.Config(init="ekf"))),
        (
            "unknown id/name",
            "`Config(rho=0.5)`",
            lambda: attempt(lambda: bs.Config(**_any({"rho": 0.5}))),
        ),
        (
            "unknown id/name",
            "`Config(init='mte', rho_ini=-1)` (a PI-SR parameter)",
            lambda: attempt(lambda: bs.Config(init="mte", rho_ini=-1.0)),
        ),
        (
            "unknown id/name",
            "`from_arrays(info={'wheelbase': 0.3})`",
            lambda: attempt(arrays(info={"wheelbase": 0.3})),
        ),
        (
            "unknown id/name",
            "`simulate('no_such_scenario')`",
            lambda: attempt(lambda: bs.simulate("no_such_scenario")),
        ),
        (
            "unknown id/name",
            "`simulate('paper_fig4', seed=-1)`",
            lambda: attempt(lambda: bs.simulate("paper_fig4", seed=-1)),
        ),
        (
            "unknown id/name",
            "`montecarlo(..., {'method': 'mte', 'rho_ini': 0.5})`",
            lambda: attempt(
                lambda: bs.montecarlo(
                    "paper_fig4", {"method": "mte", "rho_ini": 0.5}, runs=1, progress=False
                )
            ),
        ),
        (
            "unknown id/name",
            "`montecarlo(..., thresholds={'drift_pos': 1})`",
            lambda: attempt(
                lambda: bs.montecarlo(
                    "paper_fig4", "mte", runs=1, thresholds={"drift_pos": 1.0}, progress=False
                )
            ),
        ),
        (
            "unknown id/name",
            "`load_mrclam(D6, robot=-1)`",
            lambda: attempt(lambda: bs.load_mrclam(d6, -1)),
        ),
        (
            "unknown id/name",
            "`evaluate_mrclam(D6, 1, 'ekf')`",
            lambda: attempt(lambda: bs.evaluate_mrclam(d6, 1, "ekf")),
        ),
        # time order
        (
            "time order",
            "`predict_wheels` at t=0.05 after t=0.1",
            lambda: attempt(lambda: fresh().predict_wheels(0.05, 0.0, 0.0)),
        ),
        (
            "time order",
            "`predict_velocity(t, 0.2, 0, dt=-0.1)`",
            lambda: attempt(lambda: fresh().predict_velocity(0.2, 0.2, 0.0, -0.1)),
        ),
        (
            "time order",
            "`from_arrays(velocity=[[0, .2, 0, 0]])` (dt = 0)",
            lambda: attempt(arrays(velocity=[[0.0, 0.2, 0.0, 0.0]])),
        ),
        (
            "time order",
            "`from_arrays(wheels=` rows out of order `)`",
            lambda: _accepted_ok(
                lambda: len(bs.SensorLog.from_arrays(wheels=[[1.0, 0.0, 0.0], [0.5, 0.0, 0.0]]))
            ),
        ),
        (
            "time order",
            "`SensorLog.from_json` with times going back",
            lambda: attempt(
                lambda: bs.SensorLog.from_json(
                    json.dumps(
                        {
                            "info": {
                                "source": "x",
                                "seed": None,
                                "wheel_base_m": None,
                                "bearing_sigma_rad": None,
                                "initial_pose": None,
                            },
                            "events": [
                                {"time": 1.0, "kind": {"Wheels": {"left_m": 0.0, "right_m": 0.0}}},
                                {"time": 0.5, "kind": {"Wheels": {"left_m": 0.0, "right_m": 0.0}}},
                            ],
                            "landmarks": [],
                        }
                    )
                )
            ),
        ),
        # negative variances and out-of-range parameters
        (
            "variance/range",
            "`Config(bearing_sigma=-0.01)`",
            lambda: attempt(lambda: bs.Config(bearing_sigma=-0.01)),
        ),
        (
            "variance/range",
            "`Config(initial_pose_sigma=(-1, 0, 0))`",
            lambda: attempt(lambda: bs.Config(initial_pose_sigma=(-1.0, 0.0, 0.0))),
        ),
        (
            "variance/range",
            "`Config(init='pi-sr', sigma_rho=0)`",
            lambda: attempt(lambda: bs.Config(init="pi-sr", sigma_rho=0.0)),
        ),
        (
            "variance/range",
            "`Config(wheel_floor_sigma=-1)`",
            lambda: attempt(lambda: bs.Config(wheel_floor_sigma=-1.0)),
        ),
        (
            "variance/range",
            "`Config(gate_probability=1.5)`",
            lambda: attempt(lambda: bs.Config(gate_probability=1.5)),
        ),
        (
            "variance/range",
            "`simulate('paper_fig4', encoder_noise=-1)`",
            lambda: attempt(lambda: bs.simulate("paper_fig4", encoder_noise=-1.0)),
        ),
        (
            "variance/range",
            "`simulate('paper_fig4', duration=1e12)`",
            lambda: attempt(lambda: bs.simulate("paper_fig4", duration=1e12)),
        ),
        (
            "variance/range",
            "`simulate('paper_fig8', landmark_count=10**7)`",
            lambda: attempt(lambda: bs.simulate("paper_fig8", landmark_count=10**7)),
        ),
        (
            "variance/range",
            "`experiment_fig5(sigma_deg=-1)`",
            lambda: attempt(lambda: bs._native.experiment_fig5(sigma_deg=-1.0)),
        ),
        (
            "variance/range",
            "`chi2_interval(-3, 1, 0.95)`",
            lambda: attempt(lambda: bs.chi2_interval(-3.0, 1, 0.95)),
        ),
        # mismatches
        (
            "mismatch",
            "`evaluate_mrclam(D6, 1, 'mte', particles=10)` (no particles in the EKF)",
            lambda: attempt(lambda: bs.evaluate_mrclam(d6, 1, "mte", particles=10)),
        ),
        (
            "mismatch",
            "`write_mcap(p, logA, run(logB))`",
            lambda: attempt(
                lambda: bs.write_mcap(
                    tmp / "mixed.mcap", log.head(1.0), bs.run(log, bs.Config.for_log(log))
                )
            ),
        ),
        (
            "mismatch",
            "`run(velocity log, wheels Config())`",
            lambda: attempt(
                lambda: bs.run(
                    bs.SensorLog.from_arrays(
                        velocity=[[0.0, 0.2, 0.0, 0.1], [0.1, 0.2, 0.0, 0.1]],
                        truth=[[0.2, 0.04, 0.0, 0.0]],
                    ),
                    bs.Config(),
                )
            ),
        ),
        (
            "mismatch",
            "`SensorLog.from_json('{}')`",
            lambda: attempt(lambda: bs.SensorLog.from_json("{}")),
        ),
        (
            "mismatch",
            "`SensorLog.from_json('[1, 2]')`",
            lambda: attempt(lambda: bs.SensorLog.from_json("[1, 2]")),
        ),
        # files
        ("file", "`read_mcap` of an empty file", lambda: attempt(lambda: bs.read_mcap(empty))),
        ("file", "`read_mcap` of a CSV text file", lambda: attempt(lambda: bs.read_mcap(text))),
        ("file", "`read_mcap` of a PNG", lambda: attempt(lambda: bs.read_mcap(png))),
        ("file", "`read_mcap('/dev/zero')`", lambda: attempt(lambda: bs.read_mcap("/dev/zero"))),
        (
            "file",
            "`read_mcap` of an 8 GiB file of zeros",
            lambda: attempt(lambda: bs.read_mcap(huge)),
        ),
        (
            "file",
            "`read_mcap` of a file cut in half",
            lambda: _accepted_ok(lambda: bs.read_mcap(cut)[2][:1]),
        ),
        (
            "file",
            "`read_mcap` with one flipped bit",
            lambda: _accepted_ok(lambda: bs.read_mcap(flipped)[2][:1]),
        ),
        ("file", "`read_mcap` of a folder", lambda: attempt(lambda: bs.read_mcap(tmp))),
        (
            "file",
            "`read_mcap` of a missing file",
            lambda: attempt(lambda: bs.read_mcap(tmp / "missing.mcap")),
        ),
        (
            "file",
            "`write_mcap` into a missing folder",
            lambda: attempt(lambda: bs.write_mcap(tmp / "no" / "x.mcap", log)),
        ),
        (
            "file",
            "`simulate` of an empty `.toml`",
            lambda: attempt(lambda: bs.simulate(_write(tmp / "e.toml", ""))),
        ),
        (
            "file",
            "`simulate` of a `.json` that is an MCAP",
            lambda: attempt(
                lambda: bs.simulate(_write_bytes(tmp / "m.json", mcap_ok.read_bytes()))
            ),
        ),
        (
            "file",
            "`load_mrclam` of a folder without the files",
            lambda: attempt(lambda: bs.load_mrclam(not_a_dataset, 1)),
        ),
        (
            "file",
            "`load_mrclam` of MRCLAM names holding MCAP bytes",
            lambda: attempt(lambda: bs.load_mrclam(foreign_dataset, 1)),
        ),
        (
            "file",
            "`load_mrclam` of an MCAP file as the folder",
            lambda: attempt(lambda: bs.load_mrclam(mcap_ok, 1)),
        ),
    ]
    return cases


def _any(value: Any) -> Any:
    """``value`` untyped: the census passes wrong types on purpose."""
    return value


def _write(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


def _write_bytes(path: Path, data: bytes) -> Path:
    path.write_bytes(data)
    return path


def cli_cases(tmp: Path) -> list[tuple[str, str, Callable[[], tuple[str, bool]]]]:
    log = tmp / "cli.mcap"
    bs.write_mcap(log, bs.simulate("paper_fig4", duration=3.0))
    folder = tmp / "a_folder"
    folder.mkdir()
    garbage = _write_bytes(tmp / "garbage.mcap", b"garbage" * 20)
    out = tmp / "cli_out"
    return [
        (
            "CLI",
            "`simulate paper_fig4 --seed -1`",
            lambda: cli("simulate", "paper_fig4", "--seed", "-1", "--out", out / "x.mcap"),
        ),
        (
            "CLI",
            "`simulate paper_fig4 --seed 18446744073709551616`",
            lambda: cli("simulate", "paper_fig4", "--seed", str(2**64), "--out", out / "x.mcap"),
        ),
        (
            "CLI",
            "`simulate paper_fig4 --landmark-count -3`",
            lambda: cli(
                "simulate", "paper_fig4", "--landmark-count", "-3", "--out", out / "x.mcap"
            ),
        ),
        (
            "CLI",
            "`simulate paper_fig4 --duration nan`",
            lambda: cli("simulate", "paper_fig4", "--duration", "nan", "--out", out / "x.mcap"),
        ),
        (
            "CLI",
            "`simulate paper_fig4 --out DIR`",
            lambda: cli("simulate", "paper_fig4", "--out", folder),
        ),
        ("CLI", "`simulate nowhere`", lambda: cli("simulate", "nowhere", "--out", out / "x.mcap")),
        ("CLI", "`run garbage.mcap`", lambda: cli("run", garbage, "--out", out)),
        (
            "CLI",
            "`run LOG --init mte --rho-ini 0.5`",
            lambda: cli("run", log, "--init", "mte", "--rho-ini", "0.5", "--out", out),
        ),
        (
            "CLI",
            "`run LOG --alpha-min-deg -5`",
            lambda: cli("run", log, "--alpha-min-deg", "-5", "--out", out),
        ),
        (
            "CLI",
            "`run LOG --init pi-sr --sigma-rho inf`",
            lambda: cli("run", log, "--init", "pi-sr", "--sigma-rho", "inf", "--out", out),
        ),
        (
            "CLI",
            "`montecarlo paper_fig4 --json DIR`",
            lambda: cli("montecarlo", "paper_fig4", "--runs", "1000000", "--json", folder),
        ),
        (
            "CLI",
            "`montecarlo paper_fig4 --runs 0`",
            lambda: cli("montecarlo", "paper_fig4", "--runs", "0", "--json", out / "r.json"),
        ),
        (
            "CLI",
            "`mrclam DIR --robot 9`",
            lambda: cli("mrclam", folder, "--robot", "9", "--out", out),
        ),
        (
            "CLI",
            "`mrclam D6 --robot 1 --start 5 --end 2`",
            lambda: cli(
                "mrclam",
                DATA / "MRCLAM_Dataset6",
                "--robot",
                "1",
                "--start",
                "5",
                "--end",
                "2",
                "--out",
                out,
            ),
        ),
        (
            "CLI",
            "`mrclam missing_dir --robot 1`",
            lambda: cli("mrclam", tmp / "missing", "--robot", "1", "--out", out),
        ),
        (
            "CLI",
            "`experiment fig5 --seed0 -4`",
            lambda: cli("experiment", "fig5", "--seed0", "-4", "--out", out),
        ),
        (
            "CLI",
            "`demo --out DIR_WITH_OTHER_FILES`",
            lambda: cli("demo", "--out", _with_file(folder)),
        ),
    ]


def _with_file(folder: Path) -> Path:
    (folder / "notes.txt").write_text("mine")
    return folder


def census() -> tuple[list[Row], int]:
    rows: list[Row] = []
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        log = bs.simulate("paper_fig4", seed=3, duration=4.0)
        for group, (through, cases) in (
            ("api", ("Python API", api_cases(tmp, log))),
            ("cli", ("CLI", cli_cases(tmp))),
        ):
            del group
            for kind, case, run_case in cases:
                result, ok = run_case()
                rows.append((kind, through, case, result, ok))
    return rows, sum(1 for r in rows if not r[4])


def main() -> int:
    rows, bad = census()
    print("| # | kind | through | input | what it returns |")
    print("|---|---|---|---|---|")
    for i, (kind, through, case, result, ok) in enumerate(rows, 1):
        mark = "" if ok else " ⚠"
        print(f"| {i} | {kind} | {through} | {case} | {result}{mark} |")
    print()
    print(
        f"{len(rows)} cases; {len(rows) - bad} end in a clear library error or an honest "
        f"result; {bad} do not (⚠)."
    )
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
