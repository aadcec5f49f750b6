"""MCAP file sizes of the writer (``bearing_slam.write_mcap``), by chunk
compression and estimate-snapshot decimation, with the bytes per topic.

Runs MTE on the simulated ``slip_patch`` (seed 0, 98 s) and, when the MRCLAM
data are there, on robot 1 of MRCLAM Dataset 1 (1490 s, about 25 minutes), then
writes each log + estimate with every setting of :data:`SETTINGS` and prints a
markdown table (the one of ``docs/results/mcap.md``)::

    python benches/mcap_size.py [MRCLAM_DATA_DIR]   # default: $BEARING_SLAM_DATA
"""

from __future__ import annotations

import os
import sys
import tempfile
from collections import Counter
from pathlib import Path
from typing import Any

from mcap.reader import make_reader

import bearing_slam as bs
from bearing_slam import mrclam

#: (label, write_mcap keyword arguments).
SETTINGS: tuple[tuple[str, dict[str, Any]], ...] = (
    ("lz4, every snapshot", {"compression": "lz4"}),
    ("zstd, every snapshot (the default)", {"compression": "zstd"}),
    ("zstd, --snapshot-every 1", {"compression": "zstd", "snapshot_every": 1.0}),
    ("zstd, --snapshot-every 5", {"compression": "zstd", "snapshot_every": 5.0}),
    ("zstd, --snapshot-every 10", {"compression": "zstd", "snapshot_every": 10.0}),
)


def topic_bytes(path: Path) -> Counter[str]:
    """Uncompressed message bytes per topic."""
    out: Counter[str] = Counter()
    with path.open("rb") as f:
        for _schema, channel, message in make_reader(f).iter_messages():
            out[channel.topic] += len(message.data)
    return out


def measure(name: str, log: bs.SensorLog, result: bs.RunResult, tmp: Path) -> list[str]:
    rows = []
    for label, kwargs in SETTINGS:
        path = tmp / "run.mcap"
        bs.write_mcap(path, log, result, **kwargs)
        per = topic_bytes(path)
        top = ", ".join(f"{t} {b / 1e6:.1f}" for t, b in per.most_common(3))
        rows.append(
            f"| {name} | {label} | {path.stat().st_size / 1e6:.2f} | "
            f"{sum(per.values()) / 1e6:.1f} | {top} |"
        )
    return rows


def main(argv: list[str]) -> int:
    rows = [
        "| run | writer | file MB | messages MB (uncompressed) | largest topics, MB |",
        "|---|---|---|---|---|",
    ]
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        log = bs.simulate("slip_patch", seed=0)
        result = bs.run(log, bs.Config.for_log(log, init="mte"))
        rows += measure(f"slip_patch, {log.duration:.0f} s", log, result, tmp)
        data = argv[0] if argv else os.environ.get(mrclam.DATA_ENV)
        if data:
            run = mrclam.evaluate(Path(data) / "MRCLAM_Dataset1", 1, "mte")
            name = f"MRCLAM Dataset 1 robot 1, {run.log.duration:.0f} s"
            rows += measure(name, run.log, run.result, tmp)
    print("\n".join(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
