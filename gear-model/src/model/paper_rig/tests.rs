//! The paper rig with its mesh: modes at the start, smooth jumps, the power balance of the
//! contact torques, friction off, objects left out, and the vector forces' moments.

use super::*;
use crate::model::contact::slot_flank;
use crate::model::rig;

fn paper() -> (Params, Inputs) {
    let p = Params {
        c_load: 2.0,
        w_A_start: 100.0,
        w_B_start: 100.0 / 1.5,
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

#[test]
fn initial_modes_of_the_paper_rig() {
    let (p, i) = paper();
    let (m, y) = PaperRig::new(&p, &i).unwrap();
    // f1 at a (moving onto the segment) and f2 one pitch ahead are both gated. At dte = 0
    // with no relative speed the forward flank touches (the spec's closed interval) with
    // zero force; the backward flank is a backlash away.
    assert!(m.sign[EventFn::Gate(0).index()] && m.sign[EventFn::Gate(1).index()]);
    assert!(!m.sign[EventFn::Gate(2).index()] && m.sign[EventFn::Gate(3).index()]);
    assert!(m.flank_on(Flank::Forward) && !m.flank_on(Flank::Backward));
    let o = m.readout(&y).unwrap();
    assert_eq!((o.mesh.flank_force[0], o.mesh.flank_pairs[0]), (0.0, 2));
}

/// A jump of a pair on the idle flank leaves the right-hand side as it was, and says so (the
/// driver then continues its step); a jump of a carrying pair does not.
#[test]
fn only_a_jump_that_carries_no_force_is_smooth() {
    let (p, i) = paper();
    let (m, y) = PaperRig::new(&p, &i).unwrap();
    let mut dy = [0.0; NY];
    m.rhs(&y, &mut dy).unwrap();
    for e in [EventFn::Top(2), EventFn::Bottom(2), EventFn::Bottom(3)] {
        let (mut m2, mut y2) = (m.clone(), y);
        assert!(m2.handle_event(e.index(), &mut y2).unwrap().smooth, "{e:?}");
        let mut dy2 = [0.0; NY];
        m2.rhs(&y2, &mut dy2).unwrap();
        assert_eq!((y2, dy2), (y, dy), "{e:?}");
    }
    let mut m2 = m.clone();
    assert!(m2.carrying(0));
    assert!(
        !m2.handle_event(EventFn::Top(0).index(), &mut y.clone())
            .unwrap()
            .smooth
    );
}

/// Spec §4: the power of the contact torques equals -F_n d(delta)/dt - F_t v_s, i.e. the
/// mesh power equals -dE_el/dt - P_loss, on both flanks, with friction and damping.
#[test]
fn mesh_power_balances_elastic_energy_and_losses() {
    for (dte, flank) in [(4e-7, Flank::Forward), (-1e-4 - 3e-7, Flank::Backward)] {
        let p = Params {
            chi: 5.0,
            mu: 0.3,
            dte_start: dte,
            w_A_start: 50.0,
            w_B_start: 33.0,
            c_load: 0.0,
            ..Params::default()
        };
        // No external torque: the wheels' power is the mesh's.
        let no_drive = Inputs {
            tau_A: 0.0,
            ..Inputs::default()
        };
        let (m, y) = PaperRig::new(&p, &no_drive).unwrap();
        assert!(m.flank_on(flank));
        let mut dy = [0.0; NY];
        m.rhs(&y, &mut dy).unwrap();
        let acc_b = (m.geo.r_ab * dy[W_A] - dy[DDTE]) / m.geo.r_bb;
        let p_mesh = (dy[W_A] * p.J_A) * y[W_A] + (acc_b * p.J_B) * m.w_b(&y);
        let h = 1e-9;
        let mut y2 = y;
        for c in 0..NY {
            y2[c] += h * dy[c];
        }
        let de_el = (m.elastic_energy(&y2).unwrap() - m.elastic_energy(&y).unwrap()) / h;
        let residual = p_mesh + de_el + dy[W_LOSS];
        // Forward difference of E_el over h: relative error ~ h * d2E/dt2 / dE/dt ~ 1e-5.
        assert!(
            residual.abs() <= 1e-4 * p_mesh.abs(),
            "{flank:?}: {residual} vs {p_mesh}"
        );
    }
}

#[test]
fn friction_off_costs_nothing_and_changes_nothing_when_mu_is_zero() {
    let p = Params {
        dte_start: 3e-7,
        w_A_start: 80.0,
        w_B_start: 50.0,
        chi: 0.0,
        mu: 0.0,
        ..Params::default()
    };
    let (m, y) = PaperRig::new(&p, &Inputs::default()).unwrap();
    let o = m.readout(&y).unwrap();
    let f = o.mesh.flank_force[0];
    assert_eq!(o.p_loss, 0.0);
    // Without friction the torques are the normal force times the base radii exactly.
    assert!((o.mesh.tq_a + f * m.geo.r_ab).abs() <= 1e-12 * f);
    assert!((o.mesh.tq_b - f * m.geo.r_bb).abs() <= 1e-12 * f);
}

#[test]
fn backward_contacts_can_be_left_out() {
    let p = Params {
        backward_contacts: false,
        ..Params::default()
    };
    let (m, _) = PaperRig::new(&p, &Inputs::default()).unwrap();
    assert!(m.present(0) && m.present(1) && !m.present(2) && !m.present(3));
    let p = Params {
        zA: 20,
        zB: 30,
        ..Params::default()
    };
    let (m, _) = PaperRig::new(&p, &Inputs::default()).unwrap();
    assert_eq!(m.geo.m_c, 1);
    assert!(m.present(0) && !m.present(1) && m.present(2) && !m.present(3));
}

/// rig-and-modes §1 end to end: the vector force of every carrying pair (F_B_x, F_B_y of
/// the outputs, pair by pair), taken at B's contact point built from the spec's vectors
/// (forward K_B - s_B u, backward K_B' - s_B u_b), has the moment about O_B that the
/// right-hand side applies to B, and its opposite at A's contact point (K_A + s_A u) the
/// moment it applies to A (interface frame: theta_A = -psi_A, theta_B = psi_B). Both flanks,
/// with friction and damping, compliant and rigid, with double and single contact. Only
/// rounding separates them: sums of products of lengths below 0.5 m and forces, 1e-12.
#[test]
fn vector_forces_at_the_contact_points_give_the_torques() {
    for (contact_model, dte) in [(1, 4e-7), (1, -1e-4 - 3e-7), (2, 0.0), (2, -1e-4)] {
        for theta in [0.0, 0.004, 0.011] {
            let p = Params {
                contact_model,
                chi: 5.0,
                mu: 0.3,
                dte_start: dte,
                w_A_start: 50.0,
                // The flank that carries is approaching (a rigid one then locks at t = 0).
                w_B_start: if dte < 0.0 { 34.0 } else { 33.0 },
                ..Params::default()
            };
            let tau = if dte < 0.0 { -100.0 } else { 100.0 };
            let i = Inputs {
                tau_A: tau,
                ..Inputs::default()
            };
            let (mut m, mut y) = PaperRig::new(&p, &i).unwrap();
            // Move A on by theta at the same penetration and re-derive the gates there.
            y[THETA_A] += theta;
            m.mesh.init_signs(&kin(&y));
            if m.rigid() {
                m.init_rigid(&mut y);
            }
            let (pairs, load) = m.pair_forces(&y).unwrap();
            let g = m.geo.clone();
            let (a, d) = (g.alpha_w, g.d);
            let (mut m_a, mut m_b, mut n) = (0.0, 0.0, 0);
            for k in (0..SLOTS).filter(|&k| m.carrying(k)) {
                let f = slot_flank(k);
                let (delta, _) = m.flank_delta(f, &y);
                let s_a = m.s_contact(k, &y);
                let s_b = g.l + delta - s_a;
                let (k_b, u) = match f {
                    Flank::Forward => (
                        (d - g.r_bb * a.cos(), -g.r_bb * a.sin()),
                        (a.sin(), -a.cos()),
                    ),
                    Flank::Backward => {
                        ((d - g.r_bb * a.cos(), g.r_bb * a.sin()), (a.sin(), a.cos()))
                    }
                };
                // Each tooth's own contact point: they differ by the penetration along u.
                let k_a = (g.r_ab * a.cos(), k_b.1 * -g.r_ab / g.r_bb);
                let pt_b = (k_b.0 - s_b * u.0, k_b.1 - s_b * u.1);
                let pt_a = (k_a.0 + s_a * u.0, k_a.1 + s_a * u.1);
                let (fx, fy) = rig::force_on_b(f, pairs[k].0, pairs[k].1, a.sin(), a.cos());
                m_b += (pt_b.0 - d) * fy - pt_b.1 * fx;
                m_a += pt_a.0 * -fy - pt_a.1 * -fx;
                n += 1;
            }
            assert!(
                n >= 1,
                "model {contact_model}, dte {dte}, theta {theta}: a flank carries"
            );
            let scale = 1e-9 * (load.tq_a.abs() + load.tq_b.abs());
            assert!(
                (m_b - load.tq_b).abs() <= scale,
                "B: {m_b} vs {}",
                load.tq_b
            );
            assert!(
                (-m_a - load.tq_a).abs() <= scale,
                "A: {} vs {}",
                -m_a,
                load.tq_a
            );
        }
    }
}
