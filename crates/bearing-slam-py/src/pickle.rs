//! Pickling support: the state of `SensorLog`, `Trace` and `RunResult` as
//! CBOR bytes of the core's serde types (exact floats, NaN and infinities
//! kept, which JSON cannot), so that `pickle`, `multiprocessing`, joblib and
//! Dask carry them between processes. `Config` pickles through its
//! parameters dict (`config.rs`).

use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use serde::Serialize;
use serde::de::DeserializeOwned;

/// Bumped when a pickled state's layout changes: an old pickle then fails
/// with a clear error instead of decoding into garbage.
pub(crate) const PICKLE_VERSION: u32 = 1;

/// The CBOR bytes of `(PICKLE_VERSION, value)`.
pub(crate) fn to_state<T: Serialize>(value: &T, what: &str) -> PyResult<Vec<u8>> {
    let mut bytes = Vec::new();
    ciborium::into_writer(&(PICKLE_VERSION, value), &mut bytes)
        .map_err(|e| PyValueError::new_err(format!("cannot pickle the {what}: {e}")))?;
    Ok(bytes)
}

/// The value of bytes from [`to_state`].
pub(crate) fn from_state<T: DeserializeOwned>(bytes: &[u8], what: &str) -> PyResult<T> {
    let (version, value): (u32, T) = ciborium::from_reader(bytes)
        .map_err(|e| PyValueError::new_err(format!("invalid pickled {what}: {e}")))?;
    if version != PICKLE_VERSION {
        return Err(PyValueError::new_err(format!(
            "pickled {what} of format {version}, this bearing_slam reads format {PICKLE_VERSION}"
        )));
    }
    Ok(value)
}
