//! The lumped mesh (`contact_model = 4`, lateral.md §4) on the paper rig, against closed forms:
//! its static deflection, its free vibration, the square wave's mean and its energy balance.
//! Every tolerance states where it comes from.

use spur_gear_mesh::fmi::outputs::outputs;
use spur_gear_mesh::model::geometry::Geometry;
use spur_gear_mesh::model::paper_rig::statics;
use spur_gear_mesh::table;
use spur_gear_mesh::variables::{Inputs, Outputs, Params};

const K: f64 = 4e8;

fn lumped(varies: bool) -> Params {
    Params {
        contact_model: 4,
        k_lumped: K,
        k_lumped_varies: varies,
        ..Params::default()
    }
}

/// No torques (the inputs' defaults are the paper's 100 N.m on A).
fn unloaded() -> Inputs {
    Inputs {
        tau_A: 0.0,
        tau_B: 0.0,
        ..Inputs::default()
    }
}

fn geometry(p: &Params) -> Geometry {
    Geometry::new(&table::pair(p).unwrap()).unwrap()
}

/// The outputs at t = 0 and then every h up to t_end.
fn run(p: &Params, i: &Inputs, rtol: f64, h: f64, t_end: f64) -> Vec<(f64, Outputs)> {
    let mut sim = table::simulation(p, i, 0.0, rtol).unwrap();
    let mut out = vec![(0.0, outputs(&sim).unwrap())];
    let n = (t_end / h).round() as usize;
    for k in 1..=n {
        let t = k as f64 * h;
        sim.advance(t, &mut |_, _| {}).unwrap();
        out.push((t, outputs(&sim).unwrap()));
    }
    out
}

/// The static start under the paper's loads: the rolling wheels accelerate together, so the
/// mesh force F balances both in that frame, (tau_A - F rAb) / (i J_A) = (F rBb - c w_B) / J_B
/// with i = rBb / rAb, and the spring's deflection is F / k (F eps / (k n) on the square wave,
/// n the pairs there). The static solve converges to 1e-12 of the deflection
/// (paper_rig::statics::TOL); 1e-10 leaves room for the rounding of F itself.
#[test]
fn the_static_start_deflects_the_spring_by_force_over_stiffness() {
    for varies in [false, true] {
        let p = Params {
            c_load: 2.0,
            w_A_start: 100.0,
            w_B_start: 100.0 / 1.5,
            static_start: true,
            ..lumped(varies)
        };
        let i = Inputs {
            tau_A: 100.0,
            ..Inputs::default()
        };
        let g = geometry(&p);
        let dte_start =
            statics::static_dte_start(&table::rig(&p).unwrap(), &table::loads(&p, &i)).unwrap();
        let p = Params {
            dte_start,
            static_start: false,
            ..p
        };
        let ratio = g.r_bb / g.r_ab;
        let force = (i.tau_A / (ratio * p.J_A) + p.c_load * p.w_B_start / p.J_B)
            / (g.r_bb / p.J_B + g.r_ab / (ratio * p.J_A));
        let o = &run(&p, &i, 1e-10, 1e-4, 0.0)[0].1;
        let k = if varies {
            K * o.n_fwd as f64 / g.eps
        } else {
            K
        };
        assert!(o.n_fwd >= 1 && o.n_fwd <= 2, "{}", o.n_fwd);
        assert!(
            (o.dte - force / k).abs() <= 1e-10 * force / k,
            "varies {varies}: dte {} vs F/k {}",
            o.dte,
            force / k
        );
        assert!(
            (o.F_fwd - force).abs() <= 1e-10 * force,
            "{} vs {force}",
            o.F_fwd
        );
        assert!(
            (o.k_mesh - k).abs() <= 1e-12 * k,
            "k_mesh {} vs {k}",
            o.k_mesh
        );
        assert_eq!(o.F_bwd, 0.0);
    }
}

/// Without backlash the two flanks' springs make one linear spring about the axes: the error
/// oscillates as dte0 cos(omega t), omega^2 = k (rAb^2 / J_A + rBb^2 / J_B), crossing from
/// one flank to the other at every half period (events). Each accepted step errs by at most
/// about rtol of the amplitude, and for an undamped oscillator these add at most linearly:
/// the bound is the step count times rtol, times 10 for the controller's safety margin on the
/// rate (whose scale is omega dte0).
#[test]
fn without_backlash_the_error_oscillates_at_the_springs_frequency() {
    let dte0 = 1e-6;
    let p = Params {
        backlash: 0.0,
        c_load: 0.0,
        w_A_start: 100.0,
        w_B_start: 100.0 / 1.5,
        dte_start: dte0,
        ..lumped(false)
    };
    let g = geometry(&p);
    let p = Params {
        w_B_start: 100.0 * g.r_ab / g.r_bb,
        ..p
    };
    let omega = (K * (g.r_ab * g.r_ab / p.J_A + g.r_bb * g.r_bb / p.J_B)).sqrt();
    let period = 2.0 * std::f64::consts::PI / omega;
    let rtol = 1e-11;
    let out = run(&p, &unloaded(), rtol, period / 40.0, 10.0 * period);
    let (_, last) = out.last().unwrap();
    assert!(last.n_events >= 20, "{} events", last.n_events);
    let bound = 10.0 * rtol * dte0 * last.n_steps as f64;
    for (t, o) in &out {
        let exact = dte0 * (omega * t).cos();
        assert!(
            (o.dte - exact).abs() <= bound,
            "t = {t}: dte {} vs {exact} (bound {bound})",
            o.dte
        );
        // One flank at a time carries the whole spring force.
        let f = if o.dte > 0.0 { o.F_fwd } else { -o.F_bwd };
        assert!((f - K * o.dte).abs() <= 1e-12 * K * dte0, "t = {t}: {f}");
    }
}

/// The square wave's stiffness is k n / eps with n the pairs on the contact segment at the
/// rigid position: over a mesh cycle two pairs carry for the fraction eps - 1, one for 2 - eps,
/// so its mean is k. Sampled at equal steps in time while the wheels turn at constant speed
/// (balanced torques, starting in static balance; the mesh's small vibration does not lift
/// the flank) the mean is k to within the sampling: each of the two switches per pitch falls
/// between two samples, an error of at most 1 / N of the pitch's samples each.
#[test]
fn the_square_wave_has_mean_k_over_a_mesh_cycle() {
    let p = Params {
        c_load: 0.0,
        w_A_start: 10.0,
        ..lumped(true)
    };
    let g = geometry(&p);
    let i = Inputs {
        tau_A: 100.0,
        tau_B: -100.0 * g.r_bb / g.r_ab,
        ..Inputs::default()
    };
    let p = Params {
        w_B_start: 10.0 * g.r_ab / g.r_bb,
        ..p
    };
    let dte_start =
        statics::static_dte_start(&table::rig(&p).unwrap(), &table::loads(&p, &i)).unwrap();
    let p = Params { dte_start, ..p };
    let pitches = 5.0;
    let pitch_time = g.p_b / (g.r_ab * 10.0);
    let n = 2000;
    let out = run(
        &p,
        &i,
        1e-10,
        pitches * pitch_time / n as f64,
        pitches * pitch_time,
    );
    let mean = out[1..].iter().map(|(_, o)| o.k_mesh).sum::<f64>() / n as f64;
    let per_pitch = n as f64 / pitches;
    assert!(
        (mean - K).abs() <= 2.0 / per_pitch * K,
        "mean {mean} vs {K} (eps {})",
        g.eps
    );
    let pairs: Vec<f64> = out.iter().map(|(_, o)| o.k_mesh / K * g.eps).collect();
    assert!(pairs
        .iter()
        .all(|&x| (x - 1.0).abs() < 1e-12 || (x - 2.0).abs() < 1e-12));
    assert!(pairs.iter().any(|&x| x > 1.5) && pairs.iter().any(|&x| x < 1.5));
}

/// Energy closes with the square wave's jumps booked at its events (E_gate), the damper's work
/// in W_loss, through a load reversal that crosses the backlash, with B's bearing rigid and on
/// the slider S: E_kin + E_el + W_loss - W_ext - E_gate is constant for the exact solution.
/// The bound is as tests/deviations.rs's: each accepted step errs by at most ~2 rtol E_kin,
/// summed over the steps; and the residual must shrink with rtol.
#[test]
fn energy_closes_through_switches_and_the_backlash() {
    for slider_stiffness in [0.0, 2e8] {
        let p = Params {
            c_load: 2.0,
            c_lumped: 2000.0,
            w_A_start: 100.0,
            w_B_start: 100.0 / 1.5,
            statistics: true,
            slider_stiffness,
            slider_damping: 500.0,
            ..lumped(true)
        };
        let i = Inputs {
            tau_A: -300.0,
            ..Inputs::default()
        };
        let residual = |rtol: f64| {
            let mut sim = table::simulation(&p, &i, 0.0, rtol).unwrap();
            sim.advance(0.02, &mut |_, _| {}).unwrap();
            let o = outputs(&sim).unwrap();
            (
                o.energy_residual,
                o.E_kin,
                o.n_events,
                o.n_steps,
                o.t_backward,
                o.E_gate,
            )
        };
        let (loose, e_kin, events, _, _, _) = residual(1e-7);
        let (tight, _, _, steps, t_backward, e_gate) = residual(1e-10);
        let case = format!("slider {slider_stiffness}");
        assert!(events > 10, "{case}: {events} events");
        assert!(t_backward > 0.0, "{case}: the backward flank carries");
        assert!(e_gate != 0.0, "{case}: the square wave's jumps are booked");
        assert!(
            tight.abs() <= 1e-2 * loose.abs() + 1e-13 * e_kin,
            "{case}: residual {loose} at 1e-7, {tight} at 1e-10 (E_kin {e_kin})"
        );
        let bound = 2.0 * 1e-10 * e_kin * steps as f64;
        assert!(tight.abs() <= bound, "{case}: {tight} vs {bound}");
    }
}

/// Bad input is refused naming the parameter and the value; what the lumped mesh cannot use
/// is refused, not ignored.
#[test]
fn bad_lumped_parameters_are_refused_by_name() {
    let i = Inputs::default();
    for (p, name) in [
        (
            Params {
                k_lumped: 0.0,
                ..lumped(false)
            },
            "k_lumped = 0",
        ),
        (
            Params {
                k_lumped: -1e8,
                ..lumped(false)
            },
            "k_lumped = -100000000",
        ),
        (
            Params {
                c_lumped: -1.0,
                ..lumped(false)
            },
            "c_lumped = -1",
        ),
        (
            Params {
                c_lumped: f64::NAN,
                ..lumped(false)
            },
            "c_lumped = NaN",
        ),
        (
            Params {
                ecc_A: 1e-5,
                ..lumped(false)
            },
            "contact_model = 4",
        ),
    ] {
        let e = table::simulation(&p, &i, 0.0, 1e-6).unwrap_err();
        assert!(e.message.contains(name), "{name}: {}", e.message);
    }
}
