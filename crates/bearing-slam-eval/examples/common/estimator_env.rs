//! The estimator of a study, read from the environment: `ESTIMATOR=name`
//! (an `EstimatorKind` name; default the EKF) and, for `gaussian-sum`,
//! `GAUSSIAN_SUM=deg,components` (its split threshold in degrees and its
//! largest number of components).

use bearing_slam_core::estimator::EstimatorConfig;

/// The estimator `ESTIMATOR` and `GAUSSIAN_SUM` name.
///
/// # Errors
/// An unknown estimator name or a malformed `GAUSSIAN_SUM`.
pub fn estimator_from_env() -> Result<EstimatorConfig, String> {
    let mut estimator = EstimatorConfig::default();
    if let Ok(name) = std::env::var("ESTIMATOR") {
        estimator.kind = name.parse().map_err(|e| format!("ESTIMATOR={name}: {e}"))?;
    }
    if let Ok(text) = std::env::var("GAUSSIAN_SUM") {
        let bad = |e: &dyn std::fmt::Display| {
            format!("GAUSSIAN_SUM={text}: {e} (expected deg,components)")
        };
        let (deg, components) = text.split_once(',').ok_or_else(|| bad(&"no comma"))?;
        estimator.gaussian_sum.split_above_rad =
            deg.parse::<f64>().map_err(|e| bad(&e))?.to_radians();
        estimator.gaussian_sum.max_components = components.parse().map_err(|e| bad(&e))?;
    }
    Ok(estimator)
}
