//! The gear train (gear-train.md) against the single mesh and against closed forms: the checks
//! of its §7 that need no reference trace. Every tolerance states where it comes from.

use spur_gear_mesh::driver::train_simulation::TrainSimulation;
use spur_gear_mesh::driver::Vector;
use spur_gear_mesh::model::contact::{BASE_EVENTS, N_EVENTS};
use spur_gear_mesh::model::geometry::Geometry;
use spur_gear_mesh::model::mesh::Placement;
use spur_gear_mesh::model::pair::{MeshLaw, Pair};
use spur_gear_mesh::model::train::statics::static_start;
use spur_gear_mesh::model::train::{
    placement, Body, MeshPlace, Ripple, Shaft, State, Train, TrainSpec, N_MARGINS, W_EXT,
};
use spur_gear_mesh::table;
use spur_gear_mesh::variables::{Inputs, Params};

/// The damped paper scene (scenes/damped.toml) as single-mesh parameters.
fn damped() -> Params {
    Params {
        c_load: 2.0,
        chi: 10.0,
        w_A_start: 100.0,
        w_B_start: 100.0 / 1.5,
        dte_start: 5.592370531367129e-07,
        ..Params::default()
    }
}

/// gear-train.md §4: body 1's start angle that puts f1 at point a and then turns A by
/// dte_start (the single mesh's start), in the frame of a mesh with centre angle 0 whose A
/// turns clockwise: tooth 0's forward root at psi - tA/2 must be phiA(f1) = alpha_w - s_a/rAb,
/// less dte_start/rAb.
fn single_mesh_angle(p: &Params) -> f64 {
    let g = Geometry::new(&table::pair(p).unwrap()).unwrap();
    g.alpha_w - g.s_a / g.r_ab + 0.5 * g.t_a - p.dte_start / g.r_ab
}

/// The single mesh as a train of two bodies: B's drag is c_load.
fn one_mesh_train(p: &Params) -> TrainSpec {
    one_mesh_train_mounted(p, 0.0)
}

/// The same with B's tooth 0 at `mount_b` from B's reference.
fn one_mesh_train_mounted(p: &Params, mount_b: f64) -> TrainSpec {
    TrainSpec {
        bodies: vec![
            Body {
                j: p.J_A,
                c: 0.0,
                w_start: p.w_A_start,
                ripple: Ripple::NONE,
                speed_driven: false,
                lateral: None,
                planet: None,
            },
            Body {
                j: p.J_B,
                c: p.c_load,
                w_start: p.w_B_start,
                ripple: Ripple::NONE,
                speed_driven: false,
                lateral: None,
                planet: None,
            },
        ],
        angle_start: single_mesh_angle(p),
        shafts: vec![],
        meshes: vec![MeshPlace {
            a: 0,
            b: 1,
            center_angle: 0.0,
            mount_a: 0.0,
            mount_b,
            pair: table::pair(p).unwrap(),
            dte_start: p.dte_start,
        }],
    }
}

/// The single mesh numbers B's teeth from the one in contact at the start (f1 holds A0/B0),
/// which faces A; a train's tooth 0 is the one nearest the body's reference (§4), so mount_B
/// = pi gives the single mesh's numbering (and with it its per-tooth pitch errors). Mount 0
/// pairs the same teeth physically, with B's numbers shifted by about zB/2.
#[test]
fn the_train_places_the_teeth_where_the_single_mesh_starts_them() {
    let p = damped();
    let g = Geometry::new(&table::pair(&p).unwrap()).unwrap();
    let shifted = one_mesh_train(&p);
    let start = placement::start_of(&shifted).unwrap();
    match start.meshes[0] {
        Placement::Teeth { b_fwd, b_bwd, .. } => {
            assert_eq!(b_fwd - b_bwd, 1, "b1 holds B's tooth before f1's");
            assert!((b_fwd - 16).abs() <= 1, "about zB/2 = 16.5 teeth: {b_fwd}");
        }
        other => panic!("{other:?}"),
    }
    let spec = one_mesh_train_mounted(&p, std::f64::consts::PI);
    let start = placement::start_of(&spec).unwrap();
    // f1 holds A0/B0 and b1 A1/B0 in the single mesh (contact.rs, `teeth`).
    match start.meshes[0] {
        Placement::Teeth { b_fwd, b_bwd, .. } => assert_eq!((b_fwd, b_bwd), (0, -1)),
        other => panic!("{other:?}"),
    }
    // B is placed within half a pitch of its reference.
    assert!(start.psi[1].abs() <= std::f64::consts::PI / g.z_b);
    let (train, _) = Train::new(spec, vec![100.0, 0.0], None).unwrap();
    let (rig, _) = table::paper_rig(&p, &Inputs::default()).unwrap();
    // The same contact points at t = 0 (the train's angles start at 0, the single mesh's A at
    // dte_start/rAb): they differ by rounding of numbers below 0.2 m.
    for k in 0..4 {
        let s_train = train.meshes[0].sigma[k];
        let s_rig = rig.sigma[k] + g.r_ab * p.dte_start / g.r_ab * [1.0, 1.0, -1.0, -1.0][k];
        assert!(
            (s_train - s_rig).abs() < 1e-15,
            "slot {k}: {s_train} vs {s_rig}"
        );
        assert_eq!(train.meshes[0].teeth(k), rig.teeth(k), "slot {k}");
    }
    assert_eq!(train.meshes[0].sign, rig.sign);
}

fn run_rig(p: &Params, rtol: f64, h: f64, n: usize) -> Vec<[f64; 4]> {
    let i = Inputs {
        tau_A: 100.0,
        ..Inputs::default()
    };
    run_rig_with(p, &i, rtol, h, n)
}

fn run_rig_with(p: &Params, i: &Inputs, rtol: f64, h: f64, n: usize) -> Vec<[f64; 4]> {
    let mut sim = table::simulation(p, i, 0.0, rtol).unwrap();
    (1..=n)
        .map(|k| {
            sim.advance(k as f64 * h, &mut |_, _| {}).unwrap();
            let r = sim.rig.readout(&sim.driver.state()).unwrap();
            [r.dte, r.w_a, r.w_b, r.mesh.flank_force[0]]
        })
        .collect()
}

fn run_train(
    spec: TrainSpec,
    tau: Vec<f64>,
    rtol: f64,
    h: f64,
    n: usize,
) -> (TrainSimulation, Vec<State>) {
    let mut sim = TrainSimulation::new(spec, tau, None, 1, 0.0, rtol).unwrap();
    let ys = (1..=n)
        .map(|k| {
            sim.advance(k as f64 * h, &mut |_, _| {}).unwrap();
            sim.state()
        })
        .collect();
    (sim, ys)
}

/// gear-train.md §7, first check: one mesh and two bodies placed as §4 says is the single
/// mesh. The right-hand sides agree to rounding at the start: the same coordinates, the train
/// multiplying by reciprocals where the rig divides (a few ulp of each term; the error's
/// acceleration is a difference of terms ~1.6 m/s^2, so 8 eps of their sum bounds it). The
/// traces of the damped scene agree to the integrators' accuracy: at rel_tol 1e-10 each run's
/// dte is within about 5 rel_tol of the range of the exact solution (docs/performance.md
/// measures 5.5e-6 at 1e-6 for this scene), so 1e-7 of the range leaves a factor 100 for the
/// error's growth at tight tolerances and the two step sequences.
#[test]
fn one_mesh_and_two_bodies_is_the_single_mesh() {
    let p = damped();
    let spec = one_mesh_train(&p);
    let (train, y) = Train::new(spec.clone(), vec![100.0, 0.0], None).unwrap();
    let i = Inputs {
        tau_A: 100.0,
        ..Inputs::default()
    };
    let (rig, yr) = table::paper_rig(&p, &i).unwrap();
    let (mut dy, mut dyr) = (<State as spur_gear_mesh::driver::Vector>::zeros(), [0.0; 9]);
    train.rhs(&y, &mut dy).unwrap();
    rig.rhs(&yr, &mut dyr).unwrap();
    // [w, dw, dte rate, d(dte rate)] of body 1 / wheel A.
    let g = &rig.geo;
    let acc_b = (g.r_ab * dyr[2] - dyr[3]) / g.r_bb;
    let scale = [
        1.0,
        dyr[2].abs(),
        1.0,
        g.r_ab * dyr[2].abs() + g.r_bb * acc_b.abs(),
    ];
    // The train's state: the quadratures, then body 1's angle and speed, the mesh's dte and rate.
    for (k, (a, b)) in [dy[2], dy[3], dy[4], dy[5]]
        .into_iter()
        .zip([dyr[0], dyr[2], dyr[1], dyr[3]])
        .enumerate()
    {
        assert!(
            (a - b).abs() <= 8.0 * f64::EPSILON * scale[k].max(b.abs()),
            "{k}: {a} vs {b}"
        );
    }
    traces_agree(&p, spec);
}

/// The single mesh's traces and the one-mesh train's agree to 1e-7 of dte's range and 1e-7 of
/// the speeds (see `one_mesh_and_two_bodies_is_the_single_mesh`).
fn traces_agree(p: &Params, spec: TrainSpec) {
    let (h, n) = (1e-4, 1000);
    let reference = run_rig(p, 1e-10, h, n);
    let (sim, ys) = run_train(spec, vec![100.0, 0.0], 1e-10, h, n);
    let range = reference.iter().map(|r| r[0]).fold(f64::MIN, f64::max)
        - reference.iter().map(|r| r[0]).fold(f64::MAX, f64::min);
    let mut worst: f64 = 0.0;
    for (r, y) in reference.iter().zip(&ys) {
        let b = sim.train().bodies(y);
        worst = worst.max((sim.train().dte(0, y) - r[0]).abs() / range);
        assert!((b.w[0] - r[1]).abs() <= 1e-7 * r[1].abs());
        assert!((b.w[1] - r[2]).abs() <= 1e-7 * r[2].abs());
    }
    assert!(worst <= 1e-7, "dte differs by {worst:e} of its range");
}

/// The lumped mesh (contact_model = 4), constant and as the square wave, is the same in a
/// train as in the single mesh (the argument above; its events are the same functions).
#[test]
fn a_lumped_mesh_in_a_train_is_the_single_lumped_mesh() {
    for varies in [false, true] {
        let p = Params {
            contact_model: 4,
            k_lumped_varies: varies,
            c_lumped: 2000.0,
            ..damped()
        };
        traces_agree(&p, one_mesh_train(&p));
    }
}

fn reducer(shaft_k: f64) -> TrainSpec {
    let body = |j: f64, c: f64, w: f64| Body {
        j,
        c,
        w_start: w,
        ripple: Ripple::NONE,
        speed_driven: false,
        lateral: None,
        planet: None,
    };
    let stage = |a: usize, b: usize| MeshPlace {
        a,
        b,
        center_angle: 0.0,
        mount_a: 0.0,
        mount_b: 0.0,
        pair: Pair {
            chi: 10.0,
            ..Pair::paper()
        },
        dte_start: 0.0,
    };
    TrainSpec {
        bodies: vec![
            body(0.4, 0.0, 100.0),
            body(2.0, 0.0, 100.0 / 1.5),
            body(0.4, 0.0, 100.0 / 1.5),
            body(2.0, 2.0, 100.0 / 2.25),
        ],
        angle_start: 0.0,
        shafts: vec![Shaft {
            a: 1,
            b: 2,
            k: shaft_k,
            d: 5.0,
            twist_start: 0.0,
        }],
        meshes: vec![stage(0, 1), stage(2, 3)],
    }
}

/// Rigid kinematics (gear-train.md §7): across every mesh the angles advance in the ratio of
/// the tooth counts. rAb dtheta_A - rBb dtheta_B = d(dte), so the ratio of the angle increments
/// differs from rBb/rAb = zB/zA by d(dte)/(rAb dtheta_B): dte stays within a few micrometres
/// while rAb dtheta_B is ~0.4 m over 0.05 s, a relative 1e-5; 1e-4 bounds it.
#[test]
fn every_mesh_turns_in_the_ratio_of_its_tooth_counts() {
    let (sim, ys) = run_train(reducer(1e5), vec![100.0, 0.0, 0.0, 0.0], 1e-8, 1e-3, 50);
    let (b0, b1) = (sim.train().bodies(&ys[9]), sim.train().bodies(&ys[49]));
    let d: Vec<f64> = (0..4).map(|i| b1.theta[i] - b0.theta[i]).collect();
    for (a, b) in [(0, 1), (2, 3)] {
        let ratio = d[a] / d[b];
        assert!((ratio - 1.5).abs() <= 1e-4 * 1.5, "bodies {a}/{b}: {ratio}");
    }
    // Speeds stay positive and the shaft twists under the load it carries.
    assert!(b1.w.iter().take(4).all(|&w| w > 0.0));
}

/// What a train does not use costs nothing per step (planetary.md §5): the driver's event
/// functions are those of the meshes in use, each mesh's as many as it can trigger (16 without
/// shape deviations, 32 with pitch errors), not the capacity's 16 x 32. Model Exchange's
/// indicators keep the capacity's layout, which their names give, with the same values and +1
/// where nothing is in use. `margin(i)` evaluates one active function by another code path: it
/// agrees to rounding (1e-12 of the margin, a length of millimetres or a factor of order 1).
#[test]
fn only_the_event_functions_in_use_are_carried() {
    let mut spec = reducer(1e5);
    spec.meshes[1].pair.a.pitch_errors = (0..22).map(|k| 1.5e-7 * (k as f64 * 0.9).sin()).collect();
    let (sim, ys) = run_train(spec, vec![100.0, 0.0, 0.0, 0.0], 1e-8, 1e-3, 20);
    let t = &sim.train();
    assert_eq!(t.n_event_fns(), BASE_EVENTS + N_EVENTS);
    for y in &ys {
        let mut packed = vec![f64::NAN; t.n_event_fns()];
        t.event_margins(y, &mut packed);
        let mut z = vec![f64::NAN; N_MARGINS];
        t.event_indicators(y, &mut z);
        for (i, &m) in packed.iter().enumerate() {
            let (mesh, e) = t.event_of(i);
            let expected = if i < BASE_EVENTS {
                (0, i)
            } else {
                (1, i - BASE_EVENTS)
            };
            assert_eq!((mesh, e), expected);
            assert_eq!(
                z[mesh * N_EVENTS + e].to_bits(),
                m.to_bits(),
                "indicator of {i}"
            );
            // The driver asks `margin(i)` only of active functions (inactive ones read +1).
            if m != 1.0 {
                let one = t.margin(i, y);
                assert!(
                    (one - m).abs() <= 1e-12 * m.abs().max(1.0),
                    "{i}: {one} against {m}"
                );
            }
        }
        let unused = (BASE_EVENTS..N_EVENTS).chain(2 * N_EVENTS..N_MARGINS);
        assert!(unused.into_iter().all(|k| z[k] == 1.0));
    }
}

/// Energy (gear-train.md §5): with mu = 0 and no damping anywhere, kinetic and elastic energy
/// change only by the external work and the gate's jumps. The residual is the integration
/// error of a conserved quantity: at rel_tol 1e-9 the energies (~1e4 J) drift by far less
/// than 1e-6 of them (the single mesh's energy test, tests/model_checks.rs, holds 1e-6 too).
#[test]
fn the_energy_balance_closes_with_shafts_and_meshes() {
    let sim = undamped_reducer_balance(Ripple::NONE);
    assert!(sim.train().n_events > 100, "pair switches in both meshes");
}

/// Runs the reducer without any damping (body 1 carrying `ripple`) and checks that its energy
/// residual stays within 1e-6 of the kinetic energy.
fn undamped_reducer_balance(ripple: Ripple) -> TrainSimulation {
    let mut spec = reducer(1e5);
    for m in &mut spec.meshes {
        m.pair.chi = 0.0;
    }
    spec.shafts[0].d = 0.0;
    spec.bodies[0].ripple = ripple;
    let (sim, ys) = run_train(spec, vec![100.0, 0.0, 0.0, 0.0], 1e-9, 1e-3, 30);
    let y = ys.last().unwrap();
    let (e_kin, _, residual) = sim.train().energy(y).unwrap();
    assert!(
        residual.abs() <= 1e-6 * e_kin,
        "residual {residual} J of E_kin {e_kin} J"
    );
    sim
}

/// A stiffer and stiffer shaft tends to one body of the summed inertia (gear-train.md §7): the
/// reducer with bodies 2 and 3 merged into one carrying both gears is the limit; the
/// difference in the output speed falls as the shaft stiffens.
#[test]
fn a_stiff_shaft_tends_to_one_body() {
    let mut merged = reducer(1e5);
    merged.bodies[1].j += merged.bodies[2].j;
    merged.bodies.remove(2);
    merged.shafts.clear();
    merged.meshes[1].a = 1;
    merged.meshes[1].b = 2;
    let tau = |n: usize| {
        let mut t = vec![0.0; n];
        t[0] = 100.0;
        t
    };
    let (h, n) = (1e-3, 20);
    let (msim, my) = run_train(merged, tau(3), 1e-9, h, n);
    let w_limit = msim.train().bodies(my.last().unwrap()).w[2];
    let mut last = f64::INFINITY;
    // Each shaft 10 % of critical damping on the reduced inertia J2 J3/(J2 + J3) = 1/3, so
    // its vibration dies out and the quasi-static twist T/k remains.
    for k in [1e6, 1e7, 1e8] {
        let mut spec = reducer(k);
        spec.shafts[0].d = 0.2 * (k / 3.0f64).sqrt();
        let (sim, ys) = run_train(spec, tau(4), 1e-9, h, n);
        let w = sim.train().bodies(ys.last().unwrap()).w[3];
        let diff = (w - w_limit).abs();
        assert!(diff < last, "k = {k}: {diff} not below {last}");
        last = diff;
    }
    // At k = 1e8 the shaft's frequency (~2e4 rad/s) is far above the mesh's: the output speed
    // differs from the one-body limit by a small fraction of its change over the run.
    assert!(last <= 1e-3 * w_limit, "{last} vs {w_limit}");
}

/// Rigid contact and a broken train are refused with the elements named.
#[test]
fn rigid_contact_and_broken_trains_are_refused() {
    let mut spec = reducer(1e5);
    spec.meshes[1].pair.law = MeshLaw::Rigid;
    let e = Train::new(spec, vec![0.0; 4], None).unwrap_err().message;
    assert!(
        e.contains("mesh[2].contact_model = 2") && e.contains("rigid"),
        "{e}"
    );
    let mut spec = reducer(1e5);
    // Mesh 2 from body 3 back to body 1 closes a loop and leaves body 4 alone.
    spec.meshes[1].b = 0;
    let e = Train::new(spec, vec![0.0; 4], None).unwrap_err().message;
    assert!(e.contains("body[4] joined to body[1] by no chain"), "{e}");
    let mut spec = reducer(1e5);
    spec.meshes[0].pair.a.z = 23;
    let e = Train::new(spec, vec![0.0; 4], None).unwrap_err().message;
    assert!(e.starts_with("mesh[1]:"), "{e}");
}

/// Contact model 3 and the shape deviations work per mesh: the structure-relief scene (the
/// tooth structure with tip relief, loaded from both wheels) and the damped scene with pitch
/// errors on both wheels, each as one mesh on two bodies with B's tooth 0 where the single mesh
/// numbers it (mount_B = pi, see the placement test), agree with the single mesh to the
/// integrators' accuracy (the bound's reasoning as in `one_mesh_and_two_bodies_is_the_single_mesh`).
#[test]
fn contact_model_3_and_deviations_work_per_mesh() {
    let structure = Params {
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
    let pitch = Params {
        pitch_errors_A: "1.3e-7, 1.7e-7, 1.4e-7, 8e-8, -1.3e-7, -2.4e-7, -9e-8, 3e-8, 1.2e-7, 2.3e-7, 1.1e-7, -1.3e-7, -1.7e-7, -1.4e-7, -8e-8, 1.3e-7, 2.4e-7, 9e-8, -3e-8, -1.2e-7, -2.3e-7, -1.1e-7".into(),
        pitch_errors_B: (0..33).map(|k| format!("{:e}", 1.5e-7 * (k as f64 * 0.7).sin())).collect::<Vec<_>>().join(", "),
        ..damped()
    };
    for (name, p, tau) in [
        ("structure-relief", structure, [225.0, -337.5]),
        ("pitch errors", pitch, [100.0, 0.0]),
    ] {
        let i = Inputs {
            tau_A: tau[0],
            tau_B: tau[1],
            ..Inputs::default()
        };
        let (h, n) = (1e-4, 300);
        let reference = run_rig_with(&p, &i, 1e-10, h, n);
        let spec = one_mesh_train_mounted(&p, std::f64::consts::PI);
        let (sim, ys) = run_train(spec, tau.to_vec(), 1e-10, h, n);
        let dte: Vec<f64> = reference.iter().map(|r| r[0]).collect();
        let range = dte.iter().cloned().fold(f64::MIN, f64::max)
            - dte.iter().cloned().fold(f64::MAX, f64::min);
        let worst = ys
            .iter()
            .zip(&dte)
            .map(|(y, d)| (sim.train().dte(0, y) - d).abs() / range)
            .fold(0.0, f64::max);
        assert!(
            worst <= 1e-7,
            "{name}: dte differs by {worst:e} of its range"
        );
    }
}

/// An angle-locked ripple on a lone body has a first integral: J (w^2 - w0^2) / 2 =
/// A/n (cos(phase) - cos(n theta + phase)). At rel_tol 1e-10 the two states of this smooth,
/// non-stiff system carry a global error of a few hundred rel_tol over the 0.05 s (about two
/// ripple periods); 1e-7 of the kinetic energy leaves a factor of 10 above that.
#[test]
fn a_ripple_on_a_lone_body_does_the_work_of_its_closed_form() {
    let ripple = Ripple {
        amplitude: 20.0,
        order: 2.0,
        phase: 0.3,
    };
    let (j, w0) = (0.01, 150.0);
    let spec = TrainSpec {
        bodies: vec![Body {
            j,
            c: 0.0,
            w_start: w0,
            ripple,
            speed_driven: false,
            lateral: None,
            planet: None,
        }],
        angle_start: 0.0,
        shafts: vec![],
        meshes: vec![],
    };
    let (sim, ys) = run_train(spec, vec![0.0], 1e-10, 1e-3, 50);
    let e0 = 0.5 * j * w0 * w0;
    let mut swing: f64 = 0.0;
    for y in &ys {
        let b = sim.train().bodies(y);
        let (theta, w) = (b.theta[0], b.w[0]);
        let work = ripple.amplitude / ripple.order
            * (ripple.phase.cos() - (ripple.order * theta + ripple.phase).cos());
        let e = 0.5 * j * w * w;
        assert!(
            (e - e0 - work).abs() <= 1e-7 * e0,
            "theta {theta}: kinetic energy change {} J, the ripple's work {work} J",
            e - e0
        );
        swing = swing.max(work.abs());
    }
    // The ripple did turn: its work reached most of its full swing 2 A/n.
    assert!(swing > 0.5 * ripple.amplitude, "{swing}");
}

/// With the ripple on body 1 the energy balance of the undamped reducer still closes: the
/// ripple's power is part of W_ext (same bound as the balance above).
#[test]
fn the_energy_balance_counts_the_ripples_work() {
    undamped_reducer_balance(Ripple {
        amplitude: 40.0,
        order: 2.0,
        phase: 0.0,
    });
}

// A speed-driven body (gearbox-file.md §3): its speed is an input held over each
// communication step, its drive's torque an output.

/// The reducer, undamped (no mesh damping, no shaft damper, no drag), wheel 4 speed-driven.
fn driven_reducer() -> TrainSpec {
    let mut spec = reducer(1e5);
    for m in &mut spec.meshes {
        m.pair.chi = 0.0;
    }
    spec.shafts[0].d = 0.0;
    spec.bodies[3].c = 0.0;
    spec.bodies[3].speed_driven = true;
    spec
}

/// The driven wheel turns at its input to rounding; when the input changes only its own
/// speed jumps (the shaft and meshes are compliant: no impulse reaches the others); and the
/// energy balance closes with the drive's work, the jumps' kinetic energy included, to the
/// bound tests/train.rs holds the undamped reducer to (1e-6 of the kinetic energy at rel_tol
/// 1e-9). A drive whose power or jumps went unbooked would leave a residual of the order of
/// the jumps' energy, 0.1 J per step here against E_kin of about 4e3 J.
#[test]
fn a_speed_driven_body_holds_its_input_and_its_drive_does_the_work() {
    let mut sim = TrainSimulation::new(
        driven_reducer(),
        vec![100.0, 0.0, 0.0, 0.0],
        None,
        1,
        0.0,
        1e-9,
    )
    .unwrap();
    let w0 = 100.0 / 2.25;
    let mut work_in_jumps = 0.0;
    for k in 1..=30 {
        let t = k as f64 * 1e-3;
        sim.advance(t, &mut |_, _| {}).unwrap();
        let y = sim.state();
        let b = sim.train().bodies(&y);
        let held = sim.train().loads.w_in[3];
        assert!(
            (b.w[3] - held).abs() <= 1e-13 * held,
            "step {k}: {} against {held}",
            b.w[3]
        );
        // A new speed, 5 % about the start's at 50 Hz.
        let mut loads = sim.train().loads.clone();
        loads.w_in[3] = w0 * (1.0 + 0.05 * (2.0 * std::f64::consts::PI * 50.0 * t).sin());
        let w_ext = y[W_EXT];
        sim.set_loads(loads.clone());
        let z = sim.state();
        let after = sim.train().bodies(&z);
        for i in 0..3 {
            assert!(
                (after.w[i] - b.w[i]).abs() <= 1e-13 * b.w[i].abs(),
                "body {}",
                i + 1
            );
        }
        assert_eq!(after.w[3], loads.w_in[3]);
        let jump = 0.5 * 2.0 * (after.w[3].powi(2) - b.w[3].powi(2));
        assert!((z[W_EXT] - w_ext - jump).abs() <= 1e-9 * jump.abs().max(1.0));
        work_in_jumps += jump.abs();
    }
    let y = sim.state();
    let (e_kin, _, residual) = sim.train().energy(&y).unwrap();
    assert!(work_in_jumps > 1.0, "the input moved: {work_in_jumps} J");
    assert!(
        residual.abs() <= 1e-6 * e_kin,
        "residual {residual} J of E_kin {e_kin} J"
    );
}

/// With a static start the driven wheel holds still against pinion 1's torque: the drive
/// takes the whole load, 100 N m times the ratio 1.5 x 1.5, to the balance's tolerance
/// (statics.rs: accelerations 1e-10 of the elastic terms).
#[test]
fn a_static_start_hands_the_load_to_the_drive() {
    let tau = vec![100.0, 0.0, 0.0, 0.0];
    let mut sim = TrainSimulation::new(driven_reducer(), tau.clone(), None, 1, 0.0, 1e-9).unwrap();
    let spec = static_start(driven_reducer(), &sim.train().loads).unwrap();
    sim = TrainSimulation::new(spec, tau, None, 1, 0.0, 1e-9).unwrap();
    let y = sim.state();
    let drive = sim.train().drive_torque(3, &y).unwrap();
    assert!((drive + 225.0).abs() <= 1e-8 * 225.0, "{drive}");
    let mut dy = State::zeros();
    sim.train().rhs(&y, &mut dy).unwrap();
    assert!(
        dy[W_EXT].abs() <= 1e-8 * 100.0 * 100.0,
        "no net power: {}",
        dy[W_EXT]
    );
}

/// Two speed drives joined by gear meshes alone are refused, naming the mesh and the body.
#[test]
fn two_speed_drives_in_one_mesh_are_refused() {
    let mut spec = driven_reducer();
    spec.bodies[2].speed_driven = true;
    let e = TrainSimulation::new(spec, vec![0.0; 4], None, 1, 0.0, 1e-9).unwrap_err();
    assert!(
        e.message.contains("mesh[2]") && e.message.contains("body[3]"),
        "{}",
        e.message
    );
}
