//! The variables of the smoother's factor graph and their current estimate:
//! planar poses `[x, y, θ]` at the measurement times and 2-D point landmarks.

use crate::error::{Result, SlamError, ensure_finite};
use crate::geometry::wrap_angle;
use nalgebra::{DVector, Vector2, Vector3};
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

/// The estimate of every variable: poses by number, landmarks by id.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Values {
    poses: BTreeMap<u64, Vector3<f64>>,
    landmarks: BTreeMap<u64, Vector2<f64>>,
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
    /// the heading wrapped back to (−π, π].
    pub fn retract(&mut self, key: Key, delta: &[f64]) -> Result<()> {
        let mut v = self.get(key)?;
        if delta.len() != v.len() {
            return Err(SlamError::DimensionMismatch {
                what: "increment",
                expected: v.len(),
                got: delta.len(),
            });
        }
        for (x, d) in v.iter_mut().zip(delta) {
            *x += d;
        }
        self.set(key, v.as_slice())
    }

    /// Removes `key` (no-op when absent).
    pub fn remove(&mut self, key: Key) {
        match key {
            Key::Pose(id) => {
                self.poses.remove(&id);
            }
            Key::Landmark(id) => {
                self.landmarks.remove(&id);
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
}

/// `x ⊟ x0` for a variable: the difference with the heading wrapped.
pub(crate) fn local_difference(key: Key, x: &DVector<f64>, x0: &DVector<f64>) -> DVector<f64> {
    let mut d = x - x0;
    if matches!(key, Key::Pose(_)) {
        d[2] = wrap_angle(d[2]);
    }
    d
}
