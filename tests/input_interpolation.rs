//! Inputs interpolated over communication steps (issue 10, point 5): fmi2SetRealInputDerivatives
//! through the C API makes tau_A a polynomial in time inside fmi2DoStep.

mod fmi_support;

use fmi_support::ffi::*;
use fmi_support::Fmu;

/// A's speed in free flight: no contact all along (the backward flank left out, the forward one
/// opening at 0.14 m/s from 50 um), tau_A = 10 N.m, nothing else acting on A.
fn free_flight() -> Fmu {
    let f = Fmu::new("free");
    for (name, x) in [
        ("tau_A", 10.0),
        ("c_load", 0.0),
        ("dte_start", -5e-5),
        ("w_A_start", 10.0),
        ("w_B_start", 10.0 / 1.5 + 0.5),
    ] {
        assert_eq!(f.set_real(name, x), Status::Ok);
    }
    let no = 0;
    let backward = fmi_support::vr("backward_contacts");
    assert_eq!(
        unsafe { fmi2SetBoolean(f.c, &backward, 1, &no) },
        Status::Ok
    );
    assert_eq!(f.setup(None), Status::Ok);
    assert_eq!(f.enter_init(), Status::Ok);
    assert_eq!(f.exit_init(), Status::Ok, "{:?}", f.log.take());
    f
}

/// Free flight, no contact: A's speed is w0 + (u t + r t^2/2 + c t^3/6)/J_A
/// exactly when the master gives tau_A's value u, rate r and curvature c once at t = 0 and
/// then only steps. Dormand-Prince integrates that cubic exactly (its order is 5), so only
/// rounding remains: 1e-12 relative. Held inputs (no derivatives) are off by the missing
/// terms, r t^2/2 / J_A and more, at once.
#[test]
fn a_polynomial_input_is_followed_exactly_inside_the_steps() {
    let (u, r, c) = (10.0, 400.0, -3000.0);
    let j_a = 0.4;
    for with_derivatives in [true, false] {
        let f = free_flight();
        if with_derivatives {
            let vr = [40u32, 40];
            let order = [1, 2];
            let value = [r, c];
            let st = unsafe {
                fmi2SetRealInputDerivatives(f.c, vr.as_ptr(), 2, order.as_ptr(), value.as_ptr())
            };
            assert_eq!(st, Status::Ok);
        }
        let (w0, h) = (10.0, 2e-3);
        let mut worst: f64 = 0.0;
        for k in 1..=10 {
            let t = k as f64 * h;
            assert_eq!(f.do_step((k - 1) as f64 * h, h), Status::Ok);
            let w = f.get_real("w_A");
            let exact = w0 + (u * t + r * t * t / 2.0 + c * t * t * t / 6.0) / j_a;
            worst = worst.max(((w - exact) / exact).abs());
        }
        if with_derivatives {
            assert!(worst <= 1e-12, "interpolated: {worst:e}");
        } else {
            // r t^2 / 2 / J_A at 0.02 s is 0.2 rad/s on ~11 rad/s.
            assert!(worst > 1e-3, "held: {worst:e}");
        }
    }
}

/// A value set for an input drops its derivatives (it holds until derivatives come again), and
/// a derivative given without a new value continues from the input's current value.
#[test]
fn a_new_value_resets_the_derivatives_and_a_new_rate_continues_from_now() {
    let f = free_flight();
    let j_a = 0.4;
    let rate = 500.0;
    let st = unsafe { fmi2SetRealInputDerivatives(f.c, &40, 1, &1, &rate) };
    assert_eq!(st, Status::Ok);
    assert_eq!(f.do_step(0.0, 0.01), Status::Ok);
    let w1 = f.get_real("w_A");
    // A new rate at t = 0.01 s without a value: tau_A continues from 10 + 500 * 0.01 = 15.
    let st = unsafe { fmi2SetRealInputDerivatives(f.c, &40, 1, &1, &0.0) };
    assert_eq!(st, Status::Ok);
    assert_eq!(f.get_real("tau_A"), 15.0);
    assert_eq!(f.do_step(0.01, 0.01), Status::Ok);
    let w2 = f.get_real("w_A");
    assert!(((w2 - w1) - 15.0 * 0.01 / j_a).abs() <= 1e-12 * w2);
    // A value: held from now on.
    assert_eq!(f.set_real("tau_A", 20.0), Status::Ok);
    assert_eq!(f.do_step(0.02, 0.01), Status::Ok);
    let w3 = f.get_real("w_A");
    assert!(((w3 - w2) - 20.0 * 0.01 / j_a).abs() <= 1e-12 * w3);
}
