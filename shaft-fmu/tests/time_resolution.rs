//! TorsionalShaft (an algebraic FMU: the step only moves the time) at times that resolve a step
//! coarsely or not at all, through its exported C functions; the check is the shared layer's
//! (fmi2_slave::ffi::do_step), as in tests/fmi_time_resolution.rs for the gear.
#![allow(non_snake_case)]

use fmi2_slave::{CallbackFunctions, Component, LoggerFn, Status, LAST_SUCCESSFUL_TIME};
use std::ffi::{CStr, CString};
use std::os::raw::{c_char, c_int, c_void};
use std::sync::Mutex;
use torsional_shaft::fmi::*;
use torsional_shaft::variables::GUID;

/// Every (status, category, message) logged by the instance whose environment it is.
#[derive(Default)]
struct Sink(Mutex<Vec<(c_int, String, String)>>);

/// The logger without the variadic tail (the FMU passes no variadic arguments; on x86-64
/// System V such a call is ABI-compatible), as tests/fmi.rs does.
unsafe extern "C" fn record(
    env: *mut c_void,
    _instance: *const c_char,
    status: c_int,
    category: *const c_char,
    message: *const c_char,
) {
    let text = |p: *const c_char| CStr::from_ptr(p).to_string_lossy().into_owned();
    let sink = &*(env as *const Sink);
    sink.0
        .lock()
        .unwrap()
        .push((status, text(category), text(message).replace("%%", "%")));
}

type Plain = unsafe extern "C" fn(*mut c_void, *const c_char, c_int, *const c_char, *const c_char);

/// A shaft initialized at `start`, with its log, run through `f` and freed.
fn shaft_at(start: f64, f: impl FnOnce(Component, &Sink)) {
    let sink = Box::<Sink>::default();
    let callbacks = CallbackFunctions {
        logger: Some(unsafe { std::mem::transmute::<Plain, LoggerFn>(record as Plain) }),
        allocate_memory: None,
        free_memory: None,
        step_finished: None,
        component_environment: &*sink as *const Sink as *mut c_void,
    };
    let (name, guid) = (CString::new("shaft").unwrap(), CString::new(GUID).unwrap());
    unsafe {
        let c = fmi2Instantiate(
            name.as_ptr(),
            fmi2_slave::TYPE_CO_SIMULATION,
            guid.as_ptr(),
            std::ptr::null(),
            &callbacks,
            0,
            0,
        );
        assert!(!c.is_null());
        assert_eq!(fmi2SetupExperiment(c, 0, 0.0, start, 0, 0.0), Status::Ok);
        assert_eq!(fmi2EnterInitializationMode(c), Status::Ok);
        assert_eq!(fmi2ExitInitializationMode(c), Status::Ok);
        f(c, &sink);
        fmi2FreeInstance(c);
    }
}

fn time(c: Component) -> f64 {
    let mut t = f64::NAN;
    let s = unsafe { fmi2GetRealStatus(c, LAST_SUCCESSFUL_TIME, &mut t) };
    assert_eq!(s, Status::Ok);
    t
}

fn take(sink: &Sink) -> Vec<(c_int, String, String)> {
    std::mem::take(&mut *sink.0.lock().unwrap())
}

#[test]
fn a_step_lost_in_the_time_is_refused_naming_t_and_h() {
    for (start, t_text) in [
        (1e15, "t = currentCommunicationPoint = 1e15 s"),
        (1e300, "1e300 s"),
    ] {
        shaft_at(start, |c, sink| {
            assert_eq!(unsafe { fmi2DoStep(c, start, 1e-4, 1) }, Status::Error);
            let log = take(sink);
            assert_eq!(log.len(), 1, "{log:?}");
            let (status, category, m) = &log[0];
            assert_eq!((*status, category.as_str()), (3, "logStatusError"));
            assert!(m.starts_with("fmi2DoStep: t + h == t"), "{m}");
            assert!(
                m.contains(t_text) && m.contains("h = communicationStepSize = 1e-4 s"),
                "{m}"
            );
            assert_eq!(time(c), start);
        });
    }
}

#[test]
fn a_coarse_step_advances_by_the_represented_interval_and_says_so_once() {
    let (t0, h) = (1e12, 1e-4);
    let represented = (t0 + h) - t0;
    assert_eq!(
        represented,
        2f64.powi(-13),
        "the doubles near 1e12 are 2^-13 s apart"
    );
    shaft_at(t0, |c, sink| {
        let mut t = t0;
        for k in 0..100 {
            let s = unsafe { fmi2DoStep(c, t, h, 1) };
            let log = take(sink);
            if k == 0 {
                assert_eq!(s, Status::Warning);
                assert_eq!(log.len(), 1, "{log:?}");
                let (status, category, m) = &log[0];
                assert_eq!((*status, category.as_str()), (1, "logStatusWarning"));
                assert!(
                    m.contains("at t = 1e12 s, h = 1e-4 s")
                        && m.contains("(t + h) - t = 1.220703125e-4 s"),
                    "{m}"
                );
            } else {
                assert_eq!(
                    (s, log.len()),
                    (Status::Ok, 0),
                    "once per instance: {log:?}"
                );
            }
            t += h;
            assert_eq!(time(c), t);
        }
        assert_eq!(t, t0 + 100.0 * represented);
    });
}

#[test]
fn an_ordinary_step_is_unchanged() {
    shaft_at(0.0, |c, sink| {
        let mut t = 0.0;
        for _ in 0..1000 {
            assert_eq!(unsafe { fmi2DoStep(c, t, 1e-4, 1) }, Status::Ok);
            t += 1e-4;
            assert_eq!(time(c), t);
        }
        assert!(take(sink).is_empty());
    });
}
