//! The simulator's error type: every fallible public function returns
//! [`SimError`]; nothing on a data path panics.

use bearing_slam_core::SlamError;
use bearing_slam_core::error::readable_number;
use std::path::PathBuf;
use thiserror::Error;

/// Everything that can go wrong while loading, validating or running a
/// scenario, each variant naming the offending input.
#[derive(Debug, Error)]
pub enum SimError {
    /// A scenario file that cannot be read.
    #[error("cannot read scenario file {path}: {source}")]
    Io {
        /// The file that was asked for.
        path: PathBuf,
        /// The operating system's reason.
        #[source]
        source: std::io::Error,
    },
    /// A scenario text that is not valid TOML/JSON or does not match the
    /// scenario format (unknown field, wrong type, missing value).
    #[error("cannot parse {format} scenario: {message}")]
    Parse {
        /// `"toml"` or `"json"`.
        format: &'static str,
        /// The parser's message (with line and column when it has them).
        message: String,
    },
    /// A file extension that is neither `.toml` nor `.json`.
    #[error("unknown scenario file type {path}: expected a .toml or .json file")]
    UnknownFormat {
        /// The file that was asked for.
        path: PathBuf,
    },
    /// A scenario name that [`crate::scenario_names`] does not list.
    #[error("unknown scenario {name:?}; known scenarios: {known}")]
    UnknownScenario {
        /// The name that was asked for.
        name: String,
        /// The known names, comma separated.
        known: String,
    },
    /// A number outside its valid range (negative mass, μ < 0, σ ≤ 0, NaN, …).
    #[error("invalid parameter {name} = {}: {reason}", readable_number(*value))]
    InvalidParameter {
        /// Where the parameter lives, e.g. `robot.mass_kg`.
        name: String,
        /// The value received.
        value: f64,
        /// What the valid range is.
        reason: &'static str,
    },
    /// A size, rate, count or duration beyond the bounds of
    /// [`crate::limits`] (a run that would take hours or exhaust memory).
    #[error("{name} = {} is out of range: {allowed}", readable_number(*value))]
    OutOfRange {
        /// Where the parameter lives, e.g. `controller.repeat`.
        name: String,
        /// The value received.
        value: f64,
        /// The allowed range.
        allowed: String,
    },
    /// A scenario that is inconsistent as a whole (empty path, duplicate
    /// landmark id, option that does not apply, …).
    #[error("invalid scenario: {0}")]
    InvalidScenario(String),
    /// The physics produced a non-finite state (should not happen with valid
    /// parameters; reported instead of a panic).
    #[error("simulation diverged at t = {time} s: {what}")]
    Diverged {
        /// Simulated time of the failure, seconds.
        time: f64,
        /// What became non-finite.
        what: &'static str,
    },
    /// The produced log failed the core's validation.
    #[error("invalid sensor log: {0}")]
    Log(#[from] SlamError),
}

/// The simulator's result type.
pub type Result<T> = std::result::Result<T, SimError>;

/// Returns `value` if it is finite, otherwise [`SimError::InvalidParameter`].
pub(crate) fn check_finite(name: &str, value: f64) -> Result<f64> {
    if value.is_finite() {
        Ok(value)
    } else {
        Err(invalid(name, value, "must be finite"))
    }
}

/// Returns `value` if it is finite and `> 0`, otherwise [`SimError::InvalidParameter`].
pub(crate) fn check_positive(name: &str, value: f64) -> Result<f64> {
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(invalid(name, value, "must be positive and finite"))
    }
}

/// Returns `value` if it is finite and `>= 0`, otherwise [`SimError::InvalidParameter`].
pub(crate) fn check_non_negative(name: &str, value: f64) -> Result<f64> {
    if value.is_finite() && value >= 0.0 {
        Ok(value)
    } else {
        Err(invalid(name, value, "must be non-negative and finite"))
    }
}

/// Returns `value` if it is a probability in `[0, 1)`, otherwise [`SimError::InvalidParameter`].
pub(crate) fn check_probability(name: &str, value: f64) -> Result<f64> {
    if value.is_finite() && (0.0..1.0).contains(&value) {
        Ok(value)
    } else {
        Err(invalid(name, value, "must be a probability in [0, 1)"))
    }
}

/// Builds an [`SimError::InvalidParameter`].
pub(crate) fn invalid(name: &str, value: f64, reason: &'static str) -> SimError {
    SimError::InvalidParameter {
        name: name.to_owned(),
        value,
        reason,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A fuzzer's value reads as `1e300`, an everyday one as it was typed.
    #[test]
    fn messages_show_huge_and_tiny_values_in_scientific_notation() {
        let out = |value: f64| {
            SimError::OutOfRange {
                name: "duration_s".into(),
                value,
                allowed: "0 to 86400".into(),
            }
            .to_string()
        };
        assert_eq!(out(1e300), "duration_s = 1e300 is out of range: 0 to 86400");
        assert_eq!(
            out(-2.5e-9),
            "duration_s = -2.5e-9 is out of range: 0 to 86400"
        );
        assert_eq!(
            out(1e9),
            "duration_s = 1000000000 is out of range: 0 to 86400"
        );
        assert_eq!(out(0.25), "duration_s = 0.25 is out of range: 0 to 86400");
        assert_eq!(
            out(f64::INFINITY),
            "duration_s = inf is out of range: 0 to 86400"
        );
        let invalid = invalid("robot.mass_kg", -1e20, "must be positive").to_string();
        assert_eq!(
            invalid,
            "invalid parameter robot.mass_kg = -1e20: must be positive"
        );
    }
}
