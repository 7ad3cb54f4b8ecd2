//! What an explicit method's stability region lets a step do on an oscillation
//! (`System::max_step`).

/// `reach`: the h omega allowed on a mode of angular frequency omega whatever its damping, as
/// the bounds through a trace use it. `region`, where tabulated: (zeta, h |lambda|) under the
/// boundary of the region along the ray of a mode lambda = |lambda| (-zeta + i sqrt(1 -
/// zeta^2)), zeta from 0 to 1, the boundary concave between the points so that the chords
/// stay inside (each table is checked against its method's stability function).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stability {
    pub reach: f64,
    pub region: Option<&'static [(f64, f64)]>,
}

impl Stability {
    /// The h |lambda| the region holds for a mode of damping ratio zeta (clamped to [0, 1]);
    /// None where the method's region is not tabulated.
    pub fn reach_at(&self, zeta: f64) -> Option<f64> {
        let t = self.region?;
        let z = zeta.clamp(0.0, 1.0);
        let k = t.partition_point(|&(zk, _)| zk <= z);
        if k >= t.len() {
            return Some(t[t.len() - 1].1);
        }
        let ((z0, r0), (z1, r1)) = (t[k - 1], t[k]);
        Some(r0 + (r1 - r0) * (z - z0) / (z1 - z0))
    }
}

/// |R(z)| of an explicit Runge-Kutta method (strictly lower `a`, weights `b`) at z = x + iy:
/// k_i = 1 + z sum_j a_ij k_j, R = 1 + z sum_i b_i k_i.
#[cfg(test)]
pub(crate) fn amplification(a: &[&[f64]], b: &[f64], (x, y): (f64, f64)) -> f64 {
    let mul = |(p, q): (f64, f64), (r, s): (f64, f64)| (p * r - q * s, p * s + q * r);
    let mut k: Vec<(f64, f64)> = Vec::new();
    for row in a {
        let s = row.iter().zip(&k).fold((0.0, 0.0), |acc, (&aij, &kj)| {
            (acc.0 + aij * kj.0, acc.1 + aij * kj.1)
        });
        let zs = mul((x, y), s);
        k.push((1.0 + zs.0, zs.1));
    }
    let s = b.iter().zip(&k).fold((0.0, 0.0), |acc, (&bi, &ki)| {
        (acc.0 + bi * ki.0, acc.1 + bi * ki.1)
    });
    let r = mul((x, y), s);
    (1.0 + r.0).hypot(r.1)
}

/// Checks a method's table: along each ray, every h |lambda| up to the table's value keeps
/// |R| <= 1 (zeta on a grid finer than the table's, r in steps of 1e-3).
#[cfg(test)]
pub(crate) fn check_region(a: &[&[f64]], b: &[f64], s: Stability) {
    for i in 0..=2000 {
        let zeta = if i <= 1000 {
            0.02 * i as f64 / 1000.0
        } else {
            0.02 + 0.98 * (i - 1000) as f64 / 1000.0
        };
        let reach = s.reach_at(zeta).expect("a tabulated region");
        let (dx, dy) = (-zeta, (1.0 - zeta * zeta).max(0.0).sqrt());
        let mut r = 1e-3;
        while r <= reach {
            let g = amplification(a, b, (r * dx, r * dy));
            assert!(g <= 1.0 + 1e-12, "zeta {zeta}, h|lambda| {r}: |R| = {g}");
            r += 1e-3;
        }
    }
}
