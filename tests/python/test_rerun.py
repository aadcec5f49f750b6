"""Rerun recordings (bearing_slam.rerun, `--rerun`): the written .rrd is read
back with the SDK's chunk reader and its entities and row counts checked, for
a run logged as it goes (``on_scan``) and for one replayed after the fact; the
live run's result is the plain run's bit for bit, and the file holds the
first half of the run while the second is still to come."""

from __future__ import annotations

import os
from collections import Counter
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from rerun.chunk import RrdReader

import bearing_slam as bs
from bearing_slam import cli, mrclam
from bearing_slam.rerun import (
    ENTITY_PATHS,
    RerunLogger,
    covariance_ellipse_points,
    open_recording,
    rerun_paths,
)

ROOT = Path(__file__).resolve().parents[2]


def rrd_rows(path: Path) -> tuple[Counter[str], set[str]]:
    """(rows per entity over the time line, entities with static data) of an .rrd."""
    rows: Counter[str] = Counter()
    static: set[str] = set()
    for chunk in RrdReader(path).stream().to_chunks():
        entity = chunk.entity_path.lstrip("/")
        if entity.startswith("__"):
            continue
        if chunk.is_static:
            static.add(entity)
        else:
            assert chunk.timeline_names == ["time"] or "time" in chunk.timeline_names
            rows[entity] += chunk.num_rows
    return rows, static


@pytest.fixture(scope="module")
def short_run() -> tuple[bs.SensorLog, bs.RunResult]:
    log = bs.simulate("paper_fig4", seed=3, duration=30.0)
    return log, bs.run(log, bs.Config.for_log(log, init="mte"))


@pytest.mark.parametrize("how", ["after the run", "live"])
def test_rrd_has_every_entity_with_its_rows(
    tmp_path: Path, short_run: tuple[bs.SensorLog, bs.RunResult], how: str
) -> None:
    log, result = short_run
    path = tmp_path / "run.rrd"
    if how == "live":
        live = bs.run_with_rerun(log, result.config, path=path)
        assert np.array_equal(live.estimate, result.estimate)
    else:
        bs.log_rerun(result, log, path=path)
    rows, static = rrd_rows(path)
    trace = result.trace
    scans = len(np.unique(log.bearings[:, 0]))
    assert scans > 10
    expected = {
        "world/truth/pose": len(result.time),
        "world/dead_reckoning/pose": len(result.time),
        "world/estimate/pose": len(result.time),
        "world/estimate/covariance": len(trace),
        "world/landmarks/estimate": len(trace),
        "world/landmarks/covariance": len(trace),
        "world/scan/rays": scans,
        "events": len(trace.events),
        "metrics/nees/pose": int(np.isfinite(result.nees).sum()),
        "metrics/nees/lower_95": 2,
        "metrics/nees/upper_95": 2,
    }
    for entity, n in expected.items():
        assert rows[entity] == n, entity
    # Candidates: one row per change of the waiting set (created, initialized, expired).
    changes = sum(
        e["kind"] in ("candidate_created", "landmark_initialized", "candidate_expired")
        for e in trace.events
    )
    assert changes > 0
    assert rows["world/candidates"] == changes
    for entity in ("world/truth/path", "world/estimate/path", "world/landmarks/truth"):
        assert entity in static
    assert set(rows) | static <= set(ENTITY_PATHS)
    assert set(ENTITY_PATHS) <= set(rows) | static


def test_live_run_is_the_plain_run_bit_for_bit(
    short_run: tuple[bs.SensorLog, bs.RunResult],
) -> None:
    # The callback only reads: the runner's loop and its arithmetic are the
    # same with or without it, so the result is identical, not merely close.
    log, result = short_run
    steps: list[dict[str, Any]] = []
    live = bs.run(log, result.config, on_scan=steps.append)
    assert len(steps) == len(result.trace) > 10
    for name in ("time", "estimate", "covariance", "dead_reckoning", "truth"):
        assert np.array_equal(getattr(live, name), getattr(result, name)), name
    for a, b in zip(live.landmarks(), result.landmarks(), strict=True):
        assert np.array_equal(a, b)
    assert live.summary == result.summary
    assert live.events == result.events
    # The steps add up to the run: snapshots, events, track points in order.
    assert [s["time"] for s in steps] == result.trace.times.tolist()
    assert np.array_equal(steps[-1]["pose"], result.trace.poses[-1])
    events = [e for s in steps for e in s["events"]]
    assert events == result.events[: len(events)]
    track = np.concatenate([s["track_estimate"] for s in steps])
    assert np.array_equal(track, result.estimate[: len(track)])
    nees = np.concatenate([s["track_nees"] for s in steps])
    assert np.array_equal(nees, result.nees[: len(nees)], equal_nan=True)


@pytest.mark.filterwarnings("ignore:RRD file has no footer")  # read before it is finished
def test_the_recording_grows_while_the_run_goes(
    tmp_path: Path, short_run: tuple[bs.SensorLog, bs.RunResult]
) -> None:
    # Half-way through the run (inside the filter's callback, before run()
    # has returned), the .rrd on disk already holds the scans so far, and
    # only those.
    log, result = short_run
    path = tmp_path / "live.rrd"
    rec = open_recording(path=path)
    logger = RerunLogger(rec, log, send_every_s=0.0)  # every scan sent as it comes
    middle = len(result.trace) // 2
    seen: dict[str, Any] = {}

    def on_scan(step: dict[str, Any]) -> None:
        logger(step)
        if logger.scans == middle:
            rec.flush()
            seen["time"] = float(step["time"])
            seen["rows"], seen["static"] = rrd_rows(path)

    live = bs.run(log, result.config, on_scan=on_scan)
    logger.finish(live)
    rows = seen["rows"]
    assert rows["world/scan/rays"] == middle
    assert rows["world/landmarks/estimate"] == middle
    n_track = int(np.searchsorted(result.time, seen["time"], side="right"))
    assert 0 < rows["world/estimate/pose"] <= n_track < len(result.time)
    assert "world/landmarks/truth" in seen["static"]
    final, _ = rrd_rows(path)
    assert final["world/scan/rays"] == len(result.trace) > middle
    assert final["world/estimate/pose"] == len(result.time)


def test_mrclam_live_is_the_plain_evaluation(tmp_path: Path) -> None:
    # evaluate_mrclam takes on_scan too (the `mrclam --rerun` path): same
    # result, bit for bit, and a step per scan of the filter's log.
    data = Path(
        os.environ.get("BEARING_SLAM_DATA") or ROOT.parent / "shared" / "datasets" / "mrclam"
    )
    window = (data / "MRCLAM_Dataset6", 3, "mte", 300.0, 360.0)
    plain = mrclam.evaluate(*window)
    rec = open_recording(path=tmp_path / "r3.rrd")
    logger = RerunLogger(rec, plain.log)
    live = mrclam.evaluate(*window, on_scan=logger)
    logger.finish(live.result)
    rec.disconnect()
    assert logger.scans == len(plain.result.trace) > 10
    assert np.array_equal(live.result.estimate, plain.result.estimate)
    same = {k: v for k, v in live.metrics.items() if k != "run_time_s"}
    assert same == {k: v for k, v in plain.metrics.items() if k != "run_time_s"}
    rows, _ = rrd_rows(tmp_path / "r3.rrd")
    assert rows["world/scan/rays"] == logger.scans


def test_an_exception_in_on_scan_ends_the_run(
    short_run: tuple[bs.SensorLog, bs.RunResult],
) -> None:
    log, result = short_run
    calls = 0

    def on_scan(step: dict[str, Any]) -> None:
        nonlocal calls
        calls += 1
        if calls == 3:
            raise KeyError("stop here")

    with pytest.raises(KeyError, match="stop here"):
        bs.run(log, result.config, on_scan=on_scan)
    assert calls == 3


def test_snapshot_every_thins_the_map_and_keeps_the_last(
    tmp_path: Path, short_run: tuple[bs.SensorLog, bs.RunResult]
) -> None:
    log, result = short_run
    path = tmp_path / "thin.rrd"
    bs.log_rerun(result, log, path=path, snapshot_every=5.0)
    rows, _ = rrd_rows(path)
    times = result.trace.times
    n = rows["world/landmarks/estimate"]
    assert 2 <= n <= int((times[-1] - times[0]) / 5.0) + 2
    assert rows["world/estimate/pose"] == len(result.time)


def test_log_rerun_needs_a_sink(short_run: tuple[bs.SensorLog, bs.RunResult]) -> None:
    log, result = short_run
    with pytest.raises(ValueError, match="path, spawn=True or a recording"):
        bs.log_rerun(result, log)
    with pytest.raises(ValueError, match="snapshot_every"):
        bs.log_rerun(result, log, path="x.rrd", snapshot_every=-1.0)


def test_ellipse_points_are_on_the_two_sigma_contour() -> None:
    cov = np.array([[4.0, 1.0], [1.0, 2.0]])
    pts = covariance_ellipse_points(np.array([1.0, -2.0]), cov, 2.0, 36)
    d = pts - [1.0, -2.0]
    mahalanobis = np.einsum("ni,ij,nj->n", d, np.linalg.inv(cov), d)
    np.testing.assert_allclose(mahalanobis, 4.0, rtol=1e-9)
    np.testing.assert_allclose(pts[0], pts[-1])


def test_rerun_paths() -> None:
    assert rerun_paths("out/demo.rrd", ["a", "b"]) == ["out/demo_a.rrd", "out/demo_b.rrd"]


@pytest.mark.slow
def test_cli_run_writes_the_recording(tmp_path: Path) -> None:
    log_path = tmp_path / "log.mcap"
    assert cli.main(["simulate", "paper_fig4", "--duration", "20", "--out", str(log_path)]) == 0
    rrd = tmp_path / "view" / "run.rrd"
    status = cli.main(
        [
            "run",
            str(log_path),
            "--out",
            str(tmp_path / "out"),
            "--quiet",
            "--rerun",
            str(rrd),
            "--snapshot-every",
            "2",
        ]
    )
    assert status == 0
    rows, static = rrd_rows(rrd)
    assert rows["world/scan/rays"] > 0
    assert "world/landmarks/truth" in static
    read, trace, _ = bs.read_mcap(tmp_path / "out" / "estimate.mcap")
    assert trace is not None
    assert read == bs.read_mcap(log_path)[0]
