//! Error mapping: one Python exception class per error kind of the Rust
//! crates, all under `BearingSlamError`. Classes that also fit a built-in
//! family (a bad value, a missing key) subclass it too, so `except ValueError`
//! and `except KeyError` work as a Python user expects.

use bearing_slam::core::SlamError;
use bearing_slam::io::IoError;
use bearing_slam::io::mrclam::MrclamError;
use bearing_slam::sim::SimError;
use pyo3::exceptions::{PyException, PyKeyError, PyValueError};
use pyo3::prelude::*;
use pyo3::sync::PyOnceLock;
use pyo3::types::{PyDict, PyTuple, PyType};

/// The built-in class an exception also derives from, besides `BearingSlamError`.
#[derive(Clone, Copy)]
enum Also {
    Nothing,
    Value,
    Key,
}

/// Every exception class: name, docstring, extra base.
const CLASSES: [(&str, &str, Also); 16] = [
    (
        "NonFiniteError",
        "A NaN or infinite number where a finite one is required.",
        Also::Value,
    ),
    (
        "InvalidNoiseError",
        "A variance or standard deviation that is zero, negative or not finite.",
        Also::Value,
    ),
    (
        "InvalidParameterError",
        "A parameter outside its valid range.",
        Also::Value,
    ),
    (
        "DimensionMismatchError",
        "Arrays or matrices of the wrong size.",
        Also::Value,
    ),
    (
        "UnknownLandmarkError",
        "A landmark id that the filter does not hold.",
        Also::Key,
    ),
    (
        "DuplicateMeasurementError",
        "The same landmark id twice in one batch of measurements.",
        Also::Value,
    ),
    (
        "NotPositiveDefiniteError",
        "A covariance (or innovation covariance) that is not positive definite.",
        Also::Value,
    ),
    (
        "LandmarkAtInfinityError",
        "An inverse-depth landmark whose inverse depth is not positive has no point.",
        Also::Nothing,
    ),
    (
        "DegenerateGeometryError",
        "Geometry where a quantity is undefined (landmark at the sensor, parallel rays).",
        Also::Value,
    ),
    (
        "DivergedError",
        "The estimate would leave the range where it means anything; refused.",
        Also::Nothing,
    ),
    (
        "TimeOrderError",
        "Time stamps that run backwards.",
        Also::Value,
    ),
    (
        "MismatchError",
        "Two estimates or sequences that must align but do not (or no ground truth).",
        Also::Value,
    ),
    (
        "SimulationError",
        "The simulator refused a scenario (unknown name, bad file, bad parameter) or diverged.",
        Also::Nothing,
    ),
    (
        "McapError",
        "An MCAP file could not be read or written (missing, corrupt, not a bearing-slam log).",
        Also::Nothing,
    ),
    (
        "DatasetError",
        "A dataset (MRCLAM) could not be loaded.",
        Also::Nothing,
    ),
    // Placeholder row so the array length documents the base class too.
    (
        "BearingSlamError",
        "Base class of every error raised by bearing_slam.",
        Also::Nothing,
    ),
];

/// The classes, created once when the module is initialized.
static TYPES: PyOnceLock<Vec<(&'static str, Py<PyType>)>> = PyOnceLock::new();

/// Creates the exception classes and adds them to `module`.
pub(crate) fn register(module: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = module.py();
    let builtins = py.import("builtins")?;
    let type_fn = builtins.getattr("type")?;
    let base_str = builtins.getattr("BaseException")?.getattr("__str__")?;
    let make = |name: &str, doc: &str, bases: Bound<'_, PyTuple>| -> PyResult<Py<PyType>> {
        let dict = PyDict::new(py);
        dict.set_item("__doc__", doc)?;
        dict.set_item("__module__", "bearing_slam")?;
        // KeyError quotes its message in str(); keep the plain message.
        dict.set_item("__str__", &base_str)?;
        Ok(type_fn
            .call1((name, bases, dict))?
            .cast_into::<PyType>()?
            .unbind())
    };
    let (base_name, base_doc, _) = CLASSES[CLASSES.len() - 1];
    let base = make(
        base_name,
        base_doc,
        PyTuple::new(py, [py.get_type::<PyException>()])?,
    )?;
    let mut types = vec![(base_name, base.clone_ref(py))];
    for &(name, doc, also) in &CLASSES[..CLASSES.len() - 1] {
        let b = base.bind(py).clone();
        let bases = match also {
            Also::Nothing => PyTuple::new(py, [b])?,
            Also::Value => PyTuple::new(py, [b, py.get_type::<PyValueError>()])?,
            Also::Key => PyTuple::new(py, [b, py.get_type::<PyKeyError>()])?,
        };
        types.push((name, make(name, doc, bases)?));
    }
    for (name, ty) in &types {
        module.add(*name, ty.bind(py))?;
    }
    let _ = TYPES.set(py, types);
    Ok(())
}

/// An exception of class `name` with `message`.
pub(crate) fn raise(name: &str, message: String) -> PyErr {
    Python::attach(|py| {
        match TYPES
            .get(py)
            .and_then(|t| t.iter().find(|(n, _)| *n == name))
        {
            Some((_, ty)) => PyErr::from_type(ty.bind(py).clone(), message),
            None => PyException::new_err(message),
        }
    })
}

/// The Python class name of a core error.
fn slam_class(e: &SlamError) -> &'static str {
    match e {
        SlamError::NonFinite { .. } => "NonFiniteError",
        SlamError::InvalidNoise { .. } => "InvalidNoiseError",
        SlamError::InvalidParameter { .. } => "InvalidParameterError",
        SlamError::DimensionMismatch { .. } => "DimensionMismatchError",
        SlamError::UnknownLandmark(_) => "UnknownLandmarkError",
        SlamError::DuplicateMeasurement(_) => "DuplicateMeasurementError",
        SlamError::NotPositiveDefinite { .. } => "NotPositiveDefiniteError",
        SlamError::LandmarkAtInfinity { .. } => "LandmarkAtInfinityError",
        SlamError::TimeOrder { .. } => "TimeOrderError",
        SlamError::Degenerate(_) => "DegenerateGeometryError",
        SlamError::Diverged { .. } => "DivergedError",
        SlamError::Mismatch(_) => "MismatchError",
        SlamError::UnknownName(_) => "InvalidParameterError",
    }
}

/// Maps a core error to its Python class, with the Rust message.
pub(crate) fn slam(e: SlamError) -> PyErr {
    raise(slam_class(&e), e.to_string())
}

/// Maps a simulator error to `SimulationError`.
pub(crate) fn sim(e: SimError) -> PyErr {
    raise("SimulationError", e.to_string())
}

/// Maps an MCAP error to `McapError`.
pub(crate) fn io(e: IoError) -> PyErr {
    raise("McapError", e.to_string())
}

/// Maps a dataset error to `DatasetError`.
pub(crate) fn dataset(e: MrclamError) -> PyErr {
    raise("DatasetError", e.to_string())
}

/// Extension to map core results.
pub(crate) trait SlamResultExt<T> {
    /// Maps the error to its Python class.
    fn py(self) -> PyResult<T>;
}

impl<T> SlamResultExt<T> for Result<T, SlamError> {
    fn py(self) -> PyResult<T> {
        self.map_err(slam)
    }
}
