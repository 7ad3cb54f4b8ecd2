//! TorsionalShaft: a massless linear torsional spring-damper between two shaft ends a and b as
//! an FMI 2.0 Co-Simulation FMU (issue 24, part 1), built like SpeedController. Three parts:
//! `variables` (the one table: value references, start values, modelDescription.xml, GUID),
//! `shaft` (the law, free of FMI) and `fmi` (the shaft as an `fmi2_slave::Slave`, and the
//! exported C functions, which `fmi2_slave::export_fmi2!` defines). No global mutable state:
//! everything lives in the instance.
//!
//! The shaft has no state: its outputs are a pure function of the inputs and parameters set
//! last (a direct feedthrough), and fmi2DoStep only advances the time.

pub mod fmi;
pub mod shaft;
pub mod variables;
