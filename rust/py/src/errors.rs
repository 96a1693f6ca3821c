//! Core errors and panics as Python exceptions.

use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

pyo3::create_exception!(thicket_native, ThicketError, PyValueError, "Invalid input or a failure inside Thicket's geometry core; the message says which.");

pyo3::create_exception!(
    thicket_native,
    InvalidInput,
    ThicketError,
    "A mesh, array or setting Thicket cannot use (empty, non-finite, out of range, wrong shape); the message says which."
);

pyo3::create_exception!(
    thicket_native,
    OverLimit,
    InvalidInput,
    "Work refused because its estimated output would pass a limit (Sample Limit, memory limit); the message names the estimate, the limit and what to change."
);

pyo3::create_exception!(thicket_native, FileError, ThicketError, "A file or folder that cannot be read or written; the message names it.");

pyo3::create_exception!(
    thicket_native,
    DeviceError,
    ThicketError,
    "The GPU could not render (no adapter, a refused or lost device, a failed frame); the CPU reference can."
);

pyo3::create_exception!(thicket_native, Cancelled, ThicketError, "The work was cancelled through its progress callback (it returned False) or by Ctrl-C.");

pyo3::create_exception!(
    thicket_native,
    InternalError,
    ThicketError,
    "A bug inside thicket-native (a Rust panic, caught so Blender keeps running); please report it."
);

/// Each core error as the `ThicketError` subclass that names its kind.
pub fn to_py(e: thicket_core::Error) -> PyErr {
    use thicket_core::Error as E;
    let message = e.to_string();
    match e {
        E::Cancelled => Cancelled::new_err(message),
        E::Device(_) => DeviceError::new_err(message),
        E::File { .. } => FileError::new_err(message),
        E::OverLimit(_) => OverLimit::new_err(message),
        E::EmptyMesh | E::InvalidMesh(_) | E::NonFinite { .. } | E::InvalidParameter(_) => InvalidInput::new_err(message),
    }
}

/// Runs heavy core work with the GIL released, turning a Rust panic into an
/// `InternalError` (a `ThicketError`) instead of pyo3's `PanicException` (a BaseException that
/// `except Exception` in an operator would not catch).
pub fn run_detached<T: Send>(py: Python<'_>, work: impl FnOnce() -> thicket_core::Result<T> + Send) -> PyResult<T> {
    py.detach(|| std::panic::catch_unwind(std::panic::AssertUnwindSafe(work))).map_err(panic_error)?.map_err(to_py)
}

/// A panic's message as an `InternalError`.
fn panic_error(panic: Box<dyn std::any::Any + Send>) -> PyErr {
    let what =
        panic.downcast_ref::<&str>().map(|s| s.to_string()).or_else(|| panic.downcast_ref::<String>().cloned()).unwrap_or_else(|| "unknown panic".into());
    InternalError::new_err(format!("internal error in thicket-native (please report): {what}"))
}

/// [`run_watched`] when the caller gave a `progress` callable (None: [`run_detached`]);
/// `work` gets the [`Progress`](thicket_core::progress::Progress) to report to, if any.
pub fn run_maybe_watched<T: Send>(
    py: Python<'_>,
    progress: Option<&Bound<'_, PyAny>>,
    work: impl FnOnce(Option<&thicket_core::progress::Progress>) -> thicket_core::Result<T> + Send,
) -> PyResult<T> {
    match progress {
        Some(callback) => {
            let watch = thicket_core::progress::Progress::default();
            run_watched(py, callback, &watch, || work(Some(&watch)))
        }
        None => run_detached(py, || work(None)),
    }
}

/// Runs heavy core work on a worker thread, like [`run_detached`], while this thread
/// calls `callback(fraction)` at once, then about ten times a second, with the GIL held
/// (fraction from `progress`), and with 1.0 when the work succeeded. A callback that returns `False` or raises, or a signal such as
/// Ctrl-C, cancels the work (the callback is not called again); an exception is
/// raised once the work has stopped.
pub fn run_watched<T: Send>(
    py: Python<'_>,
    callback: &Bound<'_, PyAny>,
    progress: &thicket_core::progress::Progress,
    work: impl FnOnce() -> thicket_core::Result<T> + Send,
) -> PyResult<T> {
    let (result, raised) = std::thread::scope(|scope| {
        let worker = scope.spawn(move || std::panic::catch_unwind(std::panic::AssertUnwindSafe(work)));
        let mut raised: Option<PyErr> = None;
        let mut first = true;
        loop {
            // The callback hears at once, then every 100 ms.
            if !std::mem::take(&mut first) {
                py.detach(|| {
                    let start = std::time::Instant::now();
                    while !worker.is_finished() && start.elapsed() < std::time::Duration::from_millis(100) {
                        std::thread::sleep(std::time::Duration::from_millis(2));
                    }
                });
                if worker.is_finished() {
                    break;
                }
            }
            // Once cancelled (a `False`, an exception, a signal) the callback is not
            // asked again while the work winds down: a phase between two cancel
            // checks can outlast the 100 ms tick.
            if raised.is_some() || progress.is_cancelled() {
                continue;
            }
            let answer = py.check_signals().and_then(|_| callback.call1((progress.fraction(),)));
            match answer {
                Ok(v) if v.is(pyo3::types::PyBool::new(py, false)) => progress.cancel(),
                Ok(_) => {}
                Err(e) => {
                    progress.cancel();
                    raised = Some(e);
                }
            }
        }
        (worker.join(), raised)
    });
    if let Some(e) = raised {
        return Err(e);
    }
    match result {
        // Asked to cancel while the work was finishing: the caller asked for a cancel,
        // and gets one (never a result it said it did not want).
        Ok(Ok(Ok(_))) if progress.is_cancelled() => Err(to_py(thicket_core::Error::Cancelled)),
        Ok(Ok(Ok(value))) => {
            // Finished: the callback hears 1.0 (its answer no longer matters).
            callback.call1((1.0,))?;
            Ok(value)
        }
        Ok(Ok(Err(e))) => Err(to_py(e)),
        Ok(Err(panic)) | Err(panic) => Err(panic_error(panic)),
    }
}
