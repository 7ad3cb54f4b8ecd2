//! SpurGearTrain: the gear train of gear_model (../shared/spec/gear-train.md) as an FMI 2.0 and
//! 3.0 FMU, Co-Simulation and Model Exchange. `variables` is the one table (train.toml expanded with the single mesh's
//! rows), `build` turns the FMI parameters into the model's train, `instance` is the
//! `fmi2_slave::Slave`, and `exports` the C functions (fmi2_slave::export_fmi2!). No global
//! mutable state: everything lives in the instance.

pub mod build;
pub mod exports;
pub mod fmu;
pub mod gearbox;
pub mod gearbox_vars;
pub mod instance;
pub mod variables;
