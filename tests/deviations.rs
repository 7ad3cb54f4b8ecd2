//! Shape deviations (issue 9, point 3; tooth-structure.md §2) in the model and driver: each
//! pair's own penetration, the teeth the objects hold, and the energy account.

mod common;

use common::static_delta;
use spur_gear_mesh::fmi::outputs::outputs;
use spur_gear_mesh::model::contact::{self, Flank};
use spur_gear_mesh::model::geometry::Geometry;
use spur_gear_mesh::table;
use spur_gear_mesh::variables::{Inputs, Params};

fn pitch(z: usize, teeth: &[(usize, f64)]) -> String {
    let mut v = vec![0.0; z];
    for &(k, e) in teeth {
        v[k] = e;
    }
    v.iter()
        .map(|x| x.to_string())
        .collect::<Vec<_>>()
        .join(",")
}

/// At t = 0 f1 holds teeth A0/B0 and f2 A1/B1 (deviations.rs): pitch errors on those teeth
/// move each pair's penetration by f_A - f_B, and each force is the Johnson force at its own
/// penetration (the test's own fixed point, tests/common). Backward: b1 holds A1/B0 and the
/// sign turns.
#[test]
fn each_pair_carries_at_its_own_penetration() {
    let dte = 5e-7;
    let p = Params {
        dte_start: dte,
        w_A_start: 50.0,
        w_B_start: 50.0 / 1.5,
        pitch_errors_A: pitch(22, &[(0, 1e-7), (1, -4e-8)]),
        pitch_errors_B: pitch(33, &[(0, 3e-8), (1, 2e-8)]),
        // Undamped: the forces are the elastic ones.
        chi: 0.0,
        ..Params::default()
    };
    let g = Geometry::new(&table::pair(&p).unwrap()).unwrap();
    let (mesh, y) = table::paper_rig(&p, &Inputs::default()).unwrap();
    let o = mesh.readout(&y).unwrap();
    let own = [dte + 1e-7 - 3e-8, dte - 4e-8 - 2e-8];
    for (k, delta) in own.into_iter().enumerate() {
        let back = static_delta(o.mesh.pair_force[k] / p.width, &g);
        // The fixed point converges to rounding; d ln N / d ln delta ~ 1.07, so the force's
        // rounding (1e-16 relative) maps to ~1e-16 relative in delta; 1e-12 is far above it.
        assert!(
            (back - delta).abs() <= 1e-12 * delta,
            "{k}: {back} vs {delta}"
        );
    }
    assert_eq!(contact::teeth(&g, Flank::Forward, mesh.sigma[0]), (0, 0));
    assert_eq!(contact::teeth(&g, Flank::Forward, mesh.sigma[1]), (1, 1));
    assert_eq!(contact::teeth(&g, Flank::Backward, mesh.sigma[2]), (1, 0));
    // Backward at penetration delta0: b2 is gated at t = 0, one pitch below b1 on the
    // backward line (teeth A2/B1, one on from b1's A1/B0) or, if that leaves the window, one
    // above (A0/B32); its penetration is delta0 - f_A + f_B.
    let p = Params {
        dte_start: -1e-4 - dte,
        w_A_start: 50.0,
        w_B_start: 50.0 / 1.5 + 1e-3,
        pitch_errors_A: pitch(22, &[(0, 1e-7), (2, -4e-8)]),
        pitch_errors_B: pitch(33, &[(1, 3e-8), (32, 2e-8)]),
        ..p
    };
    let (mesh, y) = table::paper_rig(&p, &Inputs::default()).unwrap();
    let o = mesh.readout(&y).unwrap();
    let below = mesh.sigma[3] < mesh.sigma[2];
    let delta = if below {
        dte + 4e-8 + 3e-8
    } else {
        dte - 1e-7 + 2e-8
    };
    assert!(o.mesh.pair_force[3] > 0.0, "b2 carries");
    let back = static_delta(o.mesh.pair_force[3] / p.width, &g);
    assert!(
        (back - delta).abs() <= 1e-12 * delta,
        "b2: {back} vs {delta}"
    );
}

/// A slot that jumps m_c pitches moves to teeth m_c further on: forward down by m_c (back
/// along the line), backward up (the backward line runs the other way).
#[test]
fn jumps_move_the_teeth_by_the_jump() {
    let g = Geometry::new(&table::pair(&Params::default()).unwrap()).unwrap();
    let span = g.m_c as f64 * g.p_b;
    let s = contact::initial_sigmas(&g);
    let m = g.m_c as i64;
    assert_eq!(contact::teeth(&g, Flank::Forward, s[0] - span), (-m, -m));
    assert_eq!(contact::teeth(&g, Flank::Backward, s[2] - span), (1 + m, m));
    // b2 is b1's neighbour one pitch away: one tooth on.
    let (a, b) = contact::teeth(&g, Flank::Backward, s[3]);
    assert_eq!((a - 1).abs(), 1);
    assert_eq!(a - 1, b);
}

/// The work of the deviations on the pairs is booked with W_ext, so the energy residual is the
/// integration error alone: it falls with the tolerance. Between rel_tol 1e-7 and 1e-10 the
/// fifth-order method's global error falls by about the tolerance ratio (1000; granted 100);
/// a missing or wrong power term would leave a residual that does not fall. At 1e-10 it stays
/// below what the steps can add at most: each step's error is held below rel_tol relative to
/// the state, so the energy's below about 2 rel_tol E_kin per step (E ~ w^2). Both a standard
/// pair with contact model 3, linear tip relief, friction and damping, and the paper rig with
/// runout and pitch errors.
#[test]
fn the_energy_balance_holds_with_deviations() {
    let relief = Params {
        geometry: 2,
        zA: 20,
        zB: 30,
        module: 0.004,
        J_A: 1e-3,
        J_B: 5e-3,
        contact_model: 3,
        chi: 0.2,
        mu: 0.05,
        c_load: 0.0,
        w_A_start: 100.0,
        w_B_start: 100.0 / 1.5,
        tip_relief_A: 1e-5,
        tip_relief_length_A: 3e-3,
        tip_relief_B: 1e-5,
        tip_relief_length_B: 3e-3,
        ..Params::default()
    };
    let runout = Params {
        chi: 10.0,
        mu: 0.1,
        c_load: 2.0,
        w_A_start: 100.0,
        w_B_start: 100.0 / 1.5,
        ecc_A: 3e-7,
        ecc_phase_A: 0.5,
        ecc_B: 2e-7,
        ecc_phase_B: 2.0,
        pitch_errors_A: pitch(22, &[(3, 2e-7), (9, -1e-7)]),
        pitch_errors_B: pitch(33, &[(4, 1.5e-7)]),
        ..Params::default()
    };
    for (name, p, tau) in [
        ("relief", relief, (225.0, -337.5)),
        ("runout", runout, (100.0, 0.0)),
    ] {
        let i = Inputs {
            tau_A: tau.0,
            tau_B: tau.1,
            ..Inputs::default()
        };
        let residual = |rtol: f64| {
            let mut sim = table::simulation(&p, &i, 0.0, rtol).unwrap();
            sim.advance(0.02, &mut |_, _| {}).unwrap();
            let o = outputs(&sim).unwrap();
            (o.energy_residual, o.E_kin, o.n_events, o.n_steps)
        };
        let (loose, e_kin, events, _) = residual(1e-7);
        let (tight, _, _, steps) = residual(1e-10);
        assert!(events > 10, "{name}: pairs switch ({events} events)");
        assert!(
            tight.abs() <= 1e-2 * loose.abs() + 1e-13 * e_kin,
            "{name}: residual {loose} at 1e-7, {tight} at 1e-10 (E_kin {e_kin})"
        );
        let bound = 2.0 * 1e-10 * e_kin * steps as f64;
        assert!(tight.abs() <= bound, "{name}: {tight} vs {bound}");
    }
}
