//! `Config`: every parameter of a run (filter, initializer, odometry model)
//! as plain Python attributes with the paper's defaults, converted to the
//! core's `RunConfig` when a filter or a run needs it (`config_convert`).

use crate::errors::SlamResultExt;
use crate::log::PySensorLog;
use bearing_slam::core::estimator::{EstimatorConfig, EstimatorKind};
use bearing_slam::core::init::{InverseDepthPrior, TriangulationConfig, UndelayedFallback};
use bearing_slam::core::names::Named;
use bearing_slam::core::runner::OdometryKind;
use bearing_slam::core::slam::BearingOffset;
use bearing_slam::core::slam::SlamConfig;
use bearing_slam::core::smoother::{OnlineWindow, SmootherConfig};
use bearing_slam::{DEFAULT_VELOCITY_NOISE, DEFAULT_WHEEL_NOISE};
use pyo3::exceptions::{PyOverflowError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};
use std::collections::BTreeMap;

/// A name parsed into its enum, or Python's `ValueError` listing the known names.
pub(crate) fn parse_name<T: Named>(name: &str) -> PyResult<T> {
    T::from_name(name).map_err(|e| PyValueError::new_err(e.to_string()))
}

/// Configuration of a bearing-only SLAM run.
#[pyclass(module = "bearing_slam", name = "Config", from_py_object)]
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct PyConfig {
    /// The initializer's name (`InitializerKind`: `"mte"`, `"mte-clone"`,
    /// `"mte-history"`, `"pi-sr"`; `"pi-sr-mixed"` needs the far landmarks'
    /// ids, given as `per_landmark_priors`).
    #[pyo3(get, set)]
    pub init: String,
    /// Bearing noise σ, rad.
    #[pyo3(get, set)]
    pub bearing_sigma: f64,
    /// Range noise σ, m (range-bearing runs only).
    #[pyo3(get, set)]
    pub range_sigma: f64,
    /// Initial pose `(x, y, θ)` (a log's own initial pose wins in `run`).
    #[pyo3(get, set)]
    pub initial_pose: (f64, f64, f64),
    /// Initial pose σ `(σx, σy, σθ)`.
    #[pyo3(get, set)]
    pub initial_pose_sigma: (f64, f64, f64),
    /// Mahalanobis gate probability, or None for no gate.
    #[pyo3(get, set)]
    pub gate_probability: Option<f64>,
    /// Linearity-index threshold for inverse depth → Euclidean, in (0, 1]
    /// (Civera et al. use 0.1), or None.
    #[pyo3(get, set)]
    pub conversion_threshold: Option<f64>,
    /// The conversion also waits for its own linearity, `2 σ_ρ/ρ` below
    /// the threshold (default True; False: Civera et al.'s test alone).
    #[pyo3(get, set)]
    pub conversion_depth_linearity: bool,
    /// `"symmetric"` (default, the optimal-gain form) or `"joseph"`.
    #[pyo3(get, set)]
    pub covariance_update: String,
    /// `"full"` (default) or `"compressed"` (Guivant & Nebot's compressed
    /// EKF: local updates, one global update per region change).
    #[pyo3(get, set)]
    pub update: String,
    /// Where the filter's Jacobians are evaluated (`Consistency`):
    /// `"standard"` (the latest estimate), `"fej"` (first estimates),
    /// `"oc"` (observability-constrained) or `"invariant"` (the
    /// right-invariant EKF).
    #[pyo3(get, set)]
    pub consistency: String,
    /// Linearizations per scan update: 1 (default) is the EKF, more the
    /// iterated EKF.
    #[pyo3(get, set)]
    pub update_iterations: usize,
    /// The Gaussian second-order filter's bearing update (the prediction's
    /// curvature over P added to its mean and variance): True, the default
    /// since 2026-11-29; False: the paper's first-order EKF update.
    #[pyo3(get, set)]
    pub second_order: bool,
    /// MTE: minimum parallax α_min, rad.
    #[pyo3(get, set)]
    pub alpha_min: f64,
    /// MTE: minimum baseline b_min for the far rule, m.
    #[pyo3(get, set)]
    pub baseline_min: f64,
    /// MTE: minimum β for the far rule, rad.
    #[pyo3(get, set)]
    pub beta_min: f64,
    /// MTE: candidate timeout, s.
    #[pyo3(get, set)]
    pub candidate_timeout: f64,
    /// MTE: minimum depth of a triangulated landmark, m.
    #[pyo3(get, set)]
    pub min_depth: f64,
    /// MTE-clone: bearings kept per waiting candidate (each with its pose
    /// cloned) and applied once the landmark is in; 0 discards them (the paper).
    #[pyo3(get, set)]
    pub history: usize,
    /// auto: visits of a landmark that end without the parallax to
    /// triangulate before it enters undelayed with `(rho_ini, sigma_rho)`
    /// (≥ 1, default 1).
    #[pyo3(get, set)]
    pub auto_visits: usize,
    /// auto: longest a landmark waits for the parallax before it enters
    /// undelayed, s (> 0); None (default): no wait budget.
    #[pyo3(get, set)]
    pub auto_max_wait: Option<f64>,
    /// auto: a landmark whose parallax stalls (it could not reach
    /// `alpha_min` within `candidate_timeout` at the fastest rate its
    /// observed value allows) enters undelayed at once (default True since
    /// 2026-11-29; False waits for the visit to expire).
    #[pyo3(get, set)]
    pub auto_stalled_parallax: bool,
    /// auto: with a bearing σ above `alpha_min / (3√2)` the parallax test
    /// is decided by the noise, and every landmark enters undelayed at its
    /// first sighting (default True; False triangulates at any noise).
    #[pyo3(get, set)]
    pub auto_insignificant_parallax: bool,
    /// auto: a candidate whose visit ends without parallax keeps its first
    /// ray (a clone of the pose it was seen from) for the landmark's next
    /// visit, which triangulates against it or applies it once the depth
    /// is bounded, instead of dropping it.
    #[pyo3(get, set)]
    pub auto_keep_first_ray: bool,
    /// PI-SR (and auto's undelayed entry): initial inverse depth ρ_ini, 1/m.
    #[pyo3(get, set)]
    pub rho_ini: f64,
    /// PI-SR (and auto's undelayed entry): σ_ρ, 1/m.
    #[pyo3(get, set)]
    pub sigma_rho: f64,
    /// PI-SR: per-landmark `(ρ_ini, σ_ρ)` by id.
    #[pyo3(get, set)]
    pub per_landmark_priors: BTreeMap<u64, (f64, f64)>,
    /// `"wheels"` or `"velocity"`.
    #[pyo3(get, set)]
    pub odometry: String,
    /// Wheel base, m.
    #[pyo3(get, set)]
    pub wheel_base: f64,
    /// Wheel noise floor σ, m.
    #[pyo3(get, set)]
    pub wheel_floor_sigma: f64,
    /// Wheel noise growth, √m.
    #[pyo3(get, set)]
    pub wheel_scale_sqrt: f64,
    /// Velocity model α1..α6.
    #[pyo3(get, set)]
    pub velocity_alpha: (f64, f64, f64, f64, f64, f64),
    /// Velocity floor σ_v, m/s.
    #[pyo3(get, set)]
    pub velocity_sigma_v_min: f64,
    /// Velocity floor σ_ω, rad/s.
    #[pyo3(get, set)]
    pub velocity_sigma_omega_min: f64,
    /// Use the ranges too (range-bearing reference filter).
    #[pyo3(get, set)]
    pub use_range: bool,
    // --- The waiting bearings' correlation (issue 13 item 2) ---
    /// MTE-history: how the replay treats the correlated errors of
    /// consecutive scans of one landmark (`HistoryTreatment`): `"none"`
    /// (default), `"whiten"` (AR(1) whitening), `"decimate"` (one bearing per
    /// visit, or every `history_decimate_every`-th), `"visit-mean"`.
    #[pyo3(get, set)]
    pub history_correlation: String,
    /// MTE-history: lag-one correlation φ of consecutive bearings of one
    /// landmark (default 0.64, MRCLAM Dataset 6's calibration).
    #[pyo3(get, set)]
    pub history_phi: f64,
    /// MTE-history: stationary σ of one bearing's error for the treatments,
    /// rad; None uses `bearing_sigma`.
    #[pyo3(get, set)]
    pub history_sigma: Option<f64>,
    /// MTE-history with `"decimate"`: keep every n-th kept bearing of a
    /// visit; 0 (default) keeps one per visit.
    #[pyo3(get, set)]
    pub history_decimate_every: usize,
    // --- end of the waiting bearings' correlation ---
    /// The estimator (`EstimatorKind`: `"filter"`, the EKF, the default;
    /// `"smoother"`, `"filter+smoother"`, `"fastslam1"`, `"fastslam2"`,
    /// `"gaussian-sum"`).
    #[pyo3(get, set)]
    pub estimator: String,
    /// Particles of FastSLAM (≥ 1).
    #[pyo3(get, set)]
    pub particles: usize,
    /// The heading Gaussian sum (`"gaussian-sum"` only): a component is
    /// split while its heading σ exceeds this, degrees (default 3).
    #[pyo3(get, set)]
    pub gaussian_sum_split_deg: f64,
    /// The heading Gaussian sum's largest number of components (≥ 1;
    /// default 9).
    #[pyo3(get, set)]
    pub gaussian_sum_components: usize,
    /// The online smoother's window (`OnlineWindow`; `"filter+smoother"`
    /// only): `"keyframes"` (the default: every scan's pose, the window
    /// spanning 50 keyframes by motion, 0.5 m / 0.5 rad / 20 scans, solved
    /// at each, and landmarks the filter has not initialized triangulated
    /// in the window) or `"scans"` (the last 50 scans, solved at every
    /// scan); docs/results/estimators.md.
    #[pyo3(get, set)]
    pub online_window: String,
    /// The online smoother's landmark chart (`LandmarkChart`;
    /// `"filter+smoother"` only): `"inverse-depth"` (the default) or
    /// `"point"`.
    #[pyo3(get, set)]
    pub landmark_chart: String,
    /// Data association (`AssociationMethod`): `"known"` (the log's ids,
    /// the default), `"nn"`, `"jcbb"` or `"ransac"` (1-point RANSAC; ids
    /// hidden from the estimator and used only to score it). The EKF
    /// `filter` takes all three; FastSLAM (`"fastslam1"`, `"fastslam2"`)
    /// takes `"nn"`, meaning per-particle maximum-likelihood association,
    /// and refuses `"jcbb"` and `"ransac"`; the smoothers take all three,
    /// with the EKF as their front end (the batch re-associates every
    /// bearing against its smoothed estimate).
    #[pyo3(get, set)]
    pub association: String,
    /// σ of the sensor's appearance-descriptor noise per component
    /// (`DescriptorModel::sigma`; association `"nn"`/`"jcbb"`/`"ransac"`
    /// only): with it, a bearing carrying a descriptor is paired only with
    /// a landmark that looks alike; None (default) ignores descriptors.
    #[pyo3(get, set)]
    pub descriptor_sigma: Option<f64>,
    /// Moving objects (`AssociationConfig::moving_object_nis_factor`; ids
    /// hidden only): a mapped landmark whose last 10 pairings' NIS sums
    /// beyond χ²₁₀(0.999) and beyond this factor (> 1) times the other
    /// landmarks' median leaves the map; None (default) keeps every
    /// landmark. It also evicts static landmarks where the robot slips.
    #[pyo3(get, set)]
    pub moving_object_nis_factor: Option<f64>,
    /// Moving objects (`AssociationConfig::moving_object_pair_ratio`; ids
    /// hidden only): a mapped landmark paired in fewer than this fraction
    /// of its last 20 scans leaves the map (MonoSLAM's rule); only for a
    /// sensor that keeps every landmark in view. None (default): off.
    #[pyo3(get, set)]
    pub moving_object_pair_ratio: Option<f64>,
    /// Moving objects (`AssociationConfig::remember_movers`; with
    /// `moving_object_nis_factor`): where a landmark the NIS rule removed
    /// stood is remembered, and a track it explains is not mapped. False
    /// (default).
    #[pyo3(get, set)]
    pub remember_movers: bool,
    // --- robustness on a real camera (issue #13 item 3) ---
    /// Robust gating (`RobustGate::readmit_after`): a landmark's bearings
    /// gated out this many times in a row are re-admitted with inflated
    /// noise; None (default) never re-admits.
    #[pyo3(get, set)]
    pub readmit_after: Option<usize>,
    /// Robust gating (`RobustGate::huber_threshold`): Huber down-weighting
    /// of bearings whose √NIS passes this; None (default) is off.
    #[pyo3(get, set)]
    pub huber_threshold: Option<f64>,
    /// Bearing-offset state (camera yaw mount): its random walk σ, rad/√s;
    /// None (default) has no offset state.
    #[pyo3(get, set)]
    pub bearing_offset_sigma: Option<f64>,
    /// Bearing-offset state: σ of its zero-mean prior, rad.
    #[pyo3(get, set)]
    pub bearing_offset_initial_sigma: f64,
}

/// The attribute names, in display order.
const FIELDS: [&str; 54] = [
    "init",
    "bearing_sigma",
    "range_sigma",
    "initial_pose",
    "initial_pose_sigma",
    "gate_probability",
    "conversion_threshold",
    "conversion_depth_linearity",
    "covariance_update",
    "update",
    "consistency",
    "update_iterations",
    "second_order",
    "alpha_min",
    "baseline_min",
    "beta_min",
    "candidate_timeout",
    "min_depth",
    "history",
    "history_correlation",
    "history_phi",
    "history_sigma",
    "history_decimate_every",
    "auto_visits",
    "auto_max_wait",
    "auto_stalled_parallax",
    "auto_insignificant_parallax",
    "auto_keep_first_ray",
    "rho_ini",
    "sigma_rho",
    "per_landmark_priors",
    "odometry",
    "wheel_base",
    "wheel_floor_sigma",
    "wheel_scale_sqrt",
    "velocity_alpha",
    "velocity_sigma_v_min",
    "velocity_sigma_omega_min",
    "use_range",
    "estimator",
    "particles",
    "gaussian_sum_split_deg",
    "gaussian_sum_components",
    "online_window",
    "landmark_chart",
    "association",
    "descriptor_sigma",
    "moving_object_nis_factor",
    "moving_object_pair_ratio",
    "remember_movers",
    // robustness on a real camera (issue #13 item 3)
    "readmit_after",
    "huber_threshold",
    "bearing_offset_sigma",
    "bearing_offset_initial_sigma",
];

impl Default for PyConfig {
    fn default() -> Self {
        let slam = SlamConfig::default();
        let tri = TriangulationConfig::default();
        let a = DEFAULT_VELOCITY_NOISE.alpha;
        Self {
            init: slam.initializer.kind().to_string(),
            bearing_sigma: slam.bearing_sigma,
            range_sigma: slam.range_sigma,
            initial_pose: (0.0, 0.0, 0.0),
            initial_pose_sigma: (0.0, 0.0, 0.0),
            gate_probability: slam.gate_probability,
            conversion_threshold: slam.conversion_threshold,
            conversion_depth_linearity: slam.conversion_depth_linearity,
            covariance_update: slam.covariance_update.to_string(),
            update: slam.update.to_string(),
            consistency: slam.consistency.to_string(),
            update_iterations: slam.update_iterations,
            second_order: slam.second_order,
            alpha_min: tri.alpha_min,
            baseline_min: tri.baseline_min,
            beta_min: tri.beta_min,
            candidate_timeout: tri.candidate_timeout,
            min_depth: tri.min_depth,
            history: tri.history,
            history_correlation: tri.correlation.treatment.to_string(),
            history_phi: tri.correlation.phi,
            history_sigma: tri.correlation.sigma,
            history_decimate_every: tri.correlation.decimate_every,
            auto_visits: UndelayedFallback::ONE_VISIT.expired_visits,
            auto_max_wait: UndelayedFallback::ONE_VISIT.max_wait_s,
            auto_stalled_parallax: UndelayedFallback::ONE_VISIT.stalled_parallax,
            auto_insignificant_parallax: UndelayedFallback::ONE_VISIT.insignificant_parallax,
            auto_keep_first_ray: UndelayedFallback::ONE_VISIT.keep_first_ray,
            rho_ini: InverseDepthPrior::PAPER_NEAR.rho_ini,
            sigma_rho: InverseDepthPrior::PAPER_NEAR.sigma_rho,
            per_landmark_priors: BTreeMap::new(),
            odometry: OdometryKind::Wheels.to_string(),
            wheel_base: 0.2,
            wheel_floor_sigma: DEFAULT_WHEEL_NOISE.floor_sigma_m,
            wheel_scale_sqrt: DEFAULT_WHEEL_NOISE.scale_sqrt_m,
            velocity_alpha: (a[0], a[1], a[2], a[3], a[4], a[5]),
            velocity_sigma_v_min: DEFAULT_VELOCITY_NOISE.sigma_v_min,
            velocity_sigma_omega_min: DEFAULT_VELOCITY_NOISE.sigma_omega_min,
            use_range: false,
            estimator: EstimatorKind::default().to_string(),
            particles: EstimatorConfig::default().particles,
            gaussian_sum_split_deg: EstimatorConfig::default()
                .gaussian_sum
                .split_above_rad
                .to_degrees(),
            gaussian_sum_components: EstimatorConfig::default().gaussian_sum.max_components,
            online_window: OnlineWindow::default().to_string(),
            landmark_chart: SmootherConfig::default().landmark_chart.to_string(),
            association: slam.association.method.to_string(),
            descriptor_sigma: None,
            moving_object_nis_factor: slam.association.moving_object_nis_factor,
            moving_object_pair_ratio: slam.association.moving_object_pair_ratio,
            remember_movers: slam.association.remember_movers,
            readmit_after: None,
            huber_threshold: None,
            bearing_offset_sigma: None,
            bearing_offset_initial_sigma: BearingOffset::default().initial_sigma,
        }
    }
}

impl PyConfig {
    /// Sets the attributes named in `kwargs` (through Python, so each
    /// attribute's own conversion applies) and validates the result.
    /// With `refuse_unused` (construction: `Config(...)`, `Config.for_log`), a
    /// parameter given that the configuration would not use (`unused_because`)
    /// is refused unless it equals the value already there; `replace` edits
    /// fields one at a time and checks values only.
    fn apply(
        slf: &Bound<'_, Self>,
        kwargs: Option<&Bound<'_, PyDict>>,
        refuse_unused: bool,
    ) -> PyResult<()> {
        let before = Bound::new(slf.py(), slf.borrow().clone())?;
        if let Some(kw) = kwargs {
            for (k, v) in kw.iter() {
                let key: String = k.extract()?;
                if !FIELDS.contains(&key.as_str()) {
                    return Err(PyTypeError::new_err(format!(
                        "Config has no parameter {key:?}; parameters: {}",
                        FIELDS.join(", ")
                    )));
                }
                // Accept any sequence for the tuple-valued parameters.
                let v = if matches!(
                    key.as_str(),
                    "initial_pose" | "initial_pose_sigma" | "velocity_alpha"
                ) {
                    PyTuple::new(slf.py(), v.try_iter()?.collect::<PyResult<Vec<_>>>()?)?.into_any()
                } else {
                    v
                };
                let shown = v.repr()?.to_string();
                slf.setattr(key.as_str(), v).map_err(|e| {
                    let py = slf.py();
                    if e.is_instance_of::<PyOverflowError>(py) {
                        // A negative or huge integer for a count (history).
                        crate::errors::raise(
                            "InvalidParameterError",
                            format!("Config: {key} = {shown} is out of range ({e})"),
                        )
                    } else if e.is_instance_of::<PyTypeError>(py) {
                        PyTypeError::new_err(format!("Config: {key} = {shown}: {e}"))
                    } else {
                        e
                    }
                })?;
            }
        }
        if let Some(kw) = kwargs.filter(|_| refuse_unused) {
            for k in kw.keys() {
                let key: String = k.extract()?;
                let changed = !slf
                    .getattr(key.as_str())?
                    .eq(before.getattr(key.as_str())?)?;
                if changed && let Some(why) = slf.borrow().unused_because(&key) {
                    return Err(crate::errors::raise(
                        "InvalidParameterError",
                        format!("Config: {key} is not used here: {why}"),
                    ));
                }
            }
        }
        slf.borrow().run_config()?;
        slf.borrow().estimator_config()?;
        Ok(())
    }
}

#[pymethods]
impl PyConfig {
    /// A configuration with the defaults (`SlamConfig::default()`'s: the
    /// `auto` initializer, which is the paper's MTE where no landmark's
    /// visit ends before it triangulates, and the paper's parameters), any
    /// parameter overridden by keyword.
    #[new]
    #[pyo3(signature = (init = None, **kwargs))]
    fn py_new(
        py: Python<'_>,
        init: Option<&str>,
        kwargs: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Py<Self>> {
        let default = Self::default();
        let cfg = Self {
            init: init.map_or(default.init.clone(), str::to_owned),
            ..default
        };
        let obj = Bound::new(py, cfg)?;
        Self::apply(&obj, kwargs, true)?;
        Ok(obj.unbind())
    }

    /// The configuration matched to a log (odometry model and wheel base,
    /// bearing σ), as the Rust `default_run_config`, with `init` and any
    /// parameter overridden by keyword.
    #[staticmethod]
    #[pyo3(signature = (log, init = None, **kwargs))]
    fn for_log(
        py: Python<'_>,
        log: &PySensorLog,
        init: Option<&str>,
        kwargs: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Py<Self>> {
        let rc = bearing_slam::default_run_config(&log.inner).py()?;
        let mut cfg = Self::from_run_config(&rc);
        if let Some(init) = init {
            cfg.init = init.to_owned();
        }
        let obj = Bound::new(py, cfg)?;
        Self::apply(&obj, kwargs, true)?;
        Ok(obj.unbind())
    }

    /// A copy with the given parameters changed.
    #[pyo3(signature = (**kwargs))]
    fn replace(&self, py: Python<'_>, kwargs: Option<&Bound<'_, PyDict>>) -> PyResult<Py<Self>> {
        let obj = Bound::new(py, self.clone())?;
        Self::apply(&obj, kwargs, false)?;
        Ok(obj.unbind())
    }

    /// Checks every parameter; raises the matching `BearingSlamError` subclass.
    fn validate(&self) -> PyResult<()> {
        self.run_config()?;
        self.estimator_config().map(|_| ())
    }

    /// Every parameter as a dict.
    fn to_dict<'py>(slf: &Bound<'py, Self>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(slf.py());
        for f in FIELDS {
            d.set_item(f, slf.getattr(f)?)?;
        }
        Ok(d)
    }

    fn __repr__(slf: &Bound<'_, Self>) -> PyResult<String> {
        let parts = FIELDS
            .iter()
            .map(|f| Ok(format!("{f}={}", slf.getattr(*f)?.repr()?)))
            .collect::<PyResult<Vec<_>>>()?;
        Ok(format!("Config({})", parts.join(", ")))
    }

    fn __eq__(&self, other: &Bound<'_, PyAny>) -> bool {
        other
            .cast::<Self>()
            .map(|o| *o.borrow() == *self)
            .unwrap_or(false)
    }

    fn __copy__(&self) -> Self {
        self.clone()
    }

    fn __deepcopy__(&self, _memo: &Bound<'_, PyAny>) -> Self {
        self.clone()
    }

    /// Pickling: `Config()` (the defaults), then every parameter set from
    /// this dict (`to_dict`) by `__setstate__`.
    fn __getstate__<'py>(slf: &Bound<'py, Self>) -> PyResult<Bound<'py, PyDict>> {
        Self::to_dict(slf)
    }

    /// Sets every parameter of a `__getstate__` dict, checked as `replace` does.
    fn __setstate__(slf: &Bound<'_, Self>, state: &Bound<'_, PyDict>) -> PyResult<()> {
        // Our own state: every parameter, used or not by its method.
        Self::apply(slf, Some(state), false)
    }
}
