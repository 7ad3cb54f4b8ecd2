//! The gear models and their integration driver, pure Rust without FMI. Data flows one way:
//! `model` (parameters -> geometry -> contact objects -> forces -> right-hand side, in a rig)
//! -> `driver` (integration to a communication point, event location). The FMUs' FMI layers
//! (`spur_gear_mesh::fmi`, `spur_gear_train`) sit on top.

// `!(x < limit)` is how a check lets NaN fail too; `partial_cmp` would hide that.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod driver;
pub mod model;
pub mod table;
pub mod variables;
