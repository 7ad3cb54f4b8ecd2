//! Helpers shared by the integration tests.

use spur_gear_mesh::fmi::outputs::outputs;
use spur_gear_mesh::model::geometry::Geometry;
use spur_gear_mesh::table;
use spur_gear_mesh::variables::{Inputs, Outputs, Params};
use std::f64::consts::PI;

/// Static penetration for a force per unit width N: eq. 5.1 with R = L + delta (fixed point in
/// R), or R = L - delta for a convex flank in a ring's concave one (planetary.md §1).
pub fn static_delta(n: f64, g: &Geometry) -> f64 {
    let sign = if g.internal { -1.0 } else { 1.0 };
    let mut delta = 0.0;
    for _ in 0..50 {
        let r = g.l + sign * delta;
        delta = n / (PI * g.e_star) * ((4.0 * PI * g.e_star * r / n).ln() - 1.0);
    }
    delta
}

/// Runs with communication step h to t_end, returning the outputs at every communication point.
// Not every test file that shares this module runs scenes.
#[allow(dead_code)]
pub fn run(p: &Params, i: &Inputs, rtol: f64, h: f64, t_end: f64) -> Vec<Outputs> {
    let mut sim = table::simulation(p, i, 0.0, rtol).unwrap();
    let n = (t_end / h).round() as usize;
    (1..=n)
        .map(|k| {
            sim.advance(k as f64 * h, &mut |_, _| {}).unwrap();
            outputs(&sim).unwrap()
        })
        .collect()
}
