//! FMI 3.0 for a model that implements `fmi2_slave::Slave`: the C types of FMI 3.0 that
//! differ from FMI 2.0's, the bodies of the fmi3* functions (`ffi`), and `export_fmi3!`, which
//! defines them as `#[no_mangle]` functions in the model's crate.
//!
//! The functions share fmi2-slave's instance (state machine, panic guard, logging) and FMU
//! states; an instance made by an fmi3Instantiate* function names the FMI 3.0 functions in its
//! messages. What FMI 3.0 adds and the model does not have (clocks, configuration mode, event
//! mode in Co-Simulation, array and binary variables, directional derivatives) answers
//! fmi3Error with the reason.

mod export;
pub mod ffi;

pub use fmi2_slave::logging::Fmi3LogFn;
use std::os::raw::c_int;

// The C types of FMI 3.0, under names of their own so that the prototypes generated from the
// exports (tests/python/test_abi.py) carry the standard's type names.
pub type Fmi3Status = fmi2_slave::Status;
pub type Fmi3Instance = fmi2_slave::Component;
pub type Fmi3InstanceEnvironment = fmi2_slave::ComponentEnvironment;
pub type Fmi3FMUState = fmi2_slave::FmuState;
pub type Fmi3ValueReference = u32;
// The callbacks, nullable (Option<fn> is a C function pointer that may be null).
pub type Fmi3LogMessageCallback = Option<Fmi3LogFn>;
pub type Fmi3IntermediateUpdateCallback = Option<
    unsafe extern "C" fn(Fmi3InstanceEnvironment, f64, bool, bool, bool, bool, *mut bool, *mut f64),
>;
pub type Fmi3ClockUpdateCallback = Option<unsafe extern "C" fn(Fmi3InstanceEnvironment)>;
pub type Fmi3LockPreemptionCallback = Option<unsafe extern "C" fn()>;
pub type Fmi3UnlockPreemptionCallback = Option<unsafe extern "C" fn()>;
/// C enums, int-sized.
pub type Fmi3DependencyKind = c_int;
pub type Fmi3IntervalQualifier = c_int;
