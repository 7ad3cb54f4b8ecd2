//! A speed-driven body (gearbox-file.md §3): its speed is an input held over each
//! communication step, its drive's torque an output. Checked on the two-stage reducer of
//! tests/train.rs with the output wheel driven at a speed that changes every step.

use spur_gear_mesh::driver::train_simulation::TrainSimulation;
use spur_gear_mesh::driver::Vector;
use spur_gear_mesh::model::train::statics::static_start;
use spur_gear_mesh::model::train::{Body, MeshPlace, Ripple, Shaft, State, TrainSpec, W_EXT};
use spur_gear_mesh::variables::Params;

/// The reducer of tests/train.rs, undamped (no mesh damping, no shaft damper, no drag):
/// pinion 1 - wheel 2 = shaft = pinion 3 - wheel 4, wheel 4 speed-driven.
fn reducer() -> TrainSpec {
    let body = |j: f64, w: f64| Body {
        j,
        c: 0.0,
        w_start: w,
        ripple: Ripple::NONE,
        speed_driven: false,
        planet: None,
    };
    let stage = |a: usize, b: usize| MeshPlace {
        a,
        b,
        center_angle: 0.0,
        mount_a: 0.0,
        mount_b: 0.0,
        params: Params {
            chi: 0.0,
            ..Params::default()
        },
    };
    let mut spec = TrainSpec {
        bodies: vec![
            body(0.4, 100.0),
            body(2.0, 100.0 / 1.5),
            body(0.4, 100.0 / 1.5),
            body(2.0, 100.0 / 2.25),
        ],
        angle_start: 0.0,
        shafts: vec![Shaft {
            a: 1,
            b: 2,
            k: 1e5,
            d: 0.0,
            twist_start: 0.0,
        }],
        meshes: vec![stage(0, 1), stage(2, 3)],
    };
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
    let mut sim =
        TrainSimulation::new(reducer(), vec![100.0, 0.0, 0.0, 0.0], None, 1, 0.0, 1e-9).unwrap();
    let w0 = 100.0 / 2.25;
    let mut work_in_jumps = 0.0;
    for k in 1..=30 {
        let t = k as f64 * 1e-3;
        sim.advance(t, &mut |_, _| {}).unwrap();
        let y = sim.state();
        let b = sim.train.bodies(&y);
        let held = sim.train.loads.w_in[3];
        assert!(
            (b.w[3] - held).abs() <= 1e-13 * held,
            "step {k}: {} against {held}",
            b.w[3]
        );
        // A new speed, 5 % about the start's at 50 Hz.
        let mut loads = sim.train.loads.clone();
        loads.w_in[3] = w0 * (1.0 + 0.05 * (2.0 * std::f64::consts::PI * 50.0 * t).sin());
        let w_ext = y[W_EXT];
        sim.set_loads(loads.clone());
        let z = sim.state();
        let after = sim.train.bodies(&z);
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
    let (e_kin, _, residual) = sim.train.energy(&y).unwrap();
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
    let mut sim = TrainSimulation::new(reducer(), tau.clone(), None, 1, 0.0, 1e-9).unwrap();
    let spec = static_start(reducer(), &sim.train.loads).unwrap();
    sim = TrainSimulation::new(spec, tau, None, 1, 0.0, 1e-9).unwrap();
    let y = sim.state();
    let drive = sim.train.drive_torque(3, &y).unwrap();
    assert!((drive + 225.0).abs() <= 1e-8 * 225.0, "{drive}");
    let mut dy = State::zeros();
    sim.train.rhs(&y, &mut dy).unwrap();
    assert!(
        dy[W_EXT].abs() <= 1e-8 * 100.0 * 100.0,
        "no net power: {}",
        dy[W_EXT]
    );
}

/// Two speed drives joined by gear meshes alone are refused, naming the mesh and the body.
#[test]
fn two_speed_drives_in_one_mesh_are_refused() {
    let mut spec = reducer();
    spec.bodies[2].speed_driven = true;
    let e = TrainSimulation::new(spec, vec![0.0; 4], None, 1, 0.0, 1e-9).unwrap_err();
    assert!(
        e.message.contains("mesh[2]") && e.message.contains("body[3]"),
        "{}",
        e.message
    );
}
