"""`write_mcap(..., snapshot_every=S, compression=...)`: fewer estimate
snapshots, the last kept, the sensor data and filter events still exact."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import bearing_slam as bs


def test_snapshot_every_thins_the_trace_and_keeps_the_log_exact(
    tmp_path: Path, fig4_log: bs.SensorLog, fig4_result: bs.RunResult
) -> None:
    full, thin = tmp_path / "full.mcap", tmp_path / "thin.mcap"
    bs.write_mcap(full, fig4_log, fig4_result)
    bs.write_mcap(thin, fig4_log, fig4_result, snapshot_every=5.0)
    log, trace, warnings = bs.read_mcap(thin)
    assert warnings == []
    assert log == fig4_log
    assert trace is not None
    every = fig4_result.trace
    assert len(trace) < len(every) / 10
    times = trace.times
    # At least 5 s apart, but for the last (always kept).
    assert np.all(np.diff(times[:-1]) >= 5.0 - 1e-9)
    # The first and the last snapshot are kept, bit for bit.
    assert times[0] == every.times[0]
    assert times[-1] == every.times[-1]
    np.testing.assert_array_equal(trace.poses[-1], every.poses[-1])
    assert trace.events == every.events
    assert thin.stat().st_size < full.stat().st_size


@pytest.mark.parametrize("compression", ["zstd", "lz4", "none"])
def test_every_compression_reads_back(
    tmp_path: Path, fig4_log: bs.SensorLog, fig4_result: bs.RunResult, compression: str
) -> None:
    path = tmp_path / f"{compression}.mcap"
    bs.write_mcap(path, fig4_log, fig4_result, compression=compression)
    log, trace, _ = bs.read_mcap(path)
    assert log == fig4_log
    assert trace is not None
    assert len(trace) == len(fig4_result.trace)


def test_zstd_is_smaller_than_lz4(
    tmp_path: Path, fig4_log: bs.SensorLog, fig4_result: bs.RunResult
) -> None:
    sizes = {}
    for c in ("zstd", "lz4"):
        bs.write_mcap(tmp_path / f"{c}.mcap", fig4_log, fig4_result, compression=c)
        sizes[c] = (tmp_path / f"{c}.mcap").stat().st_size
    assert sizes["zstd"] < 0.8 * sizes["lz4"]


def test_bad_options_are_refused(tmp_path: Path, fig4_log: bs.SensorLog) -> None:
    with pytest.raises(ValueError, match="snapshot_every"):
        bs.write_mcap(tmp_path / "x.mcap", fig4_log, snapshot_every=-1.0)
    with pytest.raises(ValueError, match="unknown compression"):
        bs.write_mcap(tmp_path / "x.mcap", fig4_log, compression="gzip")
