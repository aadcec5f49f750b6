"""Rerun recordings (bearing_slam.rerun, `--rerun`): the written .rrd is read
back with the SDK's chunk reader and its entities and row counts checked."""

from __future__ import annotations

from collections import Counter
from pathlib import Path

import numpy as np
import pytest
from rerun.chunk import RrdReader

import bearing_slam as bs
from bearing_slam import cli
from bearing_slam.rerun import ENTITY_PATHS, covariance_ellipse_points, rerun_paths


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


def test_rrd_has_every_entity_with_its_rows(
    tmp_path: Path, short_run: tuple[bs.SensorLog, bs.RunResult]
) -> None:
    log, result = short_run
    path = tmp_path / "run.rrd"
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
