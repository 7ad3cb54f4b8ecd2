//! The bodies of the fmi2* functions, generic over the model; `export_fmi2!` defines the
//! exported functions that call them. Each one finds its instance, states which FMI states it
//! may be called in, and hands a closure to `Instance::call` (state check, panic guard, error
//! log). The Model Exchange functions are in `model_exchange.rs`.
//!
//! # Safety
//! Every function takes the arguments of its fmi2 counterpart as the master passes them: the
//! component is checked (null, or not a live instance of this model: fmi2Error), array
//! arguments are checked for null with a count, and otherwise the pointers must be as the
//! standard specifies.

#![allow(clippy::missing_safety_doc)]

use crate::instance::{allowed, error, CallResult, Failure, FmiState, Instance, Saved, MAGIC};
use crate::logging::{Logger, LOG_STATUS_DISCARD};
use crate::{fmu_state, Slave};
use crate::{
    Boolean, CallbackFunctions, Component, FmuState, Status, StatusKind, Type, ValueReference,
};
use crate::{
    DO_STEP_STATUS, LAST_SUCCESSFUL_TIME, PENDING_STATUS, TERMINATED, TYPE_CO_SIMULATION,
    TYPE_MODEL_EXCHANGE,
};
use std::ffi::{CStr, CString};
use std::os::raw::{c_char, c_int};

/// More values than any master can mean; guards against garbage counts.
const MAX_VALUES: usize = 1 << 20;

#[inline]
pub unsafe fn instance<'a, S: Slave>(c: Component) -> Option<&'a mut Instance<S>> {
    if c.is_null() {
        return None;
    }
    let i = &mut *(c as *mut Instance<S>);
    (i.magic == MAGIC).then_some(i)
}

#[inline]
pub unsafe fn with<S: Slave>(
    c: Component,
    func: &str,
    states: u32,
    body: impl FnOnce(&mut Instance<S>) -> CallResult,
) -> Status {
    match unsafe { instance::<S>(c) } {
        Some(i) => i.call(func, states, body),
        None => Status::Error,
    }
}

/// A C array argument: null is allowed only for n = 0.
pub unsafe fn slice<'a, T>(p: *const T, n: usize, what: &str) -> Result<&'a [T], Failure> {
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

pub unsafe fn slice_mut<'a, T>(p: *mut T, n: usize, what: &str) -> Result<&'a mut [T], Failure> {
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

pub fn get_types_platform() -> *const c_char {
    c"default".as_ptr()
}

pub fn get_version() -> *const c_char {
    c"2.0".as_ptr()
}

pub unsafe fn instantiate<S: Slave>(
    instance_name: *const c_char,
    fmu_type: Type,
    guid: *const c_char,
    resource_location: *const c_char,
    functions: *const CallbackFunctions,
    logging_on: Boolean,
) -> Component {
    let built = std::panic::catch_unwind(|| {
        let f = functions.as_ref()?;
        let name = text(instance_name).unwrap_or_default();
        let log = Logger::new(
            f.logger,
            f.component_environment,
            &name,
            S::LOG_CATEGORIES,
            logging_on != 0,
        );
        let fail = |msg: String| {
            log.log_status(Status::Error, &format!("fmi2Instantiate: {msg}"));
            None
        };
        if instance_name.is_null() || name.is_empty() {
            return fail("instanceName must be a non-empty string".into());
        }
        let model_exchange = match fmu_type {
            TYPE_CO_SIMULATION => false,
            TYPE_MODEL_EXCHANGE if S::MODEL_EXCHANGE => true,
            _ if S::MODEL_EXCHANGE => {
                return fail(format!(
                    "fmuType = {fmu_type}: must be fmi2ModelExchange = 0 or fmi2CoSimulation = 1"
                ))
            }
            _ => {
                return fail(format!(
                    "fmuType = {fmu_type}: {} is a Co-Simulation FMU only (fmi2CoSimulation = 1)",
                    S::MODEL_NAME
                ))
            }
        };
        let resources = text(resource_location).and_then(|u| crate::resources::directory(&u));
        let slave = match S::instantiate(resources.as_deref(), &text(guid).unwrap_or_default()) {
            Ok(s) => s,
            Err(e) => return fail(e),
        };
        let own = slave.instance_guid();
        match text(guid) {
            Some(g) if g == own => {}
            other => return fail(format!("GUID {other:?} does not match this FMU's {own}")),
        }
        let i = Instance::<S>::new(log, model_exchange, slave);
        Some(Box::into_raw(Box::new(i)) as Component)
    });
    built.ok().flatten().unwrap_or(std::ptr::null_mut())
}

pub unsafe fn free_instance<S: Slave>(c: Component) {
    if let Some(i) = instance::<S>(c) {
        let _ = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            for p in i.fmu_states.drain() {
                drop(Box::from_raw(p as *mut Saved<S>));
            }
            i.magic = 0;
            drop(Box::from_raw(c as *mut Instance<S>));
        }));
    }
}

pub unsafe fn set_debug_logging<S: Slave>(
    c: Component,
    on: Boolean,
    n: usize,
    categories: *const *const c_char,
) -> Status {
    with::<S>(c, "fmi2SetDebugLogging", allowed::ANY, |i| {
        let cats = slice(categories, n, "categories")?;
        if cats.is_empty() {
            i.log.set_all(on != 0);
            return Ok(Status::Ok);
        }
        let names: Vec<Option<String>> = cats.iter().map(|&p| text(p)).collect();
        for name in &names {
            match name {
                Some(n) if S::LOG_CATEGORIES.contains(&n.as_str()) => {}
                other => {
                    return Err(error(format!(
                        "unknown log category {other:?}; the categories are {:?}",
                        S::LOG_CATEGORIES
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

pub unsafe fn setup_experiment<S: Slave>(
    c: Component,
    tolerance_defined: Boolean,
    tolerance: f64,
    start_time: f64,
    stop_time_defined: Boolean,
    stop_time: f64,
) -> Status {
    with::<S>(c, "fmi2SetupExperiment", allowed::INST, |i| {
        i.slave.setup_experiment(
            (tolerance_defined != 0).then_some(tolerance),
            start_time,
            (stop_time_defined != 0).then_some(stop_time),
        )?;
        Ok(Status::Ok)
    })
}

pub unsafe fn enter_initialization_mode<S: Slave>(c: Component) -> Status {
    with::<S>(c, "fmi2EnterInitializationMode", allowed::INST, |i| {
        i.slave.enter_initialization()?;
        i.state = FmiState::InitializationMode;
        Ok(Status::Ok)
    })
}

pub unsafe fn exit_initialization_mode<S: Slave>(c: Component) -> Status {
    with::<S>(c, "fmi2ExitInitializationMode", allowed::INIT, |i| {
        if i.model_exchange {
            i.slave.me_exit_initialization()?;
            i.state = FmiState::EventMode;
        } else {
            i.slave.exit_initialization()?;
            i.state = FmiState::StepComplete;
        }
        let warnings = i.slave.init_warnings();
        for w in &warnings {
            i.log
                .log(Status::Warning, crate::logging::LOG_STATUS_WARNING, w);
        }
        Ok(if warnings.is_empty() {
            Status::Ok
        } else {
            Status::Warning
        })
    })
}

pub unsafe fn terminate<S: Slave>(c: Component) -> Status {
    let states = allowed::DONE | allowed::FAIL | allowed::EVENT | allowed::CONT;
    with::<S>(c, "fmi2Terminate", states, |i| {
        i.state = FmiState::Terminated;
        Ok(Status::Ok)
    })
}

pub unsafe fn reset<S: Slave>(c: Component) -> Status {
    with::<S>(c, "fmi2Reset", allowed::ANY, |i| {
        i.reset();
        Ok(Status::Ok)
    })
}

// ---- values ----------------------------------------------------------------------------------

/// fmi2Get*: one value after the other; the first failure ends the call.
unsafe fn get<S: Slave, T>(
    c: Component,
    func: &str,
    vr: *const ValueReference,
    n: usize,
    value: *mut T,
    get_one: impl Fn(&mut S, ValueReference) -> Result<T, Failure>,
) -> Status {
    with::<S>(c, func, allowed::GET, |i| {
        let vrs = slice(vr, n, i.arg("vr"))?;
        let out = slice_mut(value, n, i.arg("value"))?;
        for (o, &r) in out.iter_mut().zip(vrs) {
            *o = get_one(&mut i.slave, r)?;
        }
        Ok(Status::Ok)
    })
}

/// fmi2Set*: all values at once (the model checks all before it applies any).
unsafe fn set<S: Slave, T>(
    c: Component,
    func: &str,
    vr: *const ValueReference,
    n: usize,
    value: *const T,
    set_all: impl FnOnce(&mut S, &[ValueReference], &[T], bool) -> Result<(), Failure>,
) -> Status {
    with::<S>(c, func, allowed::SET, |i| {
        let (vrs, vals) = (slice(vr, n, i.arg("vr"))?, slice(value, n, i.arg("value"))?);
        let running = allowed::RUNNING & i.state as u32 != 0;
        set_all(&mut i.slave, vrs, vals, running)?;
        Ok(Status::Ok)
    })
}

pub unsafe fn get_real<S: Slave>(
    c: Component,
    vr: *const ValueReference,
    n: usize,
    value: *mut f64,
) -> Status {
    get(c, "fmi2GetReal", vr, n, value, S::get_real)
}

pub unsafe fn get_integer<S: Slave>(
    c: Component,
    vr: *const ValueReference,
    n: usize,
    value: *mut c_int,
) -> Status {
    get(c, "fmi2GetInteger", vr, n, value, S::get_integer)
}

pub unsafe fn get_boolean<S: Slave>(
    c: Component,
    vr: *const ValueReference,
    n: usize,
    value: *mut Boolean,
) -> Status {
    get(c, "fmi2GetBoolean", vr, n, value, |s: &mut S, r| {
        Ok(s.get_boolean(r)? as Boolean)
    })
}

pub unsafe fn set_real<S: Slave>(
    c: Component,
    vr: *const ValueReference,
    n: usize,
    value: *const f64,
) -> Status {
    set(c, "fmi2SetReal", vr, n, value, S::set_real)
}

pub unsafe fn set_integer<S: Slave>(
    c: Component,
    vr: *const ValueReference,
    n: usize,
    value: *const c_int,
) -> Status {
    set(c, "fmi2SetInteger", vr, n, value, S::set_integer)
}

pub unsafe fn set_boolean<S: Slave>(
    c: Component,
    vr: *const ValueReference,
    n: usize,
    value: *const Boolean,
) -> Status {
    set(c, "fmi2SetBoolean", vr, n, value, S::set_boolean)
}

pub unsafe fn get_string<S: Slave>(
    c: Component,
    vr: *const ValueReference,
    n: usize,
    value: *mut *const c_char,
) -> Status {
    with::<S>(c, "fmi2GetString", allowed::GET, |i| {
        let vrs = slice(vr, n, i.arg("vr"))?;
        let out = slice_mut(value, n, i.arg("value"))?;
        let texts = vrs
            .iter()
            .map(|&r| i.slave.get_string(r))
            .collect::<Result<Vec<String>, Failure>>()?;
        // Interior NULs cannot be set (they end a C string), so none come back.
        i.strings = texts
            .into_iter()
            .map(|t| CString::new(t).unwrap_or_default())
            .collect();
        for (o, t) in out.iter_mut().zip(&i.strings) {
            *o = t.as_ptr();
        }
        Ok(Status::Ok)
    })
}

pub unsafe fn set_string<S: Slave>(
    c: Component,
    vr: *const ValueReference,
    n: usize,
    value: *const *const c_char,
) -> Status {
    with::<S>(c, "fmi2SetString", allowed::SET, |i| {
        let (vrs, ptrs) = (slice(vr, n, i.arg("vr"))?, slice(value, n, i.arg("value"))?);
        let mut texts = Vec::with_capacity(n);
        for (&r, &p) in vrs.iter().zip(ptrs) {
            if p.is_null() {
                return Err(error(format!("value reference {r}: null string pointer")));
            }
            match CStr::from_ptr(p).to_str() {
                Ok(t) => texts.push(t.to_owned()),
                Err(e) => {
                    return Err(error(format!(
                        "value reference {r}: the string is not UTF-8 ({e})"
                    )))
                }
            }
        }
        let running = allowed::RUNNING & i.state as u32 != 0;
        i.slave.set_string(vrs, &texts, running)?;
        Ok(Status::Ok)
    })
}

// ---- FMU states ------------------------------------------------------------------------------

/// The FMU state behind a pointer, if this instance handed it out.
unsafe fn owned_state<'a, S: Slave>(
    i: &Instance<S>,
    s: FmuState,
) -> Result<&'a mut Saved<S>, Failure> {
    if i.fmu_states.contains(&(s as usize)) {
        Ok(&mut *(s as *mut Saved<S>))
    } else {
        Err(error(format!(
            "FMU state {s:p} was not created by this instance or was already freed"
        )))
    }
}

/// Stores an FMU state in *state: in place if *state is one of ours, else in a new allocation.
unsafe fn store_state<S: Slave>(
    i: &mut Instance<S>,
    state: *mut FmuState,
    saved: Saved<S>,
) -> CallResult {
    if state.is_null() {
        return Err(error("the FMUstate argument is a null pointer".into()));
    }
    if !(*state).is_null() && i.fmu_states.contains(&(*state as usize)) {
        *(*state as *mut Saved<S>) = saved;
    } else {
        let p = Box::into_raw(Box::new(saved)) as FmuState;
        i.fmu_states.insert(p as usize);
        *state = p;
    }
    Ok(Status::Ok)
}

pub unsafe fn get_fmu_state<S: Slave>(c: Component, state: *mut FmuState) -> Status {
    with::<S>(c, "fmi2GetFMUstate", allowed::ANY, |i| {
        let saved = i.save();
        store_state(i, state, saved)
    })
}

pub unsafe fn set_fmu_state<S: Slave>(c: Component, state: FmuState) -> Status {
    with::<S>(c, "fmi2SetFMUstate", allowed::ANY, |i| {
        let saved = owned_state(i, state)?;
        i.restore(saved)?;
        Ok(Status::Ok)
    })
}

pub unsafe fn free_fmu_state<S: Slave>(c: Component, state: *mut FmuState) -> Status {
    with::<S>(c, "fmi2FreeFMUstate", allowed::ANY, |i| {
        if state.is_null() || (*state).is_null() {
            return Ok(Status::Ok);
        }
        owned_state(i, *state)?;
        i.fmu_states.remove(&(*state as usize));
        drop(Box::from_raw(*state as *mut Saved<S>));
        *state = std::ptr::null_mut();
        Ok(Status::Ok)
    })
}

pub unsafe fn serialized_fmu_state_size<S: Slave>(
    c: Component,
    state: FmuState,
    size: *mut usize,
) -> Status {
    with::<S>(c, "fmi2SerializedFMUstateSize", allowed::ANY, |i| {
        let bytes = fmu_state::encode(owned_state(i, state)?);
        *slice_mut(size, 1, "size")?.first_mut().expect("one") = bytes.len();
        Ok(Status::Ok)
    })
}

pub unsafe fn serialize_fmu_state<S: Slave>(
    c: Component,
    state: FmuState,
    buf: *mut c_char,
    size: usize,
) -> Status {
    with::<S>(c, "fmi2SerializeFMUstate", allowed::ANY, |i| {
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

pub unsafe fn deserialize_fmu_state<S: Slave>(
    c: Component,
    buf: *const c_char,
    size: usize,
    state: *mut FmuState,
) -> Status {
    with::<S>(c, "fmi2DeSerializeFMUstate", allowed::ANY, |i| {
        let bytes = slice(buf as *const u8, size, "serializedState")?;
        let saved = fmu_state::decode::<S>(bytes, &i.slave)
            .map_err(|e| error(format!("serialized state rejected: {e}")))?;
        store_state(i, state, saved)
    })
}

// ---- Co-Simulation ---------------------------------------------------------------------------

pub unsafe fn do_step<S: Slave>(c: Component, current: f64, h: f64) -> Status {
    with::<S>(c, "fmi2DoStep", allowed::DONE, |i| {
        let t = i.slave.time();
        if !current.is_finite() || !h.is_finite() {
            return Err(error(format!("currentCommunicationPoint = {current}, communicationStepSize = {h}: must be finite")));
        }
        if !(h > 0.0) {
            return Err(error(format!(
                "communicationStepSize = {h}: must be positive"
            )));
        }
        // Masters accumulate time in floating point; a nanosecond-scale mismatch is rounding.
        if (current - t).abs() > 1e-9 * t.abs().max(1.0) {
            return Err(error(format!(
                "currentCommunicationPoint = {current} does not match the FMU's time {t}"
            )));
        }
        let represented = represented_step(current, h)?;
        let mut status = Status::Ok;
        if (represented - h).abs() > COARSE_STEP * h && !i.coarse_step_reported {
            i.coarse_step_reported = true;
            status = Status::Warning;
            let func = i.name("fmi2DoStep");
            i.log.log_status(
                status,
                &format!(
                    "{func}: the time resolves this step only coarsely: at t = {current:e} s, \
                     h = {h:e} s advances by the interval the time represents, \
                     (t + h) - t = {represented:e} s (reported once per instance)"
                ),
            );
        }
        i.slave.do_step(current, represented, &i.log)?;
        Ok(status)
    })
}

/// How far the interval the time represents, (t + h) - t, may differ from h, relative to h,
/// before the step counts as coarsely resolved (warned about once per instance).
///
/// The difference is the rounding of t + h alone, at most half an ulp of t + h:
/// |((t + h) - t) - h| <= 2^-53 |t + h| (the subtraction is exact, Sterbenz, for 0 < h <= |t|).
/// Relative to h that is 2^-53 (|t|/h + 1): it grows with |t|/h, the number of steps of this
/// size since time zero, and does not depend on the model. 1e-9 is the relative rounding this
/// layer already grants a master's communication point (the check against the FMU's time in
/// `do_step`); the bound first reaches it at |t|/h ~ 9e6, so an ordinary run (a million steps
/// of any size, or 100 s at 1e-5 s) is never warned about, while a master on epoch time
/// (t ~ 1.7e9 s) stepping 1 ms is off by up to 1.2e-4 of its step and is.
pub const COARSE_STEP: f64 = 1e-9;

/// The interval a step of `h` from `t` actually covers in double precision, (t + h) - t;
/// a step the time cannot resolve at all (t + h == t) is refused like h = 0.
pub fn represented_step(t: f64, h: f64) -> Result<f64, Failure> {
    let represented = (t + h) - t;
    if !(represented > 0.0) {
        let ulp = f64::from_bits(t.abs().to_bits() + 1) - t.abs();
        return Err(error(format!(
            "t + h == t in double precision (t = currentCommunicationPoint = {t:e} s, \
             h = communicationStepSize = {h:e} s): the step is lost in the time's resolution \
             (the doubles near t are {ulp:e} s apart)"
        )));
    }
    Ok(represented)
}

/// A function of an optional capability the FMUs here do not have: fmi2Error with the reason.
pub unsafe fn not_supported<S: Slave>(c: Component, func: &str, states: u32, why: &str) -> Status {
    with::<S>(c, func, states, |_| Err(error(why.into())))
}

pub unsafe fn cancel_step<S: Slave>(c: Component) -> Status {
    not_supported::<S>(
        c,
        "fmi2CancelStep",
        allowed::ANY,
        "fmi2DoStep runs synchronously: there is no step to cancel",
    )
}

pub unsafe fn set_real_input_derivatives<S: Slave>(
    c: Component,
    vr: *const ValueReference,
    n: usize,
    order: *const c_int,
    value: *const f64,
) -> Status {
    with::<S>(c, "fmi2SetRealInputDerivatives", allowed::SET, |i| {
        if i.model_exchange {
            return Err(error(
                "a Co-Simulation function, but the instance was instantiated for Model Exchange"
                    .into(),
            ));
        }
        let vrs = slice(vr, n, i.arg("vr"))?;
        let orders = slice(order, n, "order")?;
        let values = slice(value, n, i.arg("value"))?;
        i.slave.set_real_input_derivatives(vrs, orders, values)?;
        Ok(Status::Ok)
    })
}

pub unsafe fn get_real_output_derivatives<S: Slave>(c: Component) -> Status {
    not_supported::<S>(
        c,
        "fmi2GetRealOutputDerivatives",
        allowed::GET,
        "maxOutputDerivativeOrder is 0: output derivatives are not provided",
    )
}

/// fmi2GetStatus and friends: only fmi2LastSuccessfulTime and fmi2Terminated exist here;
/// the others answer fmi2Discard, as the standard asks for a status that is not available.
/// Like every fmi2Discard, it is explained through the logger (logStatusDiscard); the state
/// does not change.
unsafe fn status_query<S: Slave, T>(
    c: Component,
    func: &str,
    kind: StatusKind,
    value: *mut T,
    get: impl FnOnce(&Instance<S>, StatusKind) -> Option<T>,
) -> Status {
    with::<S>(c, func, allowed::STATUS, |i| {
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
                    LOG_STATUS_DISCARD,
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

pub unsafe fn get_status<S: Slave>(c: Component, kind: StatusKind, value: *mut Status) -> Status {
    status_query::<S, _>(c, "fmi2GetStatus", kind, value, |_, _| None)
}

pub unsafe fn get_real_status<S: Slave>(c: Component, kind: StatusKind, value: *mut f64) -> Status {
    status_query::<S, _>(c, "fmi2GetRealStatus", kind, value, |i, k| {
        (k == LAST_SUCCESSFUL_TIME).then(|| i.slave.time())
    })
}

pub unsafe fn get_integer_status<S: Slave>(
    c: Component,
    kind: StatusKind,
    value: *mut c_int,
) -> Status {
    status_query::<S, _>(c, "fmi2GetIntegerStatus", kind, value, |_, _| None)
}

pub unsafe fn get_boolean_status<S: Slave>(
    c: Component,
    kind: StatusKind,
    value: *mut Boolean,
) -> Status {
    // The FMU never asks the master to stop.
    status_query::<S, _>(c, "fmi2GetBooleanStatus", kind, value, |_, k| {
        (k == TERMINATED).then_some(0)
    })
}

pub unsafe fn get_string_status<S: Slave>(
    c: Component,
    kind: StatusKind,
    value: *mut *const c_char,
) -> Status {
    status_query::<S, _>(c, "fmi2GetStringStatus", kind, value, |_, _| None)
}
