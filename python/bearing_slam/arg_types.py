"""Argument types of the ``bearing-slam`` command line (argparse ``type=``).

Each one turns the text of an option into its value or raises
:class:`argparse.ArgumentTypeError` with a message that names the rule, so a
bad number is reported as ``bearing-slam <command>: error: argument --seed:
...`` with exit status 2, before any work starts, instead of a traceback
from deep inside the run.
"""

from __future__ import annotations

import argparse
import math
import os
from collections.abc import Callable
from pathlib import Path

__all__ = [
    "U64_MAX",
    "UserError",
    "angle_deg",
    "finite_float",
    "non_negative_float",
    "non_negative_int",
    "output_file",
    "positive_float",
    "positive_int",
    "positive_named",
    "robot_number",
    "seed",
]


class UserError(Exception):
    """A mistake in the command line or its inputs: reported in one line."""


#: The largest seed: seeds are unsigned 64-bit integers in the Rust simulator.
U64_MAX = 2**64 - 1


def _int(text: str) -> int:
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None


def _float(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not math.isfinite(v):
        raise argparse.ArgumentTypeError(f"must be a finite number, got {text!r}")
    return v


def seed(text: str) -> int:
    """A seed: an integer from 0 to 2**64 - 1."""
    v = _int(text)
    if not 0 <= v <= U64_MAX:
        raise argparse.ArgumentTypeError(f"a seed is an integer from 0 to 2**64 - 1, got {v}")
    return v


def positive_int(text: str) -> int:
    """An integer of at least 1 (and at most 2**64 - 1)."""
    v = _int(text)
    if not 1 <= v <= U64_MAX:
        raise argparse.ArgumentTypeError(f"must be at least 1, got {v}")
    return v


def non_negative_int(text: str) -> int:
    """An integer of at least 0 (and at most 2**64 - 1)."""
    v = _int(text)
    if not 0 <= v <= U64_MAX:
        raise argparse.ArgumentTypeError(f"must be a non-negative integer, got {v}")
    return v


def robot_number(text: str) -> int:
    """An MRCLAM robot number, 1 to 5."""
    v = _int(text)
    if not 1 <= v <= 5:
        raise argparse.ArgumentTypeError(
            f"robot number {v} is out of range: MRCLAM robots are numbered 1 to 5"
        )
    return v


def finite_float(text: str) -> float:
    """Any finite number (no NaN, no infinity)."""
    return _float(text)


def positive_float(text: str) -> float:
    """A finite number greater than 0."""
    v = _float(text)
    if not v > 0.0:
        raise argparse.ArgumentTypeError(f"must be greater than 0, got {text}")
    return v


def positive_named(name: str) -> Callable[[str], float]:
    """:func:`positive_float` whose message names the parameter (``rho_ini``),
    as ``metrics.json`` and ``Config`` call it."""

    def parse(text: str) -> float:
        v = _float(text)
        if not v > 0.0:
            raise argparse.ArgumentTypeError(f"{name} must be greater than 0, got {text}")
        return v

    parse.__name__ = name
    return parse


def non_negative_float(text: str) -> float:
    """A finite number of at least 0."""
    v = _float(text)
    if not v >= 0.0:
        raise argparse.ArgumentTypeError(f"must be at least 0, got {text}")
    return v


def angle_deg(low: float, high: float) -> Callable[[str], float]:
    """An angle in degrees within ``(low, high]``."""

    def parse(text: str) -> float:
        v = _float(text)
        if not low < v <= high:
            raise argparse.ArgumentTypeError(
                f"must be an angle greater than {low:g}° and at most {high:g}°, got {text}"
            )
        return v

    parse.__name__ = "angle_deg"
    return parse


def output_file(text: str) -> Path:
    """A file the command will write: not a directory, in a folder that exists
    (or can be made) and is writable. Checked before any work starts."""
    path = Path(text)
    if not text:
        raise argparse.ArgumentTypeError("an empty path")
    if path.is_dir():
        raise argparse.ArgumentTypeError(f"{text} is a directory; give a file name")
    parent = path.parent
    # The nearest folder that exists must be a writable folder.
    probe = parent
    while not probe.exists() and probe != probe.parent:
        probe = probe.parent
    if probe.exists() and not probe.is_dir():
        raise argparse.ArgumentTypeError(f"cannot write {text}: {probe} is not a directory")
    if probe.exists() and not os.access(probe, os.W_OK | os.X_OK):
        raise argparse.ArgumentTypeError(f"cannot write {text}: {probe} is not writable")
    return path
