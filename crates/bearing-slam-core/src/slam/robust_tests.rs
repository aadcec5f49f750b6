//! Tests of robust gating and the bearing-offset state.
