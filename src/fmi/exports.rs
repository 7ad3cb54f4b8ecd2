//! The exported fmi2* functions. Each one finds its instance, states which FMI states it may be
//! called in, and hands a closure to `Instance::call` (state check, panic guard, error log).
//! All of FMI 2.0 is exported; the Model Exchange functions answer fmi2Error.

#![allow(non_snake_case, clippy::missing_safety_doc)]

use super::fmu_state;
use super::instance::{allowed, error, CallResult, FmiState, Instance, Snapshot, MAGIC};
use super::logging::{Category, Logger};
use super::{
    Boolean, CallbackFunctions, Component, EventInfo, FmuState, Status, StatusKind, Type,
    ValueReference,
};
use super::{DO_STEP_STATUS, LAST_SUCCESSFUL_TIME, PENDING_STATUS, TERMINATED, TYPE_CO_SIMULATION};
use crate::variables::{VarType, GUID};
use std::ffi::CStr;
use std::os::raw::{c_char, c_int};

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
    fmu_type: Type,
    guid: *const c_char,
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
                super::logging::Category::Error,
                &format!("fmi2Instantiate: {msg}"),
            );
            None
        };
        if instance_name.is_null() || name.is_empty() {
            return fail("instanceName must be a non-empty string".into());
        }
        if fmu_type != TYPE_CO_SIMULATION {
            return fail(format!("fmuType = {fmu_type}: SpurGearMesh is a Co-Simulation FMU only (fmi2CoSimulation = 1)"));
        }
        match text(guid) {
            Some(g) if g == GUID => {}
            other => {
                return fail(format!(
                    "GUID {other:?} does not match this binary's {GUID}"
                ))
            }
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
                Some(n) if crate::variables::LOG_CATEGORIES.contains(&n.as_str()) => {}
                other => {
                    return Err(error(format!(
                        "unknown log category {other:?}; the categories are {:?}",
                        crate::variables::LOG_CATEGORIES
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
    tolerance_defined: Boolean,
    tolerance: f64,
    start_time: f64,
    stop_time_defined: Boolean,
    stop_time: f64,
) -> Status {
    with(c, "fmi2SetupExperiment", allowed::INST, |i| {
        i.setup_experiment(
            (tolerance_defined != 0).then_some(tolerance),
            start_time,
            (stop_time_defined != 0).then_some(stop_time),
        )
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
    with(c, "fmi2Terminate", allowed::DONE | allowed::FAIL, |i| {
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

macro_rules! getter {
    ($name:ident, $t:ty, $method:ident, $conv:expr) => {
        #[no_mangle]
        pub unsafe extern "C" fn $name(
            c: Component,
            vr: *const ValueReference,
            n: usize,
            value: *mut $t,
        ) -> Status {
            with(c, stringify!($name), allowed::GET, |i| {
                let vrs = slice(vr, n, "vr")?;
                let out = slice_mut(value, n, "value")?;
                for (o, &r) in out.iter_mut().zip(vrs) {
                    *o = $conv(i.$method(r)?);
                }
                Ok(Status::Ok)
            })
        }
    };
}

getter!(fmi2GetReal, f64, get_real, |x: f64| x);
getter!(fmi2GetInteger, c_int, get_integer, |x: i32| x);
getter!(fmi2GetBoolean, Boolean, get_boolean, |x: bool| x as Boolean);

#[no_mangle]
pub unsafe extern "C" fn fmi2GetString(
    c: Component,
    vr: *const ValueReference,
    n: usize,
    _value: *mut *const c_char,
) -> Status {
    with(c, "fmi2GetString", allowed::GET, |_| {
        match slice(vr, n, "vr")?.first() {
            Some(r) => Err(error(format!(
                "value reference {r}: SpurGearMesh has no String variables"
            ))),
            None => Ok(Status::Ok),
        }
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
        i.set_many(VarType::Real, vrs, vals, f64::is_finite, |p, inp, v, x| {
            let _ = p.set_real(v, x) || inp.set_real(v, x);
        })
    })
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetInteger(
    c: Component,
    vr: *const ValueReference,
    n: usize,
    value: *const c_int,
) -> Status {
    with(c, "fmi2SetInteger", allowed::SET, |i| {
        let (vrs, vals) = (slice(vr, n, "vr")?, slice(value, n, "value")?);
        i.set_many(
            VarType::Integer,
            vrs,
            vals,
            |_| true,
            |p, _, v, x| {
                p.set_integer(v, x);
            },
        )
    })
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetBoolean(
    c: Component,
    vr: *const ValueReference,
    n: usize,
    value: *const Boolean,
) -> Status {
    with(c, "fmi2SetBoolean", allowed::SET, |i| {
        let (vrs, vals) = (slice(vr, n, "vr")?, slice(value, n, "value")?);
        i.set_many(
            VarType::Boolean,
            vrs,
            vals,
            |_| true,
            |p, _, v, x| {
                p.set_boolean(v, x != 0);
            },
        )
    })
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetString(
    c: Component,
    vr: *const ValueReference,
    n: usize,
    _value: *const *const c_char,
) -> Status {
    with(c, "fmi2SetString", allowed::SET, |_| {
        match slice(vr, n, "vr")?.first() {
            Some(r) => Err(error(format!(
                "value reference {r}: SpurGearMesh has no String variables"
            ))),
            None => Ok(Status::Ok),
        }
    })
}

// ---- FMU states ------------------------------------------------------------------------------

/// The snapshot behind a state pointer, if this instance handed it out.
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

/// Stores a snapshot in *state: in place if *state is one of ours, else in a new allocation.
unsafe fn store_state(i: &mut Instance, state: *mut FmuState, snap: Snapshot) -> CallResult {
    if state.is_null() {
        return Err(error("the FMUstate argument is a null pointer".into()));
    }
    if !(*state).is_null() && i.fmu_states.contains(&(*state as usize)) {
        *(*state as *mut Snapshot) = snap;
    } else {
        let p = Box::into_raw(Box::new(snap)) as FmuState;
        i.fmu_states.insert(p as usize);
        *state = p;
    }
    Ok(Status::Ok)
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetFMUstate(c: Component, state: *mut FmuState) -> Status {
    with(c, "fmi2GetFMUstate", allowed::ANY, |i| {
        let snap = i.snap.clone();
        store_state(i, state, snap)
    })
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetFMUstate(c: Component, state: FmuState) -> Status {
    with(c, "fmi2SetFMUstate", allowed::ANY, |i| {
        let snap = owned_state(i, state)?.clone();
        i.restore(&snap);
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

#[no_mangle]
pub unsafe extern "C" fn fmi2SerializedFMUstateSize(
    c: Component,
    state: FmuState,
    size: *mut usize,
) -> Status {
    with(c, "fmi2SerializedFMUstateSize", allowed::ANY, |i| {
        let bytes = fmu_state::encode(owned_state(i, state)?);
        *slice_mut(size, 1, "size")?.first_mut().expect("one") = bytes.len();
        Ok(Status::Ok)
    })
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SerializeFMUstate(
    c: Component,
    state: FmuState,
    buf: *mut c_char,
    size: usize,
) -> Status {
    with(c, "fmi2SerializeFMUstate", allowed::ANY, |i| {
        let bytes = fmu_state::encode(owned_state(i, state)?);
        if size < bytes.len() {
            return Err(error(format!(
                "buffer of {size} bytes is too small: the state needs {}",
                bytes.len()
            )));
        }
        let out = slice_mut(buf as *mut u8, bytes.len(), "serializedState")?;
        out.copy_from_slice(&bytes);
        Ok(Status::Ok)
    })
}

#[no_mangle]
pub unsafe extern "C" fn fmi2DeSerializeFMUstate(
    c: Component,
    buf: *const c_char,
    size: usize,
    state: *mut FmuState,
) -> Status {
    with(c, "fmi2DeSerializeFMUstate", allowed::ANY, |i| {
        let bytes = slice(buf as *const u8, size, "serializedState")?;
        let snap = fmu_state::decode(bytes)
            .map_err(|e| error(format!("serialized state rejected: {e}")))?;
        store_state(i, state, snap)
    })
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

#[no_mangle]
pub unsafe extern "C" fn fmi2CancelStep(c: Component) -> Status {
    with(c, "fmi2CancelStep", allowed::ANY, |_| {
        Err(error(
            "fmi2DoStep runs synchronously: there is no step to cancel".into(),
        ))
    })
}

#[no_mangle]
pub unsafe extern "C" fn fmi2SetRealInputDerivatives(
    c: Component,
    _vr: *const ValueReference,
    _n: usize,
    _order: *const c_int,
    _value: *const f64,
) -> Status {
    with(c, "fmi2SetRealInputDerivatives", allowed::SET, |_| {
        Err(error(
            "canInterpolateInputs is false: input derivatives are not supported".into(),
        ))
    })
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetRealOutputDerivatives(
    c: Component,
    _vr: *const ValueReference,
    _n: usize,
    _order: *const c_int,
    _value: *mut f64,
) -> Status {
    with(c, "fmi2GetRealOutputDerivatives", allowed::GET, |_| {
        Err(error(
            "maxOutputDerivativeOrder is 0: output derivatives are not provided".into(),
        ))
    })
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetDirectionalDerivative(
    c: Component,
    _unknown: *const ValueReference,
    _nu: usize,
    _known: *const ValueReference,
    _nk: usize,
    _dv_known: *const f64,
    _dv_unknown: *mut f64,
) -> Status {
    with(c, "fmi2GetDirectionalDerivative", allowed::GET, |_| {
        Err(error("providesDirectionalDerivative is false".into()))
    })
}

/// fmi2GetStatus and friends: only fmi2LastSuccessfulTime and fmi2Terminated exist here;
/// the others answer fmi2Discard, as the standard asks for a status that is not available.
/// Like every fmi2Discard, it is explained through the logger (logStatusDiscard); the state
/// does not change.
unsafe fn status_query<T>(
    c: Component,
    func: &str,
    kind: StatusKind,
    value: *mut T,
    get: impl FnOnce(&Instance, StatusKind) -> Option<T>,
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
                    &format!(
                        "{func}: {} is not available from this function \
                         (fmi2DoStep runs synchronously and never returns fmi2Pending)",
                        [
                            "fmi2DoStepStatus",
                            "fmi2PendingStatus",
                            "fmi2LastSuccessfulTime",
                            "fmi2Terminated"
                        ][kind as usize]
                    ),
                );
                Ok(Status::Discard)
            }
            None => Err(error(format!("unknown fmi2StatusKind {kind}"))),
        }
    })
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetStatus(
    c: Component,
    kind: StatusKind,
    value: *mut Status,
) -> Status {
    status_query(c, "fmi2GetStatus", kind, value, |_, _| None)
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetRealStatus(
    c: Component,
    kind: StatusKind,
    value: *mut f64,
) -> Status {
    status_query(c, "fmi2GetRealStatus", kind, value, |i, k| {
        (k == LAST_SUCCESSFUL_TIME).then(|| i.time())
    })
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetIntegerStatus(
    c: Component,
    kind: StatusKind,
    value: *mut c_int,
) -> Status {
    status_query(c, "fmi2GetIntegerStatus", kind, value, |_, _| None)
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetBooleanStatus(
    c: Component,
    kind: StatusKind,
    value: *mut Boolean,
) -> Status {
    // The FMU never asks the master to stop.
    status_query(c, "fmi2GetBooleanStatus", kind, value, |_, k| {
        (k == TERMINATED).then_some(0)
    })
}

#[no_mangle]
pub unsafe extern "C" fn fmi2GetStringStatus(
    c: Component,
    kind: StatusKind,
    value: *mut *const c_char,
) -> Status {
    status_query(c, "fmi2GetStringStatus", kind, value, |_, _| None)
}

// ---- Model Exchange: not supported -----------------------------------------------------------

macro_rules! model_exchange_only {
    ($($name:ident($($arg:ident: $t:ty),*);)*) => {$(
        #[no_mangle]
        pub unsafe extern "C" fn $name(c: Component $(, $arg: $t)*) -> Status {
            $(let _ = $arg;)*
            with(c, stringify!($name), allowed::ANY, |_| {
                Err(error("SpurGearMesh is a Co-Simulation FMU: Model Exchange functions are not available".into()))
            })
        }
    )*};
}

model_exchange_only! {
    fmi2EnterEventMode();
    fmi2NewDiscreteStates(event_info: *mut EventInfo);
    fmi2EnterContinuousTimeMode();
    fmi2CompletedIntegratorStep(no_set_prior: Boolean, enter_event_mode: *mut Boolean, terminate: *mut Boolean);
    fmi2SetTime(time: f64);
    fmi2SetContinuousStates(x: *const f64, nx: usize);
    fmi2GetDerivatives(derivatives: *mut f64, nx: usize);
    fmi2GetEventIndicators(indicators: *mut f64, ni: usize);
    fmi2GetContinuousStates(x: *mut f64, nx: usize);
    fmi2GetNominalsOfContinuousStates(x_nominal: *mut f64, nx: usize);
}
