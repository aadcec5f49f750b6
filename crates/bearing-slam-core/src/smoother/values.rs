//! The variables of the smoother's factor graph and their current estimate:
//! planar poses `[x, y, θ]` at the measurement times and 2-D point landmarks.
//!
//! A landmark is always *stored* as its point `[x, y]`, but its increments
//! (the solver's step, the marginalization prior's coordinates, its
//! marginal before conversion) may be taken in one of two charts: the
//! point itself, or the inverse depth `[θ, ρ]` of Munguía & Grau (11)
//! about a fixed anchor `a`, `p = a + m(θ)/ρ`
//! ([`Values::anchor_landmark`]). The second is the chart for a landmark
//! whose ray is known and whose depth is not: the bearing is nearly linear
//! in `ρ`, and a step cannot carry the point past infinity or behind the
//! anchor.

use crate::error::{Result, SlamError, ensure_finite};
use crate::geometry::wrap_angle;
use crate::landmark::inverse_depth_to_point;
use nalgebra::{DVector, Matrix2, Vector2, Vector3, Vector4};
use serde::Serialize;
use std::collections::BTreeMap;

/// Names one variable of the graph.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize)]
pub enum Key {
    /// A robot pose `[x, y, θ]` (3 entries), numbered by the caller.
    Pose(u64),
    /// A point landmark `[x, y]` (2 entries), by its landmark id.
    Landmark(u64),
}

impl Key {
    /// The number of entries of the variable (its tangent dimension).
    #[must_use]
    pub fn dim(&self) -> usize {
        match self {
            Key::Pose(_) => 3,
            Key::Landmark(_) => 2,
        }
    }
}

/// Error for a key the estimate does not hold.
pub(crate) fn unknown_key(key: Key) -> SlamError {
    match key {
        Key::Landmark(id) => SlamError::UnknownLandmark(id),
        Key::Pose(id) => SlamError::InvalidParameter {
            name: "pose id",
            value: id as f64,
            reason: "no pose with this id in the estimate",
        },
    }
}

/// The chart a landmark's increments are taken in (the smoother's
/// [`super::SmootherConfig::landmark_chart`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum LandmarkChart {
    /// `[x, y]`: plain addition.
    #[default]
    Point,
    /// `[θ, ρ]` about an anchor where the landmark entered the graph
    /// (Munguía & Grau (11), the anchor held fixed).
    InverseDepth,
}

crate::named_enum!(LandmarkChart, "landmark chart", [
    Point => "point",
    InverseDepth => "inverse-depth",
]);

/// Smallest inverse depth a step may reach: 1 km from the anchor. A step
/// past it is clamped there, so a landmark with no depth information
/// stays on its ray at a finite distance instead of crossing infinity.
pub const MIN_INVERSE_DEPTH: f64 = 1e-3;

/// Largest inverse depth a step may reach: 1 mm from the anchor, the
/// nearest [`Values::anchor_landmark`] accepts (closer, the azimuth has no
/// ray to be measured along).
pub const MAX_INVERSE_DEPTH: f64 = 1e3;

/// The inverse-depth coordinates `[θ, ρ]` of `point` about `anchor`.
pub(crate) fn inverse_depth_of(anchor: &Vector2<f64>, point: &Vector2<f64>) -> Vector2<f64> {
    let ray = point - anchor;
    Vector2::new(ray.y.atan2(ray.x), 1.0 / ray.norm())
}

/// `∂p/∂[θ, ρ]` at `point` of the inverse-depth chart about `anchor`: the
/// last two columns of the Jacobian of (11) ([`inverse_depth_to_point`]).
pub(crate) fn inverse_depth_chart_jacobian(
    anchor: &Vector2<f64>,
    point: &Vector2<f64>,
) -> Result<Matrix2<f64>> {
    let [theta, rho] = inverse_depth_of(anchor, point).into();
    let converted = inverse_depth_to_point(&Vector4::new(anchor.x, anchor.y, theta, rho))?;
    Ok(converted
        .j_point_landmark
        .fixed_columns::<2>(2)
        .into_owned())
}

/// `∂[θ, ρ]/∂p` at `point` of the inverse-depth chart about `anchor` (the
/// inverse of the chart's `∂p/∂[θ, ρ]`): `∂θ/∂p = [−d_y, d_x]/r²`,
/// `∂ρ/∂p = −d/r³`, `d = point − anchor`, `r = |d|`. Errors when the point
/// lies on the anchor (no ray).
pub(crate) fn inverse_depth_gradient(
    anchor: &Vector2<f64>,
    point: &Vector2<f64>,
) -> Result<Matrix2<f64>> {
    let d = point - anchor;
    let r2 = d.norm_squared();
    if !(r2 > 1e-24 && r2.is_finite()) {
        return Err(SlamError::Degenerate(
            "a landmark's inverse-depth anchor must lie away from the landmark",
        ));
    }
    let r3 = r2 * r2.sqrt();
    Ok(Matrix2::new(-d.y / r2, d.x / r2, -d.x / r3, -d.y / r3))
}

/// The estimate of every variable: poses by number, landmarks by id.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Values {
    poses: BTreeMap<u64, Vector3<f64>>,
    landmarks: BTreeMap<u64, Vector2<f64>>,
    /// The anchors of the landmarks whose increments are inverse depth.
    anchors: BTreeMap<u64, Vector2<f64>>,
}

impl Values {
    /// An empty estimate.
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    /// Sets pose `id` to `[x, y, θ]` (heading wrapped). Errors on a
    /// non-finite entry.
    pub fn insert_pose(&mut self, id: u64, pose: Vector3<f64>) -> Result<()> {
        ensure_finite("pose x", pose.x)?;
        ensure_finite("pose y", pose.y)?;
        ensure_finite("pose theta", pose.z)?;
        self.poses
            .insert(id, Vector3::new(pose.x, pose.y, wrap_angle(pose.z)));
        Ok(())
    }

    /// Sets landmark `id` to `[x, y]`. Errors on a non-finite entry.
    pub fn insert_landmark(&mut self, id: u64, point: Vector2<f64>) -> Result<()> {
        ensure_finite("landmark x", point.x)?;
        ensure_finite("landmark y", point.y)?;
        self.landmarks.insert(id, point);
        Ok(())
    }

    /// Takes landmark `id`'s increments in inverse depth `[θ, ρ]` about
    /// `anchor` from now on (its point is unchanged). Errors on an unknown
    /// landmark, a non-finite anchor, or an anchor within 1 mm of the
    /// point (no ray to measure the azimuth along).
    pub fn anchor_landmark(&mut self, id: u64, anchor: Vector2<f64>) -> Result<()> {
        ensure_finite("anchor x", anchor.x)?;
        ensure_finite("anchor y", anchor.y)?;
        let point = self.landmark(id)?;
        if (point - anchor).norm() < 1e-3 {
            return Err(SlamError::Degenerate(
                "a landmark's inverse-depth anchor must lie away from the landmark",
            ));
        }
        self.anchors.insert(id, anchor);
        Ok(())
    }

    /// The inverse-depth anchor of landmark `id`, if it has one.
    #[must_use]
    pub fn landmark_anchor(&self, id: u64) -> Option<Vector2<f64>> {
        self.anchors.get(&id).copied()
    }

    /// Whether any landmark takes its increments in inverse depth.
    #[must_use]
    pub fn has_anchors(&self) -> bool {
        !self.anchors.is_empty()
    }

    /// `∂p/∂[θ, ρ]` of landmark `id` at its estimate when its increments
    /// are inverse depth; `None` for a point chart.
    pub fn landmark_chart_jacobian(&self, id: u64) -> Result<Option<Matrix2<f64>>> {
        match self.anchors.get(&id) {
            Some(anchor) => Ok(Some(inverse_depth_chart_jacobian(
                anchor,
                &self.landmark(id)?,
            )?)),
            None => Ok(None),
        }
    }

    /// Pose `id`, or an error naming it.
    pub fn pose(&self, id: u64) -> Result<Vector3<f64>> {
        self.poses
            .get(&id)
            .copied()
            .ok_or_else(|| unknown_key(Key::Pose(id)))
    }

    /// Landmark `id`, or [`SlamError::UnknownLandmark`].
    pub fn landmark(&self, id: u64) -> Result<Vector2<f64>> {
        self.landmarks
            .get(&id)
            .copied()
            .ok_or(SlamError::UnknownLandmark(id))
    }

    /// Whether the estimate holds `key`.
    #[must_use]
    pub fn contains(&self, key: Key) -> bool {
        match key {
            Key::Pose(id) => self.poses.contains_key(&id),
            Key::Landmark(id) => self.landmarks.contains_key(&id),
        }
    }

    /// The entries of `key` as a vector.
    pub fn get(&self, key: Key) -> Result<DVector<f64>> {
        Ok(match key {
            Key::Pose(id) => DVector::from_column_slice(self.pose(id)?.as_slice()),
            Key::Landmark(id) => DVector::from_column_slice(self.landmark(id)?.as_slice()),
        })
    }

    /// Sets `key` from a vector of its size (pose headings wrapped).
    pub fn set(&mut self, key: Key, v: &[f64]) -> Result<()> {
        if v.len() != key.dim() {
            return Err(SlamError::DimensionMismatch {
                what: "variable value",
                expected: key.dim(),
                got: v.len(),
            });
        }
        match key {
            Key::Pose(id) => self.insert_pose(id, Vector3::new(v[0], v[1], v[2])),
            Key::Landmark(id) => self.insert_landmark(id, Vector2::new(v[0], v[1])),
        }
    }

    /// Adds the increment `delta` (tangent of `key`) to `key`: plain addition,
    /// the heading wrapped back to (−π, π]; for an anchored landmark, added
    /// to its `[θ, ρ]` (`ρ` kept in [`MIN_INVERSE_DEPTH`],
    /// [`MAX_INVERSE_DEPTH`]) and converted back by (11).
    pub fn retract(&mut self, key: Key, delta: &[f64]) -> Result<()> {
        let mut v = self.get(key)?;
        if delta.len() != v.len() {
            return Err(SlamError::DimensionMismatch {
                what: "increment",
                expected: v.len(),
                got: delta.len(),
            });
        }
        if let Key::Landmark(id) = key
            && let Some(anchor) = self.anchors.get(&id).copied()
        {
            let old = inverse_depth_of(&anchor, &Vector2::new(v[0], v[1]));
            let theta = old.x + delta[0];
            let rho = (old.y + delta[1]).clamp(MIN_INVERSE_DEPTH, MAX_INVERSE_DEPTH);
            let point =
                inverse_depth_to_point(&Vector4::new(anchor.x, anchor.y, theta, rho))?.point;
            return self.insert_landmark(id, point);
        }
        for (x, d) in v.iter_mut().zip(delta) {
            *x += d;
        }
        self.set(key, v.as_slice())
    }

    /// The entries of `keys` alone (with their landmarks' anchors): a
    /// solver's trial estimate of the variables it moves, without copying
    /// the rest of a large window. Keys absent here are skipped.
    #[must_use]
    pub fn restricted_to(&self, keys: &[Key]) -> Self {
        let mut out = Self::default();
        for key in keys {
            match *key {
                Key::Pose(id) => {
                    if let Some(p) = self.poses.get(&id) {
                        out.poses.insert(id, *p);
                    }
                }
                Key::Landmark(id) => {
                    if let Some(p) = self.landmarks.get(&id) {
                        out.landmarks.insert(id, *p);
                    }
                    if let Some(a) = self.anchors.get(&id) {
                        out.anchors.insert(id, *a);
                    }
                }
            }
        }
        out
    }

    /// Overwrites the entries `other` holds (its landmarks' anchors
    /// included), leaving every other entry as it is.
    pub fn overwrite_from(&mut self, other: Self) {
        self.poses.extend(other.poses);
        self.landmarks.extend(other.landmarks);
        self.anchors.extend(other.anchors);
    }

    /// Removes `key` (no-op when absent).
    pub fn remove(&mut self, key: Key) {
        match key {
            Key::Pose(id) => {
                self.poses.remove(&id);
            }
            Key::Landmark(id) => {
                self.landmarks.remove(&id);
                self.anchors.remove(&id);
            }
        }
    }

    /// The poses by id.
    #[must_use]
    pub fn poses(&self) -> &BTreeMap<u64, Vector3<f64>> {
        &self.poses
    }

    /// The landmarks by id.
    #[must_use]
    pub fn landmarks(&self) -> &BTreeMap<u64, Vector2<f64>> {
        &self.landmarks
    }

    /// `x ⊟ x0` for values `x`, `x0` of `key` (the inverse of
    /// [`Values::retract`]), in its chart: the difference with the heading
    /// wrapped; for an anchored landmark, the difference of their `[θ, ρ]`
    /// (azimuth wrapped).
    pub fn local_difference(&self, key: Key, x: &DVector<f64>, x0: &DVector<f64>) -> DVector<f64> {
        match key {
            Key::Pose(_) => {
                let mut d = x - x0;
                d[2] = wrap_angle(d[2]);
                d
            }
            Key::Landmark(id) => match self.anchors.get(&id) {
                None => x - x0,
                Some(anchor) => {
                    let a = inverse_depth_of(anchor, &Vector2::new(x[0], x[1]));
                    let b = inverse_depth_of(anchor, &Vector2::new(x0[0], x0[1]));
                    DVector::from_column_slice(&[wrap_angle(a.x - b.x), a.y - b.y])
                }
            },
        }
    }
}
