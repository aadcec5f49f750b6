"""atheris target: any bytes as ``SensorLog.from_json``. A log that is
accepted must serialize again and round-trip to an equal log, and run."""

from __future__ import annotations

import math

from harness import bs, main


def test_one_input(data: bytes) -> None:
    text = data.decode("utf-8", errors="replace")
    log = bs.SensorLog.from_json(text)
    again = bs.SensorLog.from_json(log.to_json())
    assert again == log, "from_json(to_json(log)) != log"
    if len(log) <= 2000:
        result = bs.run(log, bs.Config.for_log(log))
        assert all(math.isfinite(v) for v in result.estimate[:, :2].ravel()), "non-finite estimate"


if __name__ == "__main__":
    main(test_one_input)
