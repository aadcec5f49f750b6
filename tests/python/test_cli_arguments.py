"""Bad command-line arguments (issue 20): each is refused before any work,
with one line naming the argument and exit status 2, never a traceback."""

from __future__ import annotations

import json
import os
import subprocess
import time
from pathlib import Path

import pytest

from conftest import cli

ROOT = Path(__file__).resolve().parents[2]
DATA = Path(os.environ.get("BEARING_SLAM_DATA") or ROOT.parent / "shared" / "datasets" / "mrclam")


def assert_refused(r: subprocess.CompletedProcess[str], *words: str) -> str:
    """Exit 2, no traceback, the last line of stderr names ``words``."""
    assert r.returncode == 2, (r.returncode, r.stderr)
    assert "Traceback" not in r.stderr, r.stderr
    last = [line for line in r.stderr.splitlines() if line.strip()][-1]
    assert "error:" in last, r.stderr
    for w in words:
        assert w in last, (w, last)
    return last


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (["simulate", "paper_fig4", "--seed", "-1"], ["--seed", "2**64 - 1", "-1"]),
        (["simulate", "paper_fig4", "--seed", str(2**64)], ["--seed", str(2**64)]),
        (["simulate", "paper_fig4", "--seed", "1.5"], ["--seed", "not an integer"]),
        (["simulate", "paper_fig4", "--landmark-count", "-3"], ["--landmark-count", "-3"]),
        (["simulate", "paper_fig4", "--duration", "-1"], ["--duration", "greater than 0"]),
        (["simulate", "paper_fig4", "--duration", "nan"], ["--duration", "finite"]),
        (["simulate", "paper_fig4", "--duration", "inf"], ["--duration", "finite"]),
        (["simulate", "paper_fig4", "--bearing-sigma-deg", "0"], ["--bearing-sigma-deg"]),
        (["demo", "--seed", "-1"], ["--seed"]),
        (["run", "LOG", "--rho-ini", "nan", "--init", "pi-sr"], ["--rho-ini", "finite"]),
        (["run", "LOG", "--sigma-rho", "-0.1", "--init", "pi-sr"], ["--sigma-rho"]),
        (["run", "LOG", "--alpha-min-deg", "-5"], ["--alpha-min-deg"]),
        (["run", "LOG", "--alpha-min-deg", "400"], ["--alpha-min-deg"]),
        (["run", "LOG", "--bearing-sigma-deg", "inf"], ["--bearing-sigma-deg"]),
        (["mrclam", "DATA", "--robot", "-1"], ["--robot", "1 to 5"]),
        (["mrclam", "DATA", "--robot", "1", "--start", "nan"], ["--start"]),
        (["mrclam", "DATA", "--robot", "1", "--end", "-3"], ["--end"]),
        (["montecarlo", "paper_fig4", "--runs", "0"], ["--runs"]),
        (["montecarlo", "paper_fig4", "--seed0", "-1"], ["--seed0"]),
        (["montecarlo", "paper_fig4", "--scale", "0"], ["--scale"]),
        (["montecarlo", "paper_fig4", "--rho-ini", "-1", "--init", "pi-sr"], ["--rho-ini"]),
        (["montecarlo", "paper_fig4", "--landmarks", "-2"], ["--landmarks"]),
        (["experiment", "fig5", "--seed0", "-4"], ["--seed0"]),
        (["experiment", "fig5", "--runs", "0"], ["--runs"]),
    ],
)
def test_bad_numbers_are_refused_by_name(tmp_path: Path, args: list[str], words: list[str]) -> None:
    swap = {"LOG": str(tmp_path / "none.mcap"), "DATA": str(tmp_path)}
    args = [swap.get(a, a) for a in args]
    if args[0] in ("simulate", "run", "mrclam"):
        args += ["--out", str(tmp_path / "out")]
    if args[0] == "montecarlo":
        args += ["--json", str(tmp_path / "mc.json")]
    t0 = time.perf_counter()
    r = cli(*args)
    assert_refused(r, *words)
    assert time.perf_counter() - t0 < 30.0
    assert not (tmp_path / "out").exists()


def test_montecarlo_json_that_is_a_folder_is_refused_before_the_runs(tmp_path: Path) -> None:
    folder = tmp_path / "reports"
    folder.mkdir()
    t0 = time.perf_counter()
    # 10**6 runs would take hours: the check must come first.
    r = cli("montecarlo", "paper_fig4", "--runs", "1000000", "--json", folder, "--quiet")
    assert_refused(r, "--json", "is a directory")
    assert time.perf_counter() - t0 < 30.0


def test_montecarlo_json_under_a_file_is_refused_before_the_runs(tmp_path: Path) -> None:
    a_file = tmp_path / "plain.txt"
    a_file.write_text("x")
    r = cli("montecarlo", "paper_fig4", "--runs", "1000000", "--json", a_file / "r.json", "--quiet")
    assert_refused(r, "--json", "not a directory")


def test_run_with_a_parameter_the_initializer_does_not_use_is_refused(tmp_path: Path) -> None:
    log = tmp_path / "log.mcap"
    assert cli("simulate", "paper_fig4", "--duration", "3", "--out", log).returncode == 0
    r = cli("run", log, "--init", "mte", "--rho-ini", "0.5", "--out", tmp_path / "o", "--quiet")
    assert_refused(r, "--rho-ini", "PI-SR")
    r = cli("run", log, "--init", "pi-sr", "--alpha-min-deg", "3", "--out", tmp_path / "o")
    assert_refused(r, "--alpha-min-deg")
    r = cli("run", log, "--init", "mte", "--no-auto-stalled-parallax", "--out", tmp_path / "o")
    assert_refused(r, "--no-auto-stalled-parallax", "--init auto only")
    r = cli("run", log, "--auto-max-wait", "0", "--out", tmp_path / "o")
    assert_refused(r, "--auto-max-wait")
    assert not (tmp_path / "o").exists()
    # With the default --init auto the options reach the run's config.
    out = tmp_path / "auto"
    r = cli("run", log, "--auto-visits", "2", "--auto-max-wait", "1.5", "--out", out, "--quiet")
    assert r.returncode == 0, r.stderr
    config = json.loads((out / "metrics.json").read_text())["config"]
    assert (config["init"], config["auto_visits"], config["auto_max_wait"]) == ("auto", 2, 1.5)
    assert config["auto_stalled_parallax"] is True
    assert config["second_order"] is True
    r = cli("run", log, "--first-order", "--out", out, "--quiet")
    assert r.returncode == 0, r.stderr
    assert json.loads((out / "metrics.json").read_text())["config"]["second_order"] is False
    r = cli("run", log, "--use-range", "--first-order", "--out", tmp_path / "o")
    assert_refused(r, "--first-order", "--use-range")
    # The two rules on by default can be switched off by name.
    assert (config["auto_insignificant_parallax"], config["conversion_depth_linearity"]) == (
        True,
        True,
    )
    r = cli(
        "run",
        log,
        "--no-auto-insignificant-parallax",
        "--no-auto-stalled-parallax",
        "--no-conversion-depth-linearity",
        "--out",
        out,
        "--quiet",
    )
    assert r.returncode == 0, r.stderr
    config = json.loads((out / "metrics.json").read_text())["config"]
    assert (
        config["auto_insignificant_parallax"],
        config["auto_stalled_parallax"],
        config["conversion_depth_linearity"],
    ) == (False, False, False)
    r = cli("run", log, "--init", "pi-sr", "--no-auto-insignificant-parallax", "--out", out)
    assert_refused(r, "--no-auto-insignificant-parallax", "--init auto only")
    r = cli("run", log, "--use-range", "--no-conversion-depth-linearity", "--out", out)
    assert_refused(r, "--no-conversion-depth-linearity", "--use-range")


def test_demo_refuses_a_folder_of_other_files(tmp_path: Path) -> None:
    (tmp_path / "notes.txt").write_text("mine")
    r = cli("demo", "--out", tmp_path, "--quiet")
    assert_refused(r, "notes.txt")
    assert (tmp_path / "notes.txt").read_text() == "mine"


# ---------------------------------------------------------------- empty and one-point runs


def test_run_on_an_empty_log_writes_every_output(tmp_path: Path) -> None:
    import bearing_slam as bs

    log = tmp_path / "empty.mcap"
    bs.write_mcap(log, bs.SensorLog.from_arrays())
    out = tmp_path / "out"
    r = cli("run", log, "--out", out, "--quiet")
    assert r.returncode == 0, r.stderr
    for name in ("metrics.json", "trajectory.png", "pose_errors.png", "nees.png", "estimate.mcap"):
        assert (out / name).stat().st_size > 0, name
    assert (out / "trajectory.png").read_bytes().startswith(b"\x89PNG")


def test_run_on_a_one_point_log_writes_every_output(tmp_path: Path) -> None:
    import bearing_slam as bs

    one = bs.SensorLog.from_arrays(
        wheels=[[0.0, 0.0, 0.0]],
        truth=[[0.0, 0.0, 0.0, 0.0]],
        bearings=[[0.0, 1, 0.3]],
        info={"wheel_base_m": 0.2},
    )
    log = tmp_path / "one.mcap"
    bs.write_mcap(log, one)
    out = tmp_path / "out"
    r = cli("run", log, "--out", out, "--quiet")
    assert r.returncode == 0, r.stderr
    for name in ("trajectory.png", "pose_errors.png", "nees.png"):
        assert (out / name).read_bytes().startswith(b"\x89PNG"), name


def test_plots_of_empty_and_one_point_results() -> None:
    import bearing_slam as bs
    from bearing_slam.plots import plot_nees, plot_pose_errors, plot_trajectory

    logs = [
        bs.SensorLog.from_arrays(),
        bs.SensorLog.from_arrays(truth=[[0.0, 1.0, 2.0, 0.1]]),
        bs.SensorLog.from_arrays(wheels=[[0.0, 0.0, 0.0]], landmarks=[[1, 3.0, 4.0]]),
    ]
    for log in logs:
        result = bs.run(log, bs.Config())
        for make in (plot_trajectory, plot_pose_errors, plot_nees):
            make(result, log)


def test_mrclam_window_of_ten_milliseconds(tmp_path: Path) -> None:
    out = tmp_path / "w"
    r = cli(
        "mrclam", DATA / "MRCLAM_Dataset6", "--robot", "1", "--start", "0", "--end", "0.01",
        "--out", out, "--quiet",
    )  # fmt: skip
    assert r.returncode == 0, r.stderr
    for name in ("metrics.json", "trajectory.png", "pose_errors.png", "nees.png", "estimate.mcap"):
        assert (out / name).stat().st_size > 0, name


class _ClosedPipe:
    """A stdout whose reader has gone (``bearing-slam ... | head -1``)."""

    def __init__(self, fd: int) -> None:
        self._fd = fd

    def write(self, _text: str) -> int:
        raise BrokenPipeError(32, "Broken pipe")

    def flush(self) -> None:
        pass

    def fileno(self) -> int:
        return self._fd


def test_a_closed_stdout_ends_quietly(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    from bearing_slam.cli import main

    with (tmp_path / "stdout").open("w") as sink:
        monkeypatch.setattr("sys.stdout", _ClosedPipe(sink.fileno()))
        status = main(["scenarios"])
    assert status == 1
    assert capsys.readouterr().err == ""
