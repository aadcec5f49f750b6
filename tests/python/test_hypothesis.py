"""Random sequences of odometry and bearings (NaN, inf and huge values
included) never crash the filter: each call updates it or raises a
BearingSlamError, and the covariance stays finite and symmetric."""

from __future__ import annotations

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import bearing_slam as bs

nasty = st.one_of(
    st.floats(min_value=-5.0, max_value=5.0),
    st.sampled_from([np.nan, np.inf, -np.inf, 1e300, -1e300, 1e12, 0.0, -0.0, 5e-324]),
)
wheel = st.tuples(st.just("wheels"), st.floats(0.0, 0.5), nasty, nasty)
velocity = st.tuples(st.just("velocity"), st.floats(0.0, 0.5), nasty, nasty, nasty)
scan = st.tuples(
    st.just("bearings"),
    st.floats(0.0, 0.5),
    st.lists(st.tuples(st.integers(0, 6), nasty), min_size=0, max_size=5),
)
range_scan = st.tuples(
    st.just("ranges"),
    st.floats(0.0, 0.5),
    st.lists(st.tuples(st.integers(0, 6), nasty, nasty), min_size=0, max_size=4),
)
step = st.one_of(wheel, velocity, scan, range_scan)


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    init=st.sampled_from(["mte", "mte-clone", "pi-sr"]),
    steps=st.lists(step, min_size=1, max_size=40),
    backwards=st.booleans(),
)
def test_random_sequences_never_crash(
    init: str, steps: list[tuple[object, ...]], backwards: bool
) -> None:
    f = bs.SlamFilter(bs.Config(init=init, initial_pose_sigma=(0.01, 0.01, 0.01)))
    t = 0.0
    for s in steps:
        kind, dt = s[0], float(s[1])  # type: ignore[arg-type]
        t = t - dt if backwards and dt > 0.4 else t + dt
        try:
            if kind == "wheels":
                f.predict_wheels(t, float(s[2]), float(s[3]))  # type: ignore[arg-type]
            elif kind == "velocity":
                f.predict_velocity(t, float(s[2]), float(s[3]), float(s[4]))  # type: ignore[arg-type]
            elif kind == "bearings":
                obs = s[2]
                ids = np.array([o[0] for o in obs], dtype=np.uint64)  # type: ignore[attr-defined]
                z = np.array([o[1] for o in obs], dtype=np.float64)  # type: ignore[attr-defined]
                f.update_bearings(t, ids, z)
            else:
                obs = s[2]
                ids = np.array([o[0] for o in obs], dtype=np.uint64)  # type: ignore[attr-defined]
                r = np.array([o[1] for o in obs], dtype=np.float64)  # type: ignore[attr-defined]
                z = np.array([o[2] for o in obs], dtype=np.float64)  # type: ignore[attr-defined]
                f.update_range_bearings(t, ids, r, z)
        except bs.BearingSlamError:
            pass
        p = f.covariance
        assert np.all(np.isfinite(p))
        np.testing.assert_allclose(p, p.T, rtol=0, atol=1e-9 * max(1.0, float(np.abs(p).max())))
        assert np.all(np.isfinite(f.state))
        assert f.pose.shape == (3,)
        f.landmarks()
        f.snapshot()
