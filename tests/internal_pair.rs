//! The internal pair (planetary.md §1): a pinion inside a ring, through the single mesh's rig,
//! with the checks the spec lists (ratio, static load under the internal law, energy, friction
//! reversal at the pitch point, contact ratio). Every tolerance states where it comes from.

mod common;

use common::{run, static_delta};
use spur_gear_mesh::fmi::outputs::outputs;
use spur_gear_mesh::model::geometry::Geometry;
use spur_gear_mesh::table;
use spur_gear_mesh::variables::{Inputs, Outputs, Params};
use std::f64::consts::PI;

/// 20/60, module 2 mm, 20 deg, xB = 0.5 (docs/internal-pair.md's worked pair): alpha_w = 23.3 deg,
/// eps = 1.73, the pitch point inside the segment. Inertias of steel discs 20 mm wide.
fn ring(chi: f64, mu: f64) -> Params {
    Params {
        geometry: 2,
        internal: true,
        module: 0.002,
        zA: 20,
        zB: 60,
        xA: 0.0,
        xB: 0.5,
        width: 0.02,
        J_A: 4e-4,
        J_B: 0.05,
        chi,
        mu,
        backlash: 5e-5,
        ..Params::default()
    }
}

/// A drive of 20 N.m on the pinion against a viscous load on the ring that balances it at
/// 100 rad/s of the pinion (33.3 rad/s of the ring, the same way).
fn drive(p: Params) -> (Params, Inputs) {
    drive_with(p, 1.0)
}

/// The same drive forward (sign 1) or backward (sign -1, on the backward flanks, started at
/// their static penetration).
fn drive_with(p: Params, sign: f64) -> (Params, Inputs) {
    let g = Geometry::new(&table::pair(&p).unwrap()).unwrap();
    let (tau, w_a) = (sign * 20.0, sign * 100.0);
    let w_b = w_a * g.r_ab / g.r_bb;
    let delta = static_delta(20.0 / g.r_ab / 2.0 / p.width, &g);
    let p = Params {
        c_load: tau * g.r_bb / g.r_ab / w_b,
        w_A_start: w_a,
        w_B_start: w_b,
        dte_start: if sign > 0.0 { delta } else { -g.j_n - delta },
        ..p
    };
    let i = Inputs {
        tau_A: tau,
        ..Inputs::default()
    };
    (p, i)
}

/// Static load: balanced torques, the start at the static penetration under the internal law
/// (R = L - delta, tests/common), two pairs at t = 0, rolling slowly. As the external check in
/// model_checks.rs: an exact equilibrium held to the integrator's tolerance, so the force and
/// the penetration match to 10 rtol.
#[test]
fn static_load_under_the_internal_law() {
    let base = ring(0.0, 0.0);
    let g = Geometry::new(&table::pair(&base).unwrap()).unwrap();
    let tau_a = 20.0;
    let delta = static_delta(tau_a / g.r_ab / 2.0 / base.width, &g);
    // The check tells the laws apart: with R = L - delta < L + delta the log term, and so the
    // penetration at the same load, is smaller than the external law's.
    let external = Geometry {
        internal: false,
        ..g.clone()
    };
    assert!(delta < static_delta(tau_a / g.r_ab / 2.0 / base.width, &external));
    let p = Params {
        dte_start: delta,
        w_A_start: 1e-3,
        w_B_start: 1e-3 * g.r_ab / g.r_bb,
        c_load: 0.0,
        ..base
    };
    let i = Inputs {
        tau_A: tau_a,
        tau_B: -tau_a * g.r_bb / g.r_ab,
        ..Inputs::default()
    };
    let rtol = 1e-10;
    for o in &run(&p, &i, rtol, 1e-3, 0.01) {
        let f = tau_a / g.r_ab;
        assert!((o.F_fwd - f).abs() <= 10.0 * rtol * f, "{} vs {f}", o.F_fwd);
        assert!(
            (o.dte - delta).abs() <= 10.0 * rtol * delta,
            "{} vs {delta}",
            o.dte
        );
        assert_eq!(o.n_fwd, 2);
        // Both pairs carry the same force (they share delta), each that of the law at N/2.
        assert!((o.F_f1 - o.F_f2).abs() <= 1e-12 * f);
    }
}

/// Steady damped drive: both wheels turn forward (the same way), the mean ratio over the
/// tail is zB/zA within what the bounded dte allows (as model_checks.rs), and A's pairs switch
/// 2 zA times per revolution (a contact ratio in (1, 2): each pair enters at a and leaves at b).
#[test]
fn ratio_and_mesh_frequency() {
    let (p, i) = drive(ring(20.0, 0.0));
    let g = Geometry::new(&table::pair(&p).unwrap()).unwrap();
    let h = 1e-6;
    let out = run(&p, &i, 1e-8, h, 0.04);
    let tail = &out[10_000..];
    assert!(tail
        .iter()
        .all(|o| o.n_fwd >= 1 && o.w_B > 0.0 && o.w_A > 0.0));
    let switches = tail.windows(2).filter(|w| w[0].n_fwd != w[1].n_fwd).count() as f64;
    let revolutions = (tail.last().unwrap().theta_A - tail[0].theta_A) / (2.0 * PI);
    assert!(
        (switches / revolutions - 40.0).abs() <= 2.0 / revolutions,
        "{} switches per revolution",
        switches / revolutions
    );
    let max_dte = tail.iter().map(|o| o.dte.abs()).fold(0.0, f64::max);
    let t_span = tail.len() as f64 * h;
    let mean = |f: fn(&Outputs) -> f64| tail.iter().map(f).sum::<f64>() / tail.len() as f64;
    let ratio = mean(|o| o.w_A) / mean(|o| o.w_B);
    let bound = 2.0 * max_dte / (t_span * g.r_bb * mean(|o| o.w_B)) + 1e-9;
    assert!((ratio - 3.0).abs() <= bound, "ratio {ratio}, bound {bound}");
}

/// Energy, as model_checks.rs: the residual is bounded by the local errors committed over the
/// steps and shrinks with the tolerance; undamped without friction, and damped with friction
/// on either flank.
#[test]
fn energy_balance() {
    for (chi, mu, sign) in [(0.0, 0.0, 1.0), (20.0, 0.1, 1.0), (20.0, 0.1, -1.0)] {
        let (p, i) = drive_with(ring(chi, mu), sign);
        let mut residuals = Vec::new();
        for rtol in [1e-6, 1e-9] {
            let mut sim = table::simulation(&p, &i, 0.0, rtol).unwrap();
            sim.advance(0.01, &mut |_, _| {}).unwrap();
            let o = outputs(&sim).unwrap();
            let bound = 4.0 * rtol * (o.E_kin + p.J_A + p.J_B) * sim.driver.stats.steps as f64;
            assert!(
                o.energy_residual.abs() <= bound,
                "{chi} {mu} {rtol}: {} > {bound}",
                o.energy_residual
            );
            residuals.push(o.energy_residual.abs());
        }
        assert!(residuals[1] < residuals[0], "{residuals:?}");
    }
}

/// Friction dissipates, and each pair's friction torque on A, mu tanh(v_s/v_reg) F s_A with
/// v_s = -w_A s_A + w_B s_B and s_B = s_A + L - delta, flips where the pair passes the pitch
/// point s_P = rAb tan(alpha_w): positive before, negative after. On this pair the pitch point
/// lies in the double-contact zone, so the total friction torque (tau_mesh_A + F_fwd rAb) is
/// checked against the sum of the pairs' terms, evaluated from the outputs (a few roundings of
/// terms of size mu F s_b: 1e-9 of that), and both signs must occur 1 mm (>> v_reg/w_A) off
/// the pitch point.
#[test]
fn friction_flips_at_the_pitch_point() {
    let (p, i) = drive(ring(20.0, 0.1));
    let g = Geometry::new(&table::pair(&p).unwrap()).unwrap();
    let s_pitch = g.r_ab * g.alpha_w.tan();
    assert!(s_pitch > g.s_a + 1e-3 && s_pitch < g.s_b - 1e-3);
    let out = run(&p, &i, 1e-8, 1e-5, 0.03);
    assert!(out.iter().all(|o| o.P_loss >= 0.0));
    let (mut before, mut after) = (0, 0);
    for o in out.iter().skip(500).filter(|o| o.F_fwd > 0.0) {
        let mut expected = 0.0;
        for (f, s) in [(o.F_f1, o.s_f1), (o.F_f2, o.s_f2)] {
            if f == 0.0 {
                continue;
            }
            let v_s = -o.w_A * s + o.w_B * (s + g.l - o.dte);
            let term = p.mu * (v_s / p.v_reg).tanh() * f * s;
            expected += term;
            if s < s_pitch - 1e-3 {
                assert!(term > 0.0, "s {s}: {term}");
                before += 1;
            } else if s > s_pitch + 1e-3 {
                assert!(term < 0.0, "s {s}: {term}");
                after += 1;
            }
        }
        let friction = o.tau_mesh_A + o.F_fwd * g.r_ab;
        let scale = p.mu * o.F_fwd * g.s_b;
        assert!(
            (friction - expected).abs() <= 1e-9 * scale,
            "{friction} vs {expected}"
        );
    }
    assert!(before > 10 && after > 10, "{before} {after}");
}

/// What is not available for a ring yet is refused with a message saying so.
#[test]
fn what_a_ring_cannot_have_yet_is_refused() {
    let i = Inputs::default();
    let e = table::paper_rig(
        &Params {
            contact_model: 3,
            ..ring(0.0, 0.0)
        },
        &i,
    )
    .unwrap_err();
    assert!(
        e.message.contains("not available for an internal pair"),
        "{}",
        e.message
    );
    let e = table::paper_rig(
        &Params {
            slider_stiffness: 1e9,
            ..ring(0.0, 0.0)
        },
        &i,
    )
    .unwrap_err();
    assert!(e.message.contains("slider"), "{}", e.message);
}

/// Rigid contact (contact_model = 2) on a ring: locked on the forward flank from the start,
/// the wheels roll as one body; at the balanced speed the constraint force is exactly
/// tau_A / rAb (rAb's lever, no friction), which the integrator holds to its tolerance, and the
/// ratio is zB/zA to rounding (dte stays 0).
#[test]
fn rigid_contact_on_a_ring_rolls_as_one_body() {
    let (p, i) = drive(ring(0.0, 0.0));
    let p = Params {
        contact_model: 2,
        dte_start: 0.0,
        ..p
    };
    let g = Geometry::new(&table::pair(&p).unwrap()).unwrap();
    let rtol = 1e-10;
    let f = i.tau_A / g.r_ab;
    for o in run(&p, &i, rtol, 1e-4, 0.01) {
        assert!((o.F_fwd - f).abs() <= 10.0 * rtol * f, "{} vs {f}", o.F_fwd);
        assert_eq!((o.F_bwd, o.dte), (0.0, 0.0));
        assert!((o.w_A / o.w_B - 3.0).abs() <= 1e-12, "{}", o.w_A / o.w_B);
    }
}

/// A housing that turns with angular acceleration alpha (rig-and-modes.md: the wheels' angles
/// are relative to it) drives free wheels at -alpha relative to it in the paper frame; both a
/// pinion's and a ring's forward sense is clockwise, so both read +alpha in the interface,
/// where an external pair's B reads -alpha. Inside the backlash nothing touches: w = alpha t
/// exactly (the integrator is exact on a linear speed).
#[test]
fn a_turning_housing_turns_both_wheels_of_a_ring_forward() {
    let p = Params {
        dte_start: -2.5e-5,
        w_A_start: 0.0,
        w_B_start: 0.0,
        c_load: 0.0,
        ..ring(0.0, 0.0)
    };
    let i = Inputs {
        tau_A: 0.0,
        alpha_housing: 10.0,
        ..Inputs::default()
    };
    let t = 1e-3;
    let o = run(&p, &i, 1e-10, t, t).pop().unwrap();
    assert_eq!((o.F_fwd, o.F_bwd), (0.0, 0.0));
    for w in [o.w_A, o.w_B] {
        assert!((w - 10.0 * t).abs() <= 1e-12, "{} vs {}", o.w_A, o.w_B);
    }
}
