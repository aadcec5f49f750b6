//! Robust kernels: the loss `ρ(s)` applied to a measurement factor's squared
//! whitened error `s = ‖e‖²`, solved by iteratively reweighted least squares
//! (each Gauss–Newton step weighs the factor by `ρ'(s)`).

use crate::error::{Result, SlamError};

/// The loss applied to each measurement factor (bearing, range-bearing).
/// Odometry and priors always use plain least squares.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub enum RobustKernel {
    /// `ρ(s) = s`: plain least squares.
    #[default]
    None,
    /// Huber with threshold `k` (in standard deviations of the whitened
    /// error): `ρ(s) = s` for `√s ≤ k`, `2k√s − k²` beyond.
    Huber(f64),
    /// Cauchy (Lorentzian) with scale `c`: `ρ(s) = c² ln(1 + s/c²)`.
    Cauchy(f64),
}

impl RobustKernel {
    /// Checks the kernel's parameter (finite and > 0).
    pub fn validate(&self) -> Result<()> {
        match *self {
            RobustKernel::None => Ok(()),
            RobustKernel::Huber(k) | RobustKernel::Cauchy(k) => {
                if k.is_finite() && k > 0.0 {
                    Ok(())
                } else {
                    Err(SlamError::InvalidParameter {
                        name: "robust kernel threshold",
                        value: k,
                        reason: "must be finite and > 0",
                    })
                }
            }
        }
    }

    /// `ρ(s)` for a squared whitened error `s ≥ 0`; the factor's cost is `½ρ(s)`.
    #[must_use]
    pub fn loss(&self, s: f64) -> f64 {
        match *self {
            RobustKernel::None => s,
            RobustKernel::Huber(k) => {
                let r = s.sqrt();
                if r <= k { s } else { 2.0 * k * r - k * k }
            }
            RobustKernel::Cauchy(c) => c * c * (s / (c * c)).ln_1p(),
        }
    }

    /// The IRLS weight `ρ'(s)` (1 for least squares, < 1 for outliers).
    #[must_use]
    pub fn weight(&self, s: f64) -> f64 {
        match *self {
            RobustKernel::None => 1.0,
            RobustKernel::Huber(k) => {
                let r = s.sqrt();
                if r <= k { 1.0 } else { k / r }
            }
            RobustKernel::Cauchy(c) => 1.0 / (1.0 + s / (c * c)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn losses_and_weights_match_their_closed_forms() {
        let none = RobustKernel::None;
        assert_eq!((none.loss(9.0), none.weight(9.0)), (9.0, 1.0));
        // Huber(1): quadratic up to |e| = 1, then 2k|e| − k².
        let huber = RobustKernel::Huber(1.0);
        assert_eq!((huber.loss(0.25), huber.weight(0.25)), (0.25, 1.0));
        assert_eq!((huber.loss(4.0), huber.weight(4.0)), (3.0, 0.5));
        // Cauchy(2): c² ln(1 + s/c²), weight 1/(1 + s/c²).
        let cauchy = RobustKernel::Cauchy(2.0);
        assert!((cauchy.loss(4.0) - 4.0 * 2f64.ln()).abs() < 1e-15);
        assert_eq!(cauchy.weight(4.0), 0.5);
        // (c = 3, where c·c and c + c differ.)
        let cauchy3 = RobustKernel::Cauchy(3.0);
        assert!((cauchy3.loss(9.0) - 9.0 * 2f64.ln()).abs() < 1e-14);
        assert_eq!(cauchy3.weight(9.0), 0.5);
        // The weight is ρ'(s), and both kernels are continuous at their knee.
        for kernel in [huber, cauchy, RobustKernel::Huber(2.5)] {
            for s in [0.3, 1.0 + 1e-3, 4.0, 30.0] {
                let h = 1e-6 * s;
                let slope = (kernel.loss(s + h) - kernel.loss(s - h)) / (2.0 * h);
                assert!((slope - kernel.weight(s)).abs() < 1e-6, "{kernel:?} at {s}");
            }
        }
        let k = 2.5;
        let knee = RobustKernel::Huber(k);
        assert!((knee.loss(k * k * (1.0 + 1e-12)) - knee.loss(k * k)).abs() < 1e-9);
    }
}
