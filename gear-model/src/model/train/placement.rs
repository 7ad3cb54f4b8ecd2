//! Where the teeth are (gear-train.md §3-§4): each mesh's paper frame in the housing, the
//! bodies' start angles from body 1 along the tree, and which teeth of A and B meet.

use super::topology::{Edge, TrainSpec, Tree};
use crate::model::geometry::Geometry;
use crate::model::mesh::Placement;
use std::f64::consts::PI;

/// A mesh's frame: `s` = +1 when the housing frame is only rotated (sigma_A = -1), -1 when it
/// is mirrored too (sigma_A = +1); psi^m = s (psi - beta), and a gear's tooth 0 axis is at
/// chi = psi^m + s mount.
fn frame_sign(sense_a: f64) -> f64 {
    -sense_a
}

/// The absolute start angle psi(0) of the gear being placed, given its axis angle chi in the
/// mesh frame up to whole teeth: chi = x + q dz. Returns psi in (-dz/2, dz/2] (the tooth
/// nearest its reference is tooth 0); `pairing` then reads which teeth meet.
fn nearest(x: f64, dz: f64, s: f64, beta: f64, mount: f64) -> f64 {
    // psi = beta - mount + s chi = base + s q dz
    let base = beta - mount + s * x;
    let psi = base + (((-0.5 * dz - base) / dz).floor() + 1.0) * dz;
    // Rounding at the interval's ends.
    if psi <= -0.5 * dz {
        psi + dz
    } else if psi > 0.5 * dz {
        psi - dz
    } else {
        psi
    }
}

/// The start of every body and mesh.
#[derive(Clone, Debug, PartialEq)]
pub struct Start {
    /// Absolute start angle of each body \[rad\].
    pub psi: Vec<f64>,
    /// Each mesh's placement for the component.
    pub meshes: Vec<Placement>,
}

/// Places the bodies along the tree (gear-train.md §4) and derives each mesh's pairing.
pub fn place(spec: &TrainSpec, tree: &Tree, geo: &[Geometry]) -> Start {
    let n = spec.bodies.len();
    let mut psi = vec![f64::NAN; n];
    psi[0] = spec.angle_start;
    let mut meshes = vec![Placement::Paper { theta_a: 0.0 }; spec.meshes.len()];
    for step in &tree.steps {
        match step.edge {
            Edge::Shaft(j) => {
                let sh = &spec.shafts[j];
                psi[step.to] = if step.from == sh.a {
                    psi[sh.a] - tree.sense[sh.a] * sh.twist_start
                } else {
                    psi[sh.b] + tree.sense[sh.b] * sh.twist_start
                };
            }
            Edge::Mesh(m) => {
                let mp = &spec.meshes[m];
                let g = &geo[m];
                let s = frame_sign(tree.sense[mp.a]);
                let beta = frame_angle(g, mp.center_angle);
                let dte = mp.params.dte_start;
                // The forward delta of A's tooth n_A against B's n_B is
                // C(chi_A, chi_B) + (n_A - n_B) p_b, linear in both axis angles: dC/dchi_A =
                // -rAb, dC/dchi_B = -kappa rBb. Solve C = dte for the gear being placed.
                if step.from == mp.a {
                    let chi_a = s * (psi[mp.a] - beta) + s * mp.mount_a;
                    let x = (dte - forward_offset(g, chi_a, 0.0)) / (-g.kappa * g.r_bb);
                    psi[mp.b] = nearest(x, g.d_b, s, beta, mp.mount_b);
                } else {
                    let chi_b = s * (psi[mp.b] - beta) + s * mp.mount_b;
                    let x = (dte - forward_offset(g, 0.0, chi_b)) / (-g.r_ab);
                    psi[mp.a] = nearest(x, g.d_a, s, beta, mp.mount_a);
                }
                meshes[m] = pairing(
                    g,
                    s,
                    mp.center_angle,
                    mp.mount_a,
                    mp.mount_b,
                    psi[mp.a],
                    psi[mp.b],
                    dte,
                );
            }
        }
    }
    Start { psi, meshes }
}

/// The mesh frame's rotation: the direction of O_A -> O_B for an external pair; for an
/// internal one the frame puts O_B at (-d, 0), so it is turned half a revolution more
/// (planetary.md §3).
fn frame_angle(g: &Geometry, center_angle: f64) -> f64 {
    if g.internal {
        center_angle + PI
    } else {
        center_angle
    }
}

/// The forward penetration of A's tooth 0 against B's tooth 0 with their axes at chi_A,
/// chi_B in the mesh frame (gear-train.md §3; planetary.md §1 for a ring, whose tooth n has
/// its forward root at chi_B - n dB + tB/2 and s_B = rBb (alpha_w - phiB)).
fn forward_offset(g: &Geometry, chi_a: f64, chi_b: f64) -> f64 {
    let s_a = g.r_ab * (g.alpha_w - chi_a + 0.5 * g.t_a);
    if g.internal {
        s_a - g.r_bb * (g.alpha_w - chi_b - 0.5 * g.t_b) + g.l
    } else {
        s_a + g.r_bb * (g.alpha_w + PI - chi_b + 0.5 * g.t_b) - g.l
    }
}

/// The same for the backward flank, whose delta is this plus (n_B - n_A) p_b.
fn backward_offset(g: &Geometry, chi_a: f64, chi_b: f64) -> f64 {
    let s_a = g.r_ab * (g.alpha_w + chi_a + 0.5 * g.t_a);
    if g.internal {
        s_a - g.r_bb * (g.alpha_w + chi_b - 0.5 * g.t_b) + g.l
    } else {
        s_a + g.r_bb * (g.alpha_w - PI + chi_b + 0.5 * g.t_b) - g.l
    }
}

/// The teeth that meet, from both gears' start angles: forward, delta = C + (n_A - n_B) p_b
/// must be dte_start; backward, delta_b = C_b + (n_B - n_A) p_b must be -j_n - dte_start
/// (the thickness closure at the actual centre distance makes both hold at once).
#[allow(clippy::too_many_arguments)]
pub fn pairing(
    g: &Geometry,
    s: f64,
    center_angle: f64,
    mount_a: f64,
    mount_b: f64,
    psi_a: f64,
    psi_b: f64,
    dte: f64,
) -> Placement {
    let beta = frame_angle(g, center_angle);
    let chi_a = s * (psi_a - beta) + s * mount_a;
    let chi_b = s * (psi_b - beta) + s * mount_b;
    let q = ((dte - forward_offset(g, chi_a, chi_b)) / g.p_b).round() as i64;
    let q_b = ((-g.j_n - dte - backward_offset(g, chi_a, chi_b)) / g.p_b).round() as i64;
    Placement::Teeth {
        chi_a,
        b_fwd: -q,
        b_bwd: q_b,
    }
}
