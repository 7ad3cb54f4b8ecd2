//! The FMI 2.0 Co-Simulation layer: the exported C functions (`exports`), the instance with its
//! state machine (`instance`), logging through the master's callback (`logging`) and FMU states
//! (`fmu_state`). It knows the model only as a `Simulation` and the variable table.

pub mod exports;
pub mod fmu_state;
pub mod instance;
pub mod logging;

use std::os::raw::{c_char, c_int, c_uint, c_void};

pub type Component = *mut c_void;
pub type ComponentEnvironment = *mut c_void;
pub type FmuState = *mut c_void;
pub type ValueReference = c_uint;
pub type Boolean = c_int;
/// fmi2Type and fmi2StatusKind: C enums, int-sized.
pub type Type = c_int;
pub type StatusKind = c_int;
/// fmi2EventInfo: only Model Exchange uses it; opaque here.
#[repr(C)]
pub struct EventInfo {
    _opaque: [u8; 0],
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
