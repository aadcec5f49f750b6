//! numpy in, numpy out: shape checks with clear `ValueError`s, and row-major
//! arrays built from nalgebra matrices (which are column-major).

use bearing_slam::core::Pose2;
use bearing_slam::core::nalgebra::{SMatrix, SVector, Vector2, Vector3};
use numpy::{
    AllowTypeChange, PyArray1, PyArray2, PyArray3, PyArrayLike1, PyArrayLike2, PyArrayMethods,
    PyUntypedArrayMethods,
};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};
use serde_json::{Map, Number, Value};

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

// ---------------------------------------------------------- serde <-> Python
//
// The one converter across the binding boundary: a serde value (a config, a
// report, a record) becomes plain Python objects and back, walked directly
// (no JSON text in between, so every float crosses exactly).

/// A serde value as a Python object: dicts, lists, str, int, float, bool, None.
pub(crate) fn to_py<'py, T: serde::Serialize>(
    py: Python<'py>,
    value: &T,
) -> PyResult<Bound<'py, PyAny>> {
    let value = serde_json::to_value(value)
        .map_err(|e| PyValueError::new_err(format!("cannot convert to Python: {e}")))?;
    value_to_py(py, &value)
}

/// A JSON value as a Python object.
fn value_to_py<'py>(py: Python<'py>, value: &Value) -> PyResult<Bound<'py, PyAny>> {
    Ok(match value {
        Value::Null => py.None().into_bound(py),
        Value::Bool(b) => PyBool::new(py, *b).to_owned().into_any(),
        Value::Number(n) if n.is_f64() => n.as_f64().into_pyobject(py)?.into_any(),
        Value::Number(n) => match (n.as_u64(), n.as_i64()) {
            (Some(u), _) => u.into_pyobject(py)?.into_any(),
            (None, Some(i)) => i.into_pyobject(py)?.into_any(),
            (None, None) => n.as_f64().into_pyobject(py)?.into_any(),
        },
        Value::String(s) => PyString::new(py, s).into_any(),
        Value::Array(items) => PyList::new(
            py,
            items
                .iter()
                .map(|item| value_to_py(py, item))
                .collect::<PyResult<Vec<_>>>()?,
        )?
        .into_any(),
        Value::Object(fields) => {
            let d = PyDict::new(py);
            for (k, v) in fields {
                d.set_item(k, value_to_py(py, v)?)?;
            }
            d.into_any()
        }
    })
}

/// A Python object made of dicts, lists, tuples, str, int, float (finite),
/// bool and None as a JSON value; `what` names it in errors.
pub(crate) fn from_py(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<Value> {
    if obj.is_none() {
        return Ok(Value::Null);
    }
    if let Ok(b) = obj.cast::<PyBool>() {
        return Ok(Value::Bool(b.is_true()));
    }
    if obj.is_instance_of::<PyInt>() {
        if let Ok(u) = obj.extract::<u64>() {
            return Ok(Value::Number(u.into()));
        }
        return Ok(Value::Number(obj.extract::<i64>()?.into()));
    }
    if let Ok(f) = obj.cast::<PyFloat>() {
        let v = f.value();
        return Number::from_f64(v)
            .map(Value::Number)
            .ok_or_else(|| PyValueError::new_err(format!("{what}: non-finite number {v}")));
    }
    if let Ok(s) = obj.cast::<PyString>() {
        return Ok(Value::String(s.to_str()?.to_owned()));
    }
    if let Ok(d) = obj.cast::<PyDict>() {
        let mut m = Map::new();
        for (k, v) in d.iter() {
            let key: String = k
                .extract()
                .map_err(|_| PyTypeError::new_err(format!("{what}: dict keys must be str")))?;
            let inner = from_py(&v, &format!("{what}.{key}"))?;
            m.insert(key, inner);
        }
        return Ok(Value::Object(m));
    }
    if obj.is_instance_of::<PyList>() || obj.is_instance_of::<PyTuple>() {
        let items = obj
            .try_iter()?
            .map(|item| from_py(&item?, what))
            .collect::<PyResult<Vec<_>>>()?;
        return Ok(Value::Array(items));
    }
    Err(PyTypeError::new_err(format!(
        "{what}: cannot convert {} (expected dict, list, str, int, float, bool or None)",
        obj.get_type().name()?
    )))
}
