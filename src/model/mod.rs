//! The gear-mesh model: pure Rust, no FMI. Parameters -> geometry -> contact objects -> forces
//! -> right-hand side. The integration driver (`crate::driver`) advances it.

pub mod chebyshev;
pub mod contact;
pub mod deviations;
pub mod geometry;
pub mod johnson;
pub mod law;
pub mod lower_branch;
pub mod lower_branch_fit;
pub mod mesh;
pub mod piecewise;
pub mod rig;
pub mod rigid;
pub mod static_mesh;
pub mod statistics;
pub mod tooth_structure;

pub use mesh::{ContactModel, Loads, Mesh, State, NY};

/// An invalid parameter set or initial state, with a message naming the variable and the value.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{message}")]
pub struct ModelError {
    pub message: String,
}

impl ModelError {
    pub fn new(message: String) -> Self {
        ModelError { message }
    }
}
