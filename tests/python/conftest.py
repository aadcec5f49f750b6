"""Shared fixtures: one simulated paper_fig4 log and its MTE run."""

from __future__ import annotations

import pytest

import bearing_slam as bs


@pytest.fixture(scope="session")
def fig4_log() -> bs.SensorLog:
    return bs.simulate("paper_fig4", seed=3)


@pytest.fixture(scope="session")
def fig4_result(fig4_log: bs.SensorLog) -> bs.RunResult:
    return bs.run(fig4_log, bs.Config.for_log(fig4_log, init="mte"))
