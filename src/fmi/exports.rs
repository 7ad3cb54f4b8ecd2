//! The exported fmi2* functions: all of FMI 2.0, defined by `fmi2_slave::export_fmi2!` for
//! SpurGearMesh's `Slave` (the Model Exchange functions answer fmi2Error).

#![allow(non_snake_case, clippy::missing_safety_doc)]

fmi2_slave::export_fmi2!(super::instance::SpurGearMesh);
