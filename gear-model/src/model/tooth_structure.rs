//! Contact model 3's compliance (tooth-structure.md §1): the tooth structure of both wheels in
//! series with Weber's local contact, which together give `delta = F/(pi b E*) ln(C/F)`.
//!
//! Per wheel, with the contact `s` its roll distance from the wheel's tangent point, the load
//! angle `alpha_1 = s/r_b - alpha_2` and `t` the involute parameter (`t = alpha_2 - phi`, phi
//! the roll angle of a profile point):
//! - bending, shear and axial compression of the involute part, integrated from the contact
//!   (t = -alpha_1) to the involute's start `alpha_t` (Yang & Lin 1987; Tian 2004);
//! - the straight part between the root and the base circle, a uniform beam of half-thickness
//!   r_b sin(alpha_2) (Chen & Shao 2011), in closed form;
//! - the fillet-foundation of the body (Sainsot, Velex & Duverger 2004) with the rack-generated
//!   root angle theta_f of Ma et al.'s improved method;
//! - Weber's contact deformation between the contact and the tooth centre line.

use super::contact_law::ContactLaw;
use super::geometry::Geometry;
use super::johnson::OutOfRange;
use super::lower_branch;
use super::pair::{Gear, Pair, Rack};
use super::piecewise::PiecewiseFit;
use super::ModelError;
use std::f64::consts::PI;

/// Sainsot et al. (2004), table 1: X* = A/theta_f^2 + B h_f^2 + C h_f/theta_f + D/theta_f +
/// E h_f + F for X = L, M, P, Q.
const SAINSOT: [[f64; 6]; 4] = [
    [-5.574e-5, -1.9986e-3, -2.3015e-4, 4.7702e-3, 0.0271, 6.8045],
    [60.111e-5, 28.100e-3, -83.431e-4, -9.9256e-3, 0.1624, 0.9086],
    [-50.952e-5, 185.50e-3, 0.0538e-4, 53.300e-3, 0.2895, 0.9236],
    [
        -6.2042e-5, 9.0889e-3, -4.0964e-4, 7.8297e-3, -0.1472, 0.6904,
    ],
];

/// Nodes of the Gauss-Legendre rule for the involute integrals: their integrands are smooth
/// (analytic) on the whole interval, and 24 nodes integrate them to rounding (checked against a
/// direct beam integration in the tests).
const GAUSS_NODES: usize = 24;

fn involute(a: f64) -> f64 {
    a.tan() - a
}

/// Gauss-Legendre nodes and weights on [-1, 1] (Newton on P_n from the Chebyshev guesses).
pub fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    (0..n)
        .map(|i| {
            let mut x = (PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
            let mut dp = 0.0;
            for _ in 0..100 {
                // P_n(x) and P_n'(x) by the three-term recurrence.
                let (mut p0, mut p1) = (1.0, x);
                for k in 2..=n {
                    let k = k as f64;
                    (p0, p1) = (p1, ((2.0 * k - 1.0) * x * p1 - (k - 1.0) * p0) / k);
                }
                dp = n as f64 * (x * p1 - p0) / (x * x - 1.0);
                let dx = p1 / dp;
                x -= dx;
                if dx.abs() < 1e-16 {
                    break;
                }
            }
            (x, 2.0 / ((1.0 - x * x) * dp * dp))
        })
        .collect()
}

/// One wheel's tooth and body.
#[derive(Clone, Debug, PartialEq)]
pub struct Wheel {
    pub r_b: f64,
    /// Root radius m (z/2 - dedendum + x).
    pub r_f: f64,
    pub r_bore: f64,
    pub e: f64,
    pub nu: f64,
    /// Half tooth angle on the base circle.
    pub alpha_2: f64,
    /// The involute's start: alpha_2, or less where the root circle lies above the base circle.
    pub alpha_t: f64,
    /// Sainsot's fillet-foundation: rack-generated root angle, S_f, and L*, M*, P*, Q*.
    pub theta_f: f64,
    pub s_f: f64,
    pub lmpq: [f64; 4],
    /// The Gauss-Legendre rule of the involute integrals (computed once).
    rule: Vec<(f64, f64)>,
}

/// A wheel's gear data (standard geometry) and material.
#[derive(Clone, Copy, Debug)]
pub struct WheelData {
    pub z: f64,
    pub shift: f64,
    pub module: f64,
    pub alpha_0: f64,
    pub dedendum: f64,
    pub rack_tip_radius: f64,
    /// 0: automatic, half the root radius.
    pub r_bore: f64,
    pub e: f64,
    pub nu: f64,
}

impl Wheel {
    pub fn new(d: &WheelData, name: &str) -> Result<Wheel, ModelError> {
        let r_b = d.module * d.z * d.alpha_0.cos() / 2.0;
        let r_f = d.module * (d.z / 2.0 - d.dedendum + d.shift);
        if !(r_f > 0.0) {
            return Err(ModelError::new(format!(
                "wheel {name}: the root radius m (z/2 - dedendum + x) = {r_f} m is not positive"
            )));
        }
        let r_bore = if d.r_bore == 0.0 { 0.5 * r_f } else { d.r_bore };
        if !(r_bore > 0.0 && r_bore < r_f) {
            return Err(ModelError::new(format!(
                "parameter bore_radius_{name} = {} m: must lie between 0 and the root radius {r_f} m",
                d.r_bore
            )));
        }
        let alpha_2 =
            PI / (2.0 * d.z) + involute(d.alpha_0) + 2.0 * d.shift * d.alpha_0.tan() / d.z;
        let alpha_t = if r_f <= r_b {
            alpha_2
        } else {
            alpha_2 - ((r_f / r_b).powi(2) - 1.0).sqrt()
        };
        let theta_f = (PI / 2.0
            + 2.0 * d.alpha_0.tan() * (d.dedendum - d.rack_tip_radius)
            + 2.0 * d.rack_tip_radius / d.alpha_0.cos())
            / d.z;
        let h_f = r_f / r_bore;
        let lmpq = SAINSOT.map(|[a, b, c, dd, e, f]| {
            a / (theta_f * theta_f) + b * h_f * h_f + c * h_f / theta_f + dd / theta_f + e * h_f + f
        });
        Ok(Wheel {
            r_b,
            r_f,
            r_bore,
            e: d.e,
            nu: d.nu,
            alpha_2,
            alpha_t,
            theta_f,
            s_f: 2.0 * r_f * theta_f,
            lmpq,
            rule: gauss_legendre(GAUSS_NODES),
        })
    }

    pub fn alpha_1(&self, s: f64) -> f64 {
        s / self.r_b - self.alpha_2
    }

    /// Bending, shear and axial compliance [m/N] of the involute part (Yang & Lin 1987; Tian
    /// 2004), Gauss-Legendre from t = -alpha_1 to alpha_t.
    pub fn involute_compliance(&self, s: f64, b: f64) -> [f64; 3] {
        let (a1, a2) = (self.alpha_1(s), self.alpha_2);
        let (c1, s1) = (a1.cos(), a1.sin());
        let (lo, hi) = (-a1, self.alpha_t);
        let (mid, half) = (0.5 * (lo + hi), 0.5 * (hi - lo));
        let mut sum = [0.0; 3];
        for &(x, w) in &self.rule {
            let t = mid + half * x;
            let (ct, st) = (t.cos(), t.sin());
            let arm = (a2 - t) * ct;
            let den = st + arm;
            let m = 1.0 + c1 * ((a2 - t) * st - ct);
            sum[0] += w * 3.0 * m * m * arm / (2.0 * den.powi(3));
            sum[1] += w * 1.2 * (1.0 + self.nu) * arm * c1 * c1 / den;
            sum[2] += w * arm * s1 * s1 / (2.0 * den);
        }
        sum.map(|x| x * half / (self.e * b))
    }

    /// Bending, shear and axial compliance [m/N] of the straight part between the root and the
    /// base circle (Chen & Shao 2011), zero where the root circle lies above the base circle: a
    /// uniform beam of half-thickness h = r_b sin(alpha_2) from where it meets the root circle
    /// up to the base circle, under the same load as the involute part.
    pub fn straight_compliance(&self, s: f64, b: f64) -> [f64; 3] {
        if self.r_f >= self.r_b {
            return [0.0; 3];
        }
        let (a1, a2) = (self.alpha_1(s), self.alpha_2);
        let (c1, s1) = (a1.cos(), a1.sin());
        let h = self.r_b * a2.sin();
        let (x_base, x_root) = (self.r_b * a2.cos(), (self.r_f * self.r_f - h * h).sqrt());
        let d = x_base - x_root;
        // The contact point: distance along the centre line and from it.
        let x_c = self.r_b * (c1 + (a1 + a2) * s1);
        let h_c = self.r_b * ((a1 + a2) * c1 - s1);
        // M(x) = F g(x) with g = cos(a1) (x_c - x) - sin(a1) h_c; int g^2 dx = [g^3]/(-3 cos a1).
        let g = |x: f64| c1 * (x_c - x) - s1 * h_c;
        let i = 2.0 * h.powi(3) * b / 3.0;
        let area = 2.0 * h * b;
        let g_mod = self.e / (2.0 * (1.0 + self.nu));
        [
            (g(x_root).powi(3) - g(x_base).powi(3)) / (3.0 * c1 * self.e * i),
            1.2 * c1 * c1 * d / (g_mod * area),
            s1 * s1 * d / (self.e * area),
        ]
    }

    /// Where the load line crosses the tooth centre line, above the root circle; negative
    /// values (large wheels with positive shift) lie outside the fit's domain and count as 0.
    pub fn u_f(&self, s: f64) -> f64 {
        self.r_b / self.alpha_1(s).cos() - self.r_f
    }

    /// Where u_f = 0 (the contacts s where the load line meets the centre line on the root
    /// circle): only where the root circle lies above the base circle.
    pub fn u_f_zero(&self) -> Option<[f64; 2]> {
        (self.r_f > self.r_b).then(|| {
            let a = (self.r_b / self.r_f).acos();
            [self.r_b * (self.alpha_2 - a), self.r_b * (self.alpha_2 + a)]
        })
    }

    /// The fillet-foundation compliance [m/N] (Sainsot, Velex & Duverger 2004).
    pub fn fillet_compliance(&self, s: f64, b: f64) -> f64 {
        let a1 = self.alpha_1(s);
        let u = self.u_f(s).max(0.0) / self.s_f;
        let [l, m, p, q] = self.lmpq;
        a1.cos().powi(2) / (self.e * b) * (l * u * u + m * u + p * (1.0 + q * a1.tan().powi(2)))
    }

    /// The tooth's and body's whole structural compliance [m/N] at contact s.
    pub fn compliance(&self, s: f64, b: f64) -> f64 {
        let inv = self.involute_compliance(s, b);
        let straight = self.straight_compliance(s, b);
        inv.iter().sum::<f64>() + straight.iter().sum::<f64>() + self.fillet_compliance(s, b)
    }

    /// Weber's h: from the contact to the tooth centre line along the line of action.
    pub fn weber_h(&self, s: f64) -> f64 {
        let a1 = self.alpha_1(s);
        self.r_b * (a1 + self.alpha_2 - a1.tan())
    }
}

/// The pair: both wheels, the face width, E* and the line of action's length.
#[derive(Clone, Debug, PartialEq)]
pub struct Structure {
    pub a: Wheel,
    pub b: Wheel,
    pub width: f64,
    pub e_star: f64,
    pub l: f64,
}

impl Structure {
    /// ln C at contact s_A, with s_B = L - s_A (tooth-structure.md: evaluating at delta = 0
    /// moves the secant stiffness by less than 1e-3):
    /// `ln C = E* sum_i (1 - nu_i^2)/E_i [ln(pi b E* h_i^2 / R) - nu_i/(1 - nu_i)] + pi b E*/k_s`.
    pub fn ln_c(&self, s_a: f64) -> f64 {
        let s_b = self.l - s_a;
        let r = s_a * s_b / (s_a + s_b);
        let pbe = PI * self.width * self.e_star;
        let weber = |w: &Wheel, s: f64| {
            let h = w.weber_h(s);
            (1.0 - w.nu * w.nu) / w.e * ((pbe * h * h / r).ln() - w.nu / (1.0 - w.nu))
        };
        let compliance = self.a.compliance(s_a, self.width) + self.b.compliance(s_b, self.width);
        self.e_star * (weber(&self.a, s_a) + weber(&self.b, s_b)) + pbe * compliance
    }
}

/// Force \[N\] of one pair at penetration delta >= 0 given ln C: `y ln y = -x` with y = F/C and
/// x = pi b E* delta / C, so F = -pi b E* delta / W_{-1}(-x); None past the law's range x < 1/e.
/// Straight from `lambert_w`: the check of the law's tables.
pub fn force(delta: f64, ln_c: f64, width: f64, e_star: f64) -> Option<f64> {
    let pbe_delta = PI * width * e_star * delta;
    let x = pbe_delta * (-ln_c).exp();
    if pbe_delta == 0.0 {
        return Some(0.0);
    }
    if !(x < 1.0 / std::f64::consts::E) {
        return None;
    }
    let w = lambert_w::lambert_wm1(-x);
    w.is_finite().then(|| -pbe_delta / w)
}

/// Contact model 3 for a pair cut by `rack` (the standard geometry).
pub fn structure_law(p: &Pair, rack: &Rack, g: &Geometry) -> Result<StructureLaw, ModelError> {
    let wheel = |gear: &Gear, name| {
        let d = WheelData {
            z: gear.z as f64,
            shift: gear.x,
            module: rack.module,
            alpha_0: rack.pressure_angle,
            dedendum: rack.dedendum,
            rack_tip_radius: rack.tip_radius,
            r_bore: gear.bore_radius,
            e: gear.e,
            nu: gear.nu,
        };
        Wheel::new(&d, name)
    };
    let structure = Structure {
        a: wheel(&p.a, "A")?,
        b: wheel(&p.b, "B")?,
        width: p.width,
        e_star: g.e_star,
        l: g.l,
    };
    StructureLaw::new(structure, g.s_a, g.s_b)
}

/// ln C is tabulated to this error (as C(s_mid)/C(s_A) to this relative error). An error e in
/// ln C moves a pair's force by e / (ln C - ln F - 1), ln C - ln F - 1 being about 30 on steel
/// gears (and above 1 inside the law's range): 1e-11 moves forces by about 3e-13, below the
/// integrator's error at any rel_tol from 1e-12 on. (The exact ln C itself is a quadrature whose
/// rounding is ~1e-13.)
pub const LN_C_TOLERANCE: f64 = 1e-11;

/// Contact model 3 as a `ContactLaw`: the closed form with C and the lower branch of W from
/// their tables.
#[derive(Clone, Debug, PartialEq)]
pub struct StructureLaw {
    pub structure: Structure,
    /// g(s_A) = C(s_mid) / C(s_A): the force needs x = pi b E* delta / C, and a table of 1/C
    /// gives it without an exp (or a log) per pair.
    pub inv_c: PiecewiseFit,
    /// pi b E*.
    p: f64,
    /// ln C at the segment's middle.
    ln_c_mid: f64,
    /// pi b E* / C(s_mid): x = delta * x_scale * g.
    x_scale: f64,
}

/// What the pairs of one flank share: |delta|, pi b E* |delta| and |delta| x_scale.
#[derive(Clone, Copy, Debug)]
struct Penetration {
    delta: f64,
    pd: f64,
    xd: f64,
}

impl StructureLaw {
    /// Tabulates C(s_mid)/C(s_A) over the contact segment [s_a, s_b] (a hundredth of it beyond
    /// each end for objects at the ends while an event is located).
    pub fn new(structure: Structure, s_a: f64, s_b: f64) -> Result<StructureLaw, ModelError> {
        let pad = 0.01 * (s_b - s_a);
        let kinks = [
            structure.a.u_f_zero(),
            structure.b.u_f_zero().map(|k| k.map(|s| structure.l - s)),
        ];
        let kinks: Vec<f64> = kinks.iter().flatten().flatten().cloned().collect();
        let ln_c_mid = structure.ln_c(0.5 * (s_a + s_b));
        let inv_c = PiecewiseFit::new(
            &|s| (ln_c_mid - structure.ln_c(s)).exp(),
            s_a - pad,
            s_b + pad,
            &kinks,
            LN_C_TOLERANCE,
            "contact model 3: C(s_mid)/C(s_A)",
        )?;
        let p = PI * structure.width * structure.e_star;
        Ok(StructureLaw {
            structure,
            inv_c,
            p,
            ln_c_mid,
            x_scale: p * (-ln_c_mid).exp(),
        })
    }

    /// ln C at s_A, from the table.
    pub fn ln_c(&self, s_a: f64) -> f64 {
        self.ln_c_mid - self.inv_c.value(s_a).ln()
    }

    /// Sainsot's fit holds for u_f >= 0; where the active profile reaches contacts with
    /// u_f < 0 (large wheels with positive shift) u_f = 0 is used there, which this says.
    pub fn warnings(&self, g: &Geometry) -> Vec<String> {
        let st = &self.structure;
        [("A", &st.a, g.s_a, g.s_b), ("B", &st.b, st.l - g.s_b, st.l - g.s_a)]
            .iter()
            .filter_map(|&(name, w, lo, hi)| {
                let [k1, k2] = w.u_f_zero()?;
                (k1 < hi && k2 > lo).then(|| {
                    format!(
                        "contact model 3: on wheel {name} the load line of contacts between s = {:.6} and {:.6} m \
                         (roll distance from {name}'s tangent point) meets the tooth centre line below the root circle \
                         (Sainsot's u_f < 0, outside his fit): u_f = 0 is used there",
                        k1.max(lo),
                        k2.min(hi)
                    )
                })
            })
            .collect()
    }

    #[inline]
    fn penetration(&self, delta: f64) -> Penetration {
        let d = delta.abs();
        Penetration {
            delta: d,
            pd: self.p * d,
            xd: d * self.x_scale,
        }
    }

    /// F at |delta| given g = C(s_mid)/C(s_A), or the range error: `y ln y = -x` with
    /// x = pi b E* delta / C and y = F/C, so F = pi b E* delta v(x).
    #[inline]
    fn solve_at(&self, pen: &Penetration, g: f64) -> Result<f64, OutOfRange> {
        if pen.pd == 0.0 {
            return Ok(0.0);
        }
        let x = pen.xd * g;
        let v = if x < 1.0 / std::f64::consts::E {
            lower_branch::v(x)
        } else {
            f64::NAN
        };
        if v.is_finite() {
            Ok(pen.pd * v)
        } else {
            Err(OutOfRange {
                delta: pen.delta,
                // x = 1/e.
                limit: 1.0 / (std::f64::consts::E * self.x_scale * g),
            })
        }
    }

    fn solve(&self, delta: f64, s_a: f64) -> Result<f64, OutOfRange> {
        self.solve_at(&self.penetration(delta), self.inv_c.value(s_a))
    }

    /// The force (odd in delta) and `energy_slope` of a pair at s_A on a flank at `pen`.
    #[inline]
    fn force_and_slope_at(
        &self,
        pen: &Penetration,
        sign: f64,
        s_a: f64,
    ) -> Result<(f64, f64), OutOfRange> {
        let (g, dg) = self.inv_c.value_and_derivative(s_a);
        let f = self.solve_at(pen, g)?;
        Ok((sign * f, self.slope(f, g, dg)))
    }

    /// dU/d(ln C) at fixed delta is -F^2/(2 pi b E*), and d(ln C)/ds = -g'/g (one division:
    /// a second cost 4 % of the right-hand side).
    #[inline(always)]
    fn slope(&self, f: f64, g: f64, dg: f64) -> f64 {
        f * f * dg / (2.0 * self.p * g)
    }
}

impl ContactLaw for StructureLaw {
    /// The odd continuation below 0, as Johnson's (see `johnson::force`).
    fn force(&self, delta: f64, s_a: f64) -> Result<f64, OutOfRange> {
        Ok(delta.signum() * self.solve(delta, s_a)?)
    }
    /// d(delta)/dF = (ln C - ln F - 1)/(pi b E*); 0 at delta = 0 (the log singularity).
    fn stiffness(&self, delta: f64, s_a: f64) -> Result<f64, OutOfRange> {
        let f = self.solve(delta, s_a)?;
        Ok(self.stiffness_at_force(f, delta, s_a))
    }
    fn stiffness_at_force(&self, force: f64, _delta: f64, s_a: f64) -> f64 {
        if force > 0.0 {
            self.p / (self.ln_c(s_a) - force.ln() - 1.0)
        } else {
            0.0
        }
    }
    /// U = F delta/2 - F^2/(4 pi b E*), from U = F delta - int delta dF.
    fn energy(&self, delta: f64, s_a: f64) -> Result<f64, OutOfRange> {
        let d = delta.max(0.0);
        let f = self.solve(d, s_a)?;
        Ok(f * d / 2.0 - f * f / (4.0 * self.p))
    }
    fn energy_slope(&self, force: f64, s_a: f64) -> f64 {
        let (g, dg) = self.inv_c.value_and_derivative(s_a);
        self.slope(force.max(0.0), g, dg)
    }
    fn force_and_slope(&self, delta: f64, s_a: f64) -> Result<(f64, f64), OutOfRange> {
        self.force_and_slope_at(&self.penetration(delta), delta.signum(), s_a)
    }
    /// |delta| and its products once for all of them.
    fn flank_forces_and_slopes(
        &self,
        delta: f64,
        s_a: &[f64],
        out: &mut [(f64, f64)],
    ) -> Result<(), OutOfRange> {
        let pen = self.penetration(delta);
        for (o, &s) in out.iter_mut().zip(s_a) {
            *o = self.force_and_slope_at(&pen, delta.signum(), s)?;
        }
        Ok(())
    }
    fn depends_on_position(&self) -> bool {
        true
    }
    fn static_delta(&self, force: f64) -> f64 {
        force / self.p * (self.ln_c_mid - force.ln())
    }
    fn limit_name(&self) -> &'static str {
        "contact model 3's limit e^(ln C - 1)/(pi b E*)"
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 20-tooth, module 4 mm, 20 degree steel pinion with the ISO 53 rack (tooth-structure.md).
    fn pinion(z: f64, shift: f64) -> WheelData {
        WheelData {
            z,
            shift,
            module: 4e-3,
            alpha_0: 20f64.to_radians(),
            dedendum: 1.25,
            rack_tip_radius: 0.38,
            r_bore: 0.0,
            e: 2.06e11,
            nu: 0.3,
        }
    }

    #[test]
    fn gauss_legendre_integrates_polynomials_exactly() {
        let rule = gauss_legendre(GAUSS_NODES);
        for n in 0..2 * GAUSS_NODES {
            let q: f64 = rule.iter().map(|(x, w)| w * x.powi(n as i32)).sum();
            let exact = if n % 2 == 1 {
                0.0
            } else {
                2.0 / (n as f64 + 1.0)
            };
            assert!((q - exact).abs() < 1e-14, "degree {n}: {q} vs {exact}");
        }
    }

    /// The alpha-integrals against a direct beam integration over the involute tooth: the
    /// profile from its polar form (radius r_b sqrt(1 + phi^2), angle alpha_2 - phi + atan(phi)
    /// from the centre line), the section at x carrying M = F [cos a1 (x_c - x) - sin a1 h_c],
    /// V = F cos a1, N = F sin a1, and M^2/(E I) + 1.2 V^2/(G A) + N^2/(E A) summed by the
    /// trapezoid rule in x on 200000 intervals (error ~1e-10 relative). Both wheels' cases: root
    /// circle below the base circle (z = 20) and above it (z = 60, x = +0.5).
    #[test]
    fn involute_integrals_match_a_direct_beam_integration() {
        let b = 0.02;
        for (z, shift) in [(20.0, 0.0), (60.0, 0.5), (17.0, -0.3)] {
            let w = Wheel::new(&pinion(z, shift), "A").unwrap();
            for frac in [0.1, 0.5, 0.9] {
                // A contact between the involute's start and the tip.
                let phi_lo = w.alpha_2 - w.alpha_t;
                let phi = phi_lo + 0.05 + frac * 0.4;
                let s = w.r_b * phi;
                let a1 = w.alpha_1(s);
                let (c1, s1) = (a1.cos(), a1.sin());
                let profile = |phi: f64| {
                    let r = w.r_b * (1.0 + phi * phi).sqrt();
                    let ang = w.alpha_2 - phi + phi.atan();
                    (r * ang.cos(), r * ang.sin())
                };
                let (x_c, h_c) = profile(phi);
                let g_mod = w.e / (2.0 * (1.0 + w.nu));
                let n = 200_000;
                let (mut sum, mut prev) = ([0.0; 3], None::<(f64, [f64; 3])>);
                for k in 0..=n {
                    // phi from the contact down to the involute's start.
                    let p = phi - (phi - phi_lo) * k as f64 / n as f64;
                    let (x, h) = profile(p);
                    let m = c1 * (x_c - x) - s1 * h_c;
                    let (i, area) = (2.0 * h.powi(3) * b / 3.0, 2.0 * h * b);
                    let f = [
                        m * m / (w.e * i),
                        1.2 * c1 * c1 / (g_mod * area),
                        s1 * s1 / (w.e * area),
                    ];
                    if let Some((x0, f0)) = prev {
                        for j in 0..3 {
                            sum[j] += 0.5 * (f[j] + f0[j]) * (x0 - x).abs();
                        }
                    }
                    prev = Some((x, f));
                }
                let alpha = w.involute_compliance(s, b);
                for j in 0..3 {
                    let rel = (alpha[j] - sum[j]).abs() / sum[j];
                    assert!(
                        rel < 1e-8,
                        "z {z} x {shift}, part {j}: {} vs {} ({rel:e})",
                        alpha[j],
                        sum[j]
                    );
                }
            }
        }
    }

    /// The straight part's closed form against the same beam integrated numerically.
    #[test]
    fn straight_part_matches_its_beam_integral() {
        let b = 0.02;
        let w = Wheel::new(&pinion(20.0, 0.0), "A").unwrap();
        assert!(w.r_f < w.r_b);
        let s = w.r_b * (w.alpha_2 + 0.3);
        let a1 = w.alpha_1(s);
        let (c1, s1) = (a1.cos(), a1.sin());
        let h = w.r_b * w.alpha_2.sin();
        let (x_base, x_root) = (w.r_b * w.alpha_2.cos(), (w.r_f * w.r_f - h * h).sqrt());
        let x_c = w.r_b * (c1 + (a1 + w.alpha_2) * s1);
        let h_c = w.r_b * ((a1 + w.alpha_2) * c1 - s1);
        let i = 2.0 * h.powi(3) * b / 3.0;
        let n = 100_000;
        let dx = (x_base - x_root) / n as f64;
        // Midpoint rule on a quadratic: error (dx^2/24) * 2 c1^2 * length / mean ~ 1e-10.
        let bend: f64 = (0..n)
            .map(|k| {
                let x = x_root + (k as f64 + 0.5) * dx;
                let m = c1 * (x_c - x) - s1 * h_c;
                m * m / (w.e * i) * dx
            })
            .sum();
        let closed = w.straight_compliance(s, b);
        assert!(
            (closed[0] - bend).abs() < 1e-9 * bend,
            "{} vs {bend}",
            closed[0]
        );
    }

    /// The law's tables (C(s_mid)/C(s_A) to 1e-11, the lower branch to 1e-13) against the closed
    /// form straight from lambert_w with the exact ln C, over the segment and penetrations from
    /// 1e-10 m to the law's limit. The first moves forces by 1e-11/(ln C - ln F - 1): below
    /// 1e-12 where x < e^-11 (ln C - ln F - 1 > 10), checked to 1e-11 above (the samples stay
    /// where it exceeds 1); the second by 1e-13. Flank-wise and pair-wise evaluation agree, and
    /// the energy slope is -F^2/(2 pi b E*) d(ln C)/ds within 1e-5 (the derivative of a fit,
    /// against a central difference of the quadrature).
    #[test]
    fn tabulated_force_matches_the_closed_form() {
        let p = Pair {
            law: crate::model::pair::MeshLaw::ToothStructure,
            ..Pair::standard()
        };
        let g = Geometry::new(&p).unwrap();
        let law = structure_law(&p, p.rack().unwrap(), &g).unwrap();
        let st = &law.structure;
        let mut checked = 0;
        for i in 0..=50 {
            let s = g.s_a + (g.s_b - g.s_a) * i as f64 / 50.0;
            let ln_c = st.ln_c(s);
            for k in 0..=60 {
                let delta = 1e-10 * 10f64.powf(k as f64 / 10.0);
                let Some(exact) = force(delta, ln_c, st.width, st.e_star) else {
                    assert!(law.force(delta, s).is_err(), "{s} {delta}");
                    continue;
                };
                let x = PI * st.width * st.e_star * delta * (-ln_c).exp();
                let bound = if x < (-11f64).exp() { 1e-12 } else { 1e-11 };
                let f = law.force(delta, s).unwrap();
                assert!(
                    (f - exact).abs() <= bound * exact,
                    "{s} {delta}: {f} vs {exact}"
                );
                let mut out = [(0.0, 0.0)];
                law.flank_forces_and_slopes(-delta, &[s], &mut out).unwrap();
                assert_eq!(out[0].0, -f);
                let h = 1e-7 * (g.s_b - g.s_a);
                let d_ln_c = (st.ln_c(s + h) - st.ln_c(s - h)) / (2.0 * h);
                let slope = -f * f / (2.0 * PI * st.width * st.e_star) * d_ln_c;
                assert!((out[0].1 - slope).abs() <= 1e-5 * slope.abs() + 1e-9, "{s}");
                checked += 1;
            }
        }
        assert!(checked > 2000, "{checked}");
    }

    /// The closed form inverts delta(F) = F/(pi b E*) ln(C/F).
    #[test]
    fn force_inverts_the_compliance_law() {
        let (b, e_star, ln_c) = (0.02, 1.13e11, 48.0);
        for f in [1.0, 1e3, 6e3, 1e5] {
            let delta = f / (PI * b * e_star) * (ln_c - f64::ln(f));
            let back = force(delta, ln_c, b, e_star).unwrap();
            assert!((back - f).abs() < 1e-12 * f, "{f}: {back}");
        }
    }

    /// Against the independent Python reference (tests/reference/tooth_structure.csv, made by
    /// tests/reference_model/tooth_structure_vectors.py): both integrate smooth integrands to
    /// rounding (Gauss-Legendre here, adaptive quadrature there), so the compliances agree to
    /// 1e-9 and ln C to 1e-9 relative.
    #[test]
    fn matches_the_python_reference() {
        let text = std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../tests/reference/tooth_structure.csv"
        ))
        .unwrap();
        let mut rows = 0;
        for line in text.lines().skip(1) {
            let v: Vec<f64> = line.split(',').map(|x| x.parse().unwrap()).collect();
            let [za, zb, m, xa, xb, b, e, nu, l, s_a, c_a, c_b, ln_c] = v[..] else {
                panic!("{line}")
            };
            let wheel = |z, shift, name| {
                let d = WheelData {
                    z,
                    shift,
                    module: m,
                    ..pinion(z, shift)
                };
                Wheel::new(&WheelData { e, nu, ..d }, name).unwrap()
            };
            let st = Structure {
                a: wheel(za, xa, "A"),
                b: wheel(zb, xb, "B"),
                width: b,
                e_star: 1.0 / (2.0 * (1.0 - nu * nu) / e),
                l,
            };
            let rel = |a: f64, b: f64| (a - b).abs() / b.abs();
            let (ca, cb) = (st.a.compliance(s_a, b), st.b.compliance(l - s_a, b));
            assert!(rel(ca, c_a) < 1e-9, "{line}: A {ca} vs {c_a}");
            assert!(rel(cb, c_b) < 1e-9, "{line}: B {cb} vs {c_b}");
            assert!(
                rel(st.ln_c(s_a), ln_c) < 1e-9,
                "{line}: ln C {} vs {ln_c}",
                st.ln_c(s_a)
            );
            rows += 1;
        }
        assert_eq!(rows, 20);
    }
}
