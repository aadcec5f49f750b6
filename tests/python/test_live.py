"""``--live``: a run streamed to a Foxglove client over the Foxglove
WebSocket protocol, checked with a plain WebSocket client: the advertised
topics and their schemas, and messages on the estimate topics.

The Foxglove SDK (0.30) names the protocol ``foxglove.sdk.v1`` (the message
format of the older ``foxglove.websocket.v1``, channel advertisements with
inline schemas) and refuses other subprotocols with HTTP 400."""

from __future__ import annotations

import json
import re
import subprocess
import sys
import threading
from collections import Counter
from pathlib import Path
from typing import Any

import pytest
from websockets.sync.client import connect
from websockets.typing import Subprotocol

import bearing_slam as bs
from bearing_slam.live import stream_live

#: Topics a Foxglove layout for bearing-slam relies on, with their schemas.
EXPECTED = {
    "/slam/estimate": "bearing_slam.EstimateSnapshot",
    "/slam/pose": "foxglove.PoseInFrame",
    "/slam/map": "foxglove.SceneUpdate",
    "/slam/path": "foxglove.PosesInFrame",
    "/bearings/rays": "foxglove.SceneUpdate",
    "/ground_truth/pose": "foxglove.PoseInFrame",
    "/tf": "foxglove.FrameTransform",
    "/bearings": "bearing_slam.BearingScan",
}

#: The WebSocket subprotocol of the Foxglove SDK's server.
SUBPROTOCOL = "foxglove.sdk.v1"

#: Binary opcode of a message data frame (server to client).
MESSAGE_DATA = 0x01


def receive_run(url: str, want: set[str]) -> tuple[dict[str, Any], Counter[str], dict[str, Any]]:
    """Connects, reads the advertised channels, subscribes to all of them and
    counts the messages per topic until each topic of ``want`` sent one.
    Returns the channels by topic, the counts and the first ``/slam/estimate``."""
    with connect(
        url, subprotocols=[Subprotocol(SUBPROTOCOL)], open_timeout=10, close_timeout=1
    ) as ws:
        assert ws.subprotocol == SUBPROTOCOL
        channels: dict[str, Any] = {}
        while not channels:
            frame = ws.recv(timeout=10)
            assert isinstance(frame, str), "text frames come first"
            msg = json.loads(frame)
            if msg["op"] == "advertise":
                channels = {c["topic"]: c for c in msg["channels"]}
        by_subscription = dict(enumerate(channels))
        subscriptions = [
            {"id": i, "channelId": channels[t]["id"]} for i, t in by_subscription.items()
        ]
        ws.send(json.dumps({"op": "subscribe", "subscriptions": subscriptions}))
        counts: Counter[str] = Counter()
        estimate: dict[str, Any] = {}
        while not all(counts[t] for t in want):
            frame = ws.recv(timeout=10)
            if isinstance(frame, str) or frame[0] != MESSAGE_DATA:
                continue
            topic = by_subscription[int.from_bytes(frame[1:5], "little")]
            counts[topic] += 1
            if topic == "/slam/estimate" and not estimate:
                estimate = json.loads(frame[13:])
    return channels, counts, estimate


def test_the_cli_streams_a_run_to_a_foxglove_client(tmp_path: Path) -> None:
    log_path = tmp_path / "log.mcap"
    # 5 s of log at 5x real time: a one-second stream.
    bs.write_mcap(log_path, bs.simulate("paper_fig4", seed=3, duration=5.0))
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "bearing_slam",
            "run",
            str(log_path),
            "--out",
            str(tmp_path / "out"),
            "--quiet",
            "--live",
            "--live-port",
            "0",
            "--live-speed",
            "5",
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    watchdog = threading.Timer(60, proc.kill)
    watchdog.start()
    try:
        assert proc.stderr is not None
        url = None
        for line in proc.stderr:
            if m := re.search(r"live: open (ws://\S+)", line):
                url = m.group(1)
                break
        assert url is not None, f"no live URL printed; exit {proc.poll()}"
        assert re.fullmatch(r"ws://127\.0\.0\.1:\d+", url)
        channels, counts, estimate = receive_run(url, {"/slam/estimate", "/slam/pose"})
        for topic, schema in EXPECTED.items():
            assert channels[topic]["schemaName"] == schema, topic
            assert channels[topic]["encoding"] == "json"
        assert counts["/slam/estimate"] >= 1
        assert counts["/slam/pose"] >= 1
        assert estimate["time"] >= 0.0
        assert set(estimate["pose"]) == {"x", "y", "theta"}
        _, err = proc.communicate(timeout=30)
        assert proc.returncode == 0, err
        assert "live: streamed" in err
    finally:
        watchdog.cancel()
        if proc.poll() is None:
            proc.kill()
            proc.wait()


def test_stream_live_gives_up_without_a_client(fig4_log: bs.SensorLog) -> None:
    stats = stream_live(fig4_log, port=0, wait_timeout=0.1, out=None)
    assert stats["subscribed"] is False
    assert stats["messages"] == 0
    assert stats["url"].startswith("ws://127.0.0.1:")


def test_bad_live_options_are_refused(fig4_log: bs.SensorLog) -> None:
    server = bs.LiveServer(0)
    try:
        with pytest.raises(ValueError, match="speed"):
            server.stream(fig4_log, speed=-1.0)
        with pytest.raises(ValueError, match="timeout"):
            server.wait_for_subscriber(float("nan"))
    finally:
        server.stop()
    with pytest.raises(RuntimeError, match="stopped"):
        _ = server.url
