//! EngineTorque: an engine's torque with its firing-order ripple, locked to the crank angle, as
//! an FMI 2.0 Co-Simulation FMU (issue 24: the drive of the co-simulated drivetrain), built like
//! TorsionalShaft. Three parts: `variables` (the one table: value references, start values,
//! modelDescription.xml, GUID), `engine` (the law, free of FMI) and `fmi` (the law as
//! `fmi2_slave`'s stateless slave, and the exported C functions). No global mutable state:
//! everything lives in the instance.
//!
//! The engine has no state: its torque is a pure function of the crank angle and the parameters
//! set last (a direct feedthrough), and fmi2DoStep only advances the time. The crank's inertia
//! belongs to the body the torque drives (SpurGearMesh's wheel A, or SpurGearTrain's body 1).

pub mod engine;
pub mod fmi;
pub mod variables;
