//! When an inverse-depth landmark becomes a point, and which landmarks a
//! map holds. A landmark converts (Munguía & Grau (11), `J P Jᵀ`) by the
//! shared [`ConversionRule`](crate::landmark::ConversionRule) of
//! [`SlamConfig::conversion_rule`](super::SlamConfig::conversion_rule):
//! Civera et al.'s linearity index of its measurement below the threshold
//! and, by default, the conversion's own, `2 σ_ρ/ρ`
//! ([`depth_linearity_index`](crate::landmark::depth_linearity_index)), too; a map
//! ([`BearingSlam::snapshot`]) holds the landmarks whose depth is bounded
//! at 95 %.

use super::BearingSlam;
use super::consistency::converted_first_estimate;
use crate::error::{Result, SlamError};
use crate::landmark::{Parameterization, depth_bounded, inverse_depth_to_point, linearity_index};
use crate::trace::SlamEvent;
use nalgebra::{DMatrix, DVector};

impl BearingSlam {
    /// Whether landmark `id`'s depth is bounded at 95 %: a point, or an
    /// inverse depth that [`depth_bounded`] passes (`ρ − 2σ_ρ > 0`).
    pub(super) fn depth_bounded(&self, id: u64) -> bool {
        let Some(slot) = self.landmarks.get(&id) else {
            return false;
        };
        match slot.parameterization {
            Parameterization::Euclidean => true,
            Parameterization::InverseDepth => {
                let rho = self.ekf.mean()[slot.offset + 3];
                let variance = self.ekf.covariance_entry(slot.offset + 3, slot.offset + 3);
                depth_bounded(rho, variance)
            }
        }
    }

    /// Converts the inverse-depth landmarks that the configured
    /// [`ConversionRule`](crate::landmark::ConversionRule) passes, seen from
    /// the current sensor position, into Euclidean points (4 → 2 state
    /// entries).
    pub(super) fn convert_linear_landmarks(&mut self) -> Result<()> {
        let Some(rule) = self.config.conversion_rule() else {
            return Ok(());
        };
        let sensor = self.ekf.block::<2>(0)?;
        let ids: Vec<u64> = self
            .landmarks
            .iter()
            .filter(|(_, s)| s.parameterization == Parameterization::InverseDepth)
            .map(|(&id, _)| id)
            .collect();
        for id in ids {
            let Some(slot) = self.landmarks.get(&id).copied() else {
                continue;
            };
            let y = self.ekf.block::<4>(slot.offset)?;
            let rho_variance = self.ekf.covariance_entry(slot.offset + 3, slot.offset + 3);
            let Ok(index) = linearity_index(&y, rho_variance, &sensor) else {
                continue;
            };
            if !rule.converts(index, y[3], rho_variance) {
                continue;
            }
            let converted = inverse_depth_to_point(&y)?;
            let j_point_landmark =
                DMatrix::from_column_slice(2, 4, converted.j_point_landmark.as_slice());
            match self.ekf.reparameterize(
                slot.offset,
                4,
                &DVector::from_column_slice(converted.point.as_slice()),
                &j_point_landmark,
            ) {
                Ok(()) => {}
                // A point too far for f64 (ρ near zero) stays in inverse
                // depth, the parameterization made for it; nothing changed.
                Err(SlamError::NonFinite { .. }) => continue,
                Err(e) => return Err(e),
            }
            self.shift_offsets_after(slot.offset, 2);
            if let Some(s) = self.landmarks.get_mut(&id) {
                s.parameterization = Parameterization::Euclidean;
                s.first = converted_first_estimate(
                    converted.point.as_slice(),
                    &slot.first,
                    &j_point_landmark,
                );
            }
            self.record(SlamEvent::LandmarkConverted {
                id,
                linearity_index: index,
            });
        }
        Ok(())
    }
}
