//! The bodies of the fmi3* functions, generic over the model. Most hand over to fmi2-slave's
//! bodies (the same state machine and checks; an FMI 3.0 instance names the FMI 3.0 function
//! in its messages); what differs in FMI 3.0 is here: instantiation, initialization with the
//! experiment, typed values with counts, bool arguments, the independent variable `time` and
//! the event indicators as variables, and fmi3DoStep's results.
//!
//! # Safety
//! Every function takes the arguments of its fmi3 counterpart as the master passes them: the
//! instance is checked (null, or not a live instance of this model: fmi3Error), array
//! arguments are checked for null with a count, and otherwise the pointers must be as the
//! standard specifies.

#![allow(clippy::missing_safety_doc)]

use crate::{Fmi3LogFn, Fmi3ValueReference as ValueReference};
use fmi2_slave::ffi::{self as f2, slice, slice_mut, with};
use fmi2_slave::instance::{allowed, error, CallResult, Failure, FmiState, Instance};
use fmi2_slave::model_exchange as me2;
use fmi2_slave::{Component, ComponentEnvironment, Logger, Slave, Status};
use std::ffi::CStr;
use std::os::raw::{c_char, c_int};

pub fn get_version() -> *const c_char {
    c"3.0".as_ptr()
}

unsafe fn text(p: *const c_char) -> Option<String> {
    (!p.is_null()).then(|| CStr::from_ptr(p).to_string_lossy().into_owned())
}

/// fmi3InstantiateModelExchange and fmi3InstantiateCoSimulation.
#[allow(clippy::too_many_arguments)]
pub unsafe fn instantiate<S: Slave>(
    func: &str,
    instance_name: *const c_char,
    token: *const c_char,
    resource_path: *const c_char,
    model_exchange: bool,
    event_mode_used: bool,
    logging_on: bool,
    env: ComponentEnvironment,
    log_message: Option<Fmi3LogFn>,
) -> Component {
    let built = std::panic::catch_unwind(|| {
        let log = Logger::new_fmi3(log_message, env, S::LOG_CATEGORIES, logging_on);
        let fail = |msg: String| {
            log.log_status(Status::Error, &format!("{func}: {msg}"));
            None
        };
        let name = text(instance_name).unwrap_or_default();
        if name.is_empty() {
            return fail("instanceName must be a non-empty string".into());
        }
        if model_exchange && !S::MODEL_EXCHANGE {
            return fail(format!("{} has no Model Exchange interface", S::MODEL_NAME));
        }
        if event_mode_used {
            return fail(
                "eventModeUsed = true, but hasEventMode is false: the FMU handles its events inside fmi3DoStep".into(),
            );
        }
        let resources = text(resource_path).and_then(|p| fmi2_slave::resources::directory(&p));
        let slave = match S::instantiate(resources.as_deref(), &text(token).unwrap_or_default()) {
            Ok(s) => s,
            Err(e) => return fail(e),
        };
        let own = slave.instance_guid();
        match text(token) {
            Some(g) if g == own => {}
            other => {
                return fail(format!(
                    "instantiationToken {other:?} does not match this FMU's {own}"
                ))
            }
        }
        let mut i = Instance::<S>::new(log, model_exchange, slave);
        i.fmi3 = true;
        Some(Box::into_raw(Box::new(i)) as Component)
    });
    built.ok().flatten().unwrap_or(std::ptr::null_mut())
}

/// fmi3InstantiateScheduledExecution: not offered (the modelDescription has no
/// ScheduledExecution element).
pub unsafe fn instantiate_scheduled<S: Slave>(
    env: ComponentEnvironment,
    log_message: Option<Fmi3LogFn>,
) -> Component {
    let log = Logger::new_fmi3(log_message, env, S::LOG_CATEGORIES, false);
    log.log_status(
        Status::Error,
        &format!(
            "fmi3InstantiateScheduledExecution: {} offers Co-Simulation and Model Exchange only",
            S::MODEL_NAME
        ),
    );
    std::ptr::null_mut()
}

pub unsafe fn set_debug_logging<S: Slave>(
    c: Component,
    on: bool,
    n: usize,
    categories: *const *const c_char,
) -> Status {
    f2::set_debug_logging::<S>(c, on as c_int, n, categories)
}

pub unsafe fn enter_initialization_mode<S: Slave>(
    c: Component,
    tolerance_defined: bool,
    tolerance: f64,
    start_time: f64,
    stop_time_defined: bool,
    stop_time: f64,
) -> Status {
    with::<S>(c, "fmi3EnterInitializationMode", allowed::INST, |i| {
        i.slave.setup_experiment(
            tolerance_defined.then_some(tolerance),
            start_time,
            stop_time_defined.then_some(stop_time),
        )?;
        i.slave.enter_initialization()?;
        i.state = FmiState::InitializationMode;
        Ok(Status::Ok)
    })
}

// ---- values ----------------------------------------------------------------------------------

/// FMI 3.0 passes the number of values beside the number of value references; with scalar
/// variables only they must agree.
fn counts(n_vr: usize, n_values: usize) -> Result<(), Failure> {
    if n_vr != n_values {
        return Err(error(format!(
            "nValues = {n_values} for nValueReferences = {n_vr}: every variable is a scalar"
        )));
    }
    Ok(())
}

/// The event indicator a value reference names, if any.
fn indicator<S: Slave>(s: &S, vr: ValueReference) -> Option<usize> {
    let vr0 = s.event_indicator_vr0();
    let k = vr.checked_sub(vr0)? as usize;
    (vr0 > 0 && k < s.n_event_indicators()).then_some(k)
}

/// The independent variable and the event indicators cannot be set.
fn settable<S: Slave>(s: &S, vrs: &[ValueReference]) -> Result<(), Failure> {
    match vrs.iter().find(|&&r| r == 0 || indicator(s, r).is_some()) {
        Some(0) => Err(error(
            "time (value reference 0) is the independent variable: it cannot be set".into(),
        )),
        Some(r) => Err(error(format!(
            "value reference {r} is an event indicator: it cannot be set"
        ))),
        None => Ok(()),
    }
}

pub unsafe fn get_float64<S: Slave>(
    c: Component,
    vr: *const ValueReference,
    n_vr: usize,
    values: *mut f64,
    n_values: usize,
) -> Status {
    with::<S>(c, "fmi3GetFloat64", allowed::GET, |i| {
        counts(n_vr, n_values)?;
        let vrs = slice(vr, n_vr, "valueReferences")?;
        let out = slice_mut(values, n_vr, "values")?;
        let mut z: Vec<f64> = Vec::new();
        for (o, &r) in out.iter_mut().zip(vrs) {
            *o = match (r, indicator(&i.slave, r)) {
                (0, _) => i.slave.time(),
                (_, Some(k)) => {
                    if z.is_empty() {
                        z = vec![0.0; i.slave.n_event_indicators()];
                        i.slave.me_event_indicators(&mut z)?;
                    }
                    z[k]
                }
                _ => i.slave.get_real(r)?,
            };
        }
        Ok(Status::Ok)
    })
}

pub unsafe fn set_float64<S: Slave>(
    c: Component,
    vr: *const ValueReference,
    n_vr: usize,
    values: *const f64,
    n_values: usize,
) -> Status {
    with::<S>(c, "fmi3SetFloat64", allowed::SET, |i| {
        counts(n_vr, n_values)?;
        let vrs = slice(vr, n_vr, "valueReferences")?;
        settable(&i.slave, vrs)?;
        let vals = slice(values, n_vr, "values")?;
        let running = allowed::RUNNING & i.state as u32 != 0;
        i.slave.set_real(vrs, vals, running)?;
        Ok(Status::Ok)
    })
}

pub unsafe fn get_int32<S: Slave>(
    c: Component,
    vr: *const ValueReference,
    n_vr: usize,
    values: *mut i32,
    n_values: usize,
) -> Status {
    with::<S>(c, "fmi3GetInt32", allowed::GET, |i| {
        counts(n_vr, n_values)?;
        let vrs = slice(vr, n_vr, "valueReferences")?;
        let out = slice_mut(values, n_vr, "values")?;
        for (o, &r) in out.iter_mut().zip(vrs) {
            *o = i.slave.get_integer(r)?;
        }
        Ok(Status::Ok)
    })
}

pub unsafe fn set_int32<S: Slave>(
    c: Component,
    vr: *const ValueReference,
    n_vr: usize,
    values: *const i32,
    n_values: usize,
) -> Status {
    with::<S>(c, "fmi3SetInt32", allowed::SET, |i| {
        counts(n_vr, n_values)?;
        let vrs = slice(vr, n_vr, "valueReferences")?;
        let vals = slice(values, n_vr, "values")?;
        let running = allowed::RUNNING & i.state as u32 != 0;
        i.slave.set_integer(vrs, vals, running)?;
        Ok(Status::Ok)
    })
}

pub unsafe fn get_boolean<S: Slave>(
    c: Component,
    vr: *const ValueReference,
    n_vr: usize,
    values: *mut bool,
    n_values: usize,
) -> Status {
    with::<S>(c, "fmi3GetBoolean", allowed::GET, |i| {
        counts(n_vr, n_values)?;
        let vrs = slice(vr, n_vr, "valueReferences")?;
        let out = slice_mut(values, n_vr, "values")?;
        for (o, &r) in out.iter_mut().zip(vrs) {
            *o = i.slave.get_boolean(r)?;
        }
        Ok(Status::Ok)
    })
}

pub unsafe fn set_boolean<S: Slave>(
    c: Component,
    vr: *const ValueReference,
    n_vr: usize,
    values: *const bool,
    n_values: usize,
) -> Status {
    with::<S>(c, "fmi3SetBoolean", allowed::SET, |i| {
        counts(n_vr, n_values)?;
        let vrs = slice(vr, n_vr, "valueReferences")?;
        // Read as bytes: a master's bool that is neither 0 nor 1 is still read, as true.
        let bytes = slice(values as *const u8, n_vr, "values")?;
        let ints: Vec<c_int> = bytes.iter().map(|&b| (b != 0) as c_int).collect();
        let running = allowed::RUNNING & i.state as u32 != 0;
        i.slave.set_boolean(vrs, &ints, running)?;
        Ok(Status::Ok)
    })
}

/// A count mismatch is reported as the call's error; otherwise `body` runs (fmi2-slave's).
unsafe fn with_counts<S: Slave>(
    c: Component,
    func: &str,
    n_vr: usize,
    n_values: usize,
    body: impl FnOnce() -> Status,
) -> Status {
    if n_vr != n_values {
        return with::<S>(c, func, allowed::ANY, |_| {
            counts(n_vr, n_values).map(|_| Status::Ok)
        });
    }
    body()
}

pub unsafe fn get_string<S: Slave>(
    c: Component,
    vr: *const ValueReference,
    n_vr: usize,
    values: *mut *const c_char,
    n_values: usize,
) -> Status {
    with_counts::<S>(c, "fmi3GetString", n_vr, n_values, || {
        f2::get_string::<S>(c, vr, n_vr, values)
    })
}

pub unsafe fn set_string<S: Slave>(
    c: Component,
    vr: *const ValueReference,
    n_vr: usize,
    values: *const *const c_char,
    n_values: usize,
) -> Status {
    with_counts::<S>(c, "fmi3SetString", n_vr, n_values, || {
        f2::set_string::<S>(c, vr, n_vr, values)
    })
}

/// The functions of variable types the model has none of (Float32, the other integer widths,
/// Binary, Clock): nothing to do for no value references, fmi3Error naming the first otherwise.
pub unsafe fn no_such_type<S: Slave>(
    c: Component,
    func: &str,
    ty: &str,
    vr: *const ValueReference,
    n_vr: usize,
) -> Status {
    with::<S>(c, func, allowed::ANY, |_| {
        let vrs = slice(vr, n_vr, "valueReferences")?;
        match vrs.first() {
            None => Ok(Status::Ok),
            Some(r) => Err(error(format!(
                "value reference {r}: {} has no {ty} variables",
                S::MODEL_NAME
            ))),
        }
    })
}

/// A function of an FMI 3.0 capability the model does not have: fmi3Error with the reason.
pub unsafe fn not_supported<S: Slave>(c: Component, func: &str, why: &str) -> Status {
    with::<S>(c, func, allowed::ANY, |_| -> CallResult {
        Err(error(why.into()))
    })
}

// ---- Model Exchange --------------------------------------------------------------------------

/// Writes through a pointer the master passed (null: fmi3Error).
unsafe fn put<T>(p: *mut T, what: &str, x: T) -> Result<(), Failure> {
    slice_mut(p, 1, what)?[0] = x;
    Ok(())
}

pub unsafe fn update_discrete_states<S: Slave>(
    c: Component,
    need_update: *mut bool,
    terminate: *mut bool,
    nominals_changed: *mut bool,
    values_changed: *mut bool,
    next_event_time_defined: *mut bool,
    next_event_time: *mut f64,
) -> Status {
    me2::update_discrete_states::<S>(c, |u| {
        put(need_update, "discreteStatesNeedUpdate", false)?;
        put(terminate, "terminateSimulation", false)?;
        put(
            nominals_changed,
            "nominalsOfContinuousStatesChanged",
            u.nominals_changed,
        )?;
        put(
            values_changed,
            "valuesOfContinuousStatesChanged",
            u.states_changed,
        )?;
        put(
            next_event_time_defined,
            "nextEventTimeDefined",
            u.next_event_time.is_some(),
        )?;
        put(
            next_event_time,
            "nextEventTime",
            u.next_event_time.unwrap_or(0.0),
        )
    })
}

/// fmi3EvaluateDiscreteStates: the model's discrete states change only at events, which
/// fmi3UpdateDiscreteStates handles; here there is nothing to evaluate.
pub unsafe fn evaluate_discrete_states<S: Slave>(c: Component) -> Status {
    me2::with_me::<S>(c, "fmi3EvaluateDiscreteStates", allowed::EVENT, |_| {
        Ok(Status::Ok)
    })
}

pub unsafe fn completed_integrator_step<S: Slave>(
    c: Component,
    enter_event_mode: *mut bool,
    terminate: *mut bool,
) -> Status {
    me2::completed_step::<S>(c, |enter| {
        put(enter_event_mode, "enterEventMode", enter)?;
        put(terminate, "terminateSimulation", false)
    })
}

/// fmi3GetNumberOfEventIndicators and fmi3GetNumberOfContinuousStates.
pub unsafe fn get_number<S: Slave>(
    c: Component,
    func: &str,
    n: fn(&S) -> usize,
    out: *mut usize,
) -> Status {
    with::<S>(c, func, allowed::ANY, |i| {
        put(out, "the count", n(&i.slave))?;
        Ok(Status::Ok)
    })
}

// ---- Co-Simulation ---------------------------------------------------------------------------

/// fmi3DoStep: fmi2DoStep's checks and step, and FMI 3.0's results. The FMU locates its events
/// inside the step and never returns early; a discarded step keeps the values at the current
/// point (lastSuccessfulTime), where the instance may step again (FMI 3.0 has no stepFailed).
#[allow(clippy::too_many_arguments)]
pub unsafe fn do_step<S: Slave>(
    c: Component,
    current: f64,
    h: f64,
    event_handling_needed: *mut bool,
    terminate: *mut bool,
    early_return: *mut bool,
    last_successful_time: *mut f64,
) -> Status {
    let outs = [event_handling_needed, terminate, early_return];
    if outs.iter().any(|p| p.is_null()) || last_successful_time.is_null() {
        return with::<S>(c, "fmi3DoStep", allowed::ANY, |_| {
            Err(error("a result pointer is null".into()))
        });
    }
    let status = f2::do_step::<S>(c, current, h);
    if let Some(i) = f2::instance::<S>(c) {
        if i.state == FmiState::StepFailed {
            i.state = FmiState::StepComplete;
        }
        for p in outs {
            *p = false;
        }
        *last_successful_time = i.slave.time();
    }
    status
}
