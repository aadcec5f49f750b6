//! Statistics shared by the estimator and its scoring: χ² quantiles and the
//! confidence band of an averaged NEES or NIS, on `statrs`. The filter's
//! chi-square gate ([`crate::slam`]) and the consistency metrics
//! ([`crate::metrics`]) both take their thresholds from here, so that the
//! estimator does not depend on the scoring module.

use crate::error::{Result, SlamError};
use statrs::distribution::{ChiSquared, Continuous, ContinuousCDF};
use statrs::function::gamma::ln_gamma;

/// Smallest degrees of freedom [`chi2_quantile`] accepts.
pub const CHI2_MIN_DOF: f64 = 0.1;
/// Largest degrees of freedom [`chi2_quantile`] accepts.
pub const CHI2_MAX_DOF: f64 = 1e7;
/// [`chi2_quantile`] accepts probabilities in
/// `[CHI2_MIN_TAIL, 1 − CHI2_MIN_TAIL]`.
pub const CHI2_MIN_TAIL: f64 = 1e-12;

/// The `p`-quantile of the χ² distribution with `dof` degrees of freedom:
/// e.g. `chi2_quantile(1.0, 0.99)` ≈ 6.635 gates a single bearing at 99 %.
///
/// statrs' `ChiSquared` inverse CDF gives the first estimate, polished by
/// safeguarded Newton steps on its CDF (with a series for the far lower
/// tail, where statrs' CDF rounds to 0) to a relative accuracy of about 1e-13.
/// The accepted domain ([`CHI2_MIN_DOF`] ≤ `dof` ≤ [`CHI2_MAX_DOF`],
/// [`CHI2_MIN_TAIL`] ≤ `p` ≤ 1 − [`CHI2_MIN_TAIL`]) keeps statrs away from
/// the underflows where it panics; it is far wider than any NEES, NIS or gate
/// needs.
///
/// # Errors
/// [`SlamError::InvalidParameter`] for `dof` or `p` outside that domain
/// (including NaN).
pub fn chi2_quantile(dof: f64, p: f64) -> Result<f64> {
    if !((CHI2_MIN_DOF..=CHI2_MAX_DOF).contains(&dof)) {
        return Err(SlamError::InvalidParameter {
            name: "dof",
            value: dof,
            reason: "must be in [0.1, 1e7]",
        });
    }
    if !((CHI2_MIN_TAIL..=1.0 - CHI2_MIN_TAIL).contains(&p)) {
        return Err(SlamError::InvalidParameter {
            name: "p",
            value: p,
            reason: "must be in [1e-12, 1 - 1e-12]",
        });
    }
    let dist = ChiSquared::new(dof).map_err(|_| SlamError::InvalidParameter {
        name: "dof",
        value: dof,
        reason: "must be in [0.1, 1e7]",
    })?;
    // In this domain the quantile is above 1e-240: bracket it in
    // [1e-280, hi] so that no CDF is evaluated at an underflowing point.
    let floor = 1e-280_f64;
    let guess = dist.inverse_cdf(p);
    let mut x = if guess.is_finite() && guess > floor {
        guess
    } else {
        dof
    };
    let mut hi = x.max(1.0);
    while chi2_cdf(&dist, dof, hi) < p {
        hi *= 2.0;
    }
    // Safeguarded Newton on G(u) = ln F(eᵘ) − ln p, u = ln x: nearly linear
    // in the lower tail (F ≈ c xᵃ), where Newton in x would crawl. Steps
    // leaving the bracket fall back to bisection in u.
    let (mut lo_u, mut hi_u) = (floor.ln(), hi.ln());
    let ln_p = p.ln();
    for _ in 0..200 {
        let f = chi2_cdf(&dist, dof, x);
        let g = f.ln() - ln_p;
        if g == 0.0 {
            break;
        }
        let u = x.ln();
        if g < 0.0 {
            lo_u = lo_u.max(u);
        } else {
            hi_u = hi_u.min(u);
        }
        let slope = x * dist.pdf(x) / f;
        let newton = u - g / slope;
        let next = if slope.is_finite() && slope > 0.0 && newton > lo_u && newton < hi_u {
            newton
        } else {
            0.5 * (lo_u + hi_u)
        };
        let done = (next - u).abs() <= 1e-14 || hi_u - lo_u <= 1e-14;
        x = next.exp();
        if done {
            break;
        }
    }
    Ok(x)
}

/// The χ² CDF: statrs' for `x ≥ 2e-3`; below, the power series of the
/// regularized lower incomplete gamma function `P(a, y)`, `a = dof/2`,
/// `y = x/2`: `P = yᵃ e⁻ʸ / Γ(a+1) · Σₙ yⁿ / ((a+1)…(a+n))`, accurate to
/// relative 1e-15 where statrs rounds tiny arguments to a CDF of 0.
fn chi2_cdf(dist: &ChiSquared, dof: f64, x: f64) -> f64 {
    let (a, y) = (0.5 * dof, 0.5 * x);
    if y >= 1e-3 {
        return dist.cdf(x);
    }
    if y <= 0.0 {
        return 0.0;
    }
    let (mut term, mut sum) = (1.0, 1.0);
    let mut n = 1.0;
    while term > 1e-17 * sum && n < 100.0 {
        term *= y / (a + n);
        sum += term;
        n += 1.0;
    }
    (a * y.ln() - y - ln_gamma(a + 1.0)).exp() * sum
}

/// The two-sided `confidence` interval for the **average** of `runs`
/// independent NEES (or NIS) values of `dof` dimensions each: the sum of the
/// runs is χ²(`runs·dof`), so the bounds are its `(1 ∓ confidence)/2`
/// quantiles divided by `runs` (Bar-Shalom et al.). E.g. `(2, 50, 0.95)` gives
/// `(74.22/50, 129.56/50) = (1.484, 2.591)`.
///
/// # Errors
/// [`SlamError::InvalidParameter`] unless `runs >= 1`,
/// `0 < confidence < 1` and `dof` and `runs·dof` and the tails
/// `(1 ∓ confidence)/2` are in [`chi2_quantile`]'s domain.
pub fn chi2_interval(dof: f64, runs: usize, confidence: f64) -> Result<(f64, f64)> {
    if runs == 0 {
        return Err(SlamError::InvalidParameter {
            name: "runs",
            value: 0.0,
            reason: "must be >= 1",
        });
    }
    if !(confidence > 0.0 && confidence < 1.0) {
        return Err(SlamError::InvalidParameter {
            name: "confidence",
            value: confidence,
            reason: "must be in (0, 1)",
        });
    }
    if !(CHI2_MIN_DOF..=CHI2_MAX_DOF).contains(&dof) {
        return Err(SlamError::InvalidParameter {
            name: "dof",
            value: dof,
            reason: "must be in [0.1, 1e7]",
        });
    }
    let runs = runs as f64;
    let total = runs * dof;
    let tail = 0.5 * (1.0 - confidence);
    let lower = chi2_quantile(total, tail)? / runs;
    let upper = chi2_quantile(total, 1.0 - tail)? / runs;
    // For a confidence near 0 both tails are near the median and the two
    // quantiles (each accurate to ~1e-13 relative) can cross by a rounding
    // error (χ²(2.1e6), confidence 1e-12: by 1e-11 absolute): keep the order.
    Ok((lower.min(upper), lower.max(upper)))
}
