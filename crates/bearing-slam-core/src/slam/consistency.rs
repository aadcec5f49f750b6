//! Where the filter's Jacobians are evaluated, and why it matters.
//!
//! Bearing-only SLAM cannot observe where the whole scene is nor how it is
//! turned: a global translation `t` and rotation `φ` of the robot and every
//! landmark change no measurement. The linearized system should keep these
//! three directions unobservable; the standard EKF does not, because it
//! evaluates the motion Jacobian at the updated pose and each measurement
//! Jacobian at the latest landmark estimate, and the mismatch lets the
//! filter gain information along the global heading. It then becomes
//! over-confident (Huang, Mourikis & Roumeliotis, "Observability-based rules
//! for designing consistent EKF SLAM estimators", IJRR 29(5), 2010).
//!
//! [`Consistency`] selects the remedy, for every landmark parameterization
//! (Euclidean points, inverse depth (11)(12), the conversion between them)
//! and for pose clones:
//!
//! - **first-estimates Jacobians** (FEJ): the motion Jacobian uses the
//!   displacement from the pose predicted at the previous step
//!   (`Φ = [I, J(p̂_{k+1|k} − p̂_{k|k−1}); 0, 1]`, `J` the 90° rotation), and
//!   every measurement Jacobian is evaluated at the *positions'* first
//!   estimates: the robot's predicted position, a clone's, a point's or an
//!   inverse-depth anchor's. Huang et al. fix every landmark entry; here a
//!   ray's azimuth and inverse depth stay at the current estimate, because
//!   `H N = 0` holds for any value of them (they carry no position) and a
//!   first inverse depth (a PI-SR prior, a 10° triangulation) is too poor
//!   to linearize at for the rest of the run (measured: with every entry
//!   fixed, PI-SR (0.5, 0.25) converged in 0 of 50 Fig. 4 runs);
//! - **observability-constrained EKF** (OC): the same motion Jacobian, and
//!   each measurement Jacobian evaluated at the latest estimate then
//!   projected onto the nearest one (in Frobenius norm) that annihilates the
//!   nullspace `N` at the first estimates: `H* = H (I − N (NᵀN)⁻¹ Nᵀ)`;
//! - **right-invariant EKF** ([`Consistency::Invariant`], Barrau &
//!   Bonnabel 2015): Jacobians at the latest estimate, the covariance that
//!   of the invariant error, whose nullspace is constant (derived in
//!   `slam/invariant.rs`); no first estimates.
//!
//! The nullspace of a block with position `p` is `[I₂, J p]` in its position
//! entries, `[0, 1]` in a heading or ray azimuth, `[0, 0]` in an inverse
//! depth. When a block enters the state through `y = g(x, e)` with Jacobians
//! `G_b` on existing blocks, its nullspace is `Σ G_b N_b`; its *first
//! estimate* is the point whose nullspace that is (its position read off the
//! rotation column, its other entries the new mean), so that augmentation,
//! cloning and the inverse-depth → Euclidean conversion all keep the
//! unobservable directions exactly (the conversion's Jacobian is evaluated at
//! the current estimate, as in the standard filter, and the new point's first
//! estimate follows from it).

use super::{BearingSlam, LandmarkSlot};
use crate::ekf::{BlockJacobian, Ekf, LinearizedMeasurement};
use crate::error::{Result, SlamError};
use crate::landmark::Parameterization;
use crate::measurement::{BearingToInverseDepth, BearingToPoint};
use crate::model::{MeasurementModel, MotionPrediction};
use nalgebra::{DMatrix, DVector, Matrix1, SMatrix, SVector, Vector1, Vector3, Vector4};
use serde::{Deserialize, Serialize};

/// How the filter linearizes, against the spurious information the standard
/// EKF gains along the unobservable global translation and heading (Huang,
/// Mourikis & Roumeliotis, "Observability-based rules for designing
/// consistent EKF SLAM estimators", IJRR 2010). Every option covers inverse
/// depth (Munguía & Grau (11)(12)), points (8)(9), the conversion between
/// them and pose clones; docs/results/filter-consistency.md measures them.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Consistency {
    /// Jacobians at the latest estimate (the paper's filter).
    #[default]
    Standard,
    /// First-estimates Jacobians (Huang, Mourikis & Roumeliotis 2010).
    Fej,
    /// The observability-constrained EKF (Huang, Mourikis & Roumeliotis
    /// 2010): Jacobians at the latest estimate projected so that they
    /// annihilate the nullspace at the first estimates.
    Oc,
    /// The right-invariant EKF (Barrau & Bonnabel, "An EKF-SLAM algorithm
    /// with consistency properties", arXiv:1510.06263, 2015): the
    /// covariance is that of the error in the robot-centred group
    /// SE_{K+1}(2), whose unobservable directions do not depend on the
    /// estimate (see `slam/invariant.rs`).
    Invariant,
}

crate::named_enum!(Consistency, "consistency", [
    Standard => "standard",
    Fej => "fej",
    Oc => "oc",
    Invariant => "invariant",
]);

/// A pose block of the state (the vehicle at 0, or a pose clone) with the
/// point its Jacobians are evaluated at under [`Consistency::Fej`] and whose
/// nullspace [`Consistency::Oc`] keeps.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct PoseAt {
    /// Where its `[x, y, θ]` starts in the state.
    pub(super) offset: usize,
    /// Its first estimate.
    pub(super) first: Vector3<f64>,
    /// Where the bearing-offset state is, if the filter has one (see
    /// `offset`): its bearings then depend on it too.
    pub(super) bearing_offset: Option<usize>,
}

/// The nullspace column of a global rotation about the origin for a block of
/// `len` entries whose position (entries 0 and 1) is `first`: `J p` in the
/// position, 1 in a heading or ray azimuth (entry 2), 0 in an inverse depth.
fn rotation_column(first: &[f64], len: usize) -> DVector<f64> {
    let mut n = DVector::zeros(len);
    n[0] = -first[1];
    n[1] = first[0];
    if len >= 3 {
        n[2] = 1.0;
    }
    n
}

/// The block's nullspace `[e_x, e_y, rotation]` (`len × 3`).
fn nullspace(first: &[f64], len: usize) -> DMatrix<f64> {
    let mut n = DMatrix::zeros(len, 3);
    n[(0, 0)] = 1.0;
    n[(1, 1)] = 1.0;
    n.set_column(2, &rotation_column(first, len));
    n
}

/// The first estimate of a block whose rotation nullspace column is `rot`:
/// its position is the point `p` with `J p = rot[..2]`, its other entries
/// those of `mean`.
fn first_from_rotation(mean: &[f64], rot: &DVector<f64>) -> Vector4<f64> {
    let mut first = Vector4::zeros();
    for (f, &m) in first.iter_mut().zip(mean) {
        *f = m;
    }
    first[0] = rot[1];
    first[1] = -rot[0];
    first
}

impl BearingSlam {
    /// The first estimate of the block starting at `offset` (the vehicle,
    /// a pose clone or a landmark), padded with zeros to four entries.
    fn block_first(&self, offset: usize) -> Option<(Vector4<f64>, usize)> {
        if offset == 0 {
            let p = self.fej_pose;
            return Some((Vector4::new(p.x, p.y, p.z, 0.0), 3));
        }
        if let Some(c) = self.clones.values().find(|c| c.offset == offset) {
            return Some((Vector4::new(c.first.x, c.first.y, c.first.z, 0.0), 3));
        }
        self.landmarks
            .values()
            .find(|s| s.offset == offset)
            .map(|s| (s.first, s.parameterization.dim()))
    }

    /// The first estimate of a block about to enter the state as
    /// `y = g(x, e)` with mean `new_mean` and Jacobians `jacobians` on
    /// existing blocks: the point whose nullspace is `Σ G_b N_b` (module
    /// documentation). Padded with zeros to four entries.
    pub(super) fn first_estimate_of_new(
        &self,
        new_mean: &[f64],
        jacobians: &[BlockJacobian],
    ) -> Vector4<f64> {
        let mut rot = DVector::zeros(new_mean.len());
        for b in jacobians {
            let Some((first, len)) = self.block_first(b.offset) else {
                continue;
            };
            if b.jacobian.ncols() == len {
                rot += &b.jacobian * rotation_column(first.as_slice(), len);
            }
        }
        first_from_rotation(new_mean, &rot)
    }

    /// The motion Jacobian of [`Consistency::Fej`] and [`Consistency::Oc`]:
    /// `Φ = [I, J(p̂_{k+1|k} − p̂_{k|k−1}); 0, 1]`, the displacement measured
    /// from the previous *predicted* pose, so that `Φ` maps the nullspace at
    /// one predicted pose onto the one at the next. Every motion model here
    /// has that structure; only its heading column changes. (Once applied,
    /// the new predicted pose becomes the vehicle's first estimate.)
    ///
    /// [`Consistency::Invariant`] sets the same column from the *current*
    /// estimate, `J(p̂_{k+1|k} − p̂_{k|k})`, which makes the invariant error's
    /// motion Jacobian the identity (`slam/invariant.rs`).
    pub(super) fn constrain_prediction(&self, prediction: &mut MotionPrediction<3>) {
        let from = match self.config.consistency {
            Consistency::Standard => return,
            Consistency::Fej | Consistency::Oc => self.fej_pose,
            Consistency::Invariant => {
                let m = self.ekf.mean();
                Vector3::new(m[0], m[1], m[2])
            }
        };
        let f = &mut prediction.j_state_state;
        f[(0, 2)] = -(prediction.state.y - from.y);
        f[(1, 2)] = prediction.state.x - from.x;
    }

    /// The vehicle block as linearized now.
    pub(super) fn vehicle_at(&self) -> PoseAt {
        PoseAt {
            offset: 0,
            first: self.fej_pose,
            bearing_offset: self.offset_index(),
        }
    }
}

/// A bearing `z` of the landmark in `slot` taken from `pose` (the vehicle or
/// a pose clone), linearized with the model of the landmark's
/// parameterization ((8)(9) for a point, (11)(12) for inverse depth) as
/// `consistency` says: the innovation always at `ekf`'s estimate.
pub(super) fn linearize_bearing(
    ekf: &Ekf,
    consistency: Consistency,
    pose: PoseAt,
    slot: LandmarkSlot,
    z: f64,
    noise: &Matrix1<f64>,
) -> Result<LinearizedMeasurement> {
    let mut out = LinearizedMeasurement {
        innovation: DVector::zeros(1),
        noise: DMatrix::zeros(1, 1),
        blocks: Vec::with_capacity(2),
    };
    let measured = Vector1::new(z);
    match slot.parameterization {
        Parameterization::Euclidean => linearize_consistent(
            ekf,
            &BearingToPoint,
            consistency,
            pose,
            slot.offset,
            &slot.first.fixed_rows::<2>(0).into_owned(),
            &measured,
            noise,
            &mut out,
        ),
        Parameterization::InverseDepth => linearize_consistent(
            ekf,
            &BearingToInverseDepth,
            consistency,
            pose,
            slot.offset,
            &slot.first,
            &measured,
            noise,
            &mut out,
        ),
    }?;
    Ok(out)
}

/// Linearizes `model` between `pose` and the landmark at `landmark_offset`
/// (first estimate `landmark_first`) into `out`: innovation at the current
/// estimate; Jacobians at the current estimate ([`Consistency::Standard`]),
/// at the first estimates ([`Consistency::Fej`]), or at the current estimate
/// projected to annihilate the nullspace at the first estimates
/// ([`Consistency::Oc`]).
#[allow(clippy::too_many_arguments)]
pub(super) fn linearize_consistent<const L: usize, const M: usize, Model>(
    ekf: &Ekf,
    model: &Model,
    consistency: Consistency,
    pose: PoseAt,
    landmark_offset: usize,
    landmark_first: &SVector<f64, L>,
    measured: &SVector<f64, M>,
    noise: &SMatrix<f64, M, M>,
    out: &mut LinearizedMeasurement,
) -> Result<()>
where
    Model: MeasurementModel<3, L, M>,
{
    ekf.linearize_from_into(model, pose.offset, landmark_offset, measured, noise, out)?;
    match consistency {
        // The invariant filter's measurement Jacobian is the standard one
        // read in invariant coordinates (`slam/invariant.rs`).
        Consistency::Standard | Consistency::Invariant => {}
        Consistency::Fej => {
            // Positions at their first estimates; a ray's azimuth and
            // inverse depth (entries 2, 3) at the current estimate: they do
            // not enter the nullspace, and a first inverse depth (a PI-SR
            // prior, a 10° triangulation) is too poor to linearize at.
            let mut at = *landmark_first;
            for i in 2..L {
                at[i] = ekf.mean()[landmark_offset + i];
            }
            let mut vehicle = pose.first;
            vehicle.z = ekf.mean()[pose.offset + 2];
            let at_first = model.predict(&vehicle, &at)?;
            out.blocks[0]
                .jacobian
                .copy_from_slice(at_first.j_z_vehicle.as_slice());
            out.blocks[1]
                .jacobian
                .copy_from_slice(at_first.j_z_landmark.as_slice());
        }
        Consistency::Oc => {
            let mut h = DMatrix::zeros(M, 3 + L);
            h.columns_mut(0, 3).copy_from(&out.blocks[0].jacobian);
            h.columns_mut(3, L).copy_from(&out.blocks[1].jacobian);
            let mut n = DMatrix::zeros(3 + L, 3);
            n.rows_mut(0, 3)
                .copy_from(&nullspace(pose.first.as_slice(), 3));
            n.rows_mut(3, L)
                .copy_from(&nullspace(landmark_first.as_slice(), L));
            let gram = n.transpose() * &n;
            let chol = gram.cholesky().ok_or(SlamError::NotPositiveDefinite {
                what: "nullspace Gram matrix NᵀN",
            })?;
            let hn = &h * &n;
            let projected = &h - hn * chol.solve(&n.transpose());
            out.blocks[0].jacobian.copy_from(&projected.columns(0, 3));
            out.blocks[1].jacobian.copy_from(&projected.columns(3, L));
        }
    }
    // The bearing offset (`offset`): `h += b` in the bearing row (the last
    // one of every model here), `∂h/∂b = 1`. Its nullspace rows are zero,
    // so FEJ and OC leave this column as it is.
    if let Some(b) = pose.bearing_offset {
        let row = M - 1;
        out.innovation[row] = crate::geometry::wrap_angle(out.innovation[row] - ekf.mean()[b]);
        let mut jacobian = DMatrix::zeros(M, 1);
        jacobian[(row, 0)] = 1.0;
        out.blocks.push(BlockJacobian {
            offset: b,
            jacobian,
        });
    }
    Ok(())
}

/// The first estimate of the Euclidean point an inverse-depth landmark with
/// first estimate `first` becomes through the conversion Jacobian
/// `j_point_landmark` (evaluated at the current estimate), at the current
/// point `point`: the point whose nullspace is `J_g N(first)`.
pub(super) fn converted_first_estimate(
    point: &[f64],
    first: &Vector4<f64>,
    j_point_landmark: &DMatrix<f64>,
) -> Vector4<f64> {
    let rot = j_point_landmark * rotation_column(first.as_slice(), 4);
    first_from_rotation(point, &rot)
}
