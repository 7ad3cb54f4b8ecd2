//! Parts of trains shared by the integration tests of planetary sets (tests/planetary.rs,
//! tests/bearing_forces.rs, tests/lateral.rs).
// Each test binary that includes this uses its own subset of it.
#![allow(dead_code)]

use spur_gear_mesh::model::train::{Body, MeshPlace, Ripple};
use spur_gear_mesh::table;
use spur_gear_mesh::variables::Params;

/// A pair of the worked set (scenes/train/planetary-simple.toml): module 2 mm, sun 21 teeth at
/// x = 0.5, planets 18 at x = 0, ring 57 at x = 0.5.
pub fn pair(z_a: i32, z_b: i32, x_a: f64, x_b: f64, internal: bool) -> Params {
    Params {
        geometry: 2,
        module: 0.002,
        zA: z_a,
        zB: z_b,
        xA: x_a,
        xB: x_b,
        width: 0.02,
        backlash: 5e-5,
        chi: 20.0,
        internal,
        ..Params::default()
    }
}

/// A body of inertia j at rest, without drag, ripple or drive, on a housing-fixed axis.
pub fn body(j: f64) -> Body {
    Body {
        j,
        c: 0.0,
        w_start: 0.0,
        ripple: Ripple::NONE,
        speed_driven: false,
        lateral: None,
        planet: None,
    }
}

/// Mesh of the pair p between bodies a and b, O_A O_B at `center_angle`.
pub fn mesh(a: usize, b: usize, center_angle: f64, p: &Params) -> MeshPlace {
    MeshPlace {
        a,
        b,
        center_angle,
        mount_a: 0.0,
        mount_b: 0.0,
        pair: table::pair(p).unwrap(),
        dte_start: 0.0,
    }
}

/// The unit vector along which mesh m's forward flank pushes B (lateral.md §3), in the housing
/// frame, from the spec's single-mesh frame: (sin a, -cos a) with O_B on the x axis and A
/// turning clockwise forward, mirrored when A turns counter-clockwise (gear-train.md §3).
pub fn n_forward(alpha_w: f64, center_angle: f64, a_counter_clockwise: bool) -> [f64; 2] {
    let (s, c) = alpha_w.sin_cos();
    let y = if a_counter_clockwise { c } else { -c };
    let (sb, cb) = center_angle.sin_cos();
    [cb * s - sb * y, sb * s + cb * y]
}
