//! Monte Carlo runner tests.
