//! A linear change of the error variables that adds a multiple of one entry
//! to others, `δx' = M δx` with `M = I + d e_sᵀ`: the covariance becomes
//! `M P Mᵀ`, the mean stays. The right-invariant filter
//! ([`Consistency::Invariant`](crate::slam::Consistency::Invariant)) uses it
//! to carry its invariant covariance from one estimate to the next.

use super::Ekf;
use crate::error::{Result, SlamError, ensure_finite};
use nalgebra::DVector;

impl Ekf {
    /// `P ← M P Mᵀ` with `M = I + d e_sᵀ` (`s = source`, `d[s] = 0`): the
    /// covariance of `δx' = δx + d δx_s`, entry by entry
    /// `P'ᵢⱼ = Pᵢⱼ + dᵢ Pₛⱼ + Pᵢₛ dⱼ + dᵢ dⱼ Pₛₛ`, on the lower triangle,
    /// O(n²). The mean is unchanged. A compressed local phase is folded in
    /// first (every row may change).
    pub fn shear_covariance(&mut self, source: usize, d: &DVector<f64>) -> Result<()> {
        let n = self.dim();
        if d.len() != n {
            return Err(SlamError::DimensionMismatch {
                what: "covariance shear",
                expected: n,
                got: d.len(),
            });
        }
        self.check_range("covariance shear source", source, 1)?;
        if d[source] != 0.0 {
            return Err(SlamError::InvalidParameter {
                name: "covariance shear at its source",
                value: d[source],
                reason: "must be zero (the source entry itself is kept)",
            });
        }
        for &v in d.iter() {
            ensure_finite("covariance shear", v)?;
        }
        self.global_update();
        let c: Vec<f64> = (0..n).map(|i| self.covariance_entry(i, source)).collect();
        let p_ss = c[source];
        let ld = self.cov.nrows();
        let p = self.cov.as_mut_slice();
        for j in 0..n {
            let (dj, cj) = (d[j], c[j]);
            let col = &mut p[j * ld + j..j * ld + n];
            for (k, v) in col.iter_mut().enumerate() {
                let i = j + k;
                *v += d[i] * cj + c[i] * dj + d[i] * dj * p_ss;
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::DMatrix;

    #[test]
    fn shear_is_m_p_mt_and_refuses_a_nonzero_source() {
        let a = DMatrix::from_fn(5, 5, |i, j| ((i * 7 + j * 3) % 5) as f64 - 1.5);
        let p = &a * a.transpose() + DMatrix::identity(5, 5);
        let mut ekf = Ekf::new(DVector::zeros(5), p.clone()).expect("valid");
        let d = DVector::from_vec(vec![0.3, -1.2, 0.0, 2.0, 0.5]);
        ekf.shear_covariance(2, &d).expect("shears");
        let mut m = DMatrix::identity(5, 5);
        m.set_column(2, &(m.column(2) + &d));
        let expected = &m * p * m.transpose();
        assert!((ekf.covariance() - expected).amax() < 1e-12);
        let bad = DVector::from_vec(vec![0.0, 0.0, 1.0, 0.0, 0.0]);
        assert!(ekf.shear_covariance(2, &bad).is_err());
        assert!(ekf.shear_covariance(2, &DVector::zeros(4)).is_err());
    }
}
