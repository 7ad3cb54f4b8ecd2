//! The gear models: pure Rust, no FMI. Parameters -> geometry -> contact objects -> forces ->
//! right-hand side. One mesh is a component (`mesh`: contact tracking, forces, events,
//! readout); rigs own the equations of motion and reuse it: the paper's two-wheel rig
//! (`paper_rig`) and the gear train (`train`). The integration driver (`crate::driver`)
//! advances them.

pub mod chebyshev;
pub mod contact;
pub mod contact_law;
pub mod deviations;
pub mod geometry;
pub mod interference;
pub mod johnson;
pub mod law;
pub mod lower_branch;
pub mod lower_branch_fit;
pub mod mesh;
pub mod pair;
pub mod paper_rig;
pub mod piecewise;
pub mod rig;
pub mod rigid;
pub mod static_mesh;
pub mod statistics;
pub mod tooth_structure;
pub mod train;

pub use mesh::ContactModel;
pub use paper_rig::{Loads, PaperRig, State, NY};

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

    /// "parameter {var} = {value}: {why}".
    pub fn parameter(var: &str, value: impl std::fmt::Display, why: &str) -> Self {
        ModelError::new(format!("parameter {var} = {value}: {why}"))
    }
}
