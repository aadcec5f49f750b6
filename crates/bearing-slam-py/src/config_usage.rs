//! Which `Config` parameters an initializer, odometry model, estimator or
//! association does not use: `Config(...)` and `replace` refuse a parameter
//! given where it would have no effect, naming why.

use crate::config::{PyConfig, parse_name};
use bearing_slam::core::association::AssociationMethod;
use bearing_slam::core::estimator::EstimatorKind;

impl PyConfig {
    /// Why parameter `key` has no effect with this configuration's
    /// initializer, odometry model or `use_range`, or None when it is used.
    pub(crate) fn unused_because(&self, key: &str) -> Option<String> {
        let pi_sr = matches!(self.init.as_str(), "pi-sr" | "pi-sr-mixed");
        let init = &self.init;
        match key {
            "rho_ini" | "sigma_rho" if !pi_sr && init != "auto" => Some(format!(
                "it is a parameter of PI-SR (init \"pi-sr\", \"pi-sr-mixed\" or \"auto\"), \
                 and init is {init:?}"
            )),
            "per_landmark_priors" if !pi_sr => Some(format!(
                "it is a parameter of PI-SR (init \"pi-sr\" or \"pi-sr-mixed\"), and init is {init:?}"
            )),
            "auto_visits"
            | "auto_max_wait"
            | "auto_stalled_parallax"
            | "auto_insignificant_parallax"
            | "auto_keep_first_ray"
                if init != "auto" =>
            {
                Some(format!(
                    "it is a parameter of the auto initializer (init \"auto\"), and init is {init:?}"
                ))
            }
            "history_correlation" | "history_phi" | "history_sigma" | "history_decimate_every"
                if init != "mte-history" && !(init == "mte-clone" && self.history > 0) =>
            {
                Some(format!(
                    "it is a parameter of the waiting bearings' replay (init \"mte-history\"), \
                     and init is {init:?}"
                ))
            }
            "alpha_min" | "baseline_min" | "beta_min" | "candidate_timeout" | "min_depth"
                if pi_sr =>
            {
                Some(format!(
                    "it is a parameter of MTE's triangulation (init \"mte\", \"mte-clone\", \
                     \"mte-history\" or \"auto\"), and init is {init:?}"
                ))
            }
            "wheel_base" | "wheel_floor_sigma" | "wheel_scale_sqrt"
                if self.odometry != "wheels" =>
            {
                Some(format!(
                    "it is a parameter of the wheel odometry model, and odometry is {:?}",
                    self.odometry
                ))
            }
            "velocity_alpha" | "velocity_sigma_v_min" | "velocity_sigma_omega_min"
                if self.odometry != "velocity" =>
            {
                Some(format!(
                    "it is a parameter of the velocity odometry model, and odometry is {:?}",
                    self.odometry
                ))
            }
            "second_order" if self.use_range => Some(
                "it is an option of the bearing-only update, and use_range is True (the \
                 range-bearing update is first order)"
                    .to_owned(),
            ),
            "second_order"
                if parse_name::<EstimatorKind>(&self.estimator)
                    .is_ok_and(EstimatorKind::is_particle_filter) =>
            {
                Some(format!(
                    "it is an option of the EKF's update, and estimator is {:?} (FastSLAM's \
                     per-landmark filters are first order)",
                    self.estimator
                ))
            }
            "particles"
                if !parse_name::<EstimatorKind>(&self.estimator)
                    .is_ok_and(EstimatorKind::is_particle_filter) =>
            {
                Some(format!(
                    "it is a parameter of FastSLAM (estimator \"fastslam1\" or \"fastslam2\"), \
                     and estimator is {:?}",
                    self.estimator
                ))
            }
            "gaussian_sum_split_deg" | "gaussian_sum_components"
                if parse_name::<EstimatorKind>(&self.estimator)
                    .is_ok_and(|e| e != EstimatorKind::GaussianSum) =>
            {
                Some(format!(
                    "it is a parameter of the heading Gaussian sum (estimator \"gaussian-sum\"), \
                     and estimator is {:?}",
                    self.estimator
                ))
            }
            "online_window" | "landmark_chart"
                if parse_name::<EstimatorKind>(&self.estimator)
                    .is_ok_and(|e| e != EstimatorKind::FilterSmoother) =>
            {
                Some(format!(
                    "it is a parameter of the online smoother (estimator \"filter+smoother\"), \
                     and estimator is {:?}",
                    self.estimator
                ))
            }
            "descriptor_sigma"
            | "moving_object_nis_factor"
            | "moving_object_pair_ratio"
            | "remember_movers"
                if self.association == AssociationMethod::Known.to_string() =>
            {
                Some(
                    "it is a parameter of the association with the ids hidden \
                     (association \"nn\", \"jcbb\" or \"ransac\"), and association is \"known\""
                        .to_owned(),
                )
            }
            "moving_object_nis_factor" | "moving_object_pair_ratio" | "remember_movers"
                if parse_name::<EstimatorKind>(&self.estimator).is_ok_and(|e| {
                    matches!(e, EstimatorKind::FastSlam1 | EstimatorKind::FastSlam2)
                }) =>
            {
                Some(format!(
                    "it is a parameter of the EKF's association (FastSLAM associates per \
                     particle), and estimator is {:?}",
                    self.estimator
                ))
            }
            "remember_movers" if self.moving_object_nis_factor.is_none() => Some(
                "it remembers the landmarks moving_object_nis_factor removes, \
                 and moving_object_nis_factor is None"
                    .to_owned(),
            ),
            "range_sigma" if !self.use_range => {
                Some("it applies to range-bearing runs (use_range=True) only".to_owned())
            }
            _ => None,
        }
    }
}
