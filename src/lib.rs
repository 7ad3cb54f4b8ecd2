//! SpurGearMesh: an FMI 2.0 Co-Simulation FMU of a spur involute gear pair after Kosenko &
//! Gusev (2012). Three layers, data flowing one way:
//! `model` (geometry, contacts, forces, equations of motion) -> `driver` (integration to a
//! communication point, event location) -> `fmi` (exported C functions, state machine, logging).

pub mod driver;
pub mod fmi;
pub mod model;
pub mod variables;
