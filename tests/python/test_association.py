"""Data association's faces (issue 16): ``Config(association=...)``,
``RunResult.association`` and ``metrics.json["association"]``."""

from __future__ import annotations

import pytest

import bearing_slam as bs
from bearing_slam.vocabulary import ASSOCIATIONS


@pytest.fixture(scope="module")
def short_log() -> bs.SensorLog:
    return bs.simulate("paper_fig4", seed=3).head(25.0)


def test_the_associations_are_named_in_rust() -> None:
    assert ASSOCIATIONS == ("known", "nn", "jcbb")
    assert bs.Config().association == "known"


def test_hidden_ids_are_associated_and_scored(short_log: bs.SensorLog) -> None:
    config = bs.Config.for_log(short_log)
    known = bs.run(short_log, config)
    assert known.association is None
    jcbb = bs.run(short_log, config.replace(association="jcbb"))
    assert jcbb.config.association == "jcbb"
    score = jcbb.association
    assert score is not None
    assert score["mapped"] > 0
    assert score["spurious"] == 0
    assert 0.9 <= score["precision"] <= 1.0


def test_a_bad_association_name_lists_the_known_ones() -> None:
    with pytest.raises(ValueError, match="known, nn, jcbb"):
        bs.Config(association="nearest").validate()


def test_fastslam_associates_per_particle_and_is_scored(short_log: bs.SensorLog) -> None:
    config = bs.Config.for_log(short_log).replace(
        estimator="fastslam2", particles=20, association="nn"
    )
    result = bs.run(short_log, config)
    assert result.config.association == "nn"
    score = result.association
    assert score is not None
    assert score["mapped"] > 0
    assert score["spurious"] == 0
    assert 0.9 <= score["precision"] <= 1.0


def test_fastslam_refuses_jcbb_and_the_smoothers_refuse_hidden_ids(
    short_log: bs.SensorLog,
) -> None:
    config = bs.Config.for_log(short_log)
    with pytest.raises(ValueError, match="jcbb is not implemented for FastSLAM"):
        bs.run(short_log, config.replace(estimator="fastslam2", association="jcbb"))
    for estimator in ("smoother", "filter+smoother"):
        with pytest.raises(ValueError, match="the smoothers need `known`"):
            bs.run(short_log, config.replace(estimator=estimator, association="nn"))
