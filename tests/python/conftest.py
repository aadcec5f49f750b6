"""Shared fixtures and helpers: one simulated paper_fig4 log and its MTE
run, the CLI in a subprocess (:func:`cli`), and a local Dask cluster."""

from __future__ import annotations

import importlib
import os
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from hypothesis import settings

import bearing_slam as bs

# Hypothesis draws its examples from a fixed seed in `make test`, so that CI
# judges the same cases every run; `make proptest-explore` sets
# BEARING_SLAM_EXPLORE=1 to search fresh random examples instead.
settings.register_profile("deterministic", derandomize=True)
settings.register_profile("explore", derandomize=False)
settings.load_profile("explore" if os.environ.get("BEARING_SLAM_EXPLORE") else "deterministic")


def cli(
    *args: str | Path, cwd: Path | None = None, timeout: float = 600
) -> subprocess.CompletedProcess[str]:
    """``python -m bearing_slam ARGS`` in a subprocess (the command a user
    types), its output captured as text; never raises on a non-zero exit."""
    return subprocess.run(
        [sys.executable, "-m", "bearing_slam", *map(str, args)],
        capture_output=True,
        text=True,
        timeout=timeout,
        check=False,
        cwd=cwd,
    )


@pytest.fixture(scope="session")
def fig4_log() -> bs.SensorLog:
    return bs.simulate("paper_fig4", seed=3)


@pytest.fixture(scope="session")
def fig4_result(fig4_log: bs.SensorLog) -> bs.RunResult:
    return bs.run(fig4_log, bs.Config.for_log(fig4_log, init="mte"))


@pytest.fixture(scope="session")
def dask_client() -> Iterator[Any]:
    """A ``distributed.Client`` of a local cluster of two worker processes
    (not threads: a task and its result really cross a process boundary by
    pickling, as on a remote cluster), started once for the session on
    loopback (a few seconds)."""
    distributed = importlib.import_module("distributed")  # installed by the dev/test extras
    with (
        distributed.LocalCluster(
            n_workers=2,
            threads_per_worker=1,
            processes=True,
            dashboard_address=None,
            host="127.0.0.1",
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        yield client
