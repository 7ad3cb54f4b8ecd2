//! The right-hand side of contact model 3 against contact model 1's (issue 9, point 1: at most
//! 1.2 times), on the standard pair (geometry 2, 22/33, module 10 mm) at states along one mesh
//! cycle of a loaded, damped run with friction: `PaperRig::rhs` alone, both models in the same
//! process, interleaved, medians of repeated timings. Since Johnson's law reads the W_-1 table
//! too (issue 12), the ratio reads about 1.65: see docs/tooth-structure.md, "Stiffness and cost".
//!
//! Also `PaperRig::rhs` of the paper rig's scenes (paper-m2 and damped: Johnson, no friction) over one
//! base pitch, the cost per evaluation behind the floors in docs/integrators.md.
//!
//! And the gear train's right-hand side (issue 23, point 6): a chain of n paper meshes
//! (n = 1, 2, 4, 6) against n times the paper rig's, interleaved in the same process. The
//! train's own work (walking the tree for the bodies' angles and speeds, the torques on the
//! bodies) comes on top of the meshes'.
//!
//! And an internal pair (planetary.md §1) against the external pair of the same gear data
//! (issue 30, point 6: within 5 %): 20/60, module 2 mm, xB = 0.5, damped, with friction, at
//! states over the double-contact zone, interleaved in the same process.
//!
//! And a planetary set (issue 31, point 7: at most 1.15 x 8 times one mesh's right-hand side,
//! plus the bodies' own work): sun 24, four planets 20, ring 64 fixed (module 2 mm, x 0.5 / 0 /
//! 0.5; scenes/train/planetary-mounted.toml's gears, (24 + 64)/4 = 22 assembles), 8 meshes at a loaded penetration, against 4 x (sun pair) + 4 x (ring pair) of
//! `PaperRig::rhs` on the same pairs at the same penetration, interleaved.
//!
//! Run: `cargo bench --bench rhs_cost`.

use spur_gear_mesh::model::paper_rig::{DTE, THETA_A};
use spur_gear_mesh::model::train::{
    self, Body, MeshPlace, Planet, Ripple, Train, TrainSpec, HOUSING,
};
use spur_gear_mesh::model::{PaperRig, State, NY};
use spur_gear_mesh::table;
use spur_gear_mesh::variables::{Inputs, Params};
use std::hint::black_box;
use std::time::Instant;

/// PaperRig and states at 64 positions over the double-contact zone (f1 from s_a, f2 a pitch ahead,
/// until f2 reaches s_b), at a penetration of the load's order: two pairs carry, the case where
/// contact model 3 does twice the per-pair work of Johnson's one evaluation per flank.
fn setup(contact_model: i32) -> (PaperRig, Vec<State>) {
    let p = Params {
        geometry: 2,
        contact_model,
        chi: 0.2,
        mu: 0.05,
        w_A_start: 100.0,
        w_B_start: 100.0 / 1.5,
        ..Params::default()
    };
    let i = Inputs {
        tau_A: 1000.0,
        ..Inputs::default()
    };
    let delta = 6e-6;
    let p = Params {
        dte_start: delta,
        ..p
    };
    let (mesh, y0) = table::paper_rig(&p, &i).unwrap();
    let g = &mesh.geo;
    let states = (0..64)
        .map(|k| {
            let mut y = y0;
            y[THETA_A] += k as f64 / 64.0 * (g.s_b - g.s_a - g.p_b) / g.r_ab;
            y[DTE] = delta;
            y
        })
        .collect();
    (mesh, states)
}

/// docs/internal-pair.md's ring pair (20/60, module 2 mm, xB = 0.5) as an internal pair, or as an external
/// pair of the same gear data, at 64 positions over the double-contact zone at a loaded
/// penetration: both do one law evaluation per flank and two pairs' friction.
fn pair_setup(internal: bool, mu: f64, v_reg: f64) -> (PaperRig, Vec<State>) {
    let delta = 1e-6;
    let p = Params {
        geometry: 2,
        internal,
        module: 0.002,
        zA: 20,
        zB: 60,
        xB: 0.5,
        width: 0.02,
        J_A: 5e-3,
        J_B: 0.5,
        chi: 20.0,
        mu,
        v_reg,
        w_A_start: 60.0,
        w_B_start: 20.0,
        dte_start: delta,
        ..Params::default()
    };
    let i = Inputs {
        tau_A: 20.0,
        ..Inputs::default()
    };
    let (mesh, y0) = table::paper_rig(&p, &i).unwrap();
    let g = &mesh.geo;
    let states = (0..64)
        .map(|k| {
            let mut y = y0;
            y[THETA_A] += k as f64 / 64.0 * (g.s_b - g.s_a - g.p_b) / g.r_ab;
            y[DTE] = delta;
            y
        })
        .collect();
    (mesh, states)
}

/// The paper rig as scenes/paper-m2.toml and damped.toml set it, at 64 positions over one base
/// pitch (single and double contact in the scenes' proportion) at the quasi-static penetration.
fn paper_setup(chi: f64) -> (PaperRig, Vec<State>) {
    let delta = 5.592370531367129e-7;
    let p = Params {
        c_load: 2.0,
        backlash: 1e-4,
        chi,
        w_A_start: 100.0,
        w_B_start: 100.0 / 1.5,
        dte_start: delta,
        ..Params::default()
    };
    let i = Inputs {
        tau_A: 100.0,
        ..Inputs::default()
    };
    let (mesh, y0) = table::paper_rig(&p, &i).unwrap();
    let g = &mesh.geo;
    let states = (0..64)
        .map(|k| {
            let mut y = y0;
            y[THETA_A] += k as f64 / 64.0 * g.p_b / g.r_ab;
            y[DTE] = delta;
            y
        })
        .collect();
    (mesh, states)
}

/// A chain of n damped paper meshes on n + 1 bodies (each at the damped scene's quasi-static
/// penetration), at 64 positions of body 1 over one base pitch of mesh 1.
fn train_setup(n: usize) -> (Train, Vec<train::State>) {
    let delta = 5.592370531367129e-7;
    let pair = Params {
        chi: 10.0,
        dte_start: delta,
        ..Params::default()
    };
    let bodies = (0..=n)
        .map(|i| Body {
            j: if i == 0 { 0.4 } else { 2.0 },
            c: if i == n { 2.0 } else { 0.0 },
            w_start: 100.0 / 1.5f64.powi(i as i32),
            ripple: Ripple::NONE,
            speed_driven: false,
            lateral: None,
            planet: None,
        })
        .collect();
    let meshes = (0..n)
        .map(|m| MeshPlace {
            a: m,
            b: m + 1,
            center_angle: 0.0,
            mount_a: 0.0,
            mount_b: 0.0,
            pair: table::pair(&pair).unwrap(),
            dte_start: pair.dte_start,
        })
        .collect();
    let spec = TrainSpec {
        bodies,
        angle_start: 0.0,
        shafts: vec![],
        meshes,
    };
    let mut tau = vec![0.0; n + 1];
    tau[0] = 100.0;
    let (t, y0) = Train::new(spec, tau, None).unwrap();
    let g = t.meshes[0].geo.clone();
    let states = (0..64)
        .map(|k| {
            let mut y = y0;
            // Coordinate 0 is body 1's angle.
            y[train::coord_index(0)] += k as f64 / 64.0 * g.p_b / g.r_ab;
            y
        })
        .collect();
    (t, states)
}

/// The planetary set and states at 64 positions of the sun over one base pitch; and the
/// paper rig on its sun pair and on its ring pair at the same penetration.
#[allow(clippy::type_complexity)]
fn planetary_setup() -> (Train, Vec<train::State>, [(PaperRig, Vec<State>); 2]) {
    let delta = 1.5e-6;
    let pair = |z_a: i32, z_b: i32, x_a: f64, x_b: f64, internal: bool| Params {
        geometry: 2,
        module: 0.002,
        zA: z_a,
        zB: z_b,
        xA: x_a,
        xB: x_b,
        width: 0.02,
        backlash: 5e-5,
        chi: 20.0,
        mu: 0.05,
        internal,
        dte_start: delta,
        w_A_start: 100.0,
        w_B_start: 100.0 * z_a as f64 / z_b as f64,
        ..Params::default()
    };
    let (sun, ring) = (pair(24, 20, 0.5, 0.0, false), pair(20, 64, 0.0, 0.5, true));
    let body = |j: f64, w: f64, planet: Option<Planet>| Body {
        j,
        c: 0.0,
        w_start: w,
        ripple: Ripple::NONE,
        speed_driven: false,
        lateral: None,
        planet,
    };
    let mut bodies = vec![
        body(2e-3, 100.0, None),
        body(0.05, 100.0 * 24.0 / 88.0, None),
    ];
    let mut meshes = Vec::new();
    let place = |a: usize, b: usize, params: &Params| MeshPlace {
        a,
        b,
        center_angle: 0.0,
        mount_a: 0.0,
        mount_b: 0.0,
        pair: table::pair(params).unwrap(),
        dte_start: params.dte_start,
    };
    for k in 0..4 {
        bodies.push(body(
            1e-4,
            0.0,
            Some(Planet {
                carrier: 1,
                orbit_angle: std::f64::consts::FRAC_PI_2 * k as f64,
                m: 0.3,
                pin_error_r: 0.0,
                pin_error_t: 0.0,
            }),
        ));
        meshes.push(place(0, 2 + k, &sun));
        meshes.push(place(2 + k, HOUSING, &ring));
    }
    let spec = TrainSpec {
        bodies,
        angle_start: 0.0,
        shafts: vec![],
        meshes,
    };
    let (t, y0) = Train::new(spec, vec![50.0, 0.0, 0.0, 0.0, 0.0, 0.0], None).unwrap();
    let p_b = t.meshes[0].geo.p_b;
    let r_sun = t.meshes[0].geo.r_ab;
    let states = (0..64)
        .map(|k| {
            let mut y = y0;
            // Coordinate 0 is the sun's angle: the set turns rigidly.
            y[train::coord_index(0)] += k as f64 / 64.0 * p_b / r_sun;
            y
        })
        .collect();
    let rig = |p: &Params| {
        let (m, y0) = table::paper_rig(p, &Inputs::default()).unwrap();
        let g = m.geo.clone();
        let st = (0..64)
            .map(|k| {
                let mut y = y0;
                y[THETA_A] += k as f64 / 64.0 * g.p_b / g.r_ab;
                y[DTE] = delta;
                y
            })
            .collect();
        (m, st)
    };
    (t, states, [rig(&sun), rig(&ring)])
}

fn time_train(t: &Train, states: &[train::State], reps: usize) -> f64 {
    let mut dy = <train::State as spur_gear_mesh::driver::Vector>::zeros();
    let start = Instant::now();
    for _ in 0..reps {
        for y in states {
            t.rhs(black_box(y), &mut dy).unwrap();
            black_box(&dy);
        }
    }
    start.elapsed().as_secs_f64() * 1e9 / (reps * states.len()) as f64
}

fn time(mesh: &PaperRig, states: &[State], reps: usize) -> f64 {
    let mut dy = [0.0; NY];
    let start = Instant::now();
    for _ in 0..reps {
        for y in states {
            mesh.rhs(black_box(y), &mut dy).unwrap();
            black_box(&dy);
        }
    }
    start.elapsed().as_secs_f64() * 1e9 / (reps * states.len()) as f64
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let (m1, s1) = setup(1);
    let (m3, s3) = setup(3);
    let (mut t1, mut t3, mut ratio) = (Vec::new(), Vec::new(), Vec::new());
    for _ in 0..41 {
        let a = time(&m1, &s1, 2000);
        let b = time(&m3, &s3, 2000);
        t1.push(a);
        t3.push(b);
        ratio.push(b / a);
    }
    println!("PaperRig::rhs, standard pair 22/33, module 10 mm, damped, friction, 41 interleaved repetitions");
    println!(
        "contact model 1: {:.1} ns, contact model 3: {:.1} ns, model 3 / model 1: {:.2} (median of per-pair ratios; min {:.2}, max {:.2})",
        median(t1),
        median(t3),
        median(ratio.clone()),
        ratio.iter().cloned().fold(f64::INFINITY, f64::min),
        ratio.iter().cloned().fold(0.0, f64::max)
    );
    let (mu, su) = paper_setup(0.0);
    let (md, sd) = paper_setup(10.0);
    let (mut tu, mut td) = (Vec::new(), Vec::new());
    for _ in 0..41 {
        tu.push(time(&mu, &su, 2000));
        td.push(time(&md, &sd, 2000));
    }
    println!(
        "PaperRig::rhs, the paper rig over one base pitch, 41 repetitions: undamped (paper-m2) {:.1} ns, damped (chi = 10 s/m) {:.1} ns",
        median(tu),
        median(td)
    );
    // Friction's tanh(v_s/v_reg) costs what its argument asks: above 22 it saturates (cheap),
    // between about 0.55 and 22 it takes an exponential. An internal pair's flanks slide about
    // half as fast (dv_s/ds_A = w_A (rAb/rBb - 1) against -w_A (1 + rAb/rBb)) and its pitch
    // point lies in double contact here, so at the default v_reg more of its evaluations fall
    // in the exponential's range: physics, not overhead. With v_reg = 10 m/s both pairs'
    // arguments lie below 0.01, in the same branch: equal work.
    for (mu, v_reg) in [(0.0, 0.01), (0.05, 0.01), (0.05, 10.0)] {
        let (me, se) = pair_setup(false, mu, v_reg);
        let (mi, si) = pair_setup(true, mu, v_reg);
        let (mut te, mut ti, mut ratio) = (Vec::new(), Vec::new(), Vec::new());
        for _ in 0..41 {
            let a = time(&me, &se, 2000);
            let b = time(&mi, &si, 2000);
            te.push(a);
            ti.push(b);
            ratio.push(b / a);
        }
        println!(
            "PaperRig::rhs, 20/60 module 2 mm xB = 0.5, damped, mu = {mu}, v_reg = {v_reg} m/s, double contact, 41 interleaved repetitions: \
             external {:.1} ns, internal {:.1} ns, internal / external {:.3} (median of per-pair ratios; min {:.3}, max {:.3})",
            median(te),
            median(ti),
            median(ratio.clone()),
            ratio.iter().cloned().fold(f64::INFINITY, f64::min),
            ratio.iter().cloned().fold(0.0, f64::max)
        );
    }
    let (pt, ps, [(sun, ss), (ring, rs)]) = planetary_setup();
    let (mut tt, mut ratio) = (Vec::new(), Vec::new());
    for _ in 0..41 {
        let single = 4.0 * time(&sun, &ss, 1000) + 4.0 * time(&ring, &rs, 1000);
        let whole = time_train(&pt, &ps, 1000);
        tt.push(whole);
        ratio.push(whole / single);
    }
    println!(
        "Train::rhs, a planetary set of 4 planets (8 meshes, 6 bodies, friction, damping), 41 interleaved repetitions: {:.1} ns, \
         set / (4 x sun pair + 4 x ring pair of PaperRig::rhs) = {:.3} (median; min {:.3}, max {:.3})",
        median(tt),
        median(ratio.clone()),
        ratio.iter().cloned().fold(f64::INFINITY, f64::min),
        ratio.iter().cloned().fold(0.0, f64::max)
    );
    println!("Train::rhs, a chain of n damped paper meshes, against n x PaperRig::rhs (damped), 41 interleaved repetitions:");
    for n in [1, 2, 4, 6] {
        let (t, st) = train_setup(n);
        let (mut tt, mut ratio) = (Vec::new(), Vec::new());
        for _ in 0..41 {
            let single = time(&md, &sd, 1000);
            let whole = time_train(&t, &st, 1000);
            tt.push(whole);
            ratio.push(whole / (n as f64 * single));
        }
        println!(
            "  n = {n}: {:.1} ns, train / (n x single) = {:.2} (median; min {:.2}, max {:.2})",
            median(tt),
            median(ratio.clone()),
            ratio.iter().cloned().fold(f64::INFINITY, f64::min),
            ratio.iter().cloned().fold(0.0, f64::max)
        );
    }
}
