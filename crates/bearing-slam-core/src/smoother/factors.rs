//! The factors of the graph, each a whitened residual `e(x)` with its
//! Jacobians with respect to the variables it touches; the cost of a factor is
//! `½‖e‖²` (or `½ρ(‖e‖²)` under a robust kernel for measurement factors).
//!
//! Measurement factors call the filter's own measurement models
//! ([`BearingToPoint`], Munguía & Grau (8)(9); [`RangeBearing`], (6)) for the
//! prediction and its Jacobians; the odometry factor holds a relative pose
//! preintegrated through the filter's motion model
//! ([`super::PreintegratedOdometry`]).

use super::preintegration::PreintegratedOdometry;
use super::values::{Key, Values};
use crate::error::{Result, SlamError, ensure_finite, ensure_positive_noise};
use crate::geometry::{Pose2, wrap_angle};
use crate::measurement::{BearingToPoint, RangeBearing};
use crate::model::MeasurementModel;
pub use linear::LinearFactor;
use nalgebra::{DMatrix, DVector, Matrix2, Matrix3, Vector1, Vector2, Vector3};
use serde::Serialize;
pub(crate) use small::SmallLinearization;

mod linear;
mod small;

/// A factor linearized at the current estimate: whitened residual `e` and,
/// per key (in [`Factor::keys`] order), `∂e/∂δ` so that
/// `e(x ⊕ δ) ≈ e + Σ_k J_k δ_k`.
#[derive(Clone, Debug, PartialEq)]
pub struct Linearization {
    /// The whitened residual.
    pub residual: DVector<f64>,
    /// One Jacobian per key, `dim(e) × dim(key)`.
    pub jacobians: Vec<DMatrix<f64>>,
}

/// The whitening matrix `S = L⁻¹` of a covariance `Σ = L Lᵀ`, so that
/// `SᵀS = Σ⁻¹` and `S r` has identity covariance.
pub fn whitening(what: &'static str, covariance: &DMatrix<f64>) -> Result<DMatrix<f64>> {
    if covariance.iter().any(|v| !v.is_finite()) {
        return Err(SlamError::NonFinite {
            what,
            value: covariance
                .iter()
                .copied()
                .find(|v| !v.is_finite())
                .unwrap_or(f64::NAN),
        });
    }
    let sym = 0.5 * (covariance + covariance.transpose());
    let l = sym
        .cholesky()
        .ok_or(SlamError::NotPositiveDefinite { what })?
        .l();
    l.try_inverse()
        .ok_or(SlamError::NotPositiveDefinite { what })
}

fn dm<const R: usize, const C: usize>(m: &nalgebra::SMatrix<f64, R, C>) -> DMatrix<f64> {
    DMatrix::from_column_slice(R, C, m.as_slice())
}

/// A Gaussian prior on one pose: `e = S (x ⊟ μ)`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PosePriorFactor {
    pose: u64,
    mean: Vector3<f64>,
    sqrt_info: Matrix3<f64>,
}

impl PosePriorFactor {
    /// Prior `N(mean, covariance)` on pose `pose`. Errors on non-finite input
    /// or a covariance that is not positive definite.
    pub fn new(pose: u64, mean: Vector3<f64>, covariance: Matrix3<f64>) -> Result<Self> {
        for v in mean.iter() {
            ensure_finite("pose prior mean", *v)?;
        }
        let s = whitening("pose prior covariance", &dm(&covariance))?;
        Ok(Self {
            pose,
            mean,
            sqrt_info: Matrix3::from_column_slice(s.as_slice()),
        })
    }
}

/// A Gaussian prior on one landmark: `e = S (p − μ)`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LandmarkPriorFactor {
    landmark: u64,
    mean: Vector2<f64>,
    sqrt_info: Matrix2<f64>,
}

impl LandmarkPriorFactor {
    /// Prior `N(mean, covariance)` on landmark `landmark`.
    pub fn new(landmark: u64, mean: Vector2<f64>, covariance: Matrix2<f64>) -> Result<Self> {
        for v in mean.iter() {
            ensure_finite("landmark prior mean", *v)?;
        }
        let s = whitening("landmark prior covariance", &dm(&covariance))?;
        Ok(Self {
            landmark,
            mean,
            sqrt_info: Matrix2::from_column_slice(s.as_slice()),
        })
    }
}

/// Relative motion between two poses, preintegrated through the motion model:
/// `e = S r`, `r = [R_iᵀ(p_j − p_i) − Δp, wrap(θ_j − θ_i − Δθ)]`, the
/// additive error on the relative pose `T_i⁻¹ T_j` in the frame of pose `i`,
/// which is the error the preintegrated covariance describes.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct OdometryFactor {
    from: u64,
    to: u64,
    delta: Vector3<f64>,
    sqrt_info: Matrix3<f64>,
}

impl OdometryFactor {
    /// Between `from` and `to`, relative pose `delta` with covariance
    /// `covariance`.
    pub fn new(from: u64, to: u64, delta: Vector3<f64>, covariance: Matrix3<f64>) -> Result<Self> {
        if from == to {
            return Err(SlamError::Degenerate(
                "odometry factor from a pose to itself",
            ));
        }
        for v in delta.iter() {
            ensure_finite("odometry delta", *v)?;
        }
        let s = whitening("odometry covariance", &dm(&covariance))?;
        Ok(Self {
            from,
            to,
            delta,
            sqrt_info: Matrix3::from_column_slice(s.as_slice()),
        })
    }

    /// From a preintegration, adding `floor_sigma² = [σ_x², σ_y², σ_θ²]` to
    /// its covariance (one step of a two-wheel model has a singular covariance:
    /// the wheels cannot slide sideways; the floor keeps the factor
    /// invertible).
    pub fn from_preintegrated(
        from: u64,
        to: u64,
        odometry: &PreintegratedOdometry,
        floor_sigma: [f64; 3],
    ) -> Result<Self> {
        let mut cov = odometry.covariance;
        for (i, s) in floor_sigma.iter().enumerate() {
            if !(s.is_finite() && *s >= 0.0) {
                return Err(SlamError::InvalidNoise {
                    what: "odometry floor sigma",
                    value: *s,
                });
            }
            cov[(i, i)] += s * s;
        }
        Self::new(from, to, odometry.delta, cov)
    }

    /// The pose the relative pose is measured from.
    #[must_use]
    pub fn from(&self) -> u64 {
        self.from
    }

    /// The pose the relative pose is measured to.
    #[must_use]
    pub fn to(&self) -> u64 {
        self.to
    }

    /// The measured relative pose `[x, y, θ]` of `to` in `from`'s frame.
    #[must_use]
    pub fn delta(&self) -> Vector3<f64> {
        self.delta
    }

    /// The unwhitened residual and its Jacobians with respect to pose `i` and `j`.
    fn raw(
        &self,
        xi: &Vector3<f64>,
        xj: &Vector3<f64>,
    ) -> (Vector3<f64>, Matrix3<f64>, Matrix3<f64>) {
        let rel = Pose2::from_vector(xi).between(&Pose2::from_vector(xj));
        let r = Vector3::new(
            rel.x - self.delta.x,
            rel.y - self.delta.y,
            wrap_angle(xj.z - xi.z - self.delta.z),
        );
        let (s, c) = xi.z.sin_cos();
        let d = xj.fixed_rows::<2>(0) - xi.fixed_rows::<2>(0);
        // R_iᵀ = [[c, s], [−s, c]]; ∂(R_iᵀ d)/∂θ_i = [[−s, c], [−c, −s]] d.
        let j_i = Matrix3::new(
            -c,
            -s,
            -s * d.x + c * d.y,
            s,
            -c,
            -c * d.x - s * d.y,
            0.0,
            0.0,
            -1.0,
        );
        let j_j = Matrix3::new(c, s, 0.0, -s, c, 0.0, 0.0, 0.0, 1.0);
        (r, j_i, j_j)
    }
}

/// One bearing to a landmark: `e = wrap(z − h(x_v, p))/σ` with the filter's
/// [`BearingToPoint`] model, Munguía & Grau (9).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BearingFactor {
    pose: u64,
    landmark: u64,
    bearing: f64,
    sigma: f64,
    /// The sensor's pose in the pose variable's frame, when the bearing was
    /// taken after the variable's time ([`Self::with_offset`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    offset: Option<Vector3<f64>>,
}

impl BearingFactor {
    /// Bearing `bearing` (radians) from pose `pose` to landmark `landmark`,
    /// standard deviation `sigma`.
    pub fn new(pose: u64, landmark: u64, bearing: f64, sigma: f64) -> Result<Self> {
        ensure_finite("bearing", bearing)?;
        ensure_positive_noise("bearing sigma", sigma)?;
        Ok(Self {
            pose,
            landmark,
            bearing,
            sigma,
            offset: None,
        })
    }

    /// The bearing taken from `x ⊕ offset` instead of the pose `x`
    /// itself: a scan between two keyframes observes from the keyframe
    /// composed with the odometry preintegrated since (held fixed).
    #[must_use]
    pub fn with_offset(mut self, offset: Vector3<f64>) -> Self {
        self.offset = Some(offset);
        self
    }

    /// The pose variable the bearing is taken from.
    #[must_use]
    pub fn pose(&self) -> u64 {
        self.pose
    }

    /// The landmark variable it measures.
    #[must_use]
    pub fn landmark(&self) -> u64 {
        self.landmark
    }

    /// The bearing, radians, in the sensor frame.
    #[must_use]
    pub fn bearing(&self) -> f64 {
        self.bearing
    }

    /// The sensor's pose in the pose variable's frame, if the bearing was
    /// taken after the variable's time ([`Self::with_offset`]).
    #[must_use]
    pub fn offset(&self) -> Option<Vector3<f64>> {
        self.offset
    }
}

/// The sensor pose `x ⊕ Δ` and its Jacobian `∂(x ⊕ Δ)/∂x` (SE(2)
/// composition with `Δ` fixed).
fn offset_pose(x: &Vector3<f64>, offset: &Vector3<f64>) -> (Vector3<f64>, Matrix3<f64>) {
    let (s, c) = x.z.sin_cos();
    let dx = c * offset.x - s * offset.y;
    let dy = s * offset.x + c * offset.y;
    let pose = Vector3::new(x.x + dx, x.y + dy, wrap_angle(x.z + offset.z));
    let jacobian = Matrix3::new(1.0, 0.0, -dy, 0.0, 1.0, dx, 0.0, 0.0, 1.0);
    (pose, jacobian)
}

/// One range and bearing to a landmark: `e = S (z − h(x_v, p))` with the
/// filter's [`RangeBearing`] model, Munguía & Grau (6).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RangeBearingFactor {
    pose: u64,
    landmark: u64,
    measured: Vector2<f64>,
    sqrt_info: Matrix2<f64>,
    /// As [`BearingFactor`]'s: the sensor at `x ⊕ offset`.
    #[serde(skip_serializing_if = "Option::is_none")]
    offset: Option<Vector3<f64>>,
}

impl RangeBearingFactor {
    /// Range `range` (m) and bearing `bearing` (rad), independent noises
    /// `range_sigma`, `bearing_sigma`.
    pub fn new(
        pose: u64,
        landmark: u64,
        range: f64,
        bearing: f64,
        range_sigma: f64,
        bearing_sigma: f64,
    ) -> Result<Self> {
        crate::measurement::ensure_range(range)?;
        ensure_finite("bearing", bearing)?;
        ensure_positive_noise("range sigma", range_sigma)?;
        ensure_positive_noise("bearing sigma", bearing_sigma)?;
        Ok(Self {
            pose,
            landmark,
            measured: Vector2::new(range, bearing),
            sqrt_info: Matrix2::new(1.0 / range_sigma, 0.0, 0.0, 1.0 / bearing_sigma),
            offset: None,
        })
    }

    /// The measurement taken from `x ⊕ offset` ([`BearingFactor::with_offset`]).
    #[must_use]
    pub fn with_offset(mut self, offset: Vector3<f64>) -> Self {
        self.offset = Some(offset);
        self
    }
}

/// The variables one factor touches ([`Factor::keys`]), read as a slice:
/// the one or two keys of a nonlinear factor held inline, a linear
/// factor's borrowed.
#[derive(Clone, Copy, Debug)]
pub enum FactorKeys<'a> {
    /// The first `n` (1 or 2) of the keys.
    Inline([Key; 2], usize),
    /// A linear factor's keys.
    Borrowed(&'a [Key]),
}

impl std::ops::Deref for FactorKeys<'_> {
    type Target = [Key];

    fn deref(&self) -> &[Key] {
        match self {
            FactorKeys::Inline(keys, n) => &keys[..*n],
            FactorKeys::Borrowed(keys) => keys,
        }
    }
}

impl<'a> IntoIterator for FactorKeys<'a> {
    type Item = Key;
    type IntoIter = FactorKeysIter<'a>;

    fn into_iter(self) -> FactorKeysIter<'a> {
        FactorKeysIter {
            keys: self,
            next: 0,
        }
    }
}

/// The keys of a [`FactorKeys`], by value.
#[derive(Clone, Debug)]
pub struct FactorKeysIter<'a> {
    keys: FactorKeys<'a>,
    next: usize,
}

impl Iterator for FactorKeysIter<'_> {
    type Item = Key;

    fn next(&mut self) -> Option<Key> {
        let key = self.keys.get(self.next).copied();
        self.next += 1;
        key
    }
}

/// Any factor of the graph.
#[derive(Clone, Debug, PartialEq, Serialize)]
#[serde(tag = "kind", content = "data", rename_all = "snake_case")]
pub enum Factor {
    /// Prior on a pose.
    PosePrior(PosePriorFactor),
    /// Prior on a landmark.
    LandmarkPrior(LandmarkPriorFactor),
    /// Preintegrated odometry between two poses.
    Odometry(OdometryFactor),
    /// Bearing from a pose to a landmark.
    Bearing(BearingFactor),
    /// Range and bearing from a pose to a landmark.
    RangeBearing(RangeBearingFactor),
    /// A linear (marginalization) prior.
    Linear(LinearFactor),
}

impl Factor {
    /// The variables the factor touches, in the order of its Jacobians
    /// (a view, not a copy: graph passes ask this of every factor).
    #[must_use]
    pub fn keys(&self) -> FactorKeys<'_> {
        let two = |a, b| FactorKeys::Inline([a, b], 2);
        match self {
            Factor::PosePrior(f) => FactorKeys::Inline([Key::Pose(f.pose); 2], 1),
            Factor::LandmarkPrior(f) => FactorKeys::Inline([Key::Landmark(f.landmark); 2], 1),
            Factor::Odometry(f) => two(Key::Pose(f.from), Key::Pose(f.to)),
            Factor::Bearing(f) => two(Key::Pose(f.pose), Key::Landmark(f.landmark)),
            Factor::RangeBearing(f) => two(Key::Pose(f.pose), Key::Landmark(f.landmark)),
            Factor::Linear(f) => FactorKeys::Borrowed(f.keys()),
        }
    }

    /// Whether the robust kernel applies (measurement factors only).
    #[must_use]
    pub fn is_measurement(&self) -> bool {
        matches!(self, Factor::Bearing(_) | Factor::RangeBearing(_))
    }

    /// A measurement's distance from its sensor (the pose, composed with
    /// the factor's offset if it has one) to its landmark at `values`;
    /// `None` for the other factors.
    ///
    /// # Errors
    /// A pose or landmark missing from `values`.
    pub fn sensor_distance(&self, values: &Values) -> Result<Option<f64>> {
        let (pose, landmark, offset) = match self {
            Factor::Bearing(f) => (f.pose, f.landmark, f.offset),
            Factor::RangeBearing(f) => (f.pose, f.landmark, f.offset),
            _ => return Ok(None),
        };
        let x = values.pose(pose)?;
        let sensor = match offset {
            Some(o) => offset_pose(&x, &o).0,
            None => x,
        };
        let p = values.landmark(landmark)?;
        Ok(Some((p - sensor.fixed_rows::<2>(0)).norm()))
    }

    /// The whitened residual and its Jacobians at `values`, each Jacobian
    /// in its variable's chart: a landmark anchored in inverse depth
    /// ([`Values::anchor_landmark`]) gets `J_p ∂p/∂[θ, ρ]`. A linear
    /// factor's Jacobian is already in the charts it was formed in.
    pub fn linearize(&self, values: &Values) -> Result<Linearization> {
        match (self, self.small_linearize(values)?) {
            (_, Some(lin)) => Ok(lin.to_dynamic()),
            (Factor::Linear(f), None) => f.linearize(values),
            (_, None) => Err(SlamError::Mismatch(
                "a nonlinear factor without a linearization",
            )),
        }
    }

    /// The landmark a point-measuring factor touches and the index of its
    /// Jacobian (a linear factor's are already in their charts: `None`).
    fn landmark_slot(&self) -> Option<(u64, usize)> {
        match self {
            Factor::LandmarkPrior(f) => Some((f.landmark, 0)),
            Factor::Bearing(f) => Some((f.landmark, 1)),
            Factor::RangeBearing(f) => Some((f.landmark, 1)),
            Factor::PosePrior(_) | Factor::Odometry(_) | Factor::Linear(_) => None,
        }
    }

    /// A nonlinear factor's linearization, on the stack, with every
    /// landmark Jacobian taken with respect to its point; `None` for a
    /// linear factor.
    fn small_at_points(&self, values: &Values) -> Result<Option<SmallLinearization>> {
        Ok(Some(match self {
            Factor::PosePrior(f) => {
                let x = values.pose(f.pose)?;
                let mut r = x - f.mean;
                r.z = wrap_angle(r.z);
                SmallLinearization::one(&(f.sqrt_info * r), &f.sqrt_info)
            }
            Factor::LandmarkPrior(f) => {
                let r = values.landmark(f.landmark)? - f.mean;
                SmallLinearization::one(&(f.sqrt_info * r), &f.sqrt_info)
            }
            Factor::Odometry(f) => {
                let (r, ji, jj) = f.raw(&values.pose(f.from)?, &values.pose(f.to)?);
                SmallLinearization::two(
                    &(f.sqrt_info * r),
                    &(f.sqrt_info * ji),
                    &(f.sqrt_info * jj),
                )
            }
            Factor::Bearing(f) => {
                let x = values.pose(f.pose)?;
                let p = values.landmark(f.landmark)?;
                let w = -1.0 / f.sigma;
                let (sensor, j_sensor) = match &f.offset {
                    Some(offset) => offset_pose(&x, offset),
                    None => (x, Matrix3::identity()),
                };
                let pred = BearingToPoint.predict(&sensor, &p)?;
                let r = BearingToPoint.residual(&Vector1::new(f.bearing), &pred.value);
                SmallLinearization::two(
                    &(r / f.sigma),
                    &(pred.j_z_vehicle * j_sensor * w),
                    &(pred.j_z_landmark * w),
                )
            }
            Factor::RangeBearing(f) => {
                let x = values.pose(f.pose)?;
                let p = values.landmark(f.landmark)?;
                let s = -f.sqrt_info;
                let (sensor, j_sensor) = match &f.offset {
                    Some(offset) => offset_pose(&x, offset),
                    None => (x, Matrix3::identity()),
                };
                let pred = RangeBearing.predict(&sensor, &p)?;
                let r = RangeBearing.residual(&f.measured, &pred.value);
                SmallLinearization::two(
                    &(f.sqrt_info * r),
                    &(s * pred.j_z_vehicle * j_sensor),
                    &(s * pred.j_z_landmark),
                )
            }
            Factor::Linear(_) => return Ok(None),
        }))
    }

    /// [`Factor::linearize`] of a nonlinear factor, on the stack (no
    /// allocation: the solver's assembly reads every factor at every
    /// iteration); `None` for a linear factor.
    pub(crate) fn small_linearize(&self, values: &Values) -> Result<Option<SmallLinearization>> {
        let Some(mut lin) = self.small_at_points(values)? else {
            return Ok(None);
        };
        if values.has_anchors()
            && let Some((id, slot)) = self.landmark_slot()
            && let Some(chart) = values.landmark_chart_jacobian(id)?
        {
            lin.apply_chart(slot, &chart);
        }
        Ok(Some(lin))
    }

    /// The whitened residual only.
    pub fn error(&self, values: &Values) -> Result<DVector<f64>> {
        match (self, self.small_at_points(values)?) {
            (_, Some(lin)) => Ok(lin.residual().into_owned()),
            (Factor::Linear(f), None) => f.residual(values),
            (_, None) => Err(SlamError::Mismatch(
                "a nonlinear factor without a linearization",
            )),
        }
    }

    /// `‖e‖²`, without allocating for a nonlinear factor (every cost
    /// evaluation asks it of every factor).
    pub(crate) fn squared_error(&self, values: &Values) -> Result<f64> {
        match self.small_at_points(values)? {
            Some(lin) => Ok(lin.squared_norm()),
            None => Ok(self.error(values)?.norm_squared()),
        }
    }
}
