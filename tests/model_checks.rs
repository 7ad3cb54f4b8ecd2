//! Spec §7 checks on the model and driver, in-process (the same checks run through the packaged
//! FMU in tests/python). Every tolerance states where it comes from.

mod common;

use common::{run, static_delta};
use spur_gear_mesh::fmi::outputs::outputs;
use spur_gear_mesh::model::geometry::Geometry;
use spur_gear_mesh::table;
use spur_gear_mesh::variables::{Inputs, Outputs, Params};
use std::f64::consts::PI;

fn paper(chi: f64) -> (Params, Inputs) {
    let p = Params {
        c_load: 2.0,
        w_A_start: 100.0,
        w_B_start: 100.0 / 1.5,
        chi,
        ..Params::default()
    };
    (
        p,
        Inputs {
            tau_A: 100.0,
            tau_B: 0.0,
            ..Inputs::default()
        },
    )
}

/// Static load: balanced torques, start at the static penetration, rolling slowly (1e-3 rad/s,
/// rigid ratio) so the pair at point a is moving onto the segment rather than resting on its
/// edge. Without friction or damping this is an exact equilibrium; the integrator holds it to
/// its tolerance, and the force's relative error is about the penetration's (d ln N/d ln delta
/// is about 1.07 here), so both must match to 10 rtol: sum F_n = tau_A/rAb and dte equal to the
/// Johnson penetration for N = F/(pairs*width). Single contact: the 20/30 rig (contact ratio 1, one pair); double: the
/// 22/33 rig at t = 0 (f1 at a, f2 one pitch ahead).
#[test]
fn static_load_single_and_double_contact() {
    for (z_a, z_b, pairs) in [(20, 30, 1.0), (22, 33, 2.0)] {
        let tau_a = 100.0;
        let base = Params {
            zA: z_a,
            zB: z_b,
            chi: 0.0,
            c_load: 0.0,
            ..Params::default()
        };
        let g = Geometry::new(&table::pair(&base).unwrap()).unwrap();
        let delta = static_delta(tau_a / g.r_ab / pairs / base.width, &g);
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
        let rtol = 1e-10;
        let out = run(&p, &i, rtol, 1e-3, 0.01);
        for o in &out {
            assert!(
                (o.F_fwd - tau_a / g.r_ab).abs() <= 10.0 * rtol * tau_a / g.r_ab,
                "{z_a}/{z_b}: F_fwd {} vs {}, dte {} vs {delta}, ddte {}",
                o.F_fwd,
                tau_a / g.r_ab,
                o.dte,
                g.r_ab * o.w_A - g.r_bb * o.w_B
            );
            assert!(
                (o.dte - delta).abs() <= 10.0 * rtol * delta,
                "{z_a}/{z_b}: dte {} vs {delta}",
                o.dte
            );
            assert_eq!(o.n_fwd as f64, pairs);
        }
    }
}

/// Gated pairs on one flank share delta (paper Fig. 9), also while the undamped mesh rattles:
/// each pair's force, checked on its own against the test's Johnson law (the penetration that
/// carries it, tests/common), is the one at dte, so the two are equal because each is right.
/// The fixed point converges to rounding and d ln N / d ln delta ~ 1.07: 1e-9 relative is far
/// above both roundings.
#[test]
fn pairs_in_double_contact_carry_equal_forces() {
    let (p, i) = paper(0.0);
    let g = Geometry::new(&table::pair(&p).unwrap()).unwrap();
    let out = run(&p, &i, 1e-6, 1e-5, 0.05);
    let double: Vec<&Outputs> = out
        .iter()
        .filter(|o| o.n_fwd == 2 && o.dte > 1e-8)
        .collect();
    assert!(
        double.len() > 50,
        "double contact occurs ({} samples)",
        double.len()
    );
    for o in double {
        for f in [o.F_f1, o.F_f2] {
            let delta = static_delta(f / p.width, &g);
            assert!(
                (delta - o.dte).abs() <= 1e-9 * o.dte,
                "{delta} vs {}",
                o.dte
            );
        }
    }
}

/// Damped steady drive (chi = 10 s/m, no separation): 2 zA forward switch events per revolution
/// of A, and the mean speed ratio over whole mesh cycles is zB/zA.
#[test]
fn mesh_frequency_and_rigid_kinematics() {
    let (p, i) = paper(10.0);
    let h = 1e-6;
    // Start after the first transient (damped at ~3 % of critical: e^-3 after ~10 ms).
    let out = run(&p, &i, 1e-8, h, 0.1);
    let tail = &out[30_000..];
    assert!(
        tail.iter().all(|o| o.n_fwd >= 1),
        "the damped drive never separates"
    );
    // Switches (changes of n_fwd) per revolution of A.
    let switches = tail.windows(2).filter(|w| w[0].n_fwd != w[1].n_fwd).count() as f64;
    let revolutions = (tail.last().unwrap().theta_A - tail[0].theta_A) / (2.0 * PI);
    let per_rev = switches / revolutions;
    // The window holds a whole number of switches: the count is off by at most one at each end.
    assert!(
        (per_rev - 44.0).abs() <= 2.0 / revolutions,
        "{per_rev} switches per revolution"
    );
    // Mean speed ratio over the tail: rAb mean(w_A) - rBb mean(w_B) = (dte_end - dte_start)/T,
    // and |dte| stays below 2e-6 m here, so |ratio - zB/zA| <= 2e-6/(T rBb mean(w_B)).
    let t_span = tail.len() as f64 * h;
    let mean = |f: fn(&Outputs) -> f64| tail.iter().map(f).sum::<f64>() / tail.len() as f64;
    let ratio = mean(|o| o.w_A) / mean(|o| o.w_B);
    let bound = 2e-6 / (t_span * 0.2818 * mean(|o| o.w_B)) + 1e-9;
    assert!((ratio - 1.5).abs() <= bound, "ratio {ratio}, bound {bound}");
}

/// Energy: kinetic + elastic + dissipated - external work - gate jumps is constant for an
/// exact solution. Each accepted step commits a local error of at most ~2 rtol (|w| + 1 rad/s)
/// per speed, so the energy error per step is at most ~4 rtol (E_kin + J) and the residual after
/// N steps at most N times that (worst case, no cancellation). It must also shrink with rtol.
#[test]
fn energy_balance_holds_and_converges() {
    for (chi, mu) in [(0.0, 0.0), (10.0, 0.3)] {
        let p = Params {
            chi,
            mu,
            c_load: 2.0,
            w_A_start: 100.0,
            w_B_start: 100.0 / 1.5,
            ..Params::default()
        };
        let i = Inputs {
            tau_A: 100.0,
            tau_B: 0.0,
            ..Inputs::default()
        };
        let mut residuals = Vec::new();
        for rtol in [1e-6, 1e-9] {
            let mut sim = table::simulation(&p, &i, 0.0, rtol).unwrap();
            sim.advance(0.02, &mut |_, _| {}).unwrap();
            let o = outputs(&sim).unwrap();
            let steps = sim.driver.stats.steps as f64;
            let bound = 4.0 * rtol * (o.E_kin + p.J_A + p.J_B) * steps;
            assert!(
                o.energy_residual.abs() <= bound,
                "chi {chi} mu {mu} rtol {rtol}: {} > {bound}",
                o.energy_residual
            );
            if mu > 0.0 {
                assert!(o.W_loss > 0.0, "friction and damping dissipate");
            }
            residuals.push(o.energy_residual.abs());
        }
        assert!(
            residuals[1] < residuals[0],
            "energy residual shrinks with the tolerance: {residuals:?}"
        );
    }
}

/// Friction always dissipates: every term of P_loss (mu tanh(v/v_reg) v F_n and chi N ddelta^2)
/// is non-negative, so the sum is too, with no tolerance.
#[test]
fn friction_dissipates_and_flips_at_the_pitch_point() {
    let p = Params {
        mu: 0.3,
        chi: 10.0,
        ..paper(10.0).0
    };
    let out = run(&p, &paper(10.0).1, 1e-8, 1e-5, 0.03);
    assert!(out.iter().all(|o| o.P_loss >= 0.0));
    let g = Geometry::new(&table::pair(&p).unwrap()).unwrap();
    let s_pitch = g.r_ab * g.alpha_w.tan();
    // Friction torque on A = tau_mesh_A minus the normal part -F_fwd rAb; in single contact it
    // is mu tanh(v_s/v_reg) F s_A with v_s changing sign at the pitch point: positive before
    // (s_A < s_P: B slides faster), negative after. Stay 1 mm (>> v_reg/w_A) away from it.
    for o in out
        .iter()
        .skip(1000)
        .filter(|o| o.n_fwd == 1 && o.F_fwd > 0.0)
    {
        let carrying_s = if o.F_f1 > 0.0 { o.s_f1 } else { o.s_f2 };
        let friction = o.tau_mesh_A + o.F_fwd * g.r_ab;
        if carrying_s < s_pitch - 1e-3 {
            assert!(friction > 0.0, "s {carrying_s}: {friction}");
        } else if carrying_s > s_pitch + 1e-3 {
            assert!(friction < 0.0, "s {carrying_s}: {friction}");
        }
    }
}

/// The internal step is independent of the communication step: 1e-6 s and 1e-3 s steps give the
/// same trajectory. Both runs hold the local error below rtol = 1e-10; over the ~36 vibration
/// periods of 20 ms the global error of a damped run stays far below 1e-6 of the signal, so a
/// difference above 1e-6 of max|dte| means the communication step leaked into the solution.
#[test]
fn communication_step_does_not_change_the_trajectory() {
    let (p, i) = paper(10.0);
    let fine = run(&p, &i, 1e-10, 1e-6, 0.02);
    let coarse = run(&p, &i, 1e-10, 1e-3, 0.02);
    let scale = fine.iter().map(|o| o.dte.abs()).fold(0.0, f64::max);
    for (k, c) in coarse.iter().enumerate() {
        let f = &fine[(k + 1) * 1000 - 1];
        assert!(
            (f.dte - c.dte).abs() <= 1e-6 * scale,
            "t = {}: {} vs {}",
            (k + 1) as f64 * 1e-3,
            f.dte,
            c.dte
        );
        assert!((f.w_A - c.w_A).abs() <= 1e-9 * f.w_A.abs());
    }
}

/// Both integrators reach the same solution (the implicit one at its second order needs a
/// tighter tolerance for the same accuracy): damped drive, 10 ms, within 1e-4 of max|dte|.
#[test]
fn implicit_and_explicit_methods_agree() {
    let (p, i) = paper(10.0);
    let explicit = run(&p, &i, 1e-10, 1e-4, 0.01);
    let implicit = run(&Params { solver: 2, ..p }, &i, 1e-8, 1e-4, 0.01);
    let scale = explicit.iter().map(|o| o.dte.abs()).fold(0.0, f64::max);
    for (e, m) in explicit.iter().zip(&implicit) {
        assert!(
            (e.dte - m.dte).abs() <= 1e-4 * scale,
            "{} vs {}",
            e.dte,
            m.dte
        );
    }
}
