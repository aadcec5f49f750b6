"""``Config(consistency=...)``: the linearization choices (standard, FEJ,
observability-constrained, right-invariant) reach the filter and are the
Rust enum's names."""

from __future__ import annotations

import pytest

import bearing_slam as bs
from bearing_slam import vocabulary


def test_consistency_names_are_the_rust_enum_and_reach_the_filter() -> None:
    assert tuple(bs._native.vocabulary()["consistencies"]) == vocabulary.CONSISTENCIES
    assert vocabulary.CONSISTENCIES == ("standard", "fej", "oc", "invariant")
    assert bs.Config().consistency in vocabulary.CONSISTENCIES
    with pytest.raises(ValueError, match="unknown consistency"):
        bs.Config(consistency="left-invariant")
    log = bs.simulate("paper_fig4", seed=3)
    nees = {}
    for name in vocabulary.CONSISTENCIES:
        config = bs.Config.for_log(log, init="mte", consistency=name)
        assert config.consistency == name
        assert config.to_dict()["consistency"] == name
        summary = bs.run(log, config).summary
        assert summary is not None
        nees[name] = summary["mean_nees_pose"]
    # The option changes the filter: FEJ's Jacobians are not the standard's.
    assert nees["fej"] != nees["standard"]
    assert nees["oc"] != nees["standard"]
    assert nees["invariant"] != nees["standard"]


def test_second_order_reaches_the_filter_and_is_refused_where_unused() -> None:
    """``Config(second_order=True)``: the Gaussian second-order bearing
    update, in the config's dict, changing the run; refused with ranges and
    with FastSLAM, whose updates are first order."""
    log = bs.simulate("paper_fig8", seed=4)
    runs = {}
    for second_order in (False, True):
        config = bs.Config.for_log(log, second_order=second_order)
        assert config.second_order is second_order
        assert config.to_dict()["second_order"] is second_order
        summary = bs.run(log, config).summary
        assert summary is not None
        runs[second_order] = summary
    assert runs[True]["mean_nees_pose"] != runs[False]["mean_nees_pose"]
    assert bs.Config().replace(second_order=True).second_order is True
    with pytest.raises(bs.InvalidParameterError, match="use_range"):
        bs.Config(use_range=True, second_order=not bs.Config().second_order)
    with pytest.raises(bs.InvalidParameterError, match="FastSLAM"):
        bs.Config(estimator="fastslam2", second_order=not bs.Config().second_order)
