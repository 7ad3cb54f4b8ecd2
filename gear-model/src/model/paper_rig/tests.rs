//! The paper rig with its mesh: modes at the start, smooth jumps, the power balance of the
//! contact torques, friction off, objects left out, and the vector forces' moments.

use super::*;
use crate::model::contact::slot_flank;
use crate::model::rig;

/// The paper's rig changed by `f`, under the paper's load (c_load = 2) and tau_A = `tau`.
fn rig(tau: f64, f: impl FnOnce(&mut RigSpec)) -> (PaperRig, State, RigSpec) {
    rig_loaded(tau, 2.0, f)
}

fn rig_loaded(tau: f64, c_load: f64, f: impl FnOnce(&mut RigSpec)) -> (PaperRig, State, RigSpec) {
    let mut spec = RigSpec::paper();
    f(&mut spec);
    let loads = Loads {
        tau_a: tau,
        ..Loads::idle(&spec.pair, c_load)
    };
    let (m, y) = PaperRig::new(&spec, loads).unwrap();
    (m, y, spec)
}

fn paper() -> (PaperRig, State) {
    let (m, y, _) = rig(100.0, |_| {});
    (m, y)
}

#[test]
fn initial_modes_of_the_paper_rig() {
    let (m, y) = paper();
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
    let (m, y) = paper();
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
        // No external torque, no load: the wheels' power is the mesh's.
        let (m, y, p) = rig_loaded(0.0, 0.0, |s| {
            (s.pair.chi, s.pair.mu) = (5.0, 0.3);
            (s.dte_start, s.w_a_start, s.w_b_start) = (dte, 50.0, 33.0);
        });
        assert!(m.flank_on(flank));
        let mut dy = [0.0; NY];
        m.rhs(&y, &mut dy).unwrap();
        let acc_b = (m.geo.r_ab * dy[W_A] - dy[DDTE]) / m.geo.r_bb;
        let p_mesh = (dy[W_A] * p.j_a) * y[W_A] + (acc_b * p.j_b) * m.w_b(&y);
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
    let (m, y, _) = rig(0.0, |s| {
        (s.pair.chi, s.pair.mu) = (0.0, 0.0);
        (s.dte_start, s.w_a_start, s.w_b_start) = (3e-7, 80.0, 50.0);
    });
    let o = m.readout(&y).unwrap();
    let f = o.mesh.flank_force[0];
    assert_eq!(o.p_loss, 0.0);
    // Without friction the torques are the normal force times the base radii exactly.
    assert!((o.mesh.tq_a + f * m.geo.r_ab).abs() <= 1e-12 * f);
    assert!((o.mesh.tq_b - f * m.geo.r_bb).abs() <= 1e-12 * f);
}

#[test]
fn backward_contacts_can_be_left_out() {
    let (m, _, _) = rig(0.0, |s| s.pair.backward_contacts = false);
    assert!(m.present(0) && m.present(1) && !m.present(2) && !m.present(3));
    let (m, _, _) = rig(0.0, |s| (s.pair.a.z, s.pair.b.z) = (20, 30));
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
    let (johnson, rigid) = (MeshLaw::Johnson, MeshLaw::Rigid);
    for (law, dte) in [
        (johnson, 4e-7),
        (johnson, -1e-4 - 3e-7),
        (rigid, 0.0),
        (rigid, -1e-4),
    ] {
        for theta in [0.0, 0.004, 0.011] {
            let tau = if dte < 0.0 { -100.0 } else { 100.0 };
            let (mut m, mut y, _) = rig(tau, |s| {
                (s.pair.law, s.pair.chi, s.pair.mu) = (law, 5.0, 0.3);
                (s.dte_start, s.w_a_start) = (dte, 50.0);
                // The flank that carries is approaching (a rigid one then locks at t = 0).
                s.w_b_start = if dte < 0.0 { 34.0 } else { 33.0 };
            });
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
            assert!(n >= 1, "{law:?}, dte {dte}, theta {theta}: a flank carries");
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
