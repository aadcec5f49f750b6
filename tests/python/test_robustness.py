"""Robust gating and the bearing-offset state (issue 13 item 3) from Python:
off in the default ``Config()``, set by keyword, round-tripped through
``to_dict``, refused when out of range, and reaching the filter."""

from __future__ import annotations

import math

import pytest

import bearing_slam as bs


def test_defaults_are_off_and_kwargs_reach_the_filter() -> None:
    c = bs.Config()
    assert c.readmit_after is None
    assert c.huber_threshold is None
    assert c.bearing_offset_sigma is None
    robust = bs.Config(readmit_after=3, huber_threshold=2.0, bearing_offset_sigma=0.001)
    d = robust.to_dict()
    assert (d["readmit_after"], d["huber_threshold"]) == (3, 2.0)
    assert d["bearing_offset_sigma"] == 0.001
    with pytest.raises(bs.BearingSlamError, match="huber_threshold"):
        bs.Config(huber_threshold=0.0)
    with pytest.raises(bs.BearingSlamError, match="gate_probability"):
        bs.Config(readmit_after=3, gate_probability=None)


def test_robust_options_change_the_run() -> None:
    log = bs.simulate("paper_fig4", seed=3)
    base = bs.Config.for_log(log, init="mte")
    plain = bs.run(log, base).summary
    offset = bs.run(log, base.replace(bearing_offset_sigma=0.001)).summary
    assert plain is not None
    assert offset is not None
    assert math.isfinite(offset["ate_rmse_m"])
    assert offset["mean_nees_pose"] != plain["mean_nees_pose"]
