//! `damping_ratio` on a mesh (gearbox-file.md §3): the chi it sets gives the mesh's own mode
//! that fraction of critical damping at its mean stiffness under the static load. Checked
//! on a pair at rest in static balance, rung by a step of its load.

use gear_model::driver::train_simulation::TrainSimulation;
use gear_model::model::mesh::ContactModel;
use gear_model::model::static_mesh;
use gear_model::model::train::statics::static_start;
use spur_gear_train::build;
use spur_gear_train::gearbox::{params, start_values, Start};

const ZETA: f64 = 0.05;

/// A pinion (z 20) and a wheel (z 40) at rest, the pinion's 50 N m held by the wheel's brake.
fn text() -> String {
    format!(
        r#"
name = "Ringing"
[defaults]
module = 0.003
width = 0.02
[[body]]
name = "pinion"
J = 0.01
tau = 50.0
gear = {{ z = 20 }}
[[body]]
name = "wheel"
J = 0.05
tau = -100.0
gear = {{ z = 40 }}
[[mesh]]
gears = ["pinion", "wheel"]
damping_ratio = {ZETA}
"#
    )
}

/// The pair rings after its loads step by 10 % at t = 0: the dte's logarithmic decrement and
/// period give the damping ratio and the natural frequency omega_n of the mode it runs in,
/// at the stiffness where the pair stands. Hunt-Crossley's damping there is c = chi F1 (F1
/// the new load), so zeta = chi F1 / (2 omega_n m_eq): the decay must show it. The step is a
/// tenth of the load, so the law's stiffness and c vary by about that over a swing, with
/// first-order effects that cancel over a cycle; 3 % bounds the second-order rest and the
/// peaks' interpolation between samples (a 200th of a period).
///
/// And the chi set is 2 zeta sqrt(k m_eq) / F0 with k the mean tangent stiffness over a
/// mesh cycle at the static load F0 (static_mesh::cycle, here without tip relief), to
/// rounding: the mode has damping ratio zeta at its mean stiffness.
#[test]
fn damping_ratio_sets_chi_for_the_mesh_mode() {
    let v = start_values(&gearbox::parse(&text()).unwrap()).unwrap();
    let chi = match v.iter().find(|(n, _)| n == "mesh[1].chi") {
        Some((_, Start::Real(x))) => *x,
        other => panic!("{other:?}"),
    };
    let (p, inputs) = params(&v).unwrap();
    let loads = build::loads(&p, &inputs, &Default::default());
    let spec = static_start(build::spec(&p, &inputs).unwrap(), &loads).unwrap();
    let mut sim =
        TrainSimulation::new(spec.clone(), loads.tau.clone(), None, 1, 0.0, 1e-10).unwrap();
    sim.set_loads(loads.clone());
    let train = &sim.train();
    let r = train.mesh_readout(0, &sim.state()).unwrap();
    let f0 = r.flank_force[0] + r.flank_force[1];
    assert!(
        (f0 - 50.0 / train.meshes[0].geo.r_ab).abs() <= 1e-8 * f0,
        "{f0}"
    );
    let g = &train.meshes[0].geo;
    let ContactModel::Compliant(law) = &train.meshes[0].law else {
        panic!("a compliant law")
    };
    let k_mean = static_mesh::cycle(law, g, f0, 64).2;
    let m_eq = 1.0 / (g.r_ab.powi(2) / 0.01 + g.r_bb.powi(2) / 0.05);
    let want = 2.0 * ZETA * (k_mean * m_eq).sqrt() / f0;
    assert!(
        (chi - want).abs() <= 1e-12 * want,
        "chi {chi}, formula {want}"
    );

    // The new balance, at the same place (the pair stays at rest).
    let mut stepped = loads.clone();
    stepped.tau = vec![55.0, -110.0];
    let settled = static_start(spec, &stepped).unwrap();
    let dte_end = settled.meshes[0].dte_start;
    let f1 = 55.0 / g.r_ab;
    sim.set_loads(stepped);
    let omega_guess = (k_mean / m_eq).sqrt();
    let h = 2.0 * std::f64::consts::PI / omega_guess / 200.0;
    let x: Vec<f64> = (1..=2000)
        .map(|k| {
            sim.advance(k as f64 * h, &mut |_, _| {}).unwrap();
            sim.train().dte(0, &sim.state()) - dte_end
        })
        .collect();
    // Each maximum of x, refined by the parabola through it and its neighbours.
    let peaks: Vec<(f64, f64)> = (1..x.len() - 1)
        .filter(|&i| x[i] > x[i - 1] && x[i] >= x[i + 1] && x[i] > 0.0)
        .map(|i| {
            let (a, b, c) = (x[i - 1], x[i], x[i + 1]);
            let d = 0.5 * (a - c) / (a - 2.0 * b + c);
            ((i as f64 + d) * h, b - 0.25 * (a - c) * d)
        })
        .collect();
    assert!(peaks.len() >= 4, "{} maxima", peaks.len());
    let n = (peaks.len() - 1).min(4);
    let decrement = (peaks[0].1 / peaks[n].1).ln() / n as f64;
    let period = (peaks[n].0 - peaks[0].0) / n as f64;
    let zeta = decrement / (4.0 * std::f64::consts::PI.powi(2) + decrement.powi(2)).sqrt();
    let omega_n = 2.0 * std::f64::consts::PI / period / (1.0 - zeta * zeta).sqrt();
    let predicted = chi * f1 / (2.0 * omega_n * m_eq);
    assert!(
        (zeta / predicted - 1.0).abs() <= 0.03,
        "measured zeta {zeta}, Hunt-Crossley's {predicted} (omega_n {omega_n}, mean {omega_guess})"
    );
}

/// A mesh that carries no static load has no chi for a ratio: refused, naming the mesh by
/// the file's name and saying what to give instead.
#[test]
fn damping_ratio_on_an_unloaded_mesh_is_refused() {
    let idle = text()
        .replace("tau = 50.0", "tau = 0.0")
        .replace("tau = -100.0", "tau = 0.0");
    let e = start_values(&gearbox::parse(&idle).unwrap()).unwrap_err();
    assert!(
        e.contains("pinion_wheel") && e.contains("carries none") && e.contains("give chi"),
        "{e}"
    );
}
