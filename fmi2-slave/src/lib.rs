//! The FMI 2.0 layer of this repository's FMUs (Co-Simulation, and Model Exchange for a model
//! that has it), written once; fmi3-slave builds FMI 3.0 on it.
//!
//! A model implements [`Slave`] (its variables, initialization, stepping, and the payload of
//! its FMU states) and invokes [`export_fmi2!`] with its type; this crate does the rest:
//!
//! - the C types of the standard (this module);
//! - `logging`: the master's logger, filtered by the model's log categories;
//! - `instance`: [`Instance`], the FMI 2.0 state machine of Co-Simulation and Model Exchange
//!   in one place (state checks, panic guard, a failure logged and turned into a state change)
//!   and the FMU states an instance hands out;
//! - `fmu_state`: the serialized FMU state: an envelope (magic, format version, GUID, length,
//!   checksum) around the model's payload, and the reader and writer of payloads;
//! - `ffi`: the bodies of the 44 fmi2* functions, generic over the model;
//! - `model_exchange`: the bodies of the Model Exchange functions;
//! - `algebraic`: the `Slave` of a stateless FMU (outputs a function of parameters and
//!   inputs), and `algebraic_fmu!`, which builds one from a crate's generated table;
//! - `export_fmi2!`: the `#[no_mangle]` functions themselves, defined in the model's crate.

// `!(x > y)` on purpose throughout: a NaN argument must fail the check.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod algebraic;
pub mod directional;
pub mod ffi;
pub mod fmu_state;
pub mod instance;
pub mod logging;
pub mod model_exchange;
pub mod resources;
mod slave;

mod export;

pub use instance::{error, CallResult, Failure, FmiState, Instance};
pub use logging::Logger;
pub use slave::{check_experiment_times, EventUpdate, Slave};

use std::os::raw::{c_char, c_int, c_uint, c_void};

pub type Component = *mut c_void;
pub type ComponentEnvironment = *mut c_void;
pub type FmuState = *mut c_void;
pub type ValueReference = c_uint;
pub type Boolean = c_int;
/// fmi2Type and fmi2StatusKind: C enums, int-sized.
pub type Type = c_int;
pub type StatusKind = c_int;
/// fmi2EventInfo: what fmi2NewDiscreteStates reports (Model Exchange).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default)]
pub struct EventInfo {
    pub new_discrete_states_needed: Boolean,
    pub terminate_simulation: Boolean,
    pub nominals_of_continuous_states_changed: Boolean,
    pub values_of_continuous_states_changed: Boolean,
    pub next_event_time_defined: Boolean,
    pub next_event_time: f64,
}

/// fmi2Status.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Status {
    Ok = 0,
    Warning = 1,
    Discard = 2,
    Error = 3,
    Fatal = 4,
    Pending = 5,
}

pub type LoggerFn = unsafe extern "C" fn(
    ComponentEnvironment,
    *const c_char,
    Status,
    *const c_char,
    *const c_char,
    ...
);
pub type AllocateFn = unsafe extern "C" fn(usize, usize) -> *mut c_void;
pub type FreeFn = unsafe extern "C" fn(*mut c_void);
pub type StepFinishedFn = unsafe extern "C" fn(ComponentEnvironment, Status);

/// fmi2CallbackFunctions.
#[repr(C)]
pub struct CallbackFunctions {
    pub logger: Option<LoggerFn>,
    pub allocate_memory: Option<AllocateFn>,
    pub free_memory: Option<FreeFn>,
    pub step_finished: Option<StepFinishedFn>,
    pub component_environment: ComponentEnvironment,
}

/// fmi2Type.
pub const TYPE_MODEL_EXCHANGE: Type = 0;
pub const TYPE_CO_SIMULATION: Type = 1;

/// fmi2StatusKind.
pub const DO_STEP_STATUS: StatusKind = 0;
pub const PENDING_STATUS: StatusKind = 1;
pub const LAST_SUCCESSFUL_TIME: StatusKind = 2;
pub const TERMINATED: StatusKind = 3;

/// A GUID in the standard's text form from a 128-bit FNV-1a hash of `bytes`: the same bytes
/// give the same GUID, changed bytes (a model's variable table and version) a new one.
pub fn guid_from_hash(bytes: impl IntoIterator<Item = u8>) -> String {
    let mut h: u128 = 0x6c62272e07bb014262b821756295c58d;
    for b in bytes {
        h ^= b as u128;
        h = h.wrapping_mul(0x0000000001000000000000000000013B);
    }
    let x = format!("{h:032x}");
    format!(
        "{{{}-{}-{}-{}-{}}}",
        &x[0..8],
        &x[8..12],
        &x[12..16],
        &x[16..20],
        &x[20..32]
    )
}
