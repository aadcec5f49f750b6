//! The right-invariant EKF for SLAM ([`Consistency::Invariant`]), after
//! Barrau & Bonnabel, "An EKF-SLAM algorithm with consistency properties"
//! (arXiv:1510.06263, 2015) and "The invariant extended Kalman filter as a
//! stable observer" (IEEE TAC 62(4), 2017), in the 2-D group
//! SE_{K+1}(2) of the robot's rotation and every position of the state.
//!
//! # The invariant error
//!
//! For the state `x = [p, θ, blocks…]` (robot position and heading, then
//! pose clones `[q, θ_c]`, points `q`, inverse-depth rays `[q, α, ρ]`) the
//! right-invariant error `η = X̂ X⁻¹` is, to first order in `δx = x̂ − x`,
//!
//! - `ξ_θ = δθ` for the robot's heading,
//! - `ξ_q = δq − δθ J q̂` for every position `q` (robot, clone, point,
//!   inverse-depth anchor; `J` the 90° rotation): positions turn with the
//!   robot's heading error,
//! - `ξ_α = δα − δθ` for every other angle (a clone's heading, a ray's
//!   azimuth),
//! - `ξ_ρ = δρ` for an inverse depth (invariant under rigid motions).
//!
//! That is `ξ = T(x̂) δx` with `T(x̂) = I − n(x̂) e_θᵀ`, where `n(x̂)` is the
//! rotation column of the nullspace (`J q̂` in positions, 1 in angles) with
//! its robot-heading entry set to 0, so `e_θᵀ n = 0` and
//! `T⁻¹ = I + n e_θᵀ`. The retraction `x = x̂ ⊞ ξ` that it linearizes turns
//! positions by `ξ_θ` and adds the rest.
//!
//! # Why the unobservable directions are constant
//!
//! A global translation `t` and rotation `φ` of the whole scene change the
//! additive error along `N(x̂) = [N_t, n(x̂) + e_θ]` (`N_t` = `I₂` in every
//! position). In invariant coordinates these become `N_ξ = T(x̂) N(x̂) =
//! [N_t, e_θ]`, which does not depend on the estimate. Then, for every
//! estimate:
//!
//! - **measurement**: a bearing is unchanged by a rigid motion, so the
//!   Jacobian at the latest estimate satisfies `H(x̂) N(x̂) = 0`, hence
//!   `H_ξ N_ξ = H T⁻¹ N_ξ = H N(x̂) = 0`;
//! - **propagation**: every motion model here moves the robot as
//!   `p⁺ = p + R(θ) u`, `θ⁺ = θ + ω`, so `F = [I, J(p̂⁺ − p̂); 0, 1]` and the
//!   invariant error's Jacobian is `F_ξ = T(x̂⁺) F T(x̂)⁻¹ = I` (landmarks and
//!   clones do not move): `F_ξ N_ξ = N_ξ`, and the error propagates
//!   independently of the estimate (Barrau & Bonnabel 2017, Thm. 2, for
//!   group-affine dynamics). The heading column is set from the current
//!   estimate in `constrain_prediction` so that this holds to rounding;
//! - **augmentation and conversion**: PI-SR (13), the triangulations, pose
//!   cloning and the inverse-depth → point conversion (11) are equivariant
//!   (`g(rigid ∘ x) = rigid ∘ g(x)`), so their Jacobians map `N(x̂)` onto the
//!   new block's `N`, and `N_ξ` onto `N_ξ`.
//!
//! So the filter can gain no information along the global translation and
//! heading, whichever estimates its Jacobians are evaluated at; unlike FEJ
//! and OC it needs no first estimates.
//!
//! # How this filter stores it
//!
//! The [`Ekf`] keeps the *additive* covariance at the current estimate,
//! `P = T(x̂)⁻¹ P_ξ T(x̂)⁻ᵀ`, so every public read (pose covariance,
//! landmark covariances, snapshots, `ekf()`) is the usual one. Prediction,
//! augmentation, conversion and removal are linear maps at one fixed
//! estimate and give the same result in either coordinates. Only the update
//! moves the estimate: the invariant EKF keeps `P_ξ⁺ = (I − K_ξ H_ξ) P_ξ` as
//! the covariance of the error *at the new estimate* `x̂⁺`, so the additive
//! covariance is carried along by `P ← M P Mᵀ`,
//! `M = T(x̂⁺)⁻¹ T(x̂⁻) = I + (n(x̂⁺) − n(x̂⁻)) e_θᵀ`, i.e. every position's
//! rows get `J(q̂⁺ − q̂⁻)` times the heading's ([`Ekf::shear_covariance`]).
//! That is the whole difference from the standard EKF, which keeps
//! `(I − KH) P` at `x̂⁺` in additive coordinates and so gains information
//! along `n(x̂⁺) ≠ n(x̂⁻)`. The state correction itself is additive,
//! `x̂⁺ = x̂⁻ + T⁻¹ K_ξ ν` (the group exponential differs in second order).
//!
//! The iterated update (`iterated.rs`) relinearizes at each iterate `x̂ᵢ`:
//! the prior's covariance is carried from `x̂₀` to `x̂ᵢ`, updated with
//! `H(x̂ᵢ)` (so `H_ξ N_ξ = 0` at every pass) and carried on to `x̂ᵢ₊₁`.

use super::{BearingSlam, Consistency};
use crate::ekf::Ekf;
use crate::error::Result;
use nalgebra::DVector;

/// The robot heading's index in the state: the shear's source `e_θ`.
pub(super) const HEADING: usize = 2;

impl BearingSlam {
    /// Where every position `[x, y]` of the state starts: the robot, each
    /// pose clone, each point and inverse-depth anchor.
    pub(super) fn position_offsets(&self) -> Vec<usize> {
        std::iter::once(0)
            .chain(self.clones.values().map(|c| c.offset))
            .chain(self.landmarks.values().map(|s| s.offset))
            .collect()
    }

    /// `d = n(to) − n(from)`: `J(q_to − q_from)` in every position, 0
    /// elsewhere (the column of `M = T(to)⁻¹ T(from)` at the heading).
    pub(super) fn invariant_shear(&self, from: &DVector<f64>, to: &DVector<f64>) -> DVector<f64> {
        let mut d = DVector::zeros(to.len());
        for o in self.position_offsets() {
            if o + 1 < to.len() && o + 1 < from.len() {
                d[o] = -(to[o + 1] - from[o + 1]);
                d[o + 1] = to[o] - from[o];
            }
        }
        d
    }

    /// Under [`Consistency::Invariant`], re-expresses `ekf`'s covariance,
    /// additive at the estimate `from`, as the additive covariance at `to`
    /// with the same invariant covariance `P_ξ` (module documentation). A
    /// no-op for the other options.
    pub(super) fn carry_invariant(
        &self,
        ekf: &mut Ekf,
        from: &DVector<f64>,
        to: &DVector<f64>,
    ) -> Result<()> {
        if self.config.consistency != Consistency::Invariant {
            return Ok(());
        }
        ekf.shear_covariance(HEADING, &self.invariant_shear(from, to))
    }

    /// The mean to carry the invariant covariance from after an update, if
    /// the filter is invariant (taken before the update).
    pub(super) fn invariant_anchor(&self) -> Option<DVector<f64>> {
        (self.config.consistency == Consistency::Invariant).then(|| self.ekf.mean().clone())
    }

    /// After an update from the estimate `from` (an
    /// [`invariant_anchor`](Self::invariant_anchor)), carries the filter's
    /// own covariance to its new estimate; `None` does nothing.
    pub(super) fn carry_invariant_from(&mut self, from: Option<DVector<f64>>) -> Result<()> {
        let Some(from) = from else {
            return Ok(());
        };
        let d = self.invariant_shear(&from, self.ekf.mean());
        self.ekf.shear_covariance(HEADING, &d)
    }
}
