//! Lateral bodies (lateral.md §1-§3) against closed forms: a pinion's bearing at static load,
//! a planet's free vibration on a spinning carrier (Coriolis and centrifugal terms), the
//! centrifugal pin load, the energy balance of a lateral planetary set whose carrier
//! accelerates, and the refusals. Every tolerance states where it comes from.

mod train_parts;

use spur_gear_mesh::driver::train_simulation::{Compact, TrainRun, TrainSimulation};
use spur_gear_mesh::driver::Vector;
use spur_gear_mesh::model::geometry::Geometry;
use spur_gear_mesh::model::train::statics::static_start;
use spur_gear_mesh::model::train::{
    Body, Lateral, Planet, State, Train, TrainSpec, HOUSING, NY_COMPACT,
};
use spur_gear_mesh::table;
use spur_gear_mesh::variables::Params;
use std::f64::consts::PI;
use train_parts::{body, mesh, n_forward, pair};

const K_LUMPED: f64 = 4e8;

fn lumped(p: Params) -> Params {
    Params {
        contact_model: 4,
        k_lumped: K_LUMPED,
        ..p
    }
}

fn bearing(m: f64, k: [f64; 2], c: [f64; 2]) -> Option<Lateral> {
    Some(Lateral {
        m,
        k,
        c,
        q_start: [0.0; 2],
        v_start: [0.0; 2],
    })
}

fn pinion_pair() -> Params {
    lumped(Params {
        geometry: 2,
        module: 0.004,
        zA: 19,
        zB: 31,
        width: 0.03,
        ..Params::default()
    })
}

/// The pinion case: a pinion (body 1) on a bearing of stiffness (k_x, k_y) = (1e8, 2.5e8) N/m
/// and mass 3 kg meshing with a wheel on a rigid axis, O_A O_B at 0.7 rad, lumped mesh, 120
/// N.m balanced at rest: its force F = tau_A / rAb and forward direction n_f.
struct PinionCase {
    p: Params,
    g: Geometry,
    k: [f64; 2],
    m: f64,
    f: f64,
    n: [f64; 2],
}

impl PinionCase {
    fn new() -> PinionCase {
        let p = pinion_pair();
        let g = Geometry::new(&table::pair(&p).unwrap()).unwrap();
        let f = 120.0 / g.r_ab;
        let n = n_forward(g.alpha_w, 0.7, false);
        PinionCase {
            p,
            g,
            k: [1e8, 2.5e8],
            m: 3.0,
            f,
            n,
        }
    }

    /// The train started at the pinion's displacement q and the mesh's dte, and its torques.
    fn train(&self, q: [f64; 2], dte_start: f64) -> (TrainSpec, Vec<f64>) {
        let mut pinion = body(0.01);
        pinion.lateral = Some(Lateral {
            q_start: q,
            ..bearing(self.m, self.k, [0.0; 2]).unwrap()
        });
        let mut meshes = vec![mesh(0, 1, 0.7, &self.p)];
        meshes[0].dte_start = dte_start;
        let spec = TrainSpec {
            bodies: vec![pinion, body(0.05)],
            angle_start: 0.0,
            shafts: vec![],
            meshes,
        };
        (spec, vec![self.f * self.g.r_ab, -self.f * self.g.r_bb])
    }
}

/// The pinion case (`PinionCase`). The static state is closed form: the pinion's bearing
/// holds the mesh force -F n_f on it, so q = -F K^-1 n_f, the gain (Dp_A - Dp_B) . n_f = -F n_f . K^-1 n_f, and the spring's
/// deflection F / k_lumped is dte plus the gain. Started there, nothing accelerates: the
/// forces are a few products each, so 1e-12 of F / m (or F r / J) bounds their rounding.
#[test]
fn a_pinion_on_its_bearing_at_static_load() {
    let c = PinionCase::new();
    let (g, k, m, f, n) = (&c.g, c.k, c.m, c.f, c.n);
    let q = [-f * n[0] / k[0], -f * n[1] / k[1]];
    let gain = q[0] * n[0] + q[1] * n[1];
    let (spec, tau) = c.train(q, f / K_LUMPED - gain);
    let sim = TrainSimulation::new(spec, tau, None, 1, 0.0, 1e-10).unwrap();
    let y = sim.state();
    let train = &sim.train();
    assert_eq!(train.lateral_state(0, &y), [q[0], q[1], 0.0, 0.0]);
    assert_eq!(train.lateral_state(1, &y), [0.0; 4]);
    let rel = |a: f64, b: f64| (a - b).abs() <= 1e-12 * b.abs();
    assert!(
        rel(train.delta_lat(0, &y), gain),
        "{}",
        train.delta_lat(0, &y)
    );
    let bf = train.bearing_forces(&y).unwrap();
    for d in 0..2 {
        assert!(rel(bf.body[0][d], f * n[d]), "{:?} vs F n_f", bf.body[0]);
        // The wheel's rigid bearing holds +F n_f on B; the housing takes both reactions.
        assert!(rel(bf.body[1][d], -f * n[d]), "{:?}", bf.body[1]);
        assert!(bf.housing[d].abs() <= 1e-12 * f, "{:?}", bf.housing);
    }
    let mut dy = State::zeros();
    train.rhs(&y, &mut dy).unwrap();
    for i in 2..train.dim() {
        let scale = if i % 2 == 1 {
            f / m + f * g.r_ab / 0.01
        } else {
            1.0
        };
        assert!(
            dy[i].abs() <= 1e-12 * scale,
            "state {i}: {} ({scale})",
            dy[i]
        );
    }
    let (e_kin, e_el, _) = train.energy(&y).unwrap();
    assert_eq!(e_kin, 0.0);
    let want = 0.5 * f * f / K_LUMPED + 0.5 * (k[0] * q[0] * q[0] + k[1] * q[1] * q[1]);
    assert!(rel(e_el, want), "{e_el} vs {want}");
}

/// A sun (body 1) and a carrier (body 2, speed-driven at Omega) with one planet (body 3) on
/// an isotropic pin of stiffness k, all turning together: the planet's outward deflection
/// opens its mesh with the sun (moving B away from A opens both flanks), so its pin is all
/// that moves it. In the carrier's frame its displacement u
/// from the pin obeys u'' + 2 Omega S u' + (w^2 - Omega^2) u = Omega^2 R e_r (w^2 = k/m):
/// the static deflection is Omega^2 R / (w^2 - Omega^2) outwards and a perturbation turns
/// back by -Omega t an inertial isotropic oscillation at w:
/// u - u_s = Rot(-Omega t) (a cos wt + (a' + Omega S a) sin(wt) / w).
/// At rel_tol 1e-12 the integrator follows this to about 1e-9 of the amplitude over the 40
/// periods; 1e-7 leaves room for the error's growth with the steps.
fn spinning_planet(omega: f64, k: f64, m: f64, q0: [f64; 2], v0: [f64; 2]) -> TrainSimulation {
    let p = lumped(pair(21, 18, 0.5, 0.0, false));
    let mut carrier = body(0.05);
    carrier.w_start = omega;
    carrier.speed_driven = true;
    // Turning with its carrier: the planet's forward sense is the other one.
    let mut planet = body(1e-4);
    planet.w_start = -omega;
    planet.planet = Some(Planet {
        carrier: 1,
        orbit_angle: 0.3,
        m,
        pin_error_r: 0.0,
        pin_error_t: 0.0,
    });
    planet.lateral = Some(Lateral {
        q_start: q0,
        v_start: v0,
        ..bearing(m, [k, k], [0.0; 2]).unwrap()
    });
    let mut sun = body(2e-3);
    sun.w_start = omega;
    let spec = TrainSpec {
        bodies: vec![sun, carrier, planet],
        angle_start: 0.0,
        shafts: vec![],
        meshes: vec![mesh(0, 2, 0.0, &p)],
    };
    TrainSimulation::new(spec, vec![0.0; 3], None, 1, 0.0, 1e-12).unwrap()
}

#[test]
fn a_planet_on_its_pin_turns_with_coriolis_and_centrifugal_terms() {
    let (omega, k, m): (f64, f64, f64) = (400.0, 2e6, 0.3);
    let w = (k / m).sqrt();
    let r = spinning_planet(omega, k, m, [0.0; 2], [0.0; 2])
        .train()
        .cfg
        .orbit_radius[2];
    let u_s = omega * omega * r / (w * w - omega * omega);
    let (a, da) = ([2e-6, -1e-6], [3e-3, 1e-3]);
    let mut sim = spinning_planet(omega, k, m, [u_s + a[0], a[1]], da);
    // The carrier's counter-clockwise speed.
    let omega = sim.train().cfg.structure.sense[1] * omega;
    // a' + Omega S a, S the quarter turn.
    let b = [(da[0] - omega * a[1]) / w, (da[1] + omega * a[0]) / w];
    let amplitude = a[0].hypot(a[1]) + b[0].hypot(b[1]);
    let period = 2.0 * PI / w;
    for step in 1..=400 {
        let t = step as f64 * 0.1 * period;
        sim.advance(t, &mut |_, _| {}).unwrap();
        let z = [0, 1].map(|d| a[d] * (w * t).cos() + b[d] * (w * t).sin());
        let (s, c) = (-omega * t).sin_cos();
        let want = [u_s + c * z[0] - s * z[1], s * z[0] + c * z[1]];
        let got = sim.train().lateral_state(2, &sim.state());
        for d in 0..2 {
            assert!(
                (got[d] - want[d]).abs() <= 1e-7 * amplitude,
                "t = {t}: {:?} vs {want:?}",
                &got[..2]
            );
        }
    }
}

/// lateral.md §7, the centrifugal pin load: at rest in the carrier's frame the planet sits
/// where k zeta = m (R + zeta) Omega^2, so its pin's force on it is -m (R + zeta) Omega^2
/// radially: the centripetal m R Omega^2 with the spring's deflection added to the radius.
/// Started there nothing moves: over 1 ms the integrator holds the rest to its tolerance,
/// 1e-12, and 1e-9 leaves room for the rounding of the start.
#[test]
fn a_lateral_planets_pin_carries_its_centripetal_force() {
    let (omega, k, m): (f64, f64, f64) = (300.0, 5e7, 0.3);
    let r = spinning_planet(omega, k, m, [0.0; 2], [0.0; 2])
        .train()
        .cfg
        .orbit_radius[2];
    let zeta = m * r * omega * omega / (k - m * omega * omega);
    let mut sim = spinning_planet(omega, k, m, [zeta, 0.0], [0.0; 2]);
    sim.advance(1e-3, &mut |_, _| {}).unwrap();
    let y = sim.state();
    let centripetal = m * (r + zeta) * omega * omega;
    let bf = sim.train().bearing_forces(&y).unwrap().body[2];
    assert!((bf[0] + centripetal).abs() <= 1e-9 * centripetal, "{bf:?}");
    assert!(bf[1].abs() <= 1e-9 * centripetal, "{bf:?}");
    let q = sim.train().lateral_state(2, &y);
    assert!(
        (q[0] - zeta).abs() <= 1e-9 * zeta && q[1].abs() <= 1e-9 * zeta,
        "{q:?}"
    );
}

/// Sun (body 1), carrier (body 2) and three planets (bodies 3-5) 21/18/57, equally spaced,
/// the ring fixed, each mesh's pair given by `law`; planet 1 `pin_error_t` ahead.
fn three_planets(
    sun: Body,
    carrier: Body,
    planet: Body,
    pin_error_t: f64,
    law: impl Fn(Params) -> Params,
) -> TrainSpec {
    let mut bodies = vec![sun, carrier];
    let mut meshes = Vec::new();
    for k in 0..3 {
        let mut p = planet;
        p.planet = Some(Planet {
            carrier: 1,
            orbit_angle: 2.0 * PI * k as f64 / 3.0,
            m: 0.3,
            pin_error_r: 0.0,
            pin_error_t: if k == 0 { pin_error_t } else { 0.0 },
        });
        bodies.push(p);
        meshes.push(mesh(0, 2 + k, 0.0, &law(pair(21, 18, 0.5, 0.0, false))));
    }
    for k in 0..3 {
        meshes.push(mesh(
            2 + k,
            HOUSING,
            0.0,
            &law(pair(18, 57, 0.0, 0.5, true)),
        ));
    }
    TrainSpec {
        bodies,
        angle_start: 0.0,
        shafts: vec![],
        meshes,
    }
}

/// A lateral planetary set: sun (body 1) and carrier (body 2) on compliant bearings, three
/// planets on compliant pins, the ring fixed; Johnson meshes with damping and friction; the
/// sun's torque accelerates the carrier against its drag.
fn lateral_set(tau_sun: f64) -> (TrainSpec, Vec<f64>) {
    let mut sun = body(2e-3);
    sun.w_start = 100.0;
    sun.lateral = bearing(1.0, [1e8, 1e8], [200.0, 200.0]);
    let mut carrier = body(0.05);
    carrier.w_start = 100.0 * 21.0 / 78.0;
    carrier.c = 2.0;
    carrier.lateral = bearing(5.0, [2e8, 2e8], [0.0; 2]);
    let mut planet = body(1e-4);
    planet.w_start = 58.333333333333336;
    planet.lateral = bearing(0.3, [5e7, 3e7], [50.0, 0.0]);
    let friction = |p: Params| Params { mu: 0.05, ..p };
    let spec = three_planets(sun, carrier, planet, 5e-6, friction);
    (spec, vec![tau_sun, 0.0, 0.0, 0.0, 0.0])
}

/// lateral.md §7, energy with the Coriolis and centrifugal terms: the carrier accelerates
/// from 27 to 45 rad/s over 20 ms, the planets swing on their pins, the meshes rattle. The
/// balance E_kin + E_el + W_loss - W_ext closes to the integrator's error, which does not
/// accumulate systematically in it (1e-11 J of 110 J here). The smallest term it checks, the
/// torque of the carrier's turning line of action (F |q| ~ 1e-3 N.m), left out leaves 1.4e-7
/// J; a Coriolis term off by half, 2.4e-4 J. 1e-10 of the kinetic energy separates them.
#[test]
fn a_lateral_planetary_set_balances_its_energy() {
    let (spec, tau) = lateral_set(50.0);
    let mut sim = TrainSimulation::new(spec, tau, None, 1, 0.0, 1e-10).unwrap();
    for k in 1..=40 {
        sim.advance(k as f64 * 5e-4, &mut |_, _| {}).unwrap();
        let y = sim.state();
        let (e_kin, _, residual) = sim.train().energy(&y).unwrap();
        assert!(
            residual.abs() <= 1e-10 * e_kin,
            "t = {}: {residual} of {e_kin}",
            k as f64 * 5e-4
        );
    }
    let q = sim.train().lateral_state(2, &sim.state());
    assert!(
        q[0].abs() + q[1].abs() > 1e-7,
        "the planet swings on its pin: {q:?}"
    );
}

/// The state's two capacities (docs/lateral.md, "Capacity"): the energy test's set (5 bodies,
/// 15 coordinates) stepped on the full state gives the compact run's trace bit for bit, events
/// and all: components past `dim` take no part in any step, error norm or event. (A set of more
/// coordinates runs on the full state: tests/python/test_directional.py's Lin & Parker set,
/// tools/reliability.sh's memcheck.)
#[test]
fn the_full_state_steps_a_train_as_the_compact_one() {
    let (spec, tau) = lateral_set(50.0);
    let (train, y0) = Train::new(spec.clone(), tau.clone(), None).unwrap();
    assert!(train.dim() <= NY_COMPACT);
    let mut small = TrainRun::<Compact>::new(train.clone(), &y0, 1, 0.0, 1e-8);
    let mut full = TrainRun::<Train>::new(train, &y0, 1, 0.0, 1e-8);
    let (mut n_small, mut n_full) = (0, 0);
    for k in 1..=20 {
        small
            .advance(k as f64 * 5e-4, &mut |_, _| n_small += 1)
            .unwrap();
        full.advance(k as f64 * 5e-4, &mut |_, _| n_full += 1)
            .unwrap();
        assert_eq!(small.state().0, full.state().0, "t = {}", k as f64 * 5e-4);
    }
    assert!(
        n_small > 0 && n_small == n_full,
        "{n_small} and {n_full} events"
    );
    assert_eq!(small.driver.stats, full.driver.stats);

    let sim = TrainSimulation::new(spec, tau, None, 1, 0.0, 1e-8).unwrap();
    assert!(matches!(sim, TrainSimulation::Compact(_)));
}

/// fmi2DoStep's backup (`Clone::clone_from`, gear-model/src/model/train/copy.rs): a copy made
/// in place over an older one, whatever that held, equals the original and continues as it
/// does, bit for bit, events and all, at both capacities; over a copy of the other capacity it
/// takes the original's.
#[test]
fn a_copy_in_place_continues_as_the_original() {
    let (spec, tau) = lateral_set(50.0);
    let (train, y0) = Train::new(spec, tau, None).unwrap();
    let run = |full: bool| match full {
        false => TrainSimulation::Compact(TrainRun::new(train.clone(), &y0, 1, 0.0, 1e-8)),
        true => TrainSimulation::Full(Box::new(TrainRun::new(train.clone(), &y0, 1, 0.0, 1e-8))),
    };
    for full in [false, true] {
        let (mut sim, mut backup, mut other) = (run(full), run(full), run(!full));
        let mut events = 0;
        for k in 1..=10 {
            sim.advance(k as f64 * 5e-4, &mut |_, _| events += 1)
                .unwrap();
        }
        assert!(events > 0, "the copy is made after events");
        backup.clone_from(&sim);
        other.clone_from(&sim);
        assert!(backup == sim && other == sim, "full: {full}");
        for k in 11..=20 {
            let t = k as f64 * 5e-4;
            for s in [&mut sim, &mut backup, &mut other] {
                s.advance(t, &mut |_, _| {}).unwrap();
            }
            assert_eq!(backup.state().0, sim.state().0, "full: {full}, t = {t}");
            assert_eq!(other.state().0, sim.state().0, "full: {full}, t = {t}");
        }
        assert!(backup == sim && other == sim, "full: {full}");
    }
}

/// The refusals of lateral.md §1, each naming the body and the number.
#[test]
fn bad_bearings_are_refused_with_the_body_and_the_number() {
    let refused = |spec: TrainSpec, want: &str| {
        let n = spec.bodies.len();
        let e = TrainSimulation::new(spec, vec![0.0; n], None, 1, 0.0, 1e-8)
            .err()
            .expect("refused");
        assert!(e.message.contains(want), "{} (wanted {want})", e.message);
    };
    let pinion = |l: Option<Lateral>| {
        let mut b = body(0.01);
        b.lateral = l;
        TrainSpec {
            bodies: vec![b, body(0.05)],
            angle_start: 0.0,
            shafts: vec![],
            meshes: vec![mesh(0, 1, 0.7, &pinion_pair())],
        }
    };
    refused(
        pinion(bearing(3.0, [-1e8, 1e8], [0.0; 2])),
        "body[1].k_x = -100000000",
    );
    refused(
        pinion(bearing(3.0, [1e8, 1e8], [0.0, -5.0])),
        "body[1].c_y = -5",
    );
    refused(pinion(bearing(0.0, [1e8, 1e8], [0.0; 2])), "body[1].m = 0");
    refused(
        pinion(bearing(3.0, [1e8, f64::NAN], [0.0; 2])),
        "body[1].k_y = NaN",
    );
    // One mesh holds a floating pinion along its line of action only.
    refused(
        pinion(bearing(3.0, [0.0, 0.0], [0.0; 2])),
        "body[1]: floating at",
    );
    // A floating sun between two opposite planets (lateral.md §1).
    let (mut spec, _) = lateral_set(0.0);
    spec.bodies[0].lateral = bearing(1.0, [0.0, 0.0], [0.0; 2]);
    spec.bodies.remove(4);
    spec.meshes.retain(|m| m.a != 4 && m.b != 4);
    spec.bodies[3].planet.as_mut().unwrap().orbit_angle = PI;
    refused(spec, "body[1]: floating at");
    // A lateral carrier on rigid pins.
    let (mut spec, _) = lateral_set(0.0);
    spec.bodies[3].lateral = None;
    refused(
        spec,
        "body[2].lateral = true: a lateral carrier needs lateral planets",
    );
}

/// Three planets hold a floating sun in every direction: accepted.
#[test]
fn a_floating_sun_among_three_planets_is_held() {
    let (mut spec, tau) = lateral_set(50.0);
    spec.bodies[0].lateral = bearing(1.0, [0.0, 0.0], [0.0; 2]);
    TrainSimulation::new(spec, tau, None, 1, 0.0, 1e-8).unwrap();
}

/// The static start solves for the lateral displacements too (gearbox-file.md §3): on the
/// pinion of `a_pinion_on_its_bearing_at_static_load` it finds that test's closed form. It
/// balances the accelerations to 1e-10 of the elastic terms (statics.rs), so 1e-8 of q.
#[test]
fn the_static_start_finds_the_bearings_deflection() {
    let c = PinionCase::new();
    let (k, f, n) = (c.k, c.f, c.n);
    let (spec, tau) = c.train([0.0; 2], 0.0);
    let sim = TrainSimulation::new(spec.clone(), tau, None, 1, 0.0, 1e-10).unwrap();
    let solved = static_start(spec, &sim.train().loads).unwrap();
    let q = solved.bodies[0].lateral.unwrap().q_start;
    for d in 0..2 {
        let want = -f * n[d] / k[d];
        assert!((q[d] - want).abs() <= 1e-8 * want.abs(), "{q:?} vs {want}");
    }
    let gain = q[0] * n[0] + q[1] * n[1];
    let dte = solved.meshes[0].dte_start;
    assert!(
        (dte + gain - f / K_LUMPED).abs() <= 1e-8 * f / K_LUMPED,
        "{dte}"
    );
}

/// lateral.md §7, the floating sun: among three equally spaced planets on rigid pins, a sun
/// with no bearing stiffness shares the load equally whatever one planet's tangential pin
/// error e (the set is statically determinate); held rigidly, the same error unbalances the
/// shares. Equal up to the error's own geometry: it turns planet 1's line of action by
/// e / R = 2.3e-5 rad, so the sun's three forces are no longer exactly 120 deg apart and their
/// balance shifts the shares by that order; 3 e / R bounds it (the static start's own accuracy,
/// 1e-10 of the elastic terms, is far below). The rigid sun's unbalance is of order
/// k_mesh e / F = 4e8 x 1e-6 / 850, far above 10 % (a larger error unloads two planets
/// entirely, and their rotation in the backlash has no unique static balance).
#[test]
fn a_floating_sun_shares_the_load_equally() {
    let shares = |floating: bool| {
        let mut sun = body(2e-3);
        if floating {
            sun.lateral = bearing(1.0, [0.0, 0.0], [0.0; 2]);
        }
        let spec = three_planets(sun, body(0.05), body(1e-4), 1e-6, lumped);
        // The sun's 50 N.m against the carrier's (1 + 57/21) x 50 N.m: balanced at rest.
        let tau = vec![50.0, -50.0 * (1.0 + 57.0 / 21.0), 0.0, 0.0, 0.0];
        let sim = TrainSimulation::new(spec.clone(), tau.clone(), None, 1, 0.0, 1e-10).unwrap();
        let solved = static_start(spec, &sim.train().loads).unwrap();
        let sim = TrainSimulation::new(solved, tau, None, 1, 0.0, 1e-10).unwrap();
        let y = sim.state();
        let f = [0, 1, 2].map(|m| sim.train().mesh_readout(m, &y).unwrap().flank_force[0]);
        (f, sim.train().cfg.orbit_radius[2])
    };
    let (f, r) = shares(true);
    let mean = (f[0] + f[1] + f[2]) / 3.0;
    assert!(mean > 100.0, "{f:?}");
    let turn = 1e-6 / r;
    for x in f {
        assert!((x - mean).abs() <= 3.0 * turn * mean, "floating: {f:?}");
    }
    let (f, _) = shares(false);
    let mean = (f[0] + f[1] + f[2]) / 3.0;
    assert!((f[0] - mean).abs() > 0.1 * mean, "held: {f:?}");
}

/// The static start balances a floating sun whatever one planet's tangential pin error. The
/// error moves the sun's loop-closing meshes by as much as their deflections (~2 um): Newton
/// from its guess found the sun on one mesh (Johnson at 5 um: singular) or, at -5 um, where
/// the balance has a sun mesh's dte negative and only the sun's displacement loads it, kept
/// that dte on its flank and found none (statics.rs now keeps the whole penetration on its
/// flank and follows the balance from the set without pin errors). The balance is the
/// floating sun's: equal shares within 3 |e| / R, as in `a_floating_sun_shares_the_load_equally`,
/// with lumped meshes and with Johnson's law (the shares follow from the sun's statics alone).
#[test]
fn the_static_start_balances_a_floating_sun_with_pin_errors() {
    for (law, is_lumped) in [("lumped", true), ("Johnson", false)] {
        let pair_of = |p| if is_lumped { lumped(p) } else { p };
        for e in [2e-6, 5e-6, 10e-6, -5e-6] {
            let mut sun = body(2e-3);
            sun.lateral = bearing(1.0, [0.0, 0.0], [0.0; 2]);
            let spec = three_planets(sun, body(0.05), body(1e-4), e, pair_of);
            let tau = vec![50.0, -50.0 * (1.0 + 57.0 / 21.0), 0.0, 0.0, 0.0];
            let sim = TrainSimulation::new(spec.clone(), tau.clone(), None, 1, 0.0, 1e-10).unwrap();
            let solved = static_start(spec, &sim.train().loads)
                .unwrap_or_else(|err| panic!("{law}, e = {e}: {err}"));
            let sim = TrainSimulation::new(solved, tau, None, 1, 0.0, 1e-10).unwrap();
            let y = sim.state();
            let f = [0, 1, 2].map(|m| sim.train().mesh_readout(m, &y).unwrap().flank_force[0]);
            let mean = (f[0] + f[1] + f[2]) / 3.0;
            assert!(mean > 100.0, "{law}, e = {e}: {f:?}");
            let turn = e.abs() / sim.train().cfg.orbit_radius[2];
            for x in f {
                assert!(
                    (x - mean).abs() <= 3.0 * turn * mean,
                    "{law}, e = {e}: {f:?}"
                );
            }
        }
    }
}

/// The modes that set an explicit method's steps where the flanks in contact set them
/// (gear-model/src/model/train/modal.rs), in closed form: the pinion case on an isotropic
/// bearing k_b, undamped, meshing with a wheel whose speed is given. In mass-normalized
/// coordinates (sqrt(J) theta, sqrt(m) q) the stiffness is k g g^T plus k_b on q, with
/// g = (rAb / sqrt(J), n_f / sqrt(m)): the translation across n_f vibrates at sqrt(k_b / m),
/// the rotation with the translation along n_f at the roots of [[k rAb^2 / J, k rAb /
/// sqrt(J m)], [k rAb / sqrt(J m), (k + k_b) / m]]. Central differences are exact on linear
/// springs but for rounding (steps of 1e-3 of each coordinate's scale): 1e-6 is far above it.
#[test]
fn the_modes_that_limit_the_steps_are_the_pinions_closed_form() {
    let c = PinionCase::new();
    let k_b = 1.5e8;
    let p = Params {
        c_lumped: 0.0,
        ..c.p
    };
    let mut pinion = body(0.01);
    pinion.lateral = bearing(c.m, [k_b, k_b], [0.0; 2]);
    let mut wheel = body(0.05);
    wheel.speed_driven = true;
    let mut meshes = vec![mesh(0, 1, 0.7, &p)];
    meshes[0].dte_start = c.f / K_LUMPED;
    let spec = TrainSpec {
        bodies: vec![pinion, wheel],
        angle_start: 0.0,
        shafts: vec![],
        meshes,
    };
    let (train, _) = Train::new(spec, vec![c.f * c.g.r_ab, 0.0], None).unwrap();
    let mut found: Vec<f64> = train
        .limiting_modes()
        .expect("a lateral train of constant lumped meshes")
        .iter()
        .map(|&(w, _)| w)
        .filter(|&w| w > 1.0)
        .collect();
    found.sort_by(f64::total_cmp);
    let (j, m, r) = (0.01, c.m, c.g.r_ab);
    let (a, d, b) = (
        K_LUMPED * r * r / j,
        (K_LUMPED + k_b) / m,
        K_LUMPED * r / (j * m).sqrt(),
    );
    let root = (0.25 * (a - d) * (a - d) + b * b).sqrt();
    let mut want = [
        (0.5 * (a + d) - root).sqrt(),
        (k_b / m).sqrt(),
        (0.5 * (a + d) + root).sqrt(),
    ];
    want.sort_by(f64::total_cmp);
    assert_eq!(found.len(), 3, "{found:?}");
    for (f, w) in found.iter().zip(want) {
        assert!((f - w).abs() <= 1e-6 * w, "{found:?} vs {want:?}");
    }
}

/// The modal step limit where it sets the steps: a planetary set of constant lumped meshes
/// with sun, carrier and planets lateral (isotropic bearings on the housing's axes), in static
/// balance at rest (`static_start`), its sun's centre pushed at 1e-8 m/s (1e-7 of its
/// vibration's velocity scale) so that its modes ring at an amplitude the error control at
/// rel_tol 1e-6 hardly resolves. The run takes fewer steps than the trace's bound would allow
/// (the modal limit set them), and its states follow a run whose steps are held to 1 us at
/// rel_tol 1e-10: at rel_tol 1e-6 each of its 700 steps adds at most about 1e-6 of a
/// coordinate's scale (its error tolerance at rel_tol 1), so 1e-3 of the larger of that scale
/// and the coordinate's range. (That the limit lies inside the method's stability region is
/// the region table's test, dopri5.rs, and the modes' closed form above; past it, here, the
/// error control would cut the steps back with rejections.)
#[test]
fn the_modal_step_limit_keeps_a_ringing_set_stable_and_accurate() {
    let constant = |p: Params| Params {
        c_lumped: 500.0,
        ..lumped(p)
    };
    let mut sun = body(2e-3);
    sun.lateral = bearing(1.0, [1e8, 1e8], [200.0, 200.0]);
    let mut carrier = body(0.05);
    carrier.lateral = bearing(5.0, [2e8, 2e8], [300.0, 300.0]);
    let mut planet = body(1e-4);
    planet.lateral = bearing(0.3, [5e7, 3e7], [50.0, 20.0]);
    let spec = three_planets(sun, carrier, planet, 1e-6, constant);
    let tau = vec![50.0, -50.0 * (1.0 + 57.0 / 21.0), 0.0, 0.0, 0.0];
    let at_rest = TrainSimulation::new(spec.clone(), tau.clone(), None, 1, 0.0, 1e-10).unwrap();
    let mut spec = static_start(spec, &at_rest.train().loads).unwrap();
    spec.bodies[0].lateral.as_mut().unwrap().v_start = [1e-8, 0.0];
    let stop = 2e-2;
    let run = |rtol: f64, cap: f64| {
        let mut sim = TrainSimulation::new(spec.clone(), tau.clone(), None, 1, 0.0, rtol).unwrap();
        match &mut sim {
            TrainSimulation::Compact(r) => r.driver.max_step = cap,
            TrainSimulation::Full(r) => r.driver.max_step = cap,
        }
        let trace: Vec<State> = (1..=20)
            .map(|k| {
                sim.advance(k as f64 * stop / 20.0, &mut |_, _| {}).unwrap();
                sim.state()
            })
            .collect();
        (sim, trace)
    };
    let (sim, fast) = run(1e-6, f64::INFINITY);
    let train = sim.train();
    assert!(train.limiting_modes().is_some());
    let y = sim.state();
    let stability = spur_gear_mesh::driver::dopri5::STABILITY;
    let (modal, trace_bound) = (
        train.max_step(&y, Some(stability)),
        stability.reach / train.vibration_frequency(&y),
    );
    assert!(modal > 1.5 * trace_bound, "{modal} against {trace_bound}");
    // Fewer steps than the trace's bound allows: the modal limit set them.
    let steps = sim.stats().steps as f64;
    assert!(
        steps < stop / trace_bound,
        "{steps} steps of at most {trace_bound} s"
    );
    let (_, fine) = run(1e-10, 1e-6);
    let scale = train.abs_tol(1.0);
    for i in 2..train.dim() {
        let (lo, hi) = fine
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), y| {
                (l.min(y[i]), h.max(y[i]))
            });
        let tol = 1e-3 * (hi - lo).max(scale[i]);
        for (k, (a, b)) in fast.iter().zip(&fine).enumerate() {
            assert!(
                (a[i] - b[i]).abs() <= tol,
                "state {i} at point {k}: {} vs {} ({tol})",
                a[i],
                b[i]
            );
        }
    }
}
