//! The one error type of the core. Every public operation that reads user data
//! returns [`Result`]; nothing on a data path panics.

use thiserror::Error;

/// Everything that can go wrong in the estimator, each variant naming the
/// offending input.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum SlamError {
    /// A NaN or infinite number where a finite one is required.
    #[error("non-finite {what}: {}", readable_number(*value))]
    NonFinite {
        /// Which input was not finite.
        what: &'static str,
        /// The value received.
        value: f64,
    },
    /// A variance or standard deviation that is zero, negative or not finite.
    #[error("invalid noise for {what}: {} (must be positive and finite)", readable_number(*value))]
    InvalidNoise {
        /// Which noise parameter.
        what: &'static str,
        /// The value received.
        value: f64,
    },
    /// A parameter outside its valid range.
    #[error("invalid parameter {name} = {}: {reason}", readable_number(*value))]
    InvalidParameter {
        /// The parameter's name.
        name: &'static str,
        /// The value received.
        value: f64,
        /// What the valid range is.
        reason: &'static str,
    },
    /// Arrays or matrices of the wrong size.
    #[error("dimension mismatch in {what}: expected {expected}, got {got}")]
    DimensionMismatch {
        /// Which input had the wrong size.
        what: &'static str,
        /// The size required.
        expected: usize,
        /// The size received.
        got: usize,
    },
    /// A landmark id that the filter does not hold.
    #[error("unknown landmark id {0}")]
    UnknownLandmark(u64),
    /// The same landmark id twice in one batch.
    #[error("landmark id {0} appears twice in one batch of measurements")]
    DuplicateMeasurement(u64),
    /// An innovation covariance (or another matrix that must be) not positive
    /// definite.
    #[error("{what} is not positive definite")]
    NotPositiveDefinite {
        /// Which matrix.
        what: &'static str,
    },
    /// A landmark whose inverse depth is not positive has no Euclidean point.
    #[error("landmark {id} has inverse depth {rho} <= 0: its point is at or beyond infinity")]
    LandmarkAtInfinity {
        /// The landmark id.
        id: u64,
        /// Its inverse depth.
        rho: f64,
    },
    /// Time stamps that run backwards.
    #[error("time went backwards: {current} s after {previous} s")]
    TimeOrder {
        /// The last accepted time.
        previous: f64,
        /// The offending time.
        current: f64,
    },
    /// Geometry where a quantity is undefined (a landmark at the sensor,
    /// parallel rays, a point behind the sensor).
    #[error("degenerate geometry: {0}")]
    Degenerate(&'static str),
    /// The estimate left the range where it means anything (an absurd
    /// odometry step, a corrupt log): refused before it entered the filter.
    #[error("filter would diverge: {what} = {value:e}")]
    Diverged {
        /// Which quantity.
        what: &'static str,
        /// Its value.
        value: f64,
    },
    /// Two estimates or sequences that must align but do not.
    #[error("cannot compare: {0}")]
    Mismatch(&'static str),
    /// A name that is not one of its enum's (an initializer, an update form).
    #[error(transparent)]
    UnknownName(#[from] crate::names::UnknownName),
}

/// The core's result type.
pub type Result<T> = std::result::Result<T, SlamError>;

/// Checks `(name, value, in_range)` triples in order: the first value out of
/// its range, or not finite, becomes [`SlamError::InvalidParameter`].
pub fn ensure_in_range(checks: &[(&'static str, f64, bool)]) -> Result<()> {
    match checks
        .iter()
        .find(|(_, value, ok)| !(*ok && value.is_finite()))
    {
        Some(&(name, value, _)) => Err(SlamError::InvalidParameter {
            name,
            value,
            reason: "out of range",
        }),
        None => Ok(()),
    }
}

/// A value as a message shows it: plain decimals for everyday sizes, and
/// scientific notation beyond them (`1e300`, not three hundred digits).
#[must_use]
pub fn readable_number(value: f64) -> String {
    let magnitude = value.abs();
    if magnitude != 0.0 && magnitude.is_finite() && !(1e-6..1e15).contains(&magnitude) {
        format!("{value:e}")
    } else {
        format!("{value}")
    }
}

/// Returns `value` if it is finite, otherwise a [`SlamError::NonFinite`] naming `what`.
pub fn ensure_finite(what: &'static str, value: f64) -> Result<f64> {
    if value.is_finite() {
        Ok(value)
    } else {
        Err(SlamError::NonFinite { what, value })
    }
}

/// Returns `value` if it is finite and strictly positive, otherwise a
/// [`SlamError::InvalidNoise`] naming `what`.
pub fn ensure_positive_noise(what: &'static str, value: f64) -> Result<f64> {
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(SlamError::InvalidNoise { what, value })
    }
}
