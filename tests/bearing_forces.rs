//! The bearings' forces of a torsional train (lateral.md §6, §7 "Bearing forces") against
//! closed forms and symmetry. Every tolerance states where it comes from.

mod train_parts;

use spur_gear_mesh::driver::train_simulation::TrainSimulation;
use spur_gear_mesh::model::geometry::Geometry;
use spur_gear_mesh::model::train::statics::static_start;
use spur_gear_mesh::model::train::{Body, Planet, TrainSpec, HOUSING};
use spur_gear_mesh::table;
use spur_gear_mesh::variables::Params;
use std::f64::consts::PI;
use train_parts::{body, mesh, n_forward, pair};

/// The spec with its static start under the torques tau (at the bodies' start speeds).
fn balanced(spec: TrainSpec, tau: &[f64]) -> TrainSpec {
    let sim = TrainSimulation::new(spec.clone(), tau.to_vec(), None, 1, 0.0, 1e-10).unwrap();
    static_start(spec, &sim.train().loads).unwrap()
}

fn close(a: [f64; 2], b: [f64; 2], tol: f64) -> bool {
    (a[0] - b[0]).hypot(a[1] - b[1]) <= tol
}

/// Three wheels in a row at standing still under balanced torques, the meshes at 0.7 and 2.1
/// rad: mesh 1's A turns clockwise, mesh 2's A (the idler) counter-clockwise, so both frames
/// and the mirror are exercised. In static balance each mesh carries F = tau / rb along its
/// n_f: the pinion's bearing gives it +F1 n_f1, the idler's -(F1 n_f1 - F2 n_f2), the last
/// wheel's -F2 n_f2, and the housing the sum of their reactions, 0. No friction; the static
/// start balances the accelerations to 1e-10 of the elastic terms (statics.rs), so 1e-9 of F.
#[test]
fn at_static_load_each_bearing_holds_its_mesh_forces() {
    let p = Params {
        geometry: 2,
        module: 0.004,
        zA: 19,
        zB: 31,
        width: 0.03,
        chi: 0.0,
        ..Params::default()
    };
    let q = Params {
        zA: 31,
        zB: 23,
        ..p.clone()
    };
    let spec = TrainSpec {
        bodies: vec![body(0.01), body(0.05), body(0.03)],
        angle_start: 0.0,
        shafts: vec![],
        meshes: vec![mesh(0, 1, 0.7, &p), mesh(1, 2, 2.1, &q)],
    };
    let (g1, g2) = (
        Geometry::new(&table::pair(&p).unwrap()).unwrap(),
        Geometry::new(&table::pair(&q).unwrap()).unwrap(),
    );
    let tau1 = 120.0;
    let f1 = tau1 / g1.r_ab;
    // The idler passes F1 on: F2 rAb2 = F1 rBb1.
    let f2 = f1 * g1.r_bb / g2.r_ab;
    let tau = vec![tau1, 0.0, -f2 * g2.r_bb];
    let spec = balanced(spec, &tau);
    let sim = TrainSimulation::new(spec, tau, None, 1, 0.0, 1e-10).unwrap();
    let bf = sim.train().bearing_forces(&sim.state()).unwrap();
    let n1 = n_forward(g1.alpha_w, 0.7, false);
    let n2 = n_forward(g2.alpha_w, 2.1, true);
    let tol = 1e-9 * f1;
    let want = [
        [f1 * n1[0], f1 * n1[1]],
        [-(f1 * n1[0] - f2 * n2[0]), -(f1 * n1[1] - f2 * n2[1])],
        [-f2 * n2[0], -f2 * n2[1]],
    ];
    for (i, w) in want.iter().enumerate() {
        assert!(
            close(bf.body[i], *w, tol),
            "body {}: {:?} vs {w:?}",
            i + 1,
            bf.body[i]
        );
    }
    assert!(close(bf.housing, [0.0, 0.0], tol), "{:?}", bf.housing);
}

/// Sun (body 1), carrier (body 2), three planets of mass m equally spaced, ring fixed.
fn simple_set(m: f64, carrier_driven: bool) -> TrainSpec {
    let mut bodies = vec![body(2e-3), body(0.05)];
    bodies[0].w_start = 100.0;
    bodies[1].w_start = 100.0 * 21.0 / 78.0;
    bodies[1].speed_driven = carrier_driven;
    let mut meshes = Vec::new();
    for k in 0..3 {
        bodies.push(Body {
            planet: Some(Planet {
                carrier: 1,
                orbit_angle: 2.0 * PI * k as f64 / 3.0,
                m,
                pin_error_r: 0.0,
                pin_error_t: 0.0,
            }),
            // Rolling: in absolute speeds (sun and carrier clockwise, planets counter-
            // clockwise) w - w_c = -(21/18) (w_sun - w_c).
            w_start: 58.333333333333336,
            ..body(1e-4)
        });
        meshes.push(mesh(0, 2 + k, 0.0, &pair(21, 18, 0.5, 0.0, false)));
    }
    for k in 0..3 {
        meshes.push(mesh(2 + k, HOUSING, 0.0, &pair(18, 57, 0.0, 0.5, true)));
    }
    TrainSpec {
        bodies,
        angle_start: 0.0,
        shafts: vec![],
        meshes,
    }
}

/// lateral.md §7: a rigidly held sun among equally spaced identical planets in phase (21 / 3
/// an integer) feels no net force at any instant, and with it the ring (the housing's gear),
/// the carrier and the housing. The three meshes of a kind are the same equations; the
/// integrator holds each one's deflection to about its step count times rel_tol (1e-10 x
/// ~1e4 steps), so the forces cancel to 1e-6 of one mesh's force.
#[test]
fn a_held_sun_among_planets_in_phase_feels_no_force() {
    let spec = simple_set(0.3, false);
    let tau = vec![50.0, -185.714, 0.0, 0.0, 0.0];
    let spec = balanced(spec, &tau);
    let mut sim = TrainSimulation::new(spec, tau, None, 1, 0.0, 1e-10).unwrap();
    for k in 1..=40 {
        sim.advance(k as f64 * 2.5e-4, &mut |_, _| {}).unwrap();
        let y = sim.state();
        let mesh_force = sim.train().mesh_readout(0, &y).unwrap().flank_force[0];
        assert!(mesh_force > 100.0, "the sun carries load: {mesh_force}");
        let bf = sim.train().bearing_forces(&y).unwrap();
        let tol = 1e-6 * mesh_force;
        for (what, f) in [
            ("sun", bf.body[0]),
            ("carrier", bf.body[1]),
            ("housing", bf.housing),
        ] {
            assert!(
                close(f, [0.0, 0.0], tol),
                "step {k}: {what} {f:?} (tol {tol})"
            );
        }
        // Each planet's pin carries the tangential load of its two meshes.
        assert!(bf.body[2][1].abs() > 0.5 * mesh_force, "{:?}", bf.body[2]);
    }
}

/// lateral.md §7: a planet at carrier speed Omega: its pin carries the centripetal force
/// m R Omega^2 inwards on top of what balances its meshes. With the carrier driven at a
/// constant speed, the planets' mass changes no mesh force (their orbital inertia acts only
/// on the carrier, whose speed is given), so two runs with m = 0.3 kg and m = 0 differ in the
/// pin's radial force by exactly -m R Omega^2 and not in the tangential one; rounding of the
/// mesh forces (~1e-16 of them) is all that remains, 1e-12 of the force leaves room.
#[test]
fn a_planets_pin_carries_its_centripetal_force() {
    let tau = vec![50.0, 0.0, 0.0, 0.0, 0.0];
    let run = |m: f64| {
        let mut sim =
            TrainSimulation::new(simple_set(m, true), tau.clone(), None, 1, 0.0, 1e-9).unwrap();
        sim.advance(5e-3, &mut |_, _| {}).unwrap();
        let y = sim.state();
        (
            sim.train().bearing_forces(&y).unwrap(),
            sim.train().bodies(&y).w[1],
            sim.train().cfg.orbit_radius[2],
        )
    };
    let (heavy, omega, r) = run(0.3);
    let (light, omega_light, _) = run(0.0);
    assert_eq!(omega, omega_light);
    let centripetal = 0.3 * r * omega * omega;
    for i in 2..5 {
        let (h, l) = (heavy.body[i], light.body[i]);
        let tol = 1e-12 * (l[0].abs() + l[1].abs() + centripetal);
        assert!(
            (h[0] - l[0] + centripetal).abs() <= tol,
            "planet {}: radial {} vs {} (m R W^2 = {centripetal})",
            i + 1,
            h[0],
            l[0]
        );
        assert!((h[1] - l[1]).abs() <= tol, "planet {}: tangential", i + 1);
    }
}
