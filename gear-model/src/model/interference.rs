//! Tip and trochoid interference of an internal pair (planetary.md §1), found numerically: the
//! pinion's two tip corners, followed relative to the ring over one pass through the mesh under
//! rigid rolling, must never enter a ring tooth. On the contact segment a corner touches the
//! ring's flank only at its end (clearance 0); anywhere else a negative clearance is a tooth
//! cutting through another, which the involute contact model cannot see.

use super::geometry::{inv, Geometry};
use std::f64::consts::PI;

/// Points per corner over the window where the pinion's tip circle lies outside the ring's:
/// about 10 um apart on a 20-tooth pinion of module 2 mm, then the smallest is refined.
const SAMPLES: usize = 2001;

/// The smallest clearance between a pinion tip corner and the ring's teeth over one pass.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Clearance {
    /// \[m\]; negative: the corner is inside a ring tooth by that much (the shorter way out:
    /// across a flank, as arc length at its radius, or back over the tip circle).
    pub clearance: f64,
    /// Polar angle of the corner about the pinion's axis, from the direction away from the
    /// ring's axis \[rad\].
    pub angle: f64,
    /// The corner on the forward (true) or backward flank side of the pinion's tooth.
    pub forward: bool,
}

/// The smallest clearance of both corners (paper frame of the internal pair: O_A at the
/// origin, O_B at (-d, 0), the forward flanks touching with no penetration).
pub fn smallest_clearance(g: &Geometry) -> Clearance {
    let (r_aa, r_ba, d) = (g.r_tip_a, g.r_tip_b, g.d);
    // The corner reaches the ring's tip circle where |p - O_B| >= r_Ba, i.e. cos(gamma) >= c.
    let c = (r_ba * r_ba - d * d - r_aa * r_aa) / (2.0 * d * r_aa);
    let window = c.clamp(-1.0, 1.0).acos();
    // Half the pinion's angular tooth thickness at its tip.
    let corner = 0.5 * g.t_a - inv((g.r_ab / r_aa).min(1.0).acos());
    let mut best = Clearance {
        clearance: f64::INFINITY,
        angle: 0.0,
        forward: true,
    };
    for forward in [true, false] {
        // The forward flank side of tooth 0 is at its axis minus `corner`.
        let offset = if forward { corner } else { -corner };
        let at = |gamma: f64| clearance_at(g, gamma, gamma + offset);
        let step = 2.0 * window / (SAMPLES - 1) as f64;
        let (mut g_min, mut c_min) = (0.0, f64::INFINITY);
        for i in 0..SAMPLES {
            let gamma = -window + i as f64 * step;
            let v = at(gamma);
            if v < c_min {
                (g_min, c_min) = (gamma, v);
            }
        }
        let (g_min, c_min) = refine(at, g_min - step, g_min + step, (g_min, c_min));
        if c_min < best.clearance {
            best = Clearance {
                clearance: c_min,
                angle: g_min,
                forward,
            };
        }
    }
    best
}

/// Golden-section search for the smallest value on [lo, hi], keeping `start` if nothing
/// smaller is found (the clearance has kinks where the nearest ring tooth changes).
fn refine(f: impl Fn(f64) -> f64, mut lo: f64, mut hi: f64, start: (f64, f64)) -> (f64, f64) {
    let r = 0.5 * (5f64.sqrt() - 1.0);
    let mut best = start;
    let (mut x1, mut x2) = (hi - r * (hi - lo), lo + r * (hi - lo));
    let (mut f1, mut f2) = (f(x1), f(x2));
    for _ in 0..60 {
        if f1 < f2 {
            hi = x2;
            (x2, f2) = (x1, f1);
            x1 = hi - r * (hi - lo);
            f1 = f(x1);
        } else {
            lo = x1;
            (x1, f1) = (x2, f2);
            x2 = lo + r * (hi - lo);
            f2 = f(x2);
        }
    }
    for (x, v) in [(x1, f1), (x2, f2)] {
        if v < best.1 {
            best = (x, v);
        }
    }
    best
}

/// Clearance of a pinion tip corner at polar angle `gamma` about O_A when the pinion's tooth 0
/// has its axis at `psi_a`, the ring rolled with it so that the forward flanks touch.
fn clearance_at(g: &Geometry, gamma: f64, psi_a: f64) -> f64 {
    // Forward flanks touching (delta = 0): s_B = s_A + L, and the ring's forward root at
    // phiB = alpha_w - s_B/rBb is its tooth's axis plus tB/2.
    let s_a = g.r_ab * (g.alpha_w - psi_a + 0.5 * g.t_a);
    let axis_b = g.alpha_w - (s_a + g.l) / g.r_bb - 0.5 * g.t_b;
    let (x, y) = (g.r_tip_a * gamma.cos() + g.d, g.r_tip_a * gamma.sin());
    let r = x.hypot(y);
    let mut eps = (y.atan2(x) - axis_b).rem_euclid(g.d_b);
    if eps > 0.5 * g.d_b {
        eps -= g.d_b;
    }
    // A ring tooth is t_B + 2 inv(alpha_r) wide at radius r >= r_Ba.
    let half = |r: f64| 0.5 * (g.t_b + 2.0 * inv((g.r_bb / r).min(1.0).acos()));
    if r >= g.r_tip_b {
        // Inside a tooth, the depth is the shorter way out: across a flank or back over the
        // tip circle.
        let across = r * (eps.abs() - half(r));
        if across >= 0.0 {
            across
        } else {
            across.max(g.r_tip_b - r)
        }
    } else {
        (g.r_tip_b - r).max(r * (eps.abs() - half(g.r_tip_b)))
    }
}

/// Refuses a pair whose pinion tip corners enter the ring's teeth. The tolerance, 1e-10 of the
/// ring's tip radius, is far above the rounding of the angles (1e-15 relative) and far below any
/// interference a gear engineer would accept as touching.
pub fn check_tip_corners(g: &Geometry) -> Result<(), String> {
    let c = smallest_clearance(g);
    if c.clearance < -1e-10 * g.r_tip_b {
        return Err(format!(
            "tip or trochoid interference: the pinion's tip corner on its {} flank side enters a ring tooth by {} m \
             (smallest clearance over one pass through the mesh, at {} deg from the line of centres; \
             tip radii {} m and {} m, centre distance {} m); a larger tooth-count difference zB - zA or shorter teeth (addendum) cure it",
            if c.forward { "forward" } else { "backward" },
            -c.clearance,
            c.angle * 180.0 / PI,
            g.r_tip_a,
            g.r_tip_b,
            g.d
        ));
    }
    Ok(())
}
