//! Why a session could not be written.

/// Why a session could not be written.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    #[error(transparent)]
    Io(#[from] std::io::Error),
    #[error(transparent)]
    Machine(#[from] crate::machine::MachineError),
    #[error("{0}")]
    Plan(String),
}
