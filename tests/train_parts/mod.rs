//! Parts of trains shared by the integration tests of planetary sets (tests/planetary.rs,
//! tests/bearing_forces.rs).

use spur_gear_mesh::model::train::{Body, Ripple};
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
        planet: None,
    }
}
