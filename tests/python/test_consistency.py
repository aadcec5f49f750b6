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
