//! The input contract of [`Ekf`]'s operations: arguments of the wrong shape
//! or out of the state are refused with the sizes they had, and leave the
//! filter as it was. Each test here was prompted by a mutation run
//! (`make mutants`) that found the check or the size it reports unpinned.

// Tests may unwrap: a panic is a test failure with a message.
#![allow(clippy::unwrap_used)]

use super::tests::random_filter;
use super::*;

/// The error's `expected` and `got`, or a failure naming the error.
fn sizes(err: &SlamError) -> (&'static str, usize, usize) {
    match err {
        SlamError::DimensionMismatch {
            what,
            expected,
            got,
        } => (*what, *expected, *got),
        other => panic!("not a dimension mismatch: {other:?}"),
    }
}

/// The noise of a new block must be `k × k`: wrong rows or wrong columns
/// alone are each refused, and the filter is unchanged.
#[test]
fn augment_refuses_a_noise_of_the_wrong_shape() {
    let before = random_filter(2, 7);
    let mean = DVector::from_vec(vec![1.0, 2.0]);
    let jacobians = [BlockJacobian {
        offset: 0,
        jacobian: DMatrix::from_element(2, 3, 0.1),
    }];
    for (rows, cols) in [(2, 3), (3, 2), (1, 1)] {
        let mut ekf = before.clone();
        let noise = DMatrix::identity(rows, cols);
        let err = ekf.augment(&mean, &jacobians, &noise).unwrap_err();
        assert_eq!(sizes(&err).0, "augmentation noise", "{rows}×{cols}");
        assert_eq!(ekf, before);
    }
}

/// A block reaching past the state reports where it would end
/// (`offset + len`), not some other size.
#[test]
fn a_block_past_the_state_reports_where_it_ends() {
    let mut ekf = random_filter(2, 7); // dim 7
    let jacobians = [BlockJacobian {
        offset: 5,
        jacobian: DMatrix::from_element(1, 3, 0.1),
    }];
    let noise = DMatrix::identity(1, 1);
    let err = ekf
        .augment(&DVector::from_element(1, 0.0), &jacobians, &noise)
        .unwrap_err();
    assert_eq!(sizes(&err), ("augmentation Jacobian block", 7, 8));
}

/// A measurement's noise must be `rows × rows`: wrong rows or wrong columns
/// alone are each refused before anything is written.
#[test]
fn update_refuses_a_noise_of_the_wrong_shape() {
    let before = random_filter(2, 9);
    for (rows, cols) in [(1, 2), (2, 1)] {
        let mut ekf = before.clone();
        let m = LinearizedMeasurement {
            innovation: DVector::from_element(1, 0.1),
            noise: DMatrix::identity(rows, cols),
            blocks: vec![BlockJacobian {
                offset: 0,
                jacobian: DMatrix::from_element(1, 3, 0.5),
            }],
        };
        let err = ekf.update(&[m]).unwrap_err();
        assert_eq!(sizes(&err).0, "measurement noise", "{rows}×{cols}");
        assert_eq!(ekf, before);
    }
}

/// The shrink guard refuses a variance shrunk by *more* than 1e12: shrunk
/// by exactly 1e12 (1e12 → 1, exact in f64) passes, by 2e12 does not.
#[test]
fn a_variance_shrunk_by_exactly_the_limit_passes() {
    use super::update::check_variance_shrink;
    assert!(check_variance_shrink(1e12, 1e12 - 1.0).is_ok());
    assert!(check_variance_shrink(1e12, 1e12 - 0.5).is_err());
}
