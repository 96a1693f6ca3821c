//! Core errors and panics as Python exceptions.

use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

pyo3::create_exception!(
    thicket_native,
    ThicketError,
    PyValueError,
    "Invalid input or a failure inside Thicket's geometry core; the message says which."
);

pub fn to_py(e: thicket_core::Error) -> PyErr {
    ThicketError::new_err(e.to_string())
}

/// Runs heavy core work with the GIL released, turning a Rust panic into a
/// `ThicketError` instead of pyo3's `PanicException` (a BaseException that
/// `except Exception` in an operator would not catch).
pub fn run_detached<T: Send>(py: Python<'_>, work: impl FnOnce() -> thicket_core::Result<T> + Send) -> PyResult<T> {
    py.detach(|| std::panic::catch_unwind(std::panic::AssertUnwindSafe(work)))
        .map_err(|panic| {
            let what = panic
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| panic.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "unknown panic".into());
            ThicketError::new_err(format!("internal error in thicket-native (please report): {what}"))
        })?
        .map_err(to_py)
}
