"""``--live``: stream a run to the Foxglove app as it goes.

A WebSocket server speaking the Foxglove WebSocket protocol
(``foxglove.websocket.v1``, from the Foxglove SDK for Rust) sends the run's
log and estimate in time order, paced at ``--live-speed`` times real time, on
the topics of the MCAP files (``/slam/estimate``, ``/slam/pose``,
``/slam/map``, ``/slam/path``, ``/bearings/rays``, ``/ground_truth/*``,
``/tf``, ...). In the Foxglove app: *Open connection* → *Foxglove WebSocket*
→ ``ws://127.0.0.1:8765``. The stream starts once a client subscribes to a
topic, so the app sees the run from its first second.

The filter runs first (it is thousands of times faster than real time) and
its log and estimates are then played out at the chosen pace.
"""

from __future__ import annotations

import argparse
import sys
import time
from typing import Any, TextIO

from bearing_slam._native import LiveServer, RunResult, SensorLog, Trace
from bearing_slam.arg_types import non_negative_float

#: Foxglove's default port for WebSocket connections.
DEFAULT_PORT = 8765

#: Seconds left to the clients to receive what is queued, before the server stops.
DRAIN_S = 0.5


def stream_live(
    log: SensorLog,
    result: RunResult | Trace | None = None,
    *,
    port: int = DEFAULT_PORT,
    speed: float = 1.0,
    snapshot_every: float = 0.0,
    wait_timeout: float | None = None,
    out: TextIO | None = sys.stderr,
) -> dict[str, Any]:
    """Serves ``log`` and ``result`` live on ``ws://127.0.0.1:port`` (0: a free
    port, printed): waits for a Foxglove client to subscribe (at most
    ``wait_timeout`` s; ``None``: until Ctrl-C), then streams at ``speed``
    times real time (0: as fast as possible) and stops the server.

    Returns the stream's statistics (``records``, ``messages``,
    ``log_seconds``, ``wall_seconds``, ``complete``) and ``url``;
    ``subscribed`` is False (and nothing was sent) when no client came in time.
    """
    server = LiveServer(port)
    try:
        url = server.url
        if out is not None:
            print(
                f"bearing-slam: live: open {url} in Foxglove (Open connection > "
                "Foxglove WebSocket); waiting for a client, Ctrl-C to stop",
                file=out,
                flush=True,
            )
        if not server.wait_for_subscriber(wait_timeout):
            return {"url": url, "subscribed": False, "records": 0, "messages": 0}
        stats = server.stream(log, result, speed=speed, snapshot_every=snapshot_every)
        if out is not None:
            print(
                f"bearing-slam: live: streamed {stats['log_seconds']:.1f} s of log "
                f"({stats['messages']} messages) in {stats['wall_seconds']:.1f} s",
                file=out,
                flush=True,
            )
        # Let the clients' queues drain before the server disconnects them.
        time.sleep(DRAIN_S)
        return {"url": url, "subscribed": True, **stats}
    finally:
        server.stop()


def add_live_arguments(p: argparse.ArgumentParser) -> None:
    """``--live``, ``--live-port`` and ``--live-speed`` (run, mrclam)."""
    p.add_argument(
        "--live",
        action="store_true",
        help="also stream the run to the Foxglove app on ws://127.0.0.1:PORT (estimate, map, "
        "bearing rays, truth where present); waits for a client, then streams",
    )
    p.add_argument(
        "--live-port",
        type=_port,
        default=DEFAULT_PORT,
        metavar="P",
        help="port of --live (default: %(default)s, Foxglove's; 0: a free port)",
    )
    p.add_argument(
        "--live-speed",
        type=non_negative_float,
        default=1.0,
        metavar="X",
        help="pace of --live, times real time (default: %(default)s; 0: as fast as possible)",
    )


def stream_if_asked(args: argparse.Namespace, log: SensorLog, result: RunResult) -> None:
    """The ``--live`` stream of a CLI run, when asked for."""
    if getattr(args, "live", False):
        stream_live(
            log,
            result,
            port=args.live_port,
            speed=args.live_speed,
            snapshot_every=getattr(args, "snapshot_every", 0.0),
        )


def _port(text: str) -> int:
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a port number: {text!r}") from None
    if not 0 <= v <= 65535:
        raise argparse.ArgumentTypeError(f"port must be 0 to 65535, got {v}")
    return v
