//! SpurGearMesh: an FMI 2.0 Co-Simulation FMU of a spur involute gear pair after Kosenko &
//! Gusev (2012). Three layers, data flowing one way:
//! `model` (geometry, contacts, forces, equations of motion) -> `driver` (integration to a
//! communication point, event location) -> `fmi` (exported C functions, state machine, logging).

// `!(x < limit)` is how a check lets NaN fail too; `partial_cmp` would hide that.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod fmi;
/// The model and the driver live in the gear_model crate, shared with the other FMUs; they are
/// re-exported here under the paths they always had.
pub use gear_model::{driver, model, table, variables};
