//! The FMI 2.0 C API as a master sees it, declared from the standard's headers
//! (fmi2TypesPlatform.h, fmi2FunctionTypes.h) and resolved at link time to the crate's
//! `#[no_mangle]` exports (the same code as in the .so). Only C types are used: fmi2Status is
//! received as a C int (`Status`), so an out-of-range value could not be undefined behaviour here.
#![allow(non_upper_case_globals, non_snake_case, dead_code)]

use std::os::raw::{c_char, c_int, c_uint, c_void};

pub type Component = *mut c_void;
pub type ComponentEnvironment = *mut c_void;
pub type FmuState = *mut c_void;
pub type ValueReference = c_uint;
pub type Boolean = c_int;

/// fmi2Status, as the int it is on the C side.
#[repr(transparent)]
#[derive(Clone, Copy, PartialEq, Eq)]
pub struct Status(pub c_int);

impl Status {
    pub const Ok: Status = Status(0);
    pub const Warning: Status = Status(1);
    pub const Discard: Status = Status(2);
    pub const Error: Status = Status(3);
    pub const Fatal: Status = Status(4);
    pub const Pending: Status = Status(5);
}

impl std::fmt::Debug for Status {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        let names = ["Ok", "Warning", "Discard", "Error", "Fatal", "Pending"];
        match names.get(self.0 as usize) {
            Some(n) => write!(f, "{n}"),
            None => write!(f, "Status({})", self.0),
        }
    }
}

/// fmi2Type
pub const TYPE_MODEL_EXCHANGE: c_int = 0;
pub const TYPE_CO_SIMULATION: c_int = 1;
/// fmi2StatusKind
pub const DO_STEP_STATUS: c_int = 0;
pub const PENDING_STATUS: c_int = 1;
pub const LAST_SUCCESSFUL_TIME: c_int = 2;
pub const TERMINATED: c_int = 3;

/// fmi2CallbackLogger. Declaring a C-variadic function pointer type is stable Rust; defining
/// such a function is not (see `record_logger` in mod.rs).
pub type LoggerFn = unsafe extern "C" fn(
    ComponentEnvironment,
    *const c_char,
    c_int,
    *const c_char,
    *const c_char,
    ...
);
pub type AllocateFn = unsafe extern "C" fn(usize, usize) -> *mut c_void;
pub type FreeFn = unsafe extern "C" fn(*mut c_void);
pub type StepFinishedFn = unsafe extern "C" fn(ComponentEnvironment, c_int);

/// fmi2CallbackFunctions
#[repr(C)]
pub struct CallbackFunctions {
    pub logger: Option<LoggerFn>,
    pub allocate_memory: Option<AllocateFn>,
    pub free_memory: Option<FreeFn>,
    pub step_finished: Option<StepFinishedFn>,
    pub component_environment: ComponentEnvironment,
}

// The crate must be linked for these to resolve: every test that uses this module also uses
// `spur_gear_mesh::variables`.
extern "C" {
    pub fn fmi2GetTypesPlatform() -> *const c_char;
    pub fn fmi2GetVersion() -> *const c_char;
    pub fn fmi2SetDebugLogging(
        c: Component,
        logging_on: Boolean,
        n: usize,
        categories: *const *const c_char,
    ) -> Status;
    pub fn fmi2Instantiate(
        instance_name: *const c_char,
        fmu_type: c_int,
        guid: *const c_char,
        resource_location: *const c_char,
        functions: *const CallbackFunctions,
        visible: Boolean,
        logging_on: Boolean,
    ) -> Component;
    pub fn fmi2FreeInstance(c: Component);
    pub fn fmi2SetupExperiment(
        c: Component,
        tolerance_defined: Boolean,
        tolerance: f64,
        start_time: f64,
        stop_time_defined: Boolean,
        stop_time: f64,
    ) -> Status;
    pub fn fmi2EnterInitializationMode(c: Component) -> Status;
    pub fn fmi2ExitInitializationMode(c: Component) -> Status;
    pub fn fmi2Terminate(c: Component) -> Status;
    pub fn fmi2Reset(c: Component) -> Status;
    pub fn fmi2GetReal(c: Component, vr: *const ValueReference, n: usize, v: *mut f64) -> Status;
    pub fn fmi2GetInteger(
        c: Component,
        vr: *const ValueReference,
        n: usize,
        v: *mut c_int,
    ) -> Status;
    pub fn fmi2GetBoolean(
        c: Component,
        vr: *const ValueReference,
        n: usize,
        v: *mut Boolean,
    ) -> Status;
    pub fn fmi2GetString(
        c: Component,
        vr: *const ValueReference,
        n: usize,
        v: *mut *const c_char,
    ) -> Status;
    pub fn fmi2SetReal(c: Component, vr: *const ValueReference, n: usize, v: *const f64) -> Status;
    pub fn fmi2SetInteger(
        c: Component,
        vr: *const ValueReference,
        n: usize,
        v: *const c_int,
    ) -> Status;
    pub fn fmi2SetBoolean(
        c: Component,
        vr: *const ValueReference,
        n: usize,
        v: *const Boolean,
    ) -> Status;
    pub fn fmi2SetString(
        c: Component,
        vr: *const ValueReference,
        n: usize,
        v: *const *const c_char,
    ) -> Status;
    pub fn fmi2GetFMUstate(c: Component, state: *mut FmuState) -> Status;
    pub fn fmi2SetFMUstate(c: Component, state: FmuState) -> Status;
    pub fn fmi2FreeFMUstate(c: Component, state: *mut FmuState) -> Status;
    pub fn fmi2SerializedFMUstateSize(c: Component, state: FmuState, size: *mut usize) -> Status;
    pub fn fmi2SerializeFMUstate(
        c: Component,
        state: FmuState,
        buf: *mut c_char,
        size: usize,
    ) -> Status;
    pub fn fmi2DeSerializeFMUstate(
        c: Component,
        buf: *const c_char,
        size: usize,
        state: *mut FmuState,
    ) -> Status;
    pub fn fmi2GetDirectionalDerivative(
        c: Component,
        unknown: *const ValueReference,
        n_unknown: usize,
        known: *const ValueReference,
        n_known: usize,
        dv_known: *const f64,
        dv_unknown: *mut f64,
    ) -> Status;
    pub fn fmi2EnterEventMode(c: Component) -> Status;
    pub fn fmi2NewDiscreteStates(c: Component, event_info: *mut c_void) -> Status;
    pub fn fmi2EnterContinuousTimeMode(c: Component) -> Status;
    pub fn fmi2CompletedIntegratorStep(
        c: Component,
        no_set_prior: Boolean,
        enter_event_mode: *mut Boolean,
        terminate: *mut Boolean,
    ) -> Status;
    pub fn fmi2SetTime(c: Component, t: f64) -> Status;
    pub fn fmi2SetContinuousStates(c: Component, x: *const f64, nx: usize) -> Status;
    pub fn fmi2GetDerivatives(c: Component, dx: *mut f64, nx: usize) -> Status;
    pub fn fmi2GetEventIndicators(c: Component, z: *mut f64, ni: usize) -> Status;
    pub fn fmi2GetContinuousStates(c: Component, x: *mut f64, nx: usize) -> Status;
    pub fn fmi2GetNominalsOfContinuousStates(c: Component, x: *mut f64, nx: usize) -> Status;
    pub fn fmi2SetRealInputDerivatives(
        c: Component,
        vr: *const ValueReference,
        n: usize,
        order: *const c_int,
        v: *const f64,
    ) -> Status;
    pub fn fmi2GetRealOutputDerivatives(
        c: Component,
        vr: *const ValueReference,
        n: usize,
        order: *const c_int,
        v: *mut f64,
    ) -> Status;
    pub fn fmi2DoStep(c: Component, current: f64, h: f64, no_set_prior: Boolean) -> Status;
    pub fn fmi2CancelStep(c: Component) -> Status;
    pub fn fmi2GetStatus(c: Component, kind: c_int, v: *mut c_int) -> Status;
    pub fn fmi2GetRealStatus(c: Component, kind: c_int, v: *mut f64) -> Status;
    pub fn fmi2GetIntegerStatus(c: Component, kind: c_int, v: *mut c_int) -> Status;
    pub fn fmi2GetBooleanStatus(c: Component, kind: c_int, v: *mut Boolean) -> Status;
    pub fn fmi2GetStringStatus(c: Component, kind: c_int, v: *mut *const c_char) -> Status;
}

/// The FMI states of the Co-Simulation state machine, with the bits the FMU writes as the first
/// word of a serialized state's payload (src/fmi/fmu_state.rs, format version 2).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FmiState {
    Instantiated = 1,
    InitializationMode = 2,
    StepComplete = 4,
    StepFailed = 8,
    Terminated = 16,
    Error = 32,
}

impl FmiState {
    pub fn from_bits(b: u64) -> Option<FmiState> {
        use FmiState::*;
        [
            Instantiated,
            InitializationMode,
            StepComplete,
            StepFailed,
            Terminated,
            Error,
        ]
        .into_iter()
        .find(|s| *s as u64 == b)
    }
}

/// Layout of a serialized FMU state (format version 9; 7's and 8's envelope was the same): magic (8), version (u32), GUID length
/// (u32) and bytes, payload length (u64), payload, FNV-1a 64 checksum (u64). Returns the
/// payload's offset and length; panics with a clear message on another format version.
pub fn payload_range(b: &[u8]) -> (usize, usize) {
    assert!(b.len() >= 24, "serialized state of {} bytes", b.len());
    let version = u32::from_le_bytes(b[8..12].try_into().unwrap());
    assert_eq!(
        version, 9,
        "the tests read serialized-state format version 9; update tests/fmi_support/ffi.rs"
    );
    let glen = u32::from_le_bytes(b[12..16].try_into().unwrap()) as usize;
    let p0 = 16 + glen + 8;
    let plen = u64::from_le_bytes(b[16 + glen..p0].try_into().unwrap()) as usize;
    (p0, plen)
}

/// FNV-1a 64, the checksum of the payload.
pub fn fnv64(data: &[u8]) -> u64 {
    data.iter().fold(0xcbf29ce484222325u64, |h, &b| {
        (h ^ b as u64).wrapping_mul(0x100000001b3)
    })
}
