"""atheris target: any bytes as an MCAP file given to ``read_mcap``
(written to a temporary file). A file that reads without warnings must write
back and read again to the same log."""

from __future__ import annotations

import os
import tempfile

from harness import bs, main

_DIR = tempfile.mkdtemp(prefix="fuzz_read_mcap_")
_PATH = os.path.join(_DIR, "input.mcap")
_BACK = os.path.join(_DIR, "back.mcap")


def test_one_input(data: bytes) -> None:
    with open(_PATH, "wb") as f:
        f.write(data)
    log, trace, warnings = bs.read_mcap(_PATH)
    if warnings:
        return
    bs.write_mcap(_BACK, log, trace)
    again, _, warnings_back = bs.read_mcap(_BACK)
    assert warnings_back == [], warnings_back
    assert again == log, "write_mcap(read_mcap(f)) reads back to another log"


if __name__ == "__main__":
    main(test_one_input)
