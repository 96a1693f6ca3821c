//! The one error type of the core; the binding maps each variant to a Python exception.

/// Errors the core reports instead of panicking. Messages are shown to Blender users
/// as they are, so they say what is wrong and, where possible, what to do.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
pub enum Error {
    #[error("the mesh is empty: it has no faces")]
    EmptyMesh,
    #[error("invalid mesh: {0}")]
    InvalidMesh(String),
    #[error("vertex {index} has a non-finite coordinate ({value:?}); fix or delete it before using the mesh")]
    NonFinite { index: usize, value: [f32; 3] },
    #[error("invalid parameter: {0}")]
    InvalidParameter(String),
    /// Work refused because its estimated output (triangles, samples or memory) would
    /// pass a limit the caller set; the message names the estimate, the limit and what
    /// to change. A kind of its own so callers can offer a remedy without reading text.
    #[error("{0}")]
    OverLimit(String),
    /// A texture file or folder that cannot be read or written; `path` names it.
    #[error("{path}: {message}")]
    File { path: String, message: String },
    /// The work was cancelled through its [`crate::progress::Progress`].
    #[error("cancelled")]
    Cancelled,
    /// The GPU could not do the work (no adapter, a refused or lost device, a
    /// failed frame); the CPU can.
    #[error("{0}")]
    Device(String),
}

pub type Result<T> = std::result::Result<T, Error>;
