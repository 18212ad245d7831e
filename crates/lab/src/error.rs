//! Why a workflow refused or failed, in the lab's own words: the kinds a
//! caller can act on (fix the request, wait, look it up again), with a
//! message that says what was wrong and what to do. The HTTP layer maps
//! each kind to a status in one place (`http::error`); the CLI prints the
//! message.

use lightbooth_store::StoreError;

#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LabError {
    /// The request itself is wrong (a field out of range, an unknown
    /// coding or scene); the message names the field.
    #[error("{0}")]
    Invalid(String),
    /// The thing asked about does not exist (no such render, scene, target).
    #[error("{0}")]
    NotFound(String),
    /// The request is well formed but the state forbids it now (a queue
    /// full, a job already finished, measurements missing).
    #[error("{0}")]
    Conflict(String),
    /// The daemon cannot do this at all, or not now (no scenes, no
    /// instrument, no camera images).
    #[error("{0}")]
    Unavailable(String),
    /// Something broke that the caller cannot fix (the database, a file).
    #[error("internal error: {0}")]
    Internal(String),
}

impl From<StoreError> for LabError {
    fn from(e: StoreError) -> Self {
        match e {
            StoreError::Conflict(m) => LabError::Conflict(m),
            other => LabError::Internal(other.to_string()),
        }
    }
}
