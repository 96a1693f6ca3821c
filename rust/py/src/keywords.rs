//! Settings given as keyword arguments (`**settings`), read by name with their
//! defaults where they are defined, once for every function that takes them.

use pyo3::conversion::FromPyObjectOwned;
use pyo3::exceptions::{PyDeprecationWarning, PyTypeError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::cell::RefCell;
use std::ffi::CString;

/// The `**settings` of one call: each [`Keywords::get`] reads a name (or gives its
/// default), and [`Keywords::finish`] refuses any name no reader asked for, as Python
/// refuses an unexpected keyword argument.
pub(crate) struct Keywords<'a, 'py> {
    function: &'static str,
    given: Option<&'a Bound<'py, PyDict>>,
    asked: RefCell<Vec<&'static str>>,
}

impl<'a, 'py> Keywords<'a, 'py> {
    /// The keywords `given` to `function` (its name, for the messages).
    pub(crate) fn new(function: &'static str, given: Option<&'a Bound<'py, PyDict>>) -> Self {
        Self { function, given, asked: RefCell::new(Vec::new()) }
    }

    /// The setting `name`, or `default` where it was not given; a value of the wrong
    /// type is a `TypeError` naming the argument, as for a declared parameter.
    pub(crate) fn get<T: FromPyObjectOwned<'py>>(&self, name: &'static str, default: T) -> PyResult<T> {
        self.asked.borrow_mut().push(name);
        let Some(value) = self.given.map(|d| d.get_item(name)).transpose()?.flatten() else {
            return Ok(default);
        };
        value.extract::<T>().map_err(|e| argument_error(value.py(), name, e.into()))
    }

    /// The setting `name`, also read under its former name `old` for one release: given
    /// as `old`, it is taken with a `DeprecationWarning`; given as both, a `TypeError`.
    pub(crate) fn get_renamed<T: FromPyObjectOwned<'py>>(&self, name: &'static str, old: &'static str, default: T) -> PyResult<T> {
        let Some(value) = self.given.map(|d| d.get_item(old)).transpose()?.flatten() else {
            return self.get(name, default);
        };
        self.asked.borrow_mut().extend([name, old]);
        let py = value.py();
        if self.given.map(|d| d.contains(name)).transpose()?.unwrap_or(false) {
            return Err(PyTypeError::new_err(format!("{}() got '{name}' and its former name '{old}': pass '{name}' only", self.function)));
        }
        let value = value.extract::<T>().map_err(|e| argument_error(py, old, e.into()))?;
        deprecated_keyword(py, self.function, old, name)?;
        Ok(value)
    }

    /// Refuses the keywords that no reader asked for.
    pub(crate) fn finish(self) -> PyResult<()> {
        let asked = self.asked.into_inner();
        for key in self.given.map(|d| d.keys()).into_iter().flatten() {
            let name: String = key.extract()?;
            if !asked.contains(&name.as_str()) {
                return Err(PyTypeError::new_err(format!("{}() got an unexpected keyword argument '{name}'", self.function)));
            }
        }
        Ok(())
    }
}

/// A failed extraction of argument `name`, worded as pyo3 words it for a declared
/// parameter (`argument 'name': ...`, the cause kept).
fn argument_error(py: Python<'_>, name: &str, error: PyErr) -> PyErr {
    if !error.get_type(py).is(py.get_type::<PyTypeError>()) {
        return error;
    }
    let remapped = PyTypeError::new_err(format!("argument '{name}': {}", error.value(py)));
    remapped.set_cause(py, error.cause(py));
    remapped
}

/// Warns that keyword `old` of `function` is now called `name` (a `DeprecationWarning`
/// pointing at the caller's line; an error where warnings are errors).
pub(crate) fn deprecated_keyword(py: Python<'_>, function: &str, old: &str, name: &str) -> PyResult<()> {
    let message = format!("{function}(): keyword '{old}' is deprecated and will be removed in the next release; use '{name}'");
    let message = CString::new(message).expect("keyword names have no NUL");
    PyErr::warn(py, &py.get_type::<PyDeprecationWarning>(), &message, 1)
}

/// A count given under its current name or, for one release, its former name `old`
/// (each None when not given; `default` when neither is): the shell functions'
/// `surfaces`, formerly `layers`. Both given is a TypeError, whatever the values.
pub(crate) fn renamed_argument<T>(
    py: Python<'_>,
    function: &str,
    (name, value): (&str, Option<T>),
    (old, given): (&str, Option<T>),
    default: T,
) -> PyResult<T> {
    match (value, given) {
        (Some(_), Some(_)) => Err(PyTypeError::new_err(format!("{function}() got '{name}' and its former name '{old}': pass '{name}' only"))),
        (value, None) => Ok(value.unwrap_or(default)),
        (None, Some(given)) => {
            deprecated_keyword(py, function, old, name)?;
            Ok(given)
        }
    }
}
