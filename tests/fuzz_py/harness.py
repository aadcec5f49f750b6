"""What the atheris targets share: the exceptions a target may raise on
hostile input (anything else is a finding), and the runner.

An input may be refused with a :class:`bearing_slam.BearingSlamError`, a
``ValueError``, ``TypeError`` or ``KeyError`` with a message; a crash, a hang,
a ``RuntimeError``, an ``OverflowError``, a ``SystemError`` or a
``pyo3_runtime.PanicException`` (a Rust panic) is a finding.
"""

from __future__ import annotations

import sys
from collections.abc import Callable

import atheris

# Coverage of the Python package only (the Rust extension is not
# instrumented here: cargo-fuzz covers it, see fuzz/); numpy and matplotlib
# are left alone, which keeps start-up short.
with atheris.instrument_imports(include=["bearing_slam"]):
    import bearing_slam as bs

__all__ = ["EXPECTED", "bs", "main"]

#: The errors a target may raise for a refused input.
EXPECTED: tuple[type[BaseException], ...] = (
    bs.BearingSlamError,
    ValueError,
    TypeError,
    KeyError,
)


def main(test_one_input: Callable[[bytes], None]) -> None:
    """Runs libFuzzer on ``test_one_input`` with the command line's options
    (``-max_total_time=60``, a corpus folder, ...)."""

    target = atheris.instrument_func(test_one_input)

    def guarded(data: bytes) -> None:
        try:
            target(data)
        except OverflowError:
            raise
        except EXPECTED:
            pass

    atheris.Setup(sys.argv, atheris.instrument_func(guarded))
    atheris.Fuzz()
