//! SpeedController: a PI speed controller as an FMI 2.0 Co-Simulation FMU, built to close a
//! speed loop around SpurGearMesh (`tau` -> `tau_A`, `w_A` -> `w_A`). Three parts:
//! `variables` (the one table: value references, start values, modelDescription.xml, GUID),
//! `controller` (the sampled PI law, free of FMI) and `fmi` (the controller as an
//! `fmi2_slave::Slave`, and the exported C functions, which `fmi2_slave::export_fmi2!` defines:
//! the FMI layer is shared with SpurGearMesh). No global mutable state: everything lives in the
//! instance.

pub mod controller;
pub mod fmi;
pub mod variables;
