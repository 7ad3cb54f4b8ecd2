//! A step the time cannot resolve, or resolves only coarsely, through the exported C functions
//! (the check is the layer's, fmi2_slave::ffi::do_step, shared by every FMU of the repository):
//! at t = 1e15 or 1e300, t + 1e-4 == t and the step is refused like h = 0, naming t and h; on
//! epoch time (t = 1.7e9 s) the step advances by (t + h) - t and says so once; at an ordinary
//! time nothing changes. The gear's integrator runs in time since the experiment's start, so
//! at t = 1e12 (ulp 1.2e-4 s, above its internal steps) it advances as from 0.

mod fmi_support;

use fmi_support::ffi::*;
use fmi_support::*;
use std::os::raw::c_int;

/// The paper scene, initialized at `start`.
fn scene_at(name: &str, start: f64) -> Fmu {
    let f = Fmu::new(name);
    for &(n, x) in PAPER_SCENE {
        assert_eq!(f.set_real(n, x), Status::Ok);
    }
    let s = unsafe { fmi2SetupExperiment(f.c, 0, 0.0, start, 0, 0.0) };
    assert_eq!(s, Status::Ok, "{:?}", f.log.take());
    assert_eq!(f.enter_init(), Status::Ok);
    assert_eq!(f.exit_init(), Status::Ok, "{:?}", f.log.take());
    f.log.take();
    f
}

fn warnings(f: &Fmu) -> Vec<String> {
    f.log
        .take()
        .into_iter()
        .filter(|r| r.status == Status::Warning.0 as c_int)
        .map(|r| r.text())
        .collect()
}

#[test]
fn a_step_lost_in_the_time_is_refused_naming_t_and_h() {
    for (start, t_text) in [
        (1e15, "t = currentCommunicationPoint = 1e15 s"),
        (1e300, "1e300 s"),
    ] {
        let f = scene_at("lost", start);
        assert_eq!(f.do_step(start, 1e-4), Status::Error);
        let log = f.log.take();
        assert_eq!(log.len(), 1, "{log:?}");
        let m = log[0].text();
        assert_eq!(log[0].category, "logStatusError");
        assert!(m.starts_with("fmi2DoStep: t + h == t"), "{m}");
        assert!(
            m.contains(t_text) && m.contains("h = communicationStepSize = 1e-4 s"),
            "{m}"
        );
        // The error state, as after h = 0: the time has not moved.
        assert_eq!(f.do_step(start, 1e-4), Status::Error);
        assert_eq!(f.time(), start);
    }
}

#[test]
fn a_coarse_step_advances_by_the_represented_interval_and_says_so_once() {
    let t0 = 1.7e9;
    let h = 1e-4;
    let represented = (t0 + h) - t0;
    assert_eq!(
        represented,
        419.0 * 2f64.powi(-22),
        "the doubles near 1.7e9 are 2^-22 s apart"
    );
    let f = scene_at("coarse", t0);
    let mut t = t0;
    for k in 0..3 {
        let s = f.do_step(t, h);
        let w = warnings(&f);
        if k == 0 {
            assert_eq!(s, Status::Warning);
            assert_eq!(w.len(), 1, "{w:?}");
            assert!(
                w[0].starts_with("fmi2DoStep: the time resolves this step only coarsely: at t = 1.7e9 s, h = 1e-4 s")
                    && w[0].contains("(t + h) - t = 9.989738464355469e-5 s"),
                "{}",
                w[0]
            );
        } else {
            assert_eq!(s, Status::Ok, "once per instance");
            assert!(w.is_empty(), "{w:?}");
        }
        t += h;
        assert_eq!(f.time(), t);
        assert_eq!(f.time(), t0 + (k + 1) as f64 * represented);
    }
    // Reset makes a new instance: it is told again.
    assert_eq!(f.reset(), Status::Ok);
    assert_eq!(
        unsafe { fmi2SetupExperiment(f.c, 0, 0.0, t0, 0, 0.0) },
        Status::Ok
    );
    assert_eq!(f.enter_init(), Status::Ok);
    assert_eq!(f.exit_init(), Status::Ok);
    f.log.take();
    assert_eq!(f.do_step(t0, h), Status::Warning);
}

/// On a late clock the trajectory is the one from t = 0 stepped by the represented interval,
/// bit for bit: the driver integrates in time since the start, and (t0 + k h_r) - t0 = k h_r
/// exactly here (t0 an integer, h_r a multiple of ulp(t0)).
#[test]
fn a_late_clock_integrates_as_from_zero() {
    for t0 in [1.7e9, 1e12] {
        let h = 1e-4;
        let represented = (t0 + h) - t0;
        let late = scene_at("late", t0);
        let early = scene_at("early", 0.0);
        let (mut t, mut u) = (t0, 0.0);
        for k in 0..50 {
            let s = late.do_step(t, h);
            assert_eq!(
                s,
                if k == 0 { Status::Warning } else { Status::Ok },
                "{:?}",
                late.log.take()
            );
            assert_eq!(early.do_step(u, represented), Status::Ok);
            t += h;
            u += represented;
        }
        assert_eq!(late.time(), t0 + 50.0 * represented);
        for name in ["theta_A", "w_A", "dte", "F_fwd"] {
            assert_eq!(
                late.get_real(name).to_bits(),
                early.get_real(name).to_bits(),
                "{name} at t0 = {t0}"
            );
        }
    }
}

#[test]
fn an_ordinary_step_is_unchanged() {
    let f = scene_at("ordinary", 0.0);
    let g = paper_scene("ordinary-ref");
    let mut t = 0.0;
    for _ in 0..20 {
        assert_eq!(f.do_step(t, 1e-4), Status::Ok);
        assert_eq!(g.do_step(t, 1e-4), Status::Ok);
        t += 1e-4;
    }
    assert!(warnings(&f).is_empty());
    assert_eq!(f.time(), t);
    assert_eq!(
        f.get_real("theta_A").to_bits(),
        g.get_real("theta_A").to_bits()
    );
}

/// FMI 3.0 shares the check (fmi3DoStep calls fmi2DoStep's body); its messages name fmi3DoStep.
#[test]
fn fmi3_refuses_a_lost_step_and_warns_of_a_coarse_one() {
    use spur_gear_mesh::fmi::exports::*;
    use std::ffi::CStr;
    use std::os::raw::{c_char, c_void};
    use std::sync::Mutex;

    unsafe extern "C" fn record(
        env: *mut c_void,
        status: spur_gear_mesh::fmi::Status,
        _category: *const c_char,
        message: *const c_char,
    ) {
        let log = &*(env as *const Mutex<Vec<(spur_gear_mesh::fmi::Status, String)>>);
        let text = CStr::from_ptr(message).to_string_lossy().into_owned();
        log.lock().unwrap().push((status, text));
    }
    for (start, expected) in [
        (1e15, "fmi3DoStep: t + h == t"),
        (
            1.7e9,
            "fmi3DoStep: the time resolves this step only coarsely",
        ),
    ] {
        let log: Box<Mutex<Vec<(spur_gear_mesh::fmi::Status, String)>>> = Box::default();
        let guid = std::ffi::CString::new(spur_gear_mesh::variables::GUID).unwrap();
        unsafe {
            let c = fmi3InstantiateCoSimulation(
                c"fmi3".as_ptr(),
                guid.as_ptr(),
                std::ptr::null(),
                false,
                false,
                false,
                false,
                std::ptr::null(),
                0,
                &*log as *const _ as *mut c_void,
                Some(record),
                None,
            );
            assert!(!c.is_null());
            let ok = spur_gear_mesh::fmi::Status::Ok;
            assert_eq!(
                fmi3EnterInitializationMode(c, false, 0.0, start, false, 0.0),
                ok
            );
            assert_eq!(fmi3ExitInitializationMode(c), ok);
            let (mut event, mut terminate, mut early, mut last) = (true, true, true, f64::NAN);
            let s = fmi3DoStep(
                c,
                start,
                1e-4,
                false,
                &mut event,
                &mut terminate,
                &mut early,
                &mut last,
            );
            let log = std::mem::take(&mut *log.lock().unwrap());
            assert_eq!(log.len(), 1, "{log:?}");
            assert_eq!(s, log[0].0);
            assert!(log[0].1.starts_with(expected), "{}", log[0].1);
            if start == 1e15 {
                assert_eq!(s, spur_gear_mesh::fmi::Status::Error);
            } else {
                assert_eq!(s, spur_gear_mesh::fmi::Status::Warning);
                assert_eq!(last, (start + 1e-4) - start + start);
            }
            fmi3FreeInstance(c);
        }
    }
}
