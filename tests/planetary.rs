//! Planetary sets in the gear train (planetary.md §3-§4): what is refused at initialization,
//! each with the elements named, and what is built for a valid set (the coordinates, the
//! loop-closing meshes' start penetrations). The dynamic checks of §6 run on the FMU
//! (tests/python/test_planetary_checks.py).

mod train_parts;

use spur_gear_mesh::model::train::{
    coord_index, Body, MeshPlace, Planet, Shaft, Train, TrainSpec, HOUSING,
};
use spur_gear_mesh::table;
use spur_gear_mesh::variables::Params;
use std::f64::consts::PI;
use train_parts::{body, pair};

fn planet(carrier: usize, orbit_angle: f64) -> Body {
    Body {
        planet: Some(Planet {
            carrier,
            orbit_angle,
            m: 0.3,
            pin_error_r: 0.0,
            pin_error_t: 0.0,
        }),
        ..body(1e-4)
    }
}

fn mesh(a: usize, b: usize, params: Params) -> MeshPlace {
    MeshPlace {
        a,
        b,
        center_angle: 0.0,
        mount_a: 0.0,
        mount_b: 0.0,
        pair: table::pair(&params).unwrap(),
        dte_start: params.dte_start,
    }
}

/// Sun (body 1), carrier (body 2), planets (bodies 3...) at `orbits`, ring fixed (B = 0):
/// meshes 1..N sun-planet, N+1..2N planet-ring.
fn simple_set(orbits: &[f64]) -> TrainSpec {
    let mut bodies = vec![body(2e-3), body(0.05)];
    let mut meshes = Vec::new();
    for (k, &psi) in orbits.iter().enumerate() {
        bodies.push(planet(1, psi));
        meshes.push(mesh(0, 2 + k, pair(21, 18, 0.5, 0.0, false)));
    }
    for k in 0..orbits.len() {
        meshes.push(mesh(2 + k, HOUSING, pair(18, 57, 0.0, 0.5, true)));
    }
    TrainSpec {
        bodies,
        angle_start: 0.0,
        shafts: vec![],
        meshes,
    }
}

fn equally_spaced(n: usize) -> Vec<f64> {
    (0..n).map(|k| 2.0 * PI * k as f64 / n as f64).collect()
}

fn refused(spec: TrainSpec) -> String {
    let n = spec.bodies.len();
    Train::new(spec, vec![0.0; n], None).unwrap_err().message
}

#[test]
fn a_simple_set_is_built_with_its_loops_assembled() {
    let spec = simple_set(&equally_spaced(3));
    let (train, y) = Train::new(spec, vec![10.0, 0.0, 0.0, 0.0, 0.0], None).unwrap();
    // (21 + 57) / 3 = 26: every loop-closing sun mesh meets its planet as the first does, at
    // the placing dte_start = 0, up to the rounding of the angles (radii below 0.1 m, angles
    // below 2 pi: a few 1e-16 m per operation).
    for m in 0..6 {
        assert!(
            train.dte(m, &y).abs() < 1e-13,
            "mesh[{}]: {}",
            m + 1,
            train.dte(m, &y)
        );
    }
    // Five bodies, one rigid motion: the carrier's angle is the one free coordinate.
    assert_eq!(train.dim(), 2 + 2 * 5);
    // The planets sit at the nominal distance of the sun pair, which both pairs share.
    let r = train.cfg.orbit_radius[2];
    assert!((r - train.meshes[0].geo.d).abs() < 1e-15, "{r}");
    assert!(
        (r - train.meshes[3].geo.d).abs() < 1e-12 * r,
        "{r} vs {}",
        train.meshes[3].geo.d
    );
}

#[test]
fn a_planet_off_the_assembly_condition_is_refused_with_it() {
    let e = refused(simple_set(&[0.0, 2.0, 4.0]));
    assert!(e.contains("cannot be assembled as placed"), "{e}");
    assert!(e.contains("assembly condition"), "{e}");
    assert!(e.contains("(21 + 57)"), "{e}");
}

#[test]
fn jammed_bodies_are_named() {
    // Sun and ring both fixed: the planets and the carrier cannot turn.
    let mut spec = simple_set(&equally_spaced(3));
    for m in 0..3 {
        spec.meshes[m].a = HOUSING;
    }
    // Body 1, no longer meshed, is joined to the carrier by a shaft so that the train stays
    // one piece.
    spec.shafts.push(Shaft {
        a: 0,
        b: 1,
        k: 1e4,
        d: 0.0,
        twist_start: 0.0,
    });
    let e = refused(spec);
    assert!(
        e.contains("body[2], body[3], body[4], body[5] cannot turn"),
        "{e}"
    );
    // Three external gears in a triangle.
    let p = pair(20, 20, 0.0, 0.0, false);
    let mut m3 = mesh(2, 0, p.clone());
    m3.center_angle = 4.0 * PI / 3.0;
    let mut m2 = mesh(1, 2, p.clone());
    m2.center_angle = 2.0 * PI / 3.0;
    let spec = TrainSpec {
        bodies: vec![body(1.0); 3],
        angle_start: 0.0,
        shafts: vec![],
        meshes: vec![mesh(0, 1, p.clone()), m2, m3],
    };
    let e = refused(spec);
    assert!(e.contains("body[1], body[2], body[3] cannot turn"), "{e}");
}

#[test]
fn a_planet_meshing_with_a_gear_off_its_carriers_axis_is_refused() {
    // Body 6 is a housing gear meshing with the sun (so 41 mm from its axis) and also with
    // planet 3: it would have to sit on the carrier's axis.
    let mut spec = simple_set(&equally_spaced(3));
    spec.bodies.push(body(1e-3));
    spec.meshes.push(mesh(0, 5, pair(21, 20, 0.0, 0.0, false)));
    spec.meshes.push(mesh(2, 5, pair(18, 20, 0.0, 0.0, false)));
    let e = refused(spec);
    assert!(e.contains("the axes do not close"), "{e}");
    assert!(e.contains("mesh[7]") && e.contains("mesh[8]"), "{e}");
}

#[test]
fn counts_above_capacity_are_refused() {
    let mut spec = simple_set(&equally_spaced(3));
    while spec.meshes.len() <= 16 {
        spec.meshes.push(spec.meshes[0].clone());
    }
    let e = refused(spec);
    assert!(e.contains("n_meshes = 17: at most 16"), "{e}");
}

/// planetary.md §4: every mesh's dte keeps full precision however far the bodies turn. The
/// set's one rigid motion is coordinate 0 (the sun's angle); turned by 1e7 rad, every mesh's
/// dte, the loops' included, is the same to the bit, and the bodies' relative angles roll.
#[test]
fn every_dte_keeps_full_precision_however_far_the_bodies_turn() {
    let (train, y0) = Train::new(simple_set(&equally_spaced(3)), vec![0.0; 5], None).unwrap();
    let mut y = y0;
    y[coord_index(0)] += 1e7;
    for m in 0..6 {
        assert_eq!(
            train.dte(m, &y).to_bits(),
            train.dte(m, &y0).to_bits(),
            "mesh[{}]",
            m + 1
        );
    }
    // Willis: the carrier turned by z_sun / (z_sun + z_ring) of the sun, to the angles'
    // rounding (1e7 rad carries 2e-9 rad of ulp).
    let b = train.bodies(&y);
    let willis = 21.0 / (21.0 + 57.0);
    assert!(
        (b.theta[1] - willis * b.theta[0]).abs() < 1e-7,
        "{} vs {}",
        b.theta[1],
        willis * b.theta[0]
    );
}
