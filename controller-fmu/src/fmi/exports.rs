//! The exported fmi2* functions. Each one finds its instance, states which FMI states it may be
//! called in, and hands a closure to `Instance::call` (state check, panic guard, error log).
//! All of FMI 2.0 is exported; the Model Exchange functions and FMU state serialization answer
//! fmi2Error.

#![allow(non_snake_case, clippy::missing_safety_doc)]

use super::instance::{allowed, error, CallResult, FmiState, Instance, Snapshot, MAGIC};
use super::logging::{Category, Logger};
use super::{Boolean, CallbackFunctions, Component, FmuState, Status, ValueReference};
use super::{DO_STEP_STATUS, LAST_SUCCESSFUL_TIME, PENDING_STATUS, TERMINATED, TYPE_CO_SIMULATION};
use crate::variables::{guid, LOG_CATEGORIES, MODEL_NAME};
use std::ffi::CStr;
use std::os::raw::{c_char, c_int, c_void};

/// More values than any master can mean; guards against garbage counts.
const MAX_VALUES: usize = 1 << 20;

unsafe fn instance<'a>(c: Component) -> Option<&'a mut Instance> {
    if c.is_null() {
        return None;
    }
    let i = &mut *(c as *mut Instance);
    (i.magic == MAGIC).then_some(i)
}

fn with(
    c: Component,
    func: &str,
    states: u32,
    body: impl FnOnce(&mut Instance) -> CallResult,
) -> Status {
    match unsafe { instance(c) } {
        Some(i) => i.call(func, states, body),
        None => Status::Error,
    }
}

/// A C array argument: null is allowed only for n = 0.
unsafe fn slice<'a, T>(
    p: *const T,
    n: usize,
    what: &str,
) -> Result<&'a [T], super::instance::Failure> {
    if n == 0 {
        Ok(&[])
    } else if p.is_null() || n > MAX_VALUES {
        Err(error(format!(
            "{what}: null pointer or implausible count {n}"
        )))
    } else {
        Ok(std::slice::from_raw_parts(p, n))
    }
}

unsafe fn slice_mut<'a, T>(
    p: *mut T,
    n: usize,
    what: &str,
) -> Result<&'a mut [T], super::instance::Failure> {
    if n == 0 {
        Ok(&mut [])
    } else if p.is_null() || n > MAX_VALUES {
        Err(error(format!(
            "{what}: null pointer or implausible count {n}"
        )))
    } else {
        Ok(std::slice::from_raw_parts_mut(p, n))
    }
}

unsafe fn text(p: *const c_char) -> Option<String> {
    (!p.is_null()).then(|| CStr::from_ptr(p).to_string_lossy().into_owned())
}

#[no_mangle]
pub extern "C" fn fmi2GetTypesPlatform() -> *const c_char {
    c"default".as_ptr()
}

#[no_mangle]
pub extern "C" fn fmi2GetVersion() -> *const c_char {
    c"2.0".as_ptr()
}

#[no_mangle]
pub unsafe extern "C" fn fmi2Instantiate(
    instance_name: *const c_char,
    fmu_type: c_int,
    guid_arg: *const c_char,
    _resource_location: *const c_char,
    functions: *const CallbackFunctions,
    _visible: Boolean,
    logging_on: Boolean,
) -> Component {
    let built = std::panic::catch_unwind(|| {
        let f = functions.as_ref()?;
        let name = text(instance_name).unwrap_or_default();
        let log = Logger::new(f.logger, f.component_environment, &name, logging_on != 0);
        let fail = |msg: String| {
            log.log(
                Status::Error,
                Category::Error,
                &format!("fmi2Instantiate: {msg}"),
            );
            None
        };
        if name.is_empty() {
            return fail("instanceName must be a non-empty string".into());
        }
        if fmu_type != TYPE_CO_SIMULATION {
            return fail(format!(
                "fmuType = {fmu_type}: {MODEL_NAME} is a Co-Simulation FMU only (fmi2CoSimulation = 1)"
            ));
        }
        let own = guid();
        match text(guid_arg) {
            Some(g) if g == own => {}
            other => return fail(format!("GUID {other:?} does not match this binary's {own}")),
        }
        Some(Box::into_raw(Box::new(Instance::new(log))) as Component)
    });
    built.ok().flatten().unwrap_or(std::ptr::null_mut())
}

#[no_mangle]
pub unsafe extern "C" fn fmi2FreeInstance(c: Component) {
    if let Some(i) = instance(c) {
        let _ = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            for p in i.fmu_states.drain() {
                drop(Box::from_raw(p as *mut Snapshot));
            }
            i.magic = 0;
            drop(Box::from_raw(c as *mut Instance));
        }));
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetDebugLogging(
    c: Component,
    on: Boolean,
    n: usize,
    categories: *const *const c_char,
) -> Status {
    with(c, "fmi2SetDebugLogging", allowed::ANY, |i| {
        let cats = slice(categories, n, "categories")?;
        if cats.is_empty() {
            i.log.set_all(on != 0);
            return Ok(Status::Ok);
        }
        let names: Vec<Option<String>> = cats.iter().map(|&p| text(p)).collect();
        for name in &names {
            match name {
                Some(n) if LOG_CATEGORIES.contains(&n.as_str()) => {}
                other => {
                    return Err(error(format!(
                        "unknown log category {other:?}; the categories are {LOG_CATEGORIES:?}"
                    )))
                }
            }
        }
        for name in names.into_iter().flatten() {
            i.log.set(&name, on != 0);
        }
        Ok(Status::Ok)
    })
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetupExperiment(
    c: Component,
    _tolerance_defined: Boolean,
    _tolerance: f64,
    start_time: f64,
    stop_time_defined: Boolean,
    stop_time: f64,
) -> Status {
    with(c, "fmi2SetupExperiment", allowed::INST, |i| {
        i.setup_experiment(start_time, (stop_time_defined != 0).then_some(stop_time))
    })
}

#[no_mangle]
pub unsafe extern "C" fn fmi2EnterInitializationMode(c: Component) -> Status {
    with(c, "fmi2EnterInitializationMode", allowed::INST, |i| {
        i.snap.state = FmiState::InitializationMode;
        Ok(Status::Ok)
    })
}

#[no_mangle]
pub unsafe extern "C" fn fmi2ExitInitializationMode(c: Component) -> Status {
    with(c, "fmi2ExitInitializationMode", allowed::INIT, |i| {
        i.exit_initialization()
    })
}

#[no_mangle]
pub unsafe extern "C" fn fmi2Terminate(c: Component) -> Status {
    with(c, "fmi2Terminate", allowed::DONE, |i| {
        i.snap.state = FmiState::Terminated;
        Ok(Status::Ok)
    })
}

#[no_mangle]
pub unsafe extern "C" fn fmi2Reset(c: Component) -> Status {
    with(c, "fmi2Reset", allowed::ANY, |i| {
        i.reset();
        Ok(Status::Ok)
    })
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetReal(
    c: Component,
    vr: *const ValueReference,
    n: usize,
    value: *mut f64,
) -> Status {
    with(c, "fmi2GetReal", allowed::GET, |i| {
        let vrs = slice(vr, n, "vr")?;
        let out = slice_mut(value, n, "value")?;
        for (o, &r) in out.iter_mut().zip(vrs) {
            *o = i.get_real(r)?;
        }
        Ok(Status::Ok)
    })
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetBoolean(
    c: Component,
    vr: *const ValueReference,
    n: usize,
    value: *mut Boolean,
) -> Status {
    with(c, "fmi2GetBoolean", allowed::GET, |i| {
        let vrs = slice(vr, n, "vr")?;
        let out = slice_mut(value, n, "value")?;
        for (o, &r) in out.iter_mut().zip(vrs) {
            *o = i.get_boolean(r)? as Boolean;
        }
        Ok(Status::Ok)
    })
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetReal(
    c: Component,
    vr: *const ValueReference,
    n: usize,
    value: *const f64,
) -> Status {
    with(c, "fmi2SetReal", allowed::SET, |i| {
        let (vrs, vals) = (slice(vr, n, "vr")?, slice(value, n, "value")?);
        i.set_reals(vrs, vals)
    })
}

/// Get/set of a type the controller has no variable of (or none that can be set): n = 0 is
/// fine, any value reference is an error.
macro_rules! no_variables_of_type {
    ($name:ident, $states:expr, $ptr:ty, $what:literal) => {
        #[no_mangle]
        pub unsafe extern "C" fn $name(
            c: Component,
            vr: *const ValueReference,
            n: usize,
            _value: $ptr,
        ) -> Status {
            with(c, stringify!($name), $states, |_| {
                match slice(vr, n, "vr")?.first() {
                    Some(r) => Err(error(format!("value reference {r}: {}", $what))),
                    None => Ok(Status::Ok),
                }
            })
        }
    };
}

no_variables_of_type!(
    fmi2GetInteger,
    allowed::GET,
    *mut c_int,
    "SpeedController has no Integer variables"
);
no_variables_of_type!(
    fmi2SetInteger,
    allowed::SET,
    *const c_int,
    "SpeedController has no Integer variables"
);
no_variables_of_type!(
    fmi2SetBoolean,
    allowed::SET,
    *const Boolean,
    "the only Boolean variable, saturated, is an output"
);
no_variables_of_type!(
    fmi2GetString,
    allowed::GET,
    *mut *const c_char,
    "SpeedController has no String variables"
);
no_variables_of_type!(
    fmi2SetString,
    allowed::SET,
    *const *const c_char,
    "SpeedController has no String variables"
);

// ---- FMU states ------------------------------------------------------------------------------

unsafe fn owned_state<'a>(
    i: &Instance,
    s: FmuState,
) -> Result<&'a mut Snapshot, super::instance::Failure> {
    if i.fmu_states.contains(&(s as usize)) {
        Ok(&mut *(s as *mut Snapshot))
    } else {
        Err(error(format!(
            "FMU state {s:p} was not created by this instance or was already freed"
        )))
    }
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetFMUstate(c: Component, state: *mut FmuState) -> Status {
    with(c, "fmi2GetFMUstate", allowed::ANY, |i| {
        if state.is_null() {
            return Err(error("the FMUstate argument is a null pointer".into()));
        }
        let snap = i.snap.clone();
        if !(*state).is_null() && i.fmu_states.contains(&(*state as usize)) {
            *(*state as *mut Snapshot) = snap;
        } else {
            let p = Box::into_raw(Box::new(snap)) as FmuState;
            i.fmu_states.insert(p as usize);
            *state = p;
        }
        Ok(Status::Ok)
    })
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetFMUstate(c: Component, state: FmuState) -> Status {
    with(c, "fmi2SetFMUstate", allowed::ANY, |i| {
        i.snap = owned_state(i, state)?.clone();
        Ok(Status::Ok)
    })
}

#[no_mangle]
pub unsafe extern "C" fn fmi2FreeFMUstate(c: Component, state: *mut FmuState) -> Status {
    with(c, "fmi2FreeFMUstate", allowed::ANY, |i| {
        if state.is_null() || (*state).is_null() {
            return Ok(Status::Ok);
        }
        owned_state(i, *state)?;
        i.fmu_states.remove(&(*state as usize));
        drop(Box::from_raw(*state as *mut Snapshot));
        *state = std::ptr::null_mut();
        Ok(Status::Ok)
    })
}

macro_rules! not_supported {
    ($($name:ident($($arg:ident: $t:ty),*) in $states:expr => $why:literal;)*) => {$(
        #[no_mangle]
        pub unsafe extern "C" fn $name(c: Component $(, $arg: $t)*) -> Status {
            $(let _ = $arg;)*
            with(c, stringify!($name), $states, |_| Err(error($why.into())))
        }
    )*};
}

not_supported! {
    fmi2SerializedFMUstateSize(state: FmuState, size: *mut usize) in allowed::ANY
        => "canSerializeFMUstate is false";
    fmi2SerializeFMUstate(state: FmuState, buf: *mut c_char, size: usize) in allowed::ANY
        => "canSerializeFMUstate is false";
    fmi2DeSerializeFMUstate(buf: *const c_char, size: usize, state: *mut FmuState) in allowed::ANY
        => "canSerializeFMUstate is false";
    fmi2GetDirectionalDerivative(unknown: *const ValueReference, nu: usize, known: *const ValueReference,
        nk: usize, dv_known: *const f64, dv_unknown: *mut f64) in allowed::GET
        => "providesDirectionalDerivative is false";
    fmi2SetRealInputDerivatives(vr: *const ValueReference, n: usize, order: *const c_int,
        value: *const f64) in allowed::SET
        => "canInterpolateInputs is false: input derivatives are not supported";
    fmi2GetRealOutputDerivatives(vr: *const ValueReference, n: usize, order: *const c_int,
        value: *mut f64) in allowed::GET
        => "maxOutputDerivativeOrder is 0: output derivatives are not provided";
    fmi2CancelStep() in allowed::ANY
        => "fmi2DoStep runs synchronously: there is no step to cancel";
}

// ---- Co-Simulation ---------------------------------------------------------------------------

#[no_mangle]
pub unsafe extern "C" fn fmi2DoStep(
    c: Component,
    current: f64,
    h: f64,
    _no_set_prior: Boolean,
) -> Status {
    with(c, "fmi2DoStep", allowed::DONE, |i| i.do_step(current, h))
}

/// fmi2GetStatus and friends: only fmi2LastSuccessfulTime and fmi2Terminated exist here; the
/// others answer fmi2Discard, explained through the logger, as the standard asks for a status
/// that is not available.
unsafe fn status_query<T>(
    c: Component,
    func: &str,
    kind: c_int,
    value: *mut T,
    get: impl FnOnce(&Instance, c_int) -> Option<T>,
) -> Status {
    with(c, func, allowed::STATUS, |i| {
        let out = slice_mut(value, 1, "value")?;
        match get(i, kind) {
            Some(v) => {
                out[0] = v;
                Ok(Status::Ok)
            }
            None if matches!(
                kind,
                DO_STEP_STATUS | PENDING_STATUS | LAST_SUCCESSFUL_TIME | TERMINATED
            ) =>
            {
                i.log.log(
                    Status::Discard,
                    Category::Discard,
                    &format!("{func}: status kind {kind} is not available from this function"),
                );
                Ok(Status::Discard)
            }
            None => Err(error(format!("unknown fmi2StatusKind {kind}"))),
        }
    })
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetStatus(c: Component, kind: c_int, value: *mut Status) -> Status {
    status_query(c, "fmi2GetStatus", kind, value, |_, _| None)
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetRealStatus(c: Component, kind: c_int, value: *mut f64) -> Status {
    status_query(c, "fmi2GetRealStatus", kind, value, |i, k| {
        (k == LAST_SUCCESSFUL_TIME).then_some(i.snap.time)
    })
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetIntegerStatus(
    c: Component,
    kind: c_int,
    value: *mut c_int,
) -> Status {
    status_query(c, "fmi2GetIntegerStatus", kind, value, |_, _| None)
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetBooleanStatus(
    c: Component,
    kind: c_int,
    value: *mut Boolean,
) -> Status {
    // The controller never asks the master to stop.
    status_query(c, "fmi2GetBooleanStatus", kind, value, |_, k| {
        (k == TERMINATED).then_some(0)
    })
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetStringStatus(
    c: Component,
    kind: c_int,
    value: *mut *const c_char,
) -> Status {
    status_query(c, "fmi2GetStringStatus", kind, value, |_, _| None)
}

// ---- Model Exchange: not supported -----------------------------------------------------------

not_supported! {
    fmi2EnterEventMode() in allowed::ANY => "SpeedController is a Co-Simulation FMU: Model Exchange functions are not available";
    fmi2NewDiscreteStates(event_info: *mut c_void) in allowed::ANY => "SpeedController is a Co-Simulation FMU: Model Exchange functions are not available";
    fmi2EnterContinuousTimeMode() in allowed::ANY => "SpeedController is a Co-Simulation FMU: Model Exchange functions are not available";
    fmi2CompletedIntegratorStep(no_set_prior: Boolean, enter_event_mode: *mut Boolean, terminate: *mut Boolean) in allowed::ANY => "SpeedController is a Co-Simulation FMU: Model Exchange functions are not available";
    fmi2SetTime(time: f64) in allowed::ANY => "SpeedController is a Co-Simulation FMU: Model Exchange functions are not available";
    fmi2SetContinuousStates(x: *const f64, nx: usize) in allowed::ANY => "SpeedController is a Co-Simulation FMU: Model Exchange functions are not available";
    fmi2GetDerivatives(derivatives: *mut f64, nx: usize) in allowed::ANY => "SpeedController is a Co-Simulation FMU: Model Exchange functions are not available";
    fmi2GetEventIndicators(indicators: *mut f64, ni: usize) in allowed::ANY => "SpeedController is a Co-Simulation FMU: Model Exchange functions are not available";
    fmi2GetContinuousStates(x: *mut f64, nx: usize) in allowed::ANY => "SpeedController is a Co-Simulation FMU: Model Exchange functions are not available";
    fmi2GetNominalsOfContinuousStates(x_nominal: *mut f64, nx: usize) in allowed::ANY => "SpeedController is a Co-Simulation FMU: Model Exchange functions are not available";
}
