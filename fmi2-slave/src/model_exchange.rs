//! The bodies of FMI 2.0's Model Exchange functions, generic over the model (`Slave`'s `me_*`
//! methods). The master integrates and locates events; the model gives its states, derivatives
//! and event indicators, and handles the events in fmi2NewDiscreteStates.
//!
//! # Safety
//! As in `ffi`: the component is checked, and array arguments are checked for null and for the
//! model's sizes.

#![allow(clippy::missing_safety_doc)]

use crate::ffi::{slice, slice_mut, with};
use crate::instance::{allowed, error, CallResult, Failure, FmiState, Instance};
use crate::{Boolean, Component, EventInfo, EventUpdate, Slave, Status, ValueReference};

/// `ffi::with` for a Model Exchange function: a Co-Simulation-only model, or a Co-Simulation
/// instance, gets fmi2Error.
pub unsafe fn with_me<S: Slave>(
    c: Component,
    func: &str,
    states: u32,
    body: impl FnOnce(&mut Instance<S>) -> CallResult,
) -> Status {
    if !S::MODEL_EXCHANGE {
        let why = crate::slave::no_model_exchange::<S>().message;
        // SAFETY: the component is checked there, as in every function.
        return unsafe { crate::ffi::not_supported::<S>(c, func, allowed::ANY, &why) };
    }
    // SAFETY: checked as in `with` (null, or not a live instance: None).
    match unsafe { crate::ffi::instance::<S>(c) } {
        Some(i) if !i.model_exchange => i.call(func, allowed::ANY, |_| {
            Err(error(
                "a Model Exchange function, but the instance was instantiated for Co-Simulation"
                    .into(),
            ))
        }),
        _ => with::<S>(c, func, states, body),
    }
}

/// The array of a state-sized (or indicator-sized) argument, its length checked.
fn sized(n: usize, expected: usize, what: &str) -> Result<(), Failure> {
    if n != expected {
        return Err(error(format!(
            "{what} = {n}: the FMU has {expected} (modelDescription.xml)"
        )));
    }
    Ok(())
}

pub unsafe fn enter_event_mode<S: Slave>(c: Component) -> Status {
    let states = allowed::EVENT | allowed::CONT;
    with_me::<S>(c, "fmi2EnterEventMode", states, |i| {
        i.slave.me_enter_event_mode()?;
        i.state = FmiState::EventMode;
        Ok(Status::Ok)
    })
}

pub unsafe fn new_discrete_states<S: Slave>(c: Component, info: *mut EventInfo) -> Status {
    update_discrete_states::<S>(c, |u| {
        let out = slice_mut(info, 1, "eventInfo")?;
        out[0] = EventInfo {
            new_discrete_states_needed: 0,
            terminate_simulation: 0,
            nominals_of_continuous_states_changed: u.nominals_changed as Boolean,
            values_of_continuous_states_changed: u.states_changed as Boolean,
            next_event_time_defined: u.next_event_time.is_some() as Boolean,
            next_event_time: u.next_event_time.unwrap_or(0.0),
        };
        Ok(())
    })
}

/// fmi2NewDiscreteStates and fmi3UpdateDiscreteStates: the model handles the events, `write`
/// hands the result to the master's arguments. (The events are settled in one call, so a
/// further update is never needed.)
pub unsafe fn update_discrete_states<S: Slave>(
    c: Component,
    write: impl FnOnce(EventUpdate) -> Result<(), Failure>,
) -> Status {
    with_me::<S>(c, "fmi2NewDiscreteStates", allowed::EVENT, |i| {
        let u = i.slave.me_new_discrete_states(&i.log)?;
        write(u)?;
        Ok(Status::Ok)
    })
}

pub unsafe fn enter_continuous_time_mode<S: Slave>(c: Component) -> Status {
    with_me::<S>(c, "fmi2EnterContinuousTimeMode", allowed::EVENT, |i| {
        i.state = FmiState::ContinuousTimeMode;
        Ok(Status::Ok)
    })
}

pub unsafe fn completed_integrator_step<S: Slave>(
    c: Component,
    _no_set_prior: Boolean,
    enter_event_mode: *mut Boolean,
    terminate: *mut Boolean,
) -> Status {
    completed_step::<S>(c, |enter| {
        slice_mut(enter_event_mode, 1, "enterEventMode")?[0] = enter as Boolean;
        slice_mut(terminate, 1, "terminateSimulation")?[0] = 0;
        Ok(())
    })
}

/// fmi2CompletedIntegratorStep and fmi3's: `write` hands the master whether to enter event
/// mode (the model never asks to terminate).
pub unsafe fn completed_step<S: Slave>(
    c: Component,
    write: impl FnOnce(bool) -> Result<(), Failure>,
) -> Status {
    with_me::<S>(c, "fmi2CompletedIntegratorStep", allowed::CONT, |i| {
        let enter = i.slave.me_completed_integrator_step()?;
        write(enter)?;
        Ok(Status::Ok)
    })
}

pub unsafe fn set_time<S: Slave>(c: Component, time: f64) -> Status {
    let states = allowed::EVENT | allowed::CONT;
    with_me::<S>(c, "fmi2SetTime", states, |i| {
        if !time.is_finite() {
            return Err(error(format!("time = {time}: must be finite")));
        }
        i.slave.me_set_time(time)?;
        Ok(Status::Ok)
    })
}

pub unsafe fn set_continuous_states<S: Slave>(c: Component, x: *const f64, nx: usize) -> Status {
    with_me::<S>(c, "fmi2SetContinuousStates", allowed::CONT, |i| {
        sized(nx, i.slave.n_states(), i.arg("nx"))?;
        let x = slice(x, nx, i.arg("x"))?;
        if let Some(k) = x.iter().position(|v| !v.is_finite()) {
            let name = i.arg("x");
            return Err(error(format!("{name}[{k}] = {}: must be finite", x[k])));
        }
        i.slave.me_set_states(x)?;
        Ok(Status::Ok)
    })
}

/// The getters of state-sized or indicator-sized arrays. A value that is not finite (states or
/// a time set beyond what the model can evaluate) is an error naming the element (`label`):
/// the master never receives NaN or infinity with fmi2OK.
unsafe fn get_array<S: Slave>(
    c: Component,
    func: &str,
    p: *mut f64,
    n: usize,
    (expected, what): (fn(&S) -> usize, &'static str),
    label: fn(&S, usize) -> String,
    get: impl FnOnce(&mut S, &mut [f64]) -> Result<(), Failure>,
) -> Status {
    with_me::<S>(c, func, allowed::ME_GET, |i| {
        sized(n, expected(&i.slave), i.arg(what))?;
        let out = slice_mut(p, n, "the array")?;
        get(&mut i.slave, out)?;
        if let Some(k) = out.iter().position(|v| !v.is_finite()) {
            return Err(error(format!(
                "{} = {} is not finite at t = {}: the states or the time set are outside what the model can evaluate",
                label(&i.slave, k),
                out[k],
                i.slave.time()
            )));
        }
        Ok(Status::Ok)
    })
}

pub unsafe fn get_derivatives<S: Slave>(c: Component, dx: *mut f64, nx: usize) -> Status {
    let size = (S::n_states as fn(&S) -> usize, "nx");
    let label = |s: &S, k| format!("der({})", s.state_name(k));
    get_array::<S>(
        c,
        "fmi2GetDerivatives",
        dx,
        nx,
        size,
        label,
        S::me_derivatives,
    )
}

pub unsafe fn get_event_indicators<S: Slave>(c: Component, z: *mut f64, ni: usize) -> Status {
    let size = (S::n_event_indicators as fn(&S) -> usize, "ni");
    let label = |_: &S, k| format!("event indicator {k}");
    get_array::<S>(
        c,
        "fmi2GetEventIndicators",
        z,
        ni,
        size,
        label,
        S::me_event_indicators,
    )
}

pub unsafe fn get_continuous_states<S: Slave>(c: Component, x: *mut f64, nx: usize) -> Status {
    let size = (S::n_states as fn(&S) -> usize, "nx");
    let label = |s: &S, k| s.state_name(k);
    get_array::<S>(
        c,
        "fmi2GetContinuousStates",
        x,
        nx,
        size,
        label,
        S::me_states,
    )
}

pub unsafe fn get_nominals_of_continuous_states<S: Slave>(
    c: Component,
    x: *mut f64,
    nx: usize,
) -> Status {
    let size = (S::n_states as fn(&S) -> usize, "nx");
    let label = |s: &S, k| format!("the nominal of {}", s.state_name(k));
    get_array::<S>(
        c,
        "fmi2GetNominalsOfContinuousStates",
        x,
        nx,
        size,
        label,
        S::me_nominals,
    )
}

/// fmi2GetDirectionalDerivative and fmi3GetDirectionalDerivative in Model Exchange, after
/// initialization (`directional.rs`): `seed` holds one value per known, `out` one per unknown.
#[allow(clippy::too_many_arguments)]
pub unsafe fn get_directional_derivative<S: Slave>(
    c: Component,
    func: &str,
    unknown: *const ValueReference,
    n_unknown: usize,
    known: *const ValueReference,
    n_known: usize,
    seed: (*const f64, usize),
    out: (*mut f64, usize),
) -> Status {
    if !S::DIRECTIONAL_DERIVATIVES {
        // SAFETY: the component is checked there, as in every function.
        return unsafe {
            crate::ffi::not_supported::<S>(
                c,
                func,
                crate::instance::allowed::ANY,
                "providesDirectionalDerivative is false",
            )
        };
    }
    with_me::<S>(c, func, allowed::EVENT | allowed::CONT, |i| {
        sized(seed.1, n_known, "the seed's length")?;
        sized(out.1, n_unknown, "the sensitivity's length")?;
        let unknowns = slice(unknown, n_unknown, "the unknowns")?;
        let knowns = slice(known, n_known, "the knowns")?;
        let seed = slice(seed.0, n_known, "the seed")?;
        let out = slice_mut(out.0, n_unknown, "the result")?;
        crate::directional::derivative(&mut i.slave, unknowns, knowns, seed, out)?;
        if let Some(k) = out.iter().position(|v| !v.is_finite()) {
            return Err(error(format!(
                "the derivative of value reference {} is {}: the point is outside what the model can evaluate",
                unknowns[k], out[k]
            )));
        }
        Ok(Status::Ok)
    })
}
