//! Model Exchange through the exported C functions (issue 10, point 3): the states,
//! derivatives and event indicators agree with the variables; a master of our own (classic
//! Runge-Kutta with events located by bisection on the indicators) follows the Co-Simulation
//! run; FMU states work; calls with wrong sizes, values or states are errors that name them.
//! FMPy's CVode and Euler drive the packaged FMU in tests/python/test_model_exchange.py.

mod fmi_support;

use fmi_support::ffi::*;
use fmi_support::*;
use spur_gear_mesh::variables::{N_EVENT_INDICATORS, STATES};
use std::os::raw::c_void;

const NX: usize = STATES.len();
const NZ: usize = N_EVENT_INDICATORS;

/// fmi2EventInfo, as the header declares it.
#[repr(C)]
#[derive(Default, Debug)]
struct EventInfo {
    new_discrete_states_needed: Boolean,
    terminate_simulation: Boolean,
    nominals_changed: Boolean,
    values_changed: Boolean,
    next_event_time_defined: Boolean,
    next_event_time: f64,
}

fn new_discrete_states(f: &Fmu) -> EventInfo {
    let mut e = EventInfo::default();
    let st = unsafe { fmi2NewDiscreteStates(f.c, &mut e as *mut EventInfo as *mut c_void) };
    assert_eq!(st, Status::Ok, "{:?}", f.log.take());
    e
}

fn states(f: &Fmu) -> [f64; NX] {
    let mut x = [f64::NAN; NX];
    assert_eq!(
        unsafe { fmi2GetContinuousStates(f.c, x.as_mut_ptr(), NX) },
        Status::Ok
    );
    x
}

fn derivatives(f: &Fmu) -> [f64; NX] {
    let mut dx = [f64::NAN; NX];
    let st = unsafe { fmi2GetDerivatives(f.c, dx.as_mut_ptr(), NX) };
    assert_eq!(st, Status::Ok, "{:?}", f.log.take());
    dx
}

fn indicators(f: &Fmu) -> [f64; NZ] {
    let mut z = [f64::NAN; NZ];
    assert_eq!(
        unsafe { fmi2GetEventIndicators(f.c, z.as_mut_ptr(), NZ) },
        Status::Ok
    );
    z
}

fn set_point(f: &Fmu, t: f64, x: &[f64; NX]) {
    unsafe {
        assert_eq!(fmi2SetTime(f.c, t), Status::Ok);
        assert_eq!(
            fmi2SetContinuousStates(f.c, x.as_ptr(), NX),
            Status::Ok,
            "{:?}",
            f.log.take()
        );
    }
}

/// The paper scene as a Model Exchange instance in continuous-time mode at t = 0.
fn paper_me(name: &str) -> Fmu {
    let f = Fmu::new_me(name);
    f.initialize(PAPER_SCENE, &[]);
    let e = new_discrete_states(&f);
    assert_eq!(e.values_changed, 0);
    assert_eq!(unsafe { fmi2EnterContinuousTimeMode(f.c) }, Status::Ok);
    f
}

#[test]
fn states_derivatives_and_variables_agree() {
    let f = paper_me("vars");
    // Away from the start point, so that every component moves.
    let mut x = states(&f);
    let dx = derivatives(&f);
    for k in 0..NX {
        x[k] += 1e-6 * dx[k];
    }
    set_point(&f, 1e-6, &x);
    let (x, dx) = (states(&f), derivatives(&f));
    for (k, &(state, der)) in STATES.iter().enumerate() {
        let name = state.info().name;
        assert_eq!(x[k], f.get_real(name), "state {k}: {name}");
        assert_eq!(
            dx[k],
            f.get_real(der.info().name),
            "derivative {k} of {name}"
        );
    }
    assert_eq!(dx[0], f.get_real("w_A"), "der(theta_A) = w_A");
    // der(dte) = rAb w_A - rBb w_B, with w_B from dte_rate: equal up to the rounding of
    // rAb w_A (~7 m/s).
    let rounding = 4.0 * f64::EPSILON * f.get_real("rAb") * f.get_real("w_A").abs();
    assert!(
        (dx[1] - f.get_real("dte_rate")).abs() <= rounding,
        "der(dte) = dte_rate"
    );
    assert!(dx[2] != 0.0 && dx[4] != 0.0, "{dx:?}");
    let z = indicators(&f);
    assert!(z.iter().all(|v| v.is_finite()), "{z:?}");
    let mut n = [0.0; NX];
    assert_eq!(
        unsafe { fmi2GetNominalsOfContinuousStates(f.c, n.as_mut_ptr(), NX) },
        Status::Ok
    );
    assert!(n.iter().all(|v| *v > 0.0 && v.is_finite()), "{n:?}");
}

/// One classic Runge-Kutta step of the master.
fn rk4(f: &Fmu, t: f64, x: &[f64; NX], h: f64) -> [f64; NX] {
    let eval = |dt: f64, k: &[f64; NX], c: f64| -> [f64; NX] {
        let y: [f64; NX] = std::array::from_fn(|i| x[i] + c * k[i]);
        set_point(f, t + dt, &y);
        derivatives(f)
    };
    let k1 = eval(0.0, &[0.0; NX], 0.0);
    let k2 = eval(h / 2.0, &k1, h / 2.0);
    let k3 = eval(h / 2.0, &k2, h / 2.0);
    let k4 = eval(h, &k3, h);
    std::array::from_fn(|i| x[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]))
}

fn crossed(z0: &[f64; NZ], z1: &[f64; NZ]) -> bool {
    z0.iter().zip(z1).any(|(a, b)| (*a > 0.0) != (*b > 0.0))
}

/// A master of our own: fixed RK4 steps; when an indicator changes sign inside a step, the
/// step is bisected down to 1e-15 s and the model handles the event at the point just past
/// the crossing. It follows the Co-Simulation run (Dormand-Prince at rel_tol 1e-10) on the
/// damped paper scene: the same events, and dte within 1e-6 of its range. RK4's error at this
/// step (h omega ~ 6e-3 for the ~5 kHz mesh vibration) is about (h omega)^5 / 120 ~ 1e-13 of
/// the amplitude per step, 1e-9 over the 25000 steps; the bisection places each event within
/// 1e-15 s. So 1e-6 of the range leaves a factor of 1000 for what these estimates miss.
#[test]
fn a_runge_kutta_master_follows_co_simulation() {
    let (h, stop, sample): (f64, f64, f64) = (2e-7, 5e-3, 5e-4);
    let cs = Fmu::new("cs");
    cs.set_real("rel_tol", 1e-10);
    cs.initialize(PAPER_SCENE, &[]);
    let me = paper_me("me");
    let (mut t, mut x) = (0.0, states(&me));
    let mut z = indicators(&me);
    let (mut worst, mut lo, mut hi) = (0.0f64, f64::INFINITY, f64::NEG_INFINITY);
    let mut next_sample = sample;
    while t < stop - 1e-15 {
        let hs = h.min(next_sample - t);
        let mut x1 = rk4(&me, t, &x, hs);
        // A step that reaches the sample lands on it exactly.
        let mut t1 = if hs < h { next_sample } else { t + hs };
        set_point(&me, t1, &x1);
        if crossed(&z, &indicators(&me)) {
            let (mut a, mut b) = (0.0, hs);
            while b - a > 1e-15 {
                let m = 0.5 * (a + b);
                let xm = rk4(&me, t, &x, m);
                set_point(&me, t + m, &xm);
                if crossed(&z, &indicators(&me)) {
                    b = m;
                } else {
                    a = m;
                }
            }
            x1 = rk4(&me, t, &x, b);
            t1 = t + b;
            set_point(&me, t1, &x1);
            unsafe { assert_eq!(fmi2EnterEventMode(me.c), Status::Ok) };
            let e = new_discrete_states(&me);
            unsafe { assert_eq!(fmi2EnterContinuousTimeMode(me.c), Status::Ok) };
            if e.values_changed != 0 {
                x1 = states(&me);
            }
        }
        let (mut enter, mut stop_sim) = (0, 0);
        let st = unsafe { fmi2CompletedIntegratorStep(me.c, 1, &mut enter, &mut stop_sim) };
        assert_eq!((st, enter, stop_sim), (Status::Ok, 0, 0));
        (t, x, z) = (t1, x1, indicators(&me));
        let dte = me.get_real("dte");
        (lo, hi) = (lo.min(dte), hi.max(dte));
        if t == next_sample {
            assert_eq!(cs.do_step(next_sample - sample, sample), Status::Ok);
            worst = worst.max((dte - cs.get_real("dte")).abs());
            next_sample += sample;
        }
    }
    assert_eq!(
        me.get_integer("n_events"),
        cs.get_integer("n_events"),
        "the same events"
    );
    assert!(me.get_integer("n_events") >= 5, "pair switches in 5 ms");
    let range = hi - lo;
    eprintln!(
        "RK4 master: dte off by {worst:e} m ({:e} of its range), {} events",
        worst / range,
        me.get_integer("n_events")
    );
    assert!(range > 1e-6, "dte range {range}");
    assert!(
        worst <= 1e-6 * range,
        "dte off by {worst} m, {} of its range",
        worst / range
    );
}

/// An FMU state saved in continuous-time mode continues identically, also through its
/// serialized form; a Co-Simulation state cannot be set in a Model Exchange instance.
#[test]
fn fmu_states_in_model_exchange() {
    let f = paper_me("state");
    let mut x = states(&f);
    let dx = derivatives(&f);
    for k in 0..NX {
        x[k] += 2e-5 * dx[k];
    }
    set_point(&f, 2e-5, &x);
    let saved = f.get_state();
    let blob = f.serialize(saved);
    let (d0, z0) = (derivatives(&f), indicators(&f));
    let mut other = x;
    (other[1], other[2]) = (1.5 * x[1], x[2] + 1.0);
    set_point(&f, 3e-5, &other);
    assert_ne!(derivatives(&f), d0);
    assert_eq!(f.set_state(saved), Status::Ok);
    assert_eq!((derivatives(&f), indicators(&f)), (d0, z0));
    let (st, restored) = f.deserialize(&blob);
    assert_eq!(st, Status::Ok);
    set_point(&f, 3e-5, &other);
    assert_eq!(f.set_state(restored), Status::Ok);
    assert_eq!((derivatives(&f), indicators(&f), states(&f)), (d0, z0, x));

    let cs = paper_scene("cs-state");
    let cs_blob = cs.serialize(cs.get_state());
    let (st, foreign) = f.deserialize(&cs_blob);
    assert_eq!(st, Status::Ok, "the blob itself is sound");
    assert_eq!(f.set_state(foreign), Status::Error);
    let text: Vec<String> = f.log.take().iter().map(|r| r.text()).collect();
    assert!(
        text.iter().any(|m| m.starts_with("fmi2SetFMUstate")
            && m.contains("StepComplete")
            && m.contains("Model Exchange")),
        "{text:?}"
    );
}

/// Each bad call answers fmi2Error with a message that names the function and the offending
/// argument or state; a fresh instance per case, since an error ends an instance's run.
#[test]
fn bad_calls_are_errors_that_name_function_and_value() {
    type Case = (&'static str, &'static str, fn(&Fmu) -> Status);
    let cases: [Case; 9] = [
        ("fmi2SetContinuousStates", "nx = 7", |f| unsafe {
            fmi2SetContinuousStates(f.c, [0.0; NX].as_ptr(), NX - 1)
        }),
        ("fmi2SetContinuousStates", "x[3] = NaN", |f| unsafe {
            let mut x = states(f);
            x[3] = f64::NAN;
            fmi2SetContinuousStates(f.c, x.as_ptr(), NX)
        }),
        ("fmi2SetTime", "time = inf", |f| unsafe {
            fmi2SetTime(f.c, f64::INFINITY)
        }),
        ("fmi2GetEventIndicators", "ni = 31", |f| unsafe {
            let mut z = [0.0; NZ];
            fmi2GetEventIndicators(f.c, z.as_mut_ptr(), NZ - 1)
        }),
        ("fmi2GetDerivatives", "nx = 9", |f| unsafe {
            let mut dx = [0.0; NX + 1];
            fmi2GetDerivatives(f.c, dx.as_mut_ptr(), NX + 1)
        }),
        (
            "fmi2NewDiscreteStates",
            "not allowed in state ContinuousTimeMode",
            |f| unsafe { fmi2NewDiscreteStates(f.c, std::ptr::null_mut()) },
        ),
        (
            "fmi2DoStep",
            "not allowed in state ContinuousTimeMode",
            |f| unsafe { fmi2DoStep(f.c, 0.0, 1e-3, 1) },
        ),
        (
            "fmi2SetRealInputDerivatives",
            "Model Exchange",
            |f| unsafe { fmi2SetRealInputDerivatives(f.c, &vr("tau_A"), 1, &1, &5.0) },
        ),
        ("fmi2SetReal", "der(w_A)", |f| f.set_real("der(w_A)", 1.0)),
    ];
    for (func, keyword, call) in cases {
        let f = paper_me("bad");
        let _ = f.log.take();
        assert_eq!(call(&f), Status::Error, "{func} ({keyword})");
        let text: Vec<String> = f.log.take().iter().map(|r| r.text()).collect();
        assert!(
            text.iter()
                .any(|m| m.starts_with(func) && m.contains(keyword)),
            "{func}: no message with '{keyword}': {text:?}"
        );
    }
    // Model Exchange functions on a Co-Simulation instance.
    let cs = paper_scene("cs");
    let mut dx = [0.0; NX];
    let st = unsafe { fmi2GetDerivatives(cs.c, dx.as_mut_ptr(), NX) };
    assert_eq!(st, Status::Error);
    let text: Vec<String> = cs.log.take().iter().map(|r| r.text()).collect();
    assert!(
        text.iter()
            .any(|m| m.starts_with("fmi2GetDerivatives") && m.contains("Co-Simulation")),
        "{text:?}"
    );
}

/// A contact law pushed out of its range by the master's states is an error at
/// fmi2GetDerivatives naming the contact and the penetration, and never a NaN.
#[test]
fn a_state_beyond_the_law_is_an_error_not_a_nan() {
    let f = paper_me("range");
    let mut x = states(&f);
    x[1] = 0.5; // dte: half a metre of penetration, beyond Johnson's limit (0.27 m here)
    set_point(&f, 1e-6, &x);
    let mut dx = [0.0; NX];
    let st = unsafe { fmi2GetDerivatives(f.c, dx.as_mut_ptr(), NX) };
    assert_eq!(st, Status::Error);
    let text: Vec<String> = f.log.take().iter().map(|r| r.text()).collect();
    assert!(
        text.iter()
            .any(|m| m.starts_with("fmi2GetDerivatives") && m.contains("penetration")),
        "{text:?}"
    );
}
