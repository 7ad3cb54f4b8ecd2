//! TorsionalShaft through its exported C functions, called in-process as a master calls them:
//! the values against the formula, every bad input, calls in the wrong FMI state, and the FMU
//! state round trip (get/set and serialize/deserialize).
#![allow(non_snake_case)]

use fmi2_slave::{CallbackFunctions, Component, FmuState, LoggerFn, Status};
use std::ffi::{CStr, CString};
use std::os::raw::{c_char, c_int, c_void};
use std::sync::Mutex;
use torsional_shaft::fmi::*;
use torsional_shaft::variables::{Var, GUID};

const THETA_A: u32 = 1;
const W_A: u32 = 2;
const THETA_B: u32 = 3;
const W_B: u32 = 4;
const K: u32 = 5;
const D: u32 = 6;
const TWIST: u32 = 7;
const TAU_A: u32 = 8;
const TAU_B: u32 = 9;

#[derive(Default)]
struct Sink(Mutex<Vec<(c_int, String, String)>>);

impl Sink {
    fn take(&self) -> Vec<(c_int, String, String)> {
        std::mem::take(&mut *self.0.lock().unwrap())
    }
}

/// The logger without the variadic tail (the FMU never passes variadic arguments; on x86-64
/// System V such a call is ABI-compatible), as tests/fmi_support/mod.rs does for the gear.
unsafe extern "C" fn record(
    env: *mut c_void,
    _instance: *const c_char,
    status: c_int,
    category: *const c_char,
    message: *const c_char,
) {
    let sink = &*(env as *const Sink);
    let text = |p: *const c_char| CStr::from_ptr(p).to_string_lossy().into_owned();
    sink.0
        .lock()
        .unwrap()
        .push((status, text(category), text(message).replace("%%", "%")));
}

/// An instance with its log; freed on drop.
struct Shaft {
    c: Component,
    log: Box<Sink>,
    _callbacks: Box<CallbackFunctions>,
}

impl Shaft {
    fn new() -> Shaft {
        Shaft::with_guid(GUID, fmi2_slave::TYPE_CO_SIMULATION).expect("instantiated")
    }

    fn with_guid(guid: &str, ty: fmi2_slave::Type) -> Option<Shaft> {
        let log = Box::new(Sink::default());
        let logger: LoggerFn = unsafe {
            std::mem::transmute::<
                unsafe extern "C" fn(
                    *mut c_void,
                    *const c_char,
                    c_int,
                    *const c_char,
                    *const c_char,
                ),
                LoggerFn,
            >(record)
        };
        let callbacks = Box::new(CallbackFunctions {
            logger: Some(logger),
            allocate_memory: None,
            free_memory: None,
            step_finished: None,
            component_environment: &*log as *const Sink as *mut c_void,
        });
        let (name, guid) = (CString::new("shaft").unwrap(), CString::new(guid).unwrap());
        let c = unsafe {
            fmi2Instantiate(
                name.as_ptr(),
                ty,
                guid.as_ptr(),
                std::ptr::null(),
                &*callbacks,
                0,
                0,
            )
        };
        (!c.is_null()).then_some(Shaft {
            c,
            log,
            _callbacks: callbacks,
        })
    }

    fn init(&self) {
        unsafe {
            assert_eq!(fmi2SetupExperiment(self.c, 0, 0.0, 0.0, 0, 0.0), Status::Ok);
            assert_eq!(fmi2EnterInitializationMode(self.c), Status::Ok);
            assert_eq!(fmi2ExitInitializationMode(self.c), Status::Ok);
        }
    }

    fn set(&self, vrs: &[u32], xs: &[f64]) -> Status {
        unsafe { fmi2SetReal(self.c, vrs.as_ptr(), vrs.len(), xs.as_ptr()) }
    }

    fn get(&self, vrs: &[u32]) -> Result<Vec<f64>, Status> {
        let mut out = vec![f64::NAN; vrs.len()];
        match unsafe { fmi2GetReal(self.c, vrs.as_ptr(), vrs.len(), out.as_mut_ptr()) } {
            Status::Ok => Ok(out),
            s => Err(s),
        }
    }

    fn step(&self, t: f64, h: f64) -> Status {
        unsafe { fmi2DoStep(self.c, t, h, 1) }
    }

    /// The last error message.
    fn last_error(&self) -> String {
        let log = self.log.take();
        let (status, category, message) = log.last().expect("a message").clone();
        assert_eq!(
            (status, category.as_str()),
            (Status::Error as c_int, "logStatusError")
        );
        message
    }
}

impl Drop for Shaft {
    fn drop(&mut self) {
        unsafe { fmi2FreeInstance(self.c) }
    }
}

fn formula(k: f64, d: f64, twist: f64, ta: f64, wa: f64, tb: f64, wb: f64) -> f64 {
    k * (ta - tb + twist) + d * (wa - wb)
}

#[test]
fn outputs_are_the_formula_of_the_latest_inputs_at_every_point() {
    let s = Shaft::new();
    assert_eq!(s.set(&[K, D, TWIST], &[2.5e4, 3.0, -0.002]), Status::Ok);
    unsafe {
        assert_eq!(fmi2SetupExperiment(s.c, 0, 0.0, 0.0, 0, 0.0), Status::Ok);
        assert_eq!(fmi2EnterInitializationMode(s.c), Status::Ok);
    }
    // In initialization mode already.
    assert_eq!(s.set(&[THETA_A, W_A], &[0.01, 4.0]), Status::Ok);
    let t = formula(2.5e4, 3.0, -0.002, 0.01, 4.0, 0.0, 0.0);
    assert_eq!(s.get(&[TAU_A, TAU_B]).unwrap(), vec![-t, t]);
    unsafe { assert_eq!(fmi2ExitInitializationMode(s.c), Status::Ok) };
    let mut time = 0.0;
    for n in 0..200 {
        let x = n as f64;
        let (ta, wa, tb, wb) = (0.3 * x.sin(), -7.0 + x, -0.1 * x, 1e3 * x.cos());
        // Changing k, d, twist_start mid-run: tunable, they act at once.
        let (k, d, tw) = (1e5 * (1.0 + 0.01 * x), 0.5 * x, -1e-3 * x.cos());
        assert_eq!(
            s.set(&[THETA_A, W_A, THETA_B, W_B], &[ta, wa, tb, wb]),
            Status::Ok
        );
        assert_eq!(s.set(&[K, D, TWIST], &[k, d, tw]), Status::Ok);
        let t = formula(k, d, tw, ta, wa, tb, wb);
        let got = s.get(&[TAU_A, TAU_B, THETA_A, W_B, K]).unwrap();
        assert_eq!(got, vec![-t, t, ta, wb, k], "n = {n}");
        // The step changes nothing but the time.
        let h = 1e-3 * (1.0 + (n % 3) as f64);
        assert_eq!(s.step(time, h), Status::Ok);
        time += h;
        assert_eq!(s.get(&[TAU_A, TAU_B]).unwrap(), vec![-t, t]);
        let mut last = f64::NAN;
        unsafe {
            assert_eq!(
                fmi2GetRealStatus(s.c, fmi2_slave::LAST_SUCCESSFUL_TIME, &mut last),
                Status::Ok
            )
        };
        assert_eq!(last, time);
    }
    assert!(s.log.take().is_empty());
}

#[test]
fn defaults_give_a_relaxed_shaft_and_the_documented_start_values() {
    let s = Shaft::new();
    s.init();
    assert_eq!(
        s.get(&[THETA_A, W_A, THETA_B, W_B, K, D, TWIST, TAU_A, TAU_B])
            .unwrap(),
        vec![0.0, 0.0, 0.0, 0.0, 1e5, 5.0, 0.0, 0.0, 0.0]
    );
    // k = 0 and d = 0 are allowed (a pure damper, a pure spring, or nothing), and so is a
    // negative twist_start.
    assert_eq!(s.set(&[K, D, TWIST], &[0.0, 0.0, -1.0]), Status::Ok);
    assert_eq!(s.get(&[TAU_B]).unwrap(), vec![0.0]);
}

#[test]
fn every_bad_value_is_refused_naming_the_variable_and_changes_nothing() {
    let bad: &[(u32, &str, f64, &str)] = &[
        (THETA_A, "theta_a", f64::NAN, "must be finite"),
        (W_A, "w_a", f64::INFINITY, "must be finite"),
        (THETA_B, "theta_b", f64::NEG_INFINITY, "must be finite"),
        (W_B, "w_b", f64::NAN, "must be finite"),
        (K, "k", f64::NAN, "must be finite"),
        (K, "k", f64::INFINITY, "must be finite"),
        (K, "k", -1.0, ">= 0"),
        (K, "k", -f64::MIN_POSITIVE, ">= 0"),
        (D, "d", f64::NEG_INFINITY, "must be finite"),
        (D, "d", -1e-9, ">= 0"),
        (TWIST, "twist_start", f64::NAN, "must be finite"),
    ];
    // In initialization mode and after it (fmi2GetReal is not allowed before).
    for running in [false, true] {
        for &(vr, name, x, why) in bad {
            let s = Shaft::new();
            unsafe {
                assert_eq!(fmi2SetupExperiment(s.c, 0, 0.0, 0.0, 0, 0.0), Status::Ok);
                assert_eq!(fmi2EnterInitializationMode(s.c), Status::Ok);
                if running {
                    assert_eq!(fmi2ExitInitializationMode(s.c), Status::Ok);
                }
            }
            assert_eq!(s.set(&[THETA_A], &[0.5]), Status::Ok);
            let all = [THETA_A, W_A, THETA_B, W_B, K, D, TWIST, TAU_A, TAU_B];
            let before = s.get(&all).unwrap();
            // Set with a good value in front: all or none.
            assert_eq!(s.set(&[W_A, vr], &[9.0, x]), Status::Error, "{name} = {x}");
            let m = s.last_error();
            assert!(m.contains(&format!("{name} = ")) && m.contains(why), "{m}");
            // The instance is in the error state, where the values can still be read: none of
            // the two was applied.
            assert_eq!(s.get(&all).unwrap(), before, "{name} = {x}");
            assert_eq!(s.step(0.0, 1e-3), Status::Error);
            s.log.take();
            unsafe { assert_eq!(fmi2Reset(s.c), Status::Ok) };
        }
    }
}

#[test]
fn a_refused_set_keeps_the_old_values() {
    // Without the error state in between: read the values from an FMU state saved before.
    let s = Shaft::new();
    s.init();
    assert_eq!(s.set(&[THETA_A, D], &[0.25, 7.0]), Status::Ok);
    let mut state: FmuState = std::ptr::null_mut();
    unsafe { assert_eq!(fmi2GetFMUstate(s.c, &mut state), Status::Ok) };
    assert_eq!(s.set(&[W_A, D], &[1.0, -7.0]), Status::Error);
    unsafe {
        assert_eq!(fmi2Reset(s.c), Status::Ok);
        assert_eq!(fmi2SetFMUstate(s.c, state), Status::Ok);
    }
    assert_eq!(s.get(&[THETA_A, W_A, D]).unwrap(), vec![0.25, 0.0, 7.0]);
    unsafe { assert_eq!(fmi2FreeFMUstate(s.c, &mut state), Status::Ok) };
}

#[test]
fn a_torque_that_overflows_is_refused() {
    let s = Shaft::new();
    s.init();
    // Each value finite, the torque not: k (theta_a - theta_b) overflows.
    assert_eq!(
        s.set(&[K, THETA_A, THETA_B], &[1e300, 1e10, -1e10]),
        Status::Error
    );
    let m = s.last_error();
    assert!(m.contains("torque") && m.contains("not finite"), "{m}");
    // The difference itself overflows.
    let s = Shaft::new();
    s.init();
    assert_eq!(
        s.set(&[THETA_A, THETA_B], &[f64::MAX, -f64::MAX]),
        Status::Error
    );
    assert!(s.last_error().contains("torque"));
    // A large torque that is finite is fine.
    let s = Shaft::new();
    s.init();
    assert_eq!(s.set(&[K, THETA_A], &[1e300, 1.0]), Status::Ok);
    assert_eq!(s.get(&[TAU_B]).unwrap(), vec![1e300]);
}

#[test]
fn outputs_and_unknown_references_cannot_be_set() {
    for (vr, what) in [
        (TAU_A, "tau_a is an output"),
        (TAU_B, "tau_b is an output"),
        (0, "unknown value reference 0"),
        (10, "unknown value reference 10"),
    ] {
        let s = Shaft::new();
        assert_eq!(s.set(&[vr], &[1.0]), Status::Error);
        assert!(s.last_error().contains(what));
    }
    let s = Shaft::new();
    s.init();
    let mut x = 0;
    let vr = [K];
    unsafe { assert_eq!(fmi2GetInteger(s.c, vr.as_ptr(), 1, &mut x), Status::Error) };
    assert!(s.last_error().contains("no Integer"));
}

#[test]
fn calls_in_the_wrong_state_are_errors() {
    // Wrong GUID, and Model Exchange: no instance.
    assert!(Shaft::with_guid(
        "{00000000-0000-0000-0000-000000000000}",
        fmi2_slave::TYPE_CO_SIMULATION
    )
    .is_none());
    assert!(Shaft::with_guid(GUID, fmi2_slave::TYPE_MODEL_EXCHANGE).is_none());

    // Before initialization: no step, no outputs.
    let s = Shaft::new();
    assert_eq!(s.step(0.0, 1e-3), Status::Error);
    s.log.take();
    let s = Shaft::new();
    assert_eq!(s.get(&[TAU_A]), Err(Status::Error));
    s.log.take();

    // After initialization: no second setup or initialization, a step from the wrong time or
    // of a non-positive or non-finite size, no Model Exchange function.
    for bad in 0..6 {
        let s = Shaft::new();
        s.init();
        let st = unsafe {
            match bad {
                0 => fmi2SetupExperiment(s.c, 0, 0.0, 0.0, 0, 0.0),
                1 => fmi2EnterInitializationMode(s.c),
                2 => fmi2DoStep(s.c, 0.5, 1e-3, 1),
                3 => fmi2DoStep(s.c, 0.0, 0.0, 1),
                4 => fmi2DoStep(s.c, 0.0, f64::NAN, 1),
                _ => fmi2SetTime(s.c, 0.0),
            }
        };
        assert_eq!(st, Status::Error, "case {bad}");
        s.last_error();
    }

    // Bad experiment times.
    for (start, stop) in [(f64::NAN, 1.0), (1.0, 0.5), (0.0, f64::INFINITY)] {
        let s = Shaft::new();
        let st = unsafe { fmi2SetupExperiment(s.c, 0, 0.0, start, 1, stop) };
        assert_eq!(st, Status::Error, "{start} {stop}");
        s.last_error();
    }

    // After termination: no step, no set; the values can be read.
    let s = Shaft::new();
    s.init();
    assert_eq!(s.set(&[THETA_A], &[0.001]), Status::Ok);
    unsafe { assert_eq!(fmi2Terminate(s.c), Status::Ok) };
    assert_eq!(s.get(&[TAU_B]).unwrap(), vec![100.0]);
    assert_eq!(s.step(0.0, 1e-3), Status::Error);
    s.last_error();
}

#[test]
fn fmu_state_round_trips_through_get_set_and_serialization() {
    let s = Shaft::new();
    s.init();
    assert_eq!(
        s.set(
            &[THETA_A, W_A, THETA_B, W_B, K, D, TWIST],
            &[0.1, 2.0, -0.3, 4.0, 3e4, 0.7, 1e-3]
        ),
        Status::Ok
    );
    assert_eq!(s.step(0.0, 0.25), Status::Ok);
    let all = [THETA_A, W_A, THETA_B, W_B, K, D, TWIST, TAU_A, TAU_B];
    let saved_values = s.get(&all).unwrap();
    let mut state: FmuState = std::ptr::null_mut();
    let mut size = 0usize;
    unsafe {
        assert_eq!(fmi2GetFMUstate(s.c, &mut state), Status::Ok);
        assert_eq!(
            fmi2SerializedFMUstateSize(s.c, state, &mut size),
            Status::Ok
        );
    }
    let mut buf = vec![0 as c_char; size];
    unsafe {
        assert_eq!(
            fmi2SerializeFMUstate(s.c, state, buf.as_mut_ptr(), size),
            Status::Ok
        )
    };

    // Change everything, then restore in place.
    assert_eq!(s.set(&[THETA_A, K], &[9.0, 1.0]), Status::Ok);
    assert_eq!(s.step(0.25, 0.5), Status::Ok);
    unsafe { assert_eq!(fmi2SetFMUstate(s.c, state), Status::Ok) };
    assert_eq!(s.get(&all).unwrap(), saved_values);
    // The time came back too: the next step starts at 0.25.
    assert_eq!(s.step(0.25, 0.1), Status::Ok);

    // Deserialize into a fresh instance.
    let s2 = Shaft::new();
    let mut state2: FmuState = std::ptr::null_mut();
    unsafe {
        assert_eq!(
            fmi2DeSerializeFMUstate(s2.c, buf.as_ptr(), size, &mut state2),
            Status::Ok
        );
        assert_eq!(fmi2SetFMUstate(s2.c, state2), Status::Ok);
    }
    assert_eq!(s2.get(&all).unwrap(), saved_values);
    assert_eq!(s2.step(0.25, 0.1), Status::Ok);

    // A damaged buffer is refused.
    let mut bad = buf.clone();
    bad[size - 3] ^= 0x10;
    let mut state3: FmuState = std::ptr::null_mut();
    unsafe {
        assert_eq!(
            fmi2DeSerializeFMUstate(s2.c, bad.as_ptr(), size, &mut state3),
            Status::Error
        )
    };
    unsafe {
        assert_eq!(fmi2FreeFMUstate(s.c, &mut state), Status::Ok);
        assert_eq!(fmi2FreeFMUstate(s2.c, &mut state2), Status::Ok);
    }
}

#[test]
fn the_table_names_match_the_value_references_used_here() {
    for (vr, name) in [
        (THETA_A, "theta_a"),
        (W_A, "w_a"),
        (THETA_B, "theta_b"),
        (W_B, "w_b"),
        (K, "k"),
        (D, "d"),
        (TWIST, "twist_start"),
        (TAU_A, "tau_a"),
        (TAU_B, "tau_b"),
    ] {
        assert_eq!(Var::from_vr(vr).unwrap().info().name, name);
    }
}
