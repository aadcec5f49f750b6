"""MCAP files: exact round trip through our reader, and the official Python
``mcap`` reader sees the Foxglove schemas and the expected message counts."""

from __future__ import annotations

from collections import Counter
from pathlib import Path

import numpy as np
from mcap.reader import make_reader

import bearing_slam as bs


def test_round_trip_log_and_trace(
    tmp_path: Path, fig4_log: bs.SensorLog, fig4_result: bs.RunResult
) -> None:
    path = tmp_path / "run.mcap"
    bs.write_mcap(path, fig4_log, fig4_result)
    log, trace, warnings = bs.read_mcap(path)
    assert warnings == []
    assert log == fig4_log
    assert trace is not None
    assert len(trace) == len(fig4_result.trace) == len(np.unique(fig4_log.bearings[:, 0]))
    np.testing.assert_array_equal(trace.poses, fig4_result.trace.poses)
    np.testing.assert_array_equal(trace.pose_covariances, fig4_result.trace.pose_covariances)
    ids, pos, cov = trace.final_landmarks()
    ids2, pos2, cov2 = fig4_result.landmarks()
    np.testing.assert_array_equal(ids, ids2)
    np.testing.assert_array_equal(pos, pos2)
    np.testing.assert_array_equal(cov, cov2)
    assert trace.events == fig4_result.events
    assert trace.snapshot(-1)["pose"].shape == (3,)


def test_log_only_and_trace_argument(tmp_path: Path, fig4_log: bs.SensorLog) -> None:
    path = tmp_path / "log.mcap"
    bs.write_mcap(path, fig4_log)
    log, trace, _ = bs.read_mcap(path)
    assert log == fig4_log
    assert trace is None


def test_official_reader(tmp_path: Path, fig4_log: bs.SensorLog, fig4_result: bs.RunResult) -> None:
    path = tmp_path / "run.mcap"
    bs.write_mcap(path, fig4_log, fig4_result)
    with path.open("rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        assert summary is not None
        schemas = {s.name for s in summary.schemas.values()}
        assert {
            "foxglove.PoseInFrame",
            "foxglove.SceneUpdate",
            "foxglove.FrameTransform",
        } <= schemas
        topics = {c.topic: c for c in summary.channels.values()}
        assert {"/bearings", "/odometry/wheels", "/slam/estimate", "/tf"} <= set(topics)
        stats = summary.statistics
        assert stats is not None
        counts = {topics_id: n for topics_id, n in stats.channel_message_counts.items()}
        by_topic = {summary.channels[cid].topic: n for cid, n in counts.items()}
        assert by_topic["/odometry/wheels"] == len(fig4_log.wheels)
        assert by_topic["/ground_truth/pose2d"] == len(fig4_log.truth)
        assert by_topic["/bearings"] == len(np.unique(fig4_log.bearings[:, 0]))
        assert by_topic["/slam/estimate"] == len(fig4_result.trace)
        assert stats.message_count == sum(by_topic.values())
        # Every message decodes through the official reader, in time order.
        seen: Counter[str] = Counter()
        last = -1
        for _schema, channel, message in reader.iter_messages(log_time_order=True):
            assert message.log_time >= last
            last = message.log_time
            seen[channel.topic] += 1
        assert dict(seen) == by_topic
