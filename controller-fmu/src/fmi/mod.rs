//! The FMI 2.0 Co-Simulation layer: the exported C functions (`exports`), the instance with its
//! state machine (`instance`) and logging through the master's callback (`logging`).
//!
//! `logging` is SpurGearMesh's own module (src/fmi/logging.rs of the repository), compiled here
//! from the same source file; it reads `crate::variables::LOG_CATEGORIES`, which this crate
//! declares in the same order. The C types below repeat those of SpurGearMesh's src/fmi/mod.rs:
//! that file also declares SpurGearMesh's exports, so it cannot be included here, and linking
//! the spur_gear_mesh rlib would bring its #[no_mangle] fmi2* functions into this binary.

pub mod exports;
pub mod instance;
#[path = "../../../src/fmi/logging.rs"]
pub mod logging;

use std::os::raw::{c_char, c_int, c_void};

pub type Component = *mut c_void;
pub type ComponentEnvironment = *mut c_void;
pub type FmuState = *mut c_void;
pub type ValueReference = std::os::raw::c_uint;
pub type Boolean = c_int;

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
pub const TYPE_CO_SIMULATION: c_int = 1;

/// fmi2StatusKind.
pub const DO_STEP_STATUS: c_int = 0;
pub const PENDING_STATUS: c_int = 1;
pub const LAST_SUCCESSFUL_TIME: c_int = 2;
pub const TERMINATED: c_int = 3;
