//! The descriptive statistics every evaluation uses: means, standard
//! deviations, order statistics, root mean squares and correlations.
//!
//! [`statrs`] computes what it provides (means, variances, covariances,
//! medians and quantiles, each with its numerically stable running
//! algorithm); this module only fixes the conventions the evaluations share:
//! an empty input gives `None` (or NaN where a field must hold a number), a
//! standard deviation is the sample one (`n − 1`) unless its name says
//! population, and quantiles are statrs' median-unbiased estimator (Hyndman
//! & Fan type 8).

use statrs::statistics::{Data, Median, OrderStatistics, Statistics};

/// The arithmetic mean, `None` for no value.
#[must_use]
pub fn mean(values: &[f64]) -> Option<f64> {
    (!values.is_empty()).then(|| values.mean())
}

/// The mean of the values that are present, `None` when none is.
#[must_use]
pub fn mean_of_present(values: impl IntoIterator<Item = Option<f64>>) -> Option<f64> {
    let present: Vec<f64> = values.into_iter().flatten().collect();
    mean(&present)
}

/// The sample standard deviation (`n − 1` in the denominator); 0 for a
/// single value, NaN for none.
#[must_use]
pub fn std_dev(values: &[f64]) -> f64 {
    match values.len() {
        0 => f64::NAN,
        1 => 0.0,
        _ => values.std_dev(),
    }
}

/// The population standard deviation (`n` in the denominator), NaN for no
/// value.
#[must_use]
pub fn population_std_dev(values: &[f64]) -> f64 {
    values.population_std_dev()
}

/// The root mean square `√(Σ x² / n)`, `None` for no value.
#[must_use]
pub fn rms(values: &[f64]) -> Option<f64> {
    (!values.is_empty()).then(|| values.iter().map(|v| v * v).mean().sqrt())
}

/// The median (the mean of the two middle values for an even count), `None`
/// for no value.
#[must_use]
pub fn median(values: &[f64]) -> Option<f64> {
    (!values.is_empty()).then(|| Data::new(values.to_vec()).median())
}

/// The median of the values that are present, `None` when none is.
#[must_use]
pub fn median_of_present(values: impl IntoIterator<Item = Option<f64>>) -> Option<f64> {
    let present: Vec<f64> = values.into_iter().flatten().collect();
    median(&present)
}

/// The `q`-quantile (`0 ≤ q ≤ 1`, type 8), NaN for no value or `q` outside
/// `[0, 1]`.
#[must_use]
pub fn quantile(values: &[f64], q: f64) -> f64 {
    Data::new(values.to_vec()).quantile(q)
}

/// The `q`-quantile of `sorted` (ascending) by nearest rank: the element at
/// index `round((n − 1) q)`, NaN for no value or `q` outside `[0, 1]`.
#[must_use]
pub fn nearest_rank_quantile(sorted: &[f64], q: f64) -> f64 {
    if !(0.0..=1.0).contains(&q) {
        return f64::NAN;
    }
    sorted
        .get(((sorted.len() as f64 - 1.0) * q).round() as usize)
        .copied()
        .unwrap_or(f64::NAN)
}

/// `1.4826 · median(|x − median(x)|)`: the standard deviation of a Gaussian
/// with the same median absolute deviation, robust to outliers; NaN for no
/// value.
#[must_use]
pub fn robust_sigma(values: &[f64]) -> f64 {
    let Some(center) = median(values) else {
        return f64::NAN;
    };
    let deviations: Vec<f64> = values.iter().map(|x| (x - center).abs()).collect();
    median(&deviations).map_or(f64::NAN, |mad| 1.4826 * mad)
}

/// Pearson's correlation of the pairs `(a, b)`: their sample covariance over
/// the product of their sample standard deviations. NaN for fewer than two
/// pairs or a constant coordinate.
#[must_use]
pub fn correlation(pairs: &[(f64, f64)]) -> f64 {
    if pairs.len() < 2 {
        return f64::NAN;
    }
    let (a, b): (Vec<f64>, Vec<f64>) = pairs.iter().copied().unzip();
    let (a, b) = (a.as_slice(), b.as_slice());
    a.covariance(b) / (a.std_dev() * b.std_dev())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn empty_inputs_have_no_statistic() {
        assert_eq!(mean(&[]), None);
        assert_eq!(mean_of_present([None, None]), None);
        assert_eq!(median(&[]), None);
        assert_eq!(rms(&[]), None);
        assert!(std_dev(&[]).is_nan());
        assert!(quantile(&[], 0.5).is_nan());
        assert!(robust_sigma(&[]).is_nan());
        assert!(correlation(&[(1.0, 2.0)]).is_nan());
    }

    #[test]
    fn statistics_of_a_small_sample() {
        let x = [1.0, 2.0, 3.0, 4.0];
        assert!((mean(&x).unwrap_or(f64::NAN) - 2.5).abs() < 1e-15);
        assert_eq!(median(&x), Some(2.5));
        assert_eq!(median(&[3.0, 1.0, 2.0]), Some(2.0));
        assert_eq!(median_of_present([Some(4.0), None, Some(2.0)]), Some(3.0));
        // Sample variance 5/3, population variance 5/4.
        assert!((std_dev(&x) - (5.0f64 / 3.0).sqrt()).abs() < 1e-15);
        assert!((population_std_dev(&x) - 1.25f64.sqrt()).abs() < 1e-15);
        assert_eq!(std_dev(&[7.0]), 0.0);
        assert!((rms(&[3.0, 4.0]).unwrap_or(f64::NAN) - 12.5f64.sqrt()).abs() < 1e-15);
        assert_eq!(quantile(&x, 0.0), 1.0);
        assert_eq!(nearest_rank_quantile(&x, 0.5), 3.0);
        assert_eq!(nearest_rank_quantile(&x, 0.1), 1.0);
        assert!(nearest_rank_quantile(&[], 0.5).is_nan());
        assert_eq!(quantile(&x, 1.0), 4.0);
        assert!((quantile(&x, 0.5) - 2.5).abs() < 1e-15);
        // |x − 2.5| = 1.5, 0.5, 0.5, 1.5: MAD 1.
        assert!((robust_sigma(&x) - 1.4826).abs() < 1e-15);
    }

    #[test]
    fn correlation_is_pearsons() {
        let line: Vec<(f64, f64)> = (0..5)
            .map(|i| (f64::from(i), 3.0 - 2.0 * f64::from(i)))
            .collect();
        assert!((correlation(&line) + 1.0).abs() < 1e-12);
        let pairs = [(1.0, 2.0), (2.0, 1.0), (3.0, 4.0), (4.0, 3.0)];
        // Sample covariance 1, sample variances 5/3 each: ρ = 0.6.
        assert!((correlation(&pairs) - 0.6).abs() < 1e-12);
        assert!(correlation(&[(1.0, 2.0), (1.0, 3.0)]).is_nan());
    }
}
