//! The FMI 2.0 Co-Simulation layer of SpurGearMesh. What every FMU of this repository shares --
//! the C types, logging, the instance with its state machine, FMU states and their serialized
//! envelope, the exported functions -- is the `fmi2_slave` crate (fmi2-slave/). Here is what is
//! SpurGearMesh's own: `instance` (the model as an `fmi2_slave::Slave`: parameters, inputs and
//! the simulation; get/set, initialization, stepping), `outputs` (the model's readout as the
//! variable table's outputs) and `fmu_state` (the payload of its serialized FMU states). `exports` defines the fmi2* functions for it. The layer knows the
//! model only as a `Simulation` and the variable table.

pub mod exports;
pub mod fmu_state;
pub mod instance;
pub mod outputs;

pub use fmi2_slave::logging;
pub use fmi2_slave::{
    AllocateFn, Boolean, CallbackFunctions, Component, ComponentEnvironment, EventInfo, FmuState,
    FreeFn, LoggerFn, Status, StatusKind, StepFinishedFn, Type, ValueReference, DO_STEP_STATUS,
    LAST_SUCCESSFUL_TIME, PENDING_STATUS, TERMINATED, TYPE_CO_SIMULATION, TYPE_MODEL_EXCHANGE,
};
