//! No event is stepped over (issue 12, point 1): grazes whose event function dips below zero and
//! comes back inside one internal step, with one long communication step, at loose and tight
//! tolerances, and random scenes whose event sequence must equal that of a run with small
//! forced steps. Both explicit methods (solvers 1 and 3) run them.

use proptest::prelude::*;
use spur_gear_mesh::model::geometry::Geometry;
use spur_gear_mesh::table;
use spur_gear_mesh::variables::{Inputs, Params};

/// Runs to t_end in one communication step; returns the located events (time, description).
fn events(p: &Params, i: &Inputs, rtol: f64, t_end: f64, max_step: f64) -> Vec<(f64, String)> {
    let mut sim = table::simulation(p, i, 0.0, rtol).unwrap();
    sim.driver.max_step = max_step;
    let mut log = Vec::new();
    sim.advance(t_end, &mut |t, r| log.push((t, r.what.clone())))
        .unwrap();
    log
}

/// The pair of `base` as a pinion in a ring (planetary.md §1, docs/internal-pair.md's worked pair):
/// the same events must be located on it.
fn ring(base: Params) -> Params {
    Params {
        geometry: 2,
        internal: true,
        module: 0.002,
        zA: 20,
        zB: 60,
        xB: 0.5,
        width: 0.02,
        J_A: 5e-3,
        J_B: 0.5,
        ..base
    }
}

/// The paper's pair and the ring pair.
fn pairs(base: Params) -> [Params; 2] {
    [base.clone(), ring(base)]
}

fn first(log: &[(f64, String)], what: &str) -> Option<f64> {
    log.iter().find(|(_, w)| w.contains(what)).map(|(t, _)| *t)
}

/// Free flight inside the backlash with A braked (tau_A = -1 N m, no load on B): dte is the
/// parabola dte_0 + v_0 t + a t^2/2 with a = rAb tau_A/J_A, and its apex reaches `depth` into
/// the forward flank. Both explicit methods integrate a parabola exactly, so the touch must be
/// located at the parabola's first root, to rounding (1e-12 s), at either tolerance.
#[test]
fn a_graze_into_the_forward_flank_is_located() {
    for (solver, depth) in [1, 3].into_iter().flat_map(|s| [(s, 1e-7), (s, 1e-6)]) {
        for (rtol, base) in [1e-6, 1e-3].into_iter().flat_map(|rtol| {
            pairs(Params {
                dte_start: -5e-5,
                c_load: 0.0,
                solver,
                ..Params::default()
            })
            .map(|b| (rtol, b))
        }) {
            let g = Geometry::new(&table::pair(&base).unwrap()).unwrap();
            let a = -g.r_ab / base.J_A;
            let v0 = (2.0 * a.abs() * (depth - base.dte_start)).sqrt();
            let w_a = 10.0;
            let p = Params {
                w_A_start: w_a,
                w_B_start: (g.r_ab * w_a - v0) / g.r_bb,
                ..base
            };
            let i = Inputs {
                tau_A: -1.0,
                ..Inputs::default()
            };
            let t_touch = (v0 - (2.0 * a.abs() * depth).sqrt()) / a.abs();
            let log = events(&p, &i, rtol, 2.0 * v0 / a.abs(), f64::INFINITY);
            let t = first(&log, "Forward flank touches").unwrap_or_else(|| {
                panic!("solver {solver}, depth {depth}, rtol {rtol}: touch missed: {log:?}")
            });
            assert!(
                (t - t_touch).abs() <= 1e-12,
                "solver {solver}, depth {depth}, rtol {rtol}: touch at {t}, parabola {t_touch}"
            );
        }
    }
}

/// A pair switch grazed the same way: f1 starts just below the gate (s_A = s_a - X, inside the
/// backlash so nothing touches) and A, braked, turns back after carrying it `depth` past s_a:
/// s_A(t) = s_a - X + rAb (w_0 t + alpha t^2/2). The gate is entered and left at the two roots.
#[test]
fn a_grazed_pair_switch_is_located() {
    for (solver, depth) in [1, 3].into_iter().flat_map(|s| [(s, 1e-7), (s, 1e-6)]) {
        let x = 2e-4;
        for (rtol, base) in [1e-6, 1e-3].into_iter().flat_map(|rtol| {
            pairs(Params {
                backlash: 1e-3,
                dte_start: -x,
                solver,
                ..Params::default()
            })
            .map(|b| (rtol, b))
        }) {
            let g = Geometry::new(&table::pair(&base).unwrap()).unwrap();
            let alpha = -1.0 / base.J_A;
            let w0 = (2.0 * alpha.abs() * (x + depth) / g.r_ab).sqrt();
            let p = Params {
                w_A_start: w0,
                w_B_start: w0 * g.r_ab / g.r_bb,
                ..base
            };
            let i = Inputs {
                tau_A: -1.0,
                ..Inputs::default()
            };
            let root = (w0 * w0 - 2.0 * alpha.abs() * x / g.r_ab).sqrt();
            let (t_in, t_out) = ((w0 - root) / alpha.abs(), (w0 + root) / alpha.abs());
            let log = events(&p, &i, rtol, 2.0 * w0 / alpha.abs(), f64::INFINITY);
            let enter = first(&log, "f1 enters the contact segment");
            let leave = first(&log, "f1 leaves the contact segment");
            let (Some(t1), Some(t2)) = (enter, leave) else {
                panic!("solver {solver}, depth {depth}, rtol {rtol}: switch missed: {log:?}");
            };
            // theta_A is a parabola: exact for both methods up to rounding.
            assert!(
                (t1 - t_in).abs() <= 1e-12,
                "solver {solver}: enter {t1} vs {t_in}"
            );
            assert!(
                (t2 - t_out).abs() <= 1e-12,
                "solver {solver}: leave {t2} vs {t_out}"
            );
        }
    }
}

/// The events of a run with one long communication step and free internal steps against those
/// of a run whose internal steps are forced below 2e-6 s: the same events in the same order, at
/// times within 1e-7 s. Both run at rel_tol 1e-10, so their states differ by about 1e-10
/// relative and an event time by that over the event function's rate; 1e-7 s leaves room for
/// the slowest crossings here (and for impacts, which carry earlier errors into later times).
fn same_events_with_forced_small_steps(
    base: Params,
    w_a: f64,
    slip: f64,
    tau_a: f64,
) -> Result<(), TestCaseError> {
    let g = Geometry::new(&table::pair(&base).unwrap()).unwrap();
    let p = Params {
        w_A_start: w_a,
        w_B_start: w_a * g.r_ab / g.r_bb * (1.0 + slip),
        ..base
    };
    let i = Inputs {
        tau_A: tau_a,
        ..Inputs::default()
    };
    let t_end = 0.01;
    let free = events(&p, &i, 1e-10, t_end, f64::INFINITY);
    let forced = events(&p, &i, 1e-10, t_end, 2e-6);
    // The messages quote positions and speeds: compared without their numbers.
    let words = |w: &str| {
        w.split_whitespace()
            .filter(|x| !x.starts_with(|c: char| c.is_ascii_digit() || c == '-'))
            .collect::<Vec<_>>()
            .join(" ")
    };
    let names = |l: &[(f64, String)]| l.iter().map(|(_, w)| words(w)).collect::<Vec<_>>();
    prop_assert_eq!(names(&free), names(&forced));
    for ((a, _), (b, _)) in free.iter().zip(&forced) {
        prop_assert!((a - b).abs() <= 1e-7, "{} vs {}", a, b);
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, .. ProptestConfig::default() })]

    /// Random damped scenes (speeds, torques, backlash, friction), with either explicit method.
    #[test]
    fn event_sequences_do_not_depend_on_the_step(
        w_a in 1.0f64..60.0,
        slip in -0.02f64..0.02,
        tau_a in -60.0f64..60.0,
        backlash in 1e-5f64..3e-4,
        mu in 0.0f64..0.2,
        dte_frac in 0.0f64..1.0,
        solver in prop_oneof![Just(1), Just(3)],
    ) {
        let base = Params {
            solver,
            chi: 10.0,
            c_load: 0.5,
            mu,
            backlash,
            dte_start: -dte_frac * backlash,
            ..Params::default()
        };
        same_events_with_forced_small_steps(base, w_a, slip, tau_a)?;
    }

    /// The same on the ring pair (internal: both wheels forward the same way).
    #[test]
    fn ring_event_sequences_do_not_depend_on_the_step(
        w_a in 1.0f64..60.0,
        slip in -0.02f64..0.02,
        tau_a in -20.0f64..20.0,
        backlash in 1e-5f64..1e-4,
        mu in 0.0f64..0.2,
        dte_frac in 0.0f64..1.0,
        solver in prop_oneof![Just(1), Just(3)],
    ) {
        let base = ring(Params {
            solver,
            chi: 20.0,
            c_load: 0.5,
            mu,
            backlash,
            dte_start: -dte_frac * backlash,
            ..Params::default()
        });
        same_events_with_forced_small_steps(base, w_a, slip, tau_a)?;
    }

    /// The same for the rigid contact (rig-and-modes §2): impacts, locks and releases, and the
    /// pair switches of a locked frictionless flank, which the step continues past without a
    /// restart (`EventReport::smooth`).
    #[test]
    fn rigid_event_sequences_do_not_depend_on_the_step(
        w_a in 1.0f64..60.0,
        slip in -0.02f64..0.02,
        tau_a in -60.0f64..60.0,
        backlash in 1e-5f64..3e-4,
        mu in prop_oneof![Just(0.0), 0.0f64..0.2],
        restitution in 0.0f64..1.0,
        dte_frac in 0.0f64..1.0,
    ) {
        let base = Params {
            contact_model: 2,
            restitution,
            c_load: 0.5,
            mu,
            backlash,
            dte_start: -dte_frac * backlash,
            ..Params::default()
        };
        same_events_with_forced_small_steps(base, w_a, slip, tau_a)?;
    }
}
