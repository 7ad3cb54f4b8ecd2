//! The paper's whole rig (rig-and-modes.md): rigid contact, the slider S, a moving housing,
//! against closed forms. Every tolerance states where it comes from.

mod common;

use common::static_delta;
use spur_gear_mesh::fmi::outputs::outputs;
use spur_gear_mesh::model::geometry::Geometry;
use spur_gear_mesh::table;
use spur_gear_mesh::variables::{Inputs, Outputs, Params};

fn run(p: &Params, i: &Inputs, rtol: f64, h: f64, t_end: f64) -> Vec<(f64, Outputs)> {
    let mut sim = table::simulation(p, i, 0.0, rtol).unwrap();
    let n = (t_end / h).round() as usize;
    (1..=n)
        .map(|k| {
            let t = k as f64 * h;
            sim.advance(t, &mut |_, _| {}).unwrap();
            (t, outputs(&sim).unwrap())
        })
        .collect()
}

/// The paper's scene, written out: 100 N.m on A, the load c_load = 2, the running start at
/// 100 rad/s with B rolling rigidly, chi = 10 (SpurGearMesh's defaults are these).
fn paper_scene() -> (Params, Inputs) {
    let p = Params {
        c_load: 2.0,
        chi: 10.0,
        w_A_start: 100.0,
        w_B_start: 100.0 / 1.5,
        ..Params::default()
    };
    let i = Inputs {
        tau_A: 100.0,
        ..Inputs::default()
    };
    (p, i)
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

/// rig-and-modes §2, exact check: the paper rig with rigid contact, mu = 0, forward locked from
/// t = 0, tau_B = 0. The wheels roll as one body: (J_A + J_B/i^2) dw_A/dt = tau_A - c w_A/i^2
/// with i = rBb/rAb, an exponential towards tau_A i^2/c; the constraint force is
/// F = (J_B dw_B/dt + c w_B)/rBb. The motion is smooth (time constant 1.45 s) and Dormand-Prince's
/// local error (h/tau)^6 with h <= a quarter pitch of travel (7e-4 s) is below 1e-19, so only
/// rounding remains: about eps per step over ~300 steps and restarts, far below 1e-12.
#[test]
fn rigid_forward_lock_matches_the_closed_form() {
    let (p, i) = paper_scene();
    let p = Params {
        contact_model: 2,
        ..p
    };
    let g = Geometry::new(&table::pair(&p).unwrap()).unwrap();
    let ratio = g.r_bb / g.r_ab;
    let j = p.J_A + p.J_B / (ratio * ratio);
    let w_inf = i.tau_A * ratio * ratio / p.c_load;
    let rate = p.c_load / (j * ratio * ratio);
    for solver in [1, 2] {
        let p = Params {
            solver,
            ..p.clone()
        };
        let out = run(&p, &i, 1e-12, 1e-3, 0.1);
        let atol_dte = table::simulation(&p, &i, 0.0, 1e-12)
            .unwrap()
            .driver
            .tol
            .atol[1];
        let bound = if solver == 1 { 1e-12 } else { 1e-9 };
        for (t, o) in &out {
            let w_a = w_inf + (p.w_A_start - w_inf) * (-rate * t).exp();
            let dw_a = -rate * (p.w_A_start - w_inf) * (-rate * t).exp();
            let (w_b, dw_b) = (w_a / ratio, dw_a / ratio);
            let force = (p.J_B * dw_b + p.c_load * w_b) / g.r_bb;
            assert!(
                rel(o.w_A, w_a) <= bound,
                "solver {solver}, t {t}: w_A {} vs {w_a}",
                o.w_A
            );
            assert!(rel(o.w_B, w_b) <= bound, "t {t}: w_B {} vs {w_b}", o.w_B);
            assert!(
                rel(o.F_fwd, force) <= bound,
                "t {t}: F_fwd {} vs {force}",
                o.F_fwd
            );
            // Dormand-Prince keeps the locked penetration exactly (its rate is exactly 0).
            // diffsol's BDF rounds it in its Newton solve and interpolation; the error control
            // bounds it by the absolute tolerance of dte.
            if solver == 1 {
                assert_eq!(o.dte, 0.0, "locked: the penetration is held exactly");
            } else {
                assert!(o.dte.abs() <= atol_dte, "t {t}: dte {}", o.dte);
            }
            assert!(o.n_fwd >= 1 && o.F_bwd == 0.0);
            // The gated pairs share the force equally (the paper's §6.3 convention).
            if o.n_fwd == 2 {
                assert_eq!(o.F_f1, o.F_f2);
            }
        }
    }
}

/// rig-and-modes §4: free flight inside the backlash (no torques, no load). The housing's
/// angular acceleration turns the wheels relative to it: w_A = w_A0 + alpha t, w_B = w_B0 - alpha
/// t, so dte = dte_0 + (rAb + rBb) alpha t^2 / 2 (the motion starts with zero mesh velocity).
/// The guide's acceleration moves the slider: x'' = -(k/m) x - a, x = -(a m/k)(1 - cos(w t)).
/// Both are polynomial or harmonic: the integrator's error stays at its tolerance, 1e-10
/// relative to the amplitudes, so 1e-8 of them bounds it with room for the accumulation.
#[test]
fn housing_motion_in_free_flight() {
    let (alpha, a_x) = (1.0, 0.1);
    let (k, m) = (1e6, 44.4);
    let p = Params {
        backlash: 1e-4,
        dte_start: -5e-5,
        w_A_start: 10.0,
        w_B_start: 10.0 / 1.5,
        slider_stiffness: k,
        slider_mass: m,
        c_load: 0.0,
        ..Params::default()
    };
    let i = Inputs {
        tau_A: 0.0,
        alpha_housing: alpha,
        a_housing_x: a_x,
        ..Inputs::default()
    };
    let g = Geometry::new(&table::pair(&p).unwrap()).unwrap();
    let w0 = (k / m).sqrt();
    let x_amp = a_x * m / k;
    for (t, o) in run(&p, &i, 1e-10, 1e-3, 0.01) {
        let dte = -5e-5
            + (g.r_ab * p.w_A_start - g.r_bb * p.w_B_start) * t
            + 0.5 * (g.r_ab + g.r_bb) * alpha * t * t;
        assert!(
            rel(o.w_A, p.w_A_start + alpha * t) <= 1e-12,
            "t {t}: w_A {}",
            o.w_A
        );
        assert!(
            rel(o.w_B, p.w_B_start - alpha * t) <= 1e-12,
            "t {t}: w_B {}",
            o.w_B
        );
        assert!(
            (o.dte - dte).abs() <= 1e-8 * 5e-5,
            "t {t}: dte {} vs {dte}",
            o.dte
        );
        let x = -x_amp * (1.0 - (w0 * t).cos());
        assert!(
            (o.x_slider - x).abs() <= 1e-8 * x_amp,
            "t {t}: x {} vs {x}",
            o.x_slider
        );
        assert_eq!((o.F_fwd, o.F_bwd, o.F_B_x, o.F_B_y), (0.0, 0.0, 0.0, 0.0));
    }
}

/// Rigid impacts through the backlash: with restitution 1 (and mu = 0) an impact returns the
/// energy it takes, so the energy balance closes to the integrator's tolerance; with 0 it is
/// plastic, locks, and the dissipated energy is the kinetic energy of the relative motion,
/// (1/2) m_eff v^2, which the balance books as a loss.
#[test]
fn rigid_impacts_keep_the_energy_balance() {
    for e in [0.0, 1.0] {
        let p = Params {
            contact_model: 2,
            restitution: e,
            dte_start: -5e-5,
            w_A_start: 10.0,
            w_B_start: 10.0 / 1.5 - 0.01,
            c_load: 0.0,
            ..Params::default()
        };
        let free = Inputs {
            tau_A: 0.0,
            ..Inputs::default()
        };
        let out = run(&p, &free, 1e-10, 1e-3, 0.05);
        let last = &out.last().unwrap().1;
        assert!(last.n_impacts >= 1, "e {e}: the teeth meet");
        let scale = last.E_kin;
        assert!(
            last.energy_residual.abs() <= 1e-8 * scale,
            "e {e}: residual {} of {scale}",
            last.energy_residual
        );
        if e == 0.0 {
            let g = Geometry::new(&table::pair(&p).unwrap()).unwrap();
            let v = g.r_bb * 0.01;
            let inv_m = g.r_ab * g.r_ab / p.J_A + g.r_bb * g.r_bb / p.J_B;
            let loss = 0.5 * v * v / inv_m;
            assert_eq!(last.n_impacts, 1, "a plastic impact locks at once");
            assert!(rel(last.W_loss, loss) <= 1e-9, "{} vs {loss}", last.W_loss);
            assert_eq!(last.dte, 0.0);
        } else {
            assert!(
                last.W_loss.abs() <= 1e-9 * scale,
                "elastic: {}",
                last.W_loss
            );
        }
    }
}

/// rig-and-modes §3, static balance: balanced torques on the paper rig (rolling at 1e-3 rad/s so
/// the pair at point a moves onto the segment), the mesh at its static penetration, the slider
/// released from x_S = 0. At rest the slider carries F_B,x = F sin(alpha_w) (mu = 0), so
/// x_S = F sin(alpha_w)/k_S, and the static dte rises by x_S sin(alpha_w) above the Johnson
/// penetration of the two pairs. The release transient (critically damped slider, mesh damped
/// at about 3 % by chi = 10 s/m, omega about 1e4 rad/s) has decayed by e^-15 after 0.05 s, and
/// the integration at rel_tol 1e-10 is far tighter: 1e-5 relative bounds both.
#[test]
fn slider_static_balance() {
    let (k, m) = (1e9, 44.4);
    let tau_a = 100.0;
    let base = Params {
        chi: 10.0,
        slider_stiffness: k,
        slider_mass: m,
        slider_damping: 2.0 * (k * m).sqrt(),
        ..Params::default()
    };
    let g = Geometry::new(&table::pair(&base).unwrap()).unwrap();
    let force = tau_a / g.r_ab;
    let delta = static_delta(force / 2.0 / base.width, &g);
    let p = Params {
        dte_start: delta,
        w_A_start: 1e-3,
        w_B_start: 1e-3 * g.r_ab / g.r_bb,
        ..base
    };
    let i = Inputs {
        tau_A: tau_a,
        tau_B: -tau_a * g.r_bb / g.r_ab,
        ..Inputs::default()
    };
    let (_, o) = run(&p, &i, 1e-10, 1e-3, 0.05).pop().unwrap();
    let sin_a = g.alpha_w.sin();
    let x = force * sin_a / k;
    assert_eq!(o.n_fwd, 2);
    assert!(rel(o.F_fwd, force) <= 1e-5, "F_fwd {} vs {force}", o.F_fwd);
    assert!(
        rel(o.F_B_x, force * sin_a) <= 1e-5,
        "F_B_x {} vs {}",
        o.F_B_x,
        force * sin_a
    );
    assert!(rel(o.x_slider, x) <= 1e-5, "x_slider {} vs {x}", o.x_slider);
    let dte = delta + x * sin_a;
    assert!(
        rel(o.dte, dte) <= 1e-5,
        "dte {} vs {dte} (Johnson {delta} + slider {})",
        o.dte,
        x * sin_a
    );
}

/// The single mesh's static start (parameter `static_start`, gearbox-file.md §3) on the
/// damped paper scene (scenes/damped.toml): the dte's acceleration vanishes at t = 0, and the
/// dte_start found is the scene's hand-written running start, which the independent reference
/// solved (gearmesh_ref.quasi_static_dte: the rigid rolling's line force shared by the two
/// pairs in contact, Johnson's law solved by fixed point). Both solves stop at rounding: 1e-9
/// of the deflection leaves room for it. Refused with rigid contact and with the slider.
#[test]
fn the_static_start_is_the_reference_running_start() {
    use spur_gear_mesh::model::paper_rig::statics::static_dte_start;
    use spur_gear_mesh::model::paper_rig::DDTE;
    let (p, i) = paper_scene();
    let d = static_dte_start(&table::rig(&p).unwrap(), &table::loads(&p, &i)).unwrap();
    let want = 5.592370531367129e-07;
    assert!(rel(d, want) <= 1e-9, "{d} against {want}");
    let q = Params {
        dte_start: d,
        ..p.clone()
    };
    let (mut lo, mut hi) = (q.clone(), q.clone());
    lo.dte_start = 0.9 * d;
    hi.dte_start = 1.1 * d;
    let acc = |p: &Params| {
        let (rig, y) = table::paper_rig(p, &i).unwrap();
        let mut dy: spur_gear_mesh::model::paper_rig::State = Default::default();
        rig.rhs(&y, &mut dy).unwrap();
        dy[DDTE]
    };
    // Against what a 10 % error in the deflection would leave.
    let balance = acc(&q);
    assert!(
        balance.abs() <= 1e-8 * (acc(&lo) - acc(&hi)).abs(),
        "{balance}"
    );
    for (key, bad) in [
        (
            "contact_model",
            Params {
                contact_model: 2,
                ..p.clone()
            },
        ),
        (
            "slider",
            Params {
                slider_stiffness: 1e6,
                ..p.clone()
            },
        ),
    ] {
        let e = static_dte_start(&table::rig(&bad).unwrap(), &table::loads(&bad, &i)).unwrap_err();
        assert!(
            e.message.starts_with("parameter static_start = true"),
            "{key}: {}",
            e.message
        );
    }
}
