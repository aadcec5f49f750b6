//! numpy in, numpy out: shape checks with clear `ValueError`s, and row-major
//! arrays built from nalgebra matrices (which are column-major).

use bearing_slam::core::Pose2;
use bearing_slam::core::nalgebra::{Matrix3, SMatrix, SVector, Vector2, Vector3};
use numpy::{
    AllowTypeChange, PyArray1, PyArray2, PyArray3, PyArrayLike1, PyArrayLike2, PyArrayMethods,
    PyUntypedArrayMethods,
};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;

/// A float64 vector given as any array-like.
pub(crate) type In1<'py> = PyArrayLike1<'py, f64, AllowTypeChange>;
/// A float64 matrix given as any array-like.
pub(crate) type In2<'py> = PyArrayLike2<'py, f64, AllowTypeChange>;

/// The entries of a vector of exactly `N` numbers named `what`.
pub(crate) fn fixed<const N: usize>(a: &In1<'_>, what: &str) -> PyResult<SVector<f64, N>> {
    let view = a.as_array();
    if view.len() != N {
        return Err(PyValueError::new_err(format!(
            "{what} must have shape ({N},), got ({},)",
            view.len()
        )));
    }
    Ok(SVector::<f64, N>::from_iterator(view.iter().copied()))
}

/// A pose `[x, y, θ]`.
pub(crate) fn vec3(a: &In1<'_>, what: &str) -> PyResult<Vector3<f64>> {
    fixed::<3>(a, what)
}

/// A point `[x, y]`.
pub(crate) fn vec2(a: &In1<'_>, what: &str) -> PyResult<Vector2<f64>> {
    fixed::<2>(a, what)
}

/// An `R×C` matrix.
pub(crate) fn mat<const R: usize, const C: usize>(
    a: &In2<'_>,
    what: &str,
) -> PyResult<SMatrix<f64, R, C>> {
    let view = a.as_array();
    if view.shape() != [R, C] {
        return Err(PyValueError::new_err(format!(
            "{what} must have shape ({R}, {C}), got {:?}",
            view.shape()
        )));
    }
    Ok(SMatrix::<f64, R, C>::from_fn(|r, c| view[[r, c]]))
}

/// The rows of an `(n, cols)` array.
pub(crate) fn rows(a: &In2<'_>, cols: usize, what: &str) -> PyResult<Vec<Vec<f64>>> {
    let view = a.as_array();
    if view.ncols() != cols {
        return Err(PyValueError::new_err(format!(
            "{what} must have shape (n, {cols}), got {:?}",
            view.shape()
        )));
    }
    Ok(view.rows().into_iter().map(|r| r.to_vec()).collect())
}

/// Poses from an `(n, 3)` array.
pub(crate) fn poses(a: &In2<'_>, what: &str) -> PyResult<Vec<Pose2>> {
    Ok(rows(a, 3, what)?
        .into_iter()
        .map(|r| Pose2::new(r[0], r[1], r[2]))
        .collect())
}

/// Landmark ids from an integer array-like: unsigned or non-negative signed
/// integers; anything else is a `TypeError` (floats, strings) or a
/// `ValueError` (negative ids, wrong dimension).
pub(crate) fn ids(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<Vec<u64>> {
    let py = obj.py();
    let np = py.import("numpy")?;
    let arr = np.call_method1("asarray", (obj,))?;
    let arr = arr
        .cast_into::<numpy::PyUntypedArray>()
        .map_err(|_| PyTypeError::new_err(format!("{what} must be an integer array")))?;
    if arr.ndim() != 1 {
        return Err(PyValueError::new_err(format!(
            "{what} must be one-dimensional, got shape {:?}",
            arr.shape()
        )));
    }
    if arr.len() == 0 {
        return Ok(Vec::new());
    }
    let kind = numpy::PyArrayDescrMethods::kind(&arr.dtype());
    match kind {
        b'u' => {
            let a = arr.call_method1("astype", ("uint64",))?;
            let a = a.cast_into::<PyArray1<u64>>()?;
            Ok(a.readonly().as_array().to_vec())
        }
        b'i' => {
            let a = arr.call_method1("astype", ("int64",))?;
            let a = a.cast_into::<PyArray1<i64>>()?;
            a.readonly()
                .as_array()
                .iter()
                .map(|&v| {
                    u64::try_from(v).map_err(|_| {
                        PyValueError::new_err(format!("{what} must be non-negative, got {v}"))
                    })
                })
                .collect()
        }
        _ => Err(PyTypeError::new_err(format!(
            "{what} must hold integers, got dtype {}",
            arr.dtype()
        ))),
    }
}

/// A float64 vector.
pub(crate) fn arr1<'py>(py: Python<'py>, v: Vec<f64>) -> Bound<'py, PyArray1<f64>> {
    PyArray1::from_vec(py, v)
}

/// A float64 `(n, cols)` array from row-major data.
pub(crate) fn arr2<'py>(
    py: Python<'py>,
    flat: Vec<f64>,
    cols: usize,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let n = flat.len().checked_div(cols).unwrap_or(0);
    PyArray1::from_vec(py, flat).reshape([n, cols])
}

/// A float64 `(n, r, c)` array from row-major data.
pub(crate) fn arr3<'py>(
    py: Python<'py>,
    flat: Vec<f64>,
    r: usize,
    c: usize,
) -> PyResult<Bound<'py, PyArray3<f64>>> {
    let n = flat.len().checked_div(r * c).unwrap_or(0);
    PyArray1::from_vec(py, flat).reshape([n, r, c])
}

/// Row-major entries of a matrix.
pub(crate) fn row_major<const R: usize, const C: usize>(m: &SMatrix<f64, R, C>) -> Vec<f64> {
    let mut out = Vec::with_capacity(R * C);
    for r in 0..R {
        for c in 0..C {
            out.push(m[(r, c)]);
        }
    }
    out
}

/// A matrix as a numpy array.
pub(crate) fn matrix<'py, const R: usize, const C: usize>(
    py: Python<'py>,
    m: &SMatrix<f64, R, C>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    arr2(py, row_major(m), C)
}

/// A vector as a numpy array.
pub(crate) fn vector<'py, const N: usize>(
    py: Python<'py>,
    v: &SVector<f64, N>,
) -> Bound<'py, PyArray1<f64>> {
    arr1(py, v.iter().copied().collect())
}

/// A pose as `[x, y, θ]`.
pub(crate) fn pose<'py>(py: Python<'py>, p: &Pose2) -> Bound<'py, PyArray1<f64>> {
    arr1(py, vec![p.x, p.y, p.theta])
}

/// A 3×3 row-major array as a matrix.
pub(crate) fn mat3_from_rows(c: &[[f64; 3]; 3]) -> Matrix3<f64> {
    Matrix3::from_fn(|r, k| c[r][k])
}

/// A serde value as a Python object (through JSON: dicts, lists, floats).
pub(crate) fn to_py<'py, T: serde::Serialize>(
    py: Python<'py>,
    value: &T,
) -> PyResult<Bound<'py, PyAny>> {
    let text = serde_json::to_string(value)
        .map_err(|e| PyValueError::new_err(format!("cannot convert to Python: {e}")))?;
    py.import("json")?.call_method1("loads", (text,))
}
