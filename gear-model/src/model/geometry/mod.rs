//! Gear geometry (spec §2, planetary.md §1-§2): from the parameters to the numbers the contact
//! model needs. Two front ends, the paper's and standard gear data (an external pair or a
//! pinion in a ring), give the gears and their nominal operating geometry; the operating
//! geometry then follows from the actual centre distance, which is how every pair gets it.

use super::pair::{Cut, Pair, PaperCut, Rack};
use super::ModelError;
use std::f64::consts::PI;

#[derive(Clone, Debug, Default, PartialEq)]
pub struct Geometry {
    pub z_a: f64,
    pub z_b: f64,
    /// Wheel B is a ring with internal teeth (planetary.md §1).
    pub internal: bool,
    /// +1 for an external pair, -1 for an internal one: B's contact coordinate is
    /// s_B = L + kappa (delta - s_A), and the Johnson law's radius rho_A + kappa rho_B = L + kappa delta.
    pub kappa: f64,
    /// Operating pressure angle alpha_w.
    pub alpha_w: f64,
    pub r_ab: f64,
    pub r_bb: f64,
    /// Actual centre distance.
    pub d: f64,
    /// Nominal operating centre distance (of the front end).
    pub d_nominal: f64,
    /// Length of the line of action |K_A K_B|.
    pub l: f64,
    /// Contact segment [s_a, s_b] on the line of action, from K_A.
    pub s_a: f64,
    pub s_b: f64,
    /// Base pitch p_b = rAb dA = rBb dB.
    pub p_b: f64,
    /// Real pitch angles 2 pi/z.
    pub d_a: f64,
    pub d_b: f64,
    pub eps: f64,
    /// Contact objects per flank.
    pub m_c: usize,
    /// Base tooth thickness angles (with backlash, at the nominal centre distance).
    pub t_a: f64,
    pub t_b: f64,
    /// Normal backlash at the actual centre distance (the thickness closure).
    pub j_n: f64,
    pub r_tip_a: f64,
    pub r_tip_b: f64,
    /// Effective modulus E*.
    pub e_star: f64,
    /// What is valid but unusual (thin tooth tips), for the log.
    pub warnings: Vec<String>,
}

/// Involute function tan(a) - a.
pub fn inv(a: f64) -> f64 {
    a.tan() - a
}

/// Inverse of the involute function on (0, pi/2) by Newton's method (inv is convex and increasing).
fn inv_inverse(target: f64) -> Option<f64> {
    if !(target > 0.0) || !target.is_finite() {
        return None;
    }
    // Start from the series inv(a) ~ a^3/3, which is below the root, so Newton converges monotonically.
    let mut a = (3.0 * target).cbrt().min(1.5);
    for _ in 0..100 {
        let f = inv(a) - target;
        let df = a.tan().powi(2);
        let next = a - f / df;
        if (next - a).abs() <= 1e-15 * a {
            return Some(next);
        }
        a = next.clamp(1e-12, PI / 2.0 - 1e-12);
    }
    None
}

impl Geometry {
    /// The pair at its nominal centre distance plus `center_distance_error`.
    pub fn new(p: &Pair) -> Result<Geometry, ModelError> {
        Self::at_distance(p, None)
    }

    /// The pair with its axes `axes` apart (None: the nominal operating distance), plus
    /// `center_distance_error` (planetary.md §2). The gears (base and tip radii, base tooth
    /// thicknesses with the `backlash` parameter) are those of the front end at the nominal
    /// distance; alpha_w, L, the contact segment and the backlash follow from the actual one.
    pub fn at_distance(p: &Pair, axes: Option<f64>) -> Result<Geometry, ModelError> {
        let (a, b) = (&p.a, &p.b);
        let e_star = 1.0 / ((1.0 - a.nu * a.nu) / a.e + (1.0 - b.nu * b.nu) / b.e);
        let (z_a, z_b) = (a.z as f64, b.z as f64);
        let (d_a, d_b) = (2.0 * PI / z_a, 2.0 * PI / z_b);
        let mut g = match (&p.cut, p.internal) {
            (Cut::Paper(c), false) => Self::paper(p, c, e_star)?,
            (Cut::Paper(_), true) => {
                return Err(ModelError::new(
                    "parameter internal = true: an internal pair needs standard gear data (geometry = 2); the paper geometry is the article's external pair".into(),
                ))
            }
            (Cut::Standard(r), _) => Self::standard(p, r, e_star)?,
        };
        g.z_a = z_a;
        g.z_b = z_b;
        g.d_a = d_a;
        g.d_b = d_b;
        g.internal = p.internal;
        g.kappa = if p.internal { -1.0 } else { 1.0 };
        g.j_n = p.backlash;
        g.d_nominal = g.d;
        let d = axes.unwrap_or(g.d) + p.center_distance_error;
        // At the nominal distance the front end's values stand: they are exact where the
        // operating formulas would round (alpha_w from an arc cosine).
        if d != g.d {
            g.operate(d, p)?;
        }
        g.check_segment(p)?;
        g.eps = (g.s_b - g.s_a) / g.p_b;
        if g.eps < 1.0 - 1e-9 || g.eps > 2.0 + 1e-9 {
            return Err(ModelError::new(format!(
                "contact ratio eps = (s_b - s_a)/p_b = ({} - {})/{} = {} must lie in [1, 2]{}",
                g.s_b,
                g.s_a,
                g.p_b,
                g.eps,
                g.where_placed(p)
            )));
        }
        let needed = (g.eps - 1e-9).ceil() as usize;
        g.m_c = match p.contacts_per_flank {
            0 => needed,
            m if m > 2 => {
                return Err(ModelError::parameter(
                    "contacts_per_flank",
                    m,
                    "must be 0 (automatic), 1 or 2",
                ))
            }
            m if m < needed => {
                return Err(ModelError::parameter(
                    "contacts_per_flank",
                    m,
                    &format!(
                        "the contact ratio {} needs {needed} contact objects per flank",
                        g.eps
                    ),
                ))
            }
            m => m,
        };
        g.check_teeth(p)?;
        if g.internal {
            super::interference::check_tip_corners(&g).map_err(|e| {
                ModelError::new(format!("{e} ({}){}", g.shape(p), g.where_placed(p)))
            })?;
        }
        Ok(g)
    }

    /// The operating geometry at centre distance d (planetary.md §2): d cos(alpha_w) is
    /// rAb + rBb (external) or rBb - rAb (internal), whatever d is; the backlash follows from
    /// the thickness closure at the new alpha_w.
    fn operate(&mut self, d: f64, p: &Pair) -> Result<(), ModelError> {
        let base = self.r_bb + self.kappa * self.r_ab;
        if !(d > base) {
            return Err(ModelError::parameter(
                "center_distance_error",
                p.center_distance_error,
                &format!(
                    "puts the axes {d} m apart, not more than {base} m ({}): the gears cannot mesh there",
                    if self.internal { "rBb - rAb" } else { "rAb + rBb" }
                ),
            ));
        }
        self.alpha_w = (base / d).acos();
        self.d = d;
        self.l = d * self.alpha_w.sin();
        let tip_b = (self.r_tip_b * self.r_tip_b - self.r_bb * self.r_bb)
            .max(0.0)
            .sqrt();
        self.s_a = if self.internal {
            tip_b - self.l
        } else {
            self.l - tip_b
        };
        let closure = self.p_b - self.r_ab * self.t_a - self.r_bb * self.t_b;
        self.j_n = closure + self.kappa * 2.0 * base * inv(self.alpha_w);
        if !(self.j_n >= 0.0) {
            return Err(ModelError::parameter(
                "center_distance_error",
                p.center_distance_error,
                &format!(
                    "jams the teeth: at the actual centre distance {d} m (nominal {} m) the backlash would be {} m < 0 (backlash {} m at the nominal distance)",
                    self.d_nominal, self.j_n, p.backlash
                ),
            ));
        }
        Ok(())
    }

    /// The contact segment lies where both flanks are involutes: external, on the line of
    /// action [0, L]; internal, from K_A on (the ring's tangent point lies behind K_A).
    fn check_segment(&self, p: &Pair) -> Result<(), ModelError> {
        let (s_a, s_b, l) = (self.s_a, self.s_b, self.l);
        if self.internal && s_a < 0.0 {
            return Err(ModelError::new(format!(
                "involute interference at the pinion's root: the ring's tip circle (radius {} m) reaches past K_A, \
                 the pinion's base-circle tangent point: s_a = sqrt(r_Ba^2 - rBb^2) - L = {s_a} m < 0; a positive xB \
                 lifts the ring's tips and cures it ({}){}",
                self.r_tip_b,
                self.shape(p),
                self.where_placed(p)
            )));
        }
        if !self.internal && (s_a < 0.0 || s_b > l) {
            return Err(ModelError::new(format!(
                "interference: the contact segment [s_a, s_b] = [{s_a}, {s_b}] leaves the line of action [0, {l}] \
                 (tip radii {}, {}; reduce addendum or change the profile shifts){}",
                self.r_tip_a,
                self.r_tip_b,
                self.where_placed(p)
            )));
        }
        Ok(())
    }

    /// The gear data, for messages.
    fn shape(&self, p: &Pair) -> String {
        match &p.cut {
            Cut::Paper(c) => format!(
                "alpha_factor = {}, zA = {}, zB = {}, backlash = {}",
                c.alpha_factor, p.a.z, p.b.z, p.backlash
            ),
            Cut::Standard(r) => format!(
                "{}module = {}, zA = {}, zB = {}, xA = {}, xB = {}, addendum = {}, backlash = {}",
                if p.internal { "internal, " } else { "" },
                r.module,
                p.a.z,
                p.b.z,
                p.a.x,
                p.b.x,
                r.addendum,
                p.backlash
            ),
        }
    }

    /// Where the axes are, for messages when they are not at the nominal distance.
    fn where_placed(&self, p: &Pair) -> String {
        if self.d == self.d_nominal {
            String::new()
        } else {
            format!(
                " at the actual centre distance {} m (nominal {} m, center_distance_error = {} m)",
                self.d, self.d_nominal, p.center_distance_error
            )
        }
    }

    /// Teeth that cannot exist are rejected with their numbers: no thickness on the operating
    /// pitch circle (too much backlash), pointed tips, an active profile below where a rack
    /// cutter generates the involute (undercut). A tip thinner than 0.2 module is a warning.
    /// An involute tooth whose angular thickness on the base circle is t has the angular
    /// thickness t - 2 inv(alpha_r) on the circle of radius r, cos(alpha_r) = r_b/r; a ring's
    /// tooth is the complement of an external tooth space, t + 2 inv(alpha_r).
    fn check_teeth(&mut self, p: &Pair) -> Result<(), ModelError> {
        let thickness = |t: f64, r_b: f64, r: f64, ring: bool| {
            let sign = if ring { 1.0 } else { -1.0 };
            r * (t + sign * 2.0 * inv((r_b / r).min(1.0).acos()))
        };
        let shape = self.shape(p);
        let module = match p.rack() {
            // The operating module: the base pitch over pi cos(alpha_w).
            None => self.p_b / (PI * self.alpha_w.cos()),
            Some(r) => r.module,
        };
        for (wheel, t, r_b, r_tip, z, x, ring) in [
            ("A", self.t_a, self.r_ab, self.r_tip_a, p.a.z, p.a.x, false),
            (
                "B",
                self.t_b,
                self.r_bb,
                self.r_tip_b,
                p.b.z,
                p.b.x,
                self.internal,
            ),
        ] {
            // The operating pitch circle, or the tip circle where the tooth ends short of it
            // (an internal pair at a large alpha_w can have its pitch point off the segment).
            let r_w = r_b / self.alpha_w.cos();
            let r_w = if ring { r_w.max(r_tip) } else { r_w.min(r_tip) };
            let pitch = thickness(t, r_b, r_w, ring);
            if !(pitch > 0.0) {
                return Err(ModelError::parameter(
                    "backlash",
                    p.backlash,
                    &format!(
                        "leaves wheel {wheel}'s tooth no thickness on its operating pitch circle (radius {r_w} m): {pitch} m"
                    ),
                ));
            }
            let tip = thickness(t, r_b, r_tip, ring);
            if !(tip > 0.0) {
                return Err(ModelError::new(format!(
                    "pointed teeth: wheel {wheel}'s tooth thickness on its tip circle (radius {r_tip} m) is {tip} m ({shape})"
                )));
            }
            if tip < 0.2 * module {
                self.warnings.push(format!(
                    "wheel {wheel}'s tooth tip is {tip} m thick, below 0.2 module ({} m) ({shape})",
                    0.2 * module
                ));
            }
            // A ring is cut by a pinion-type cutter, not a rack: its involute reaches down to
            // the tip circle whatever the shift, so only external gears are checked here.
            if let (Some(rack), false) = (p.rack(), ring) {
                // ISO 53 profile A: the cutter's straight flank ends (1.25 - 0.38 (1 - sin a0))
                // modules above the datum line, where the generated involute begins: at the roll
                // distance r sin(a0) - (h - x) m / sin(a0) from the base circle's tangent point.
                let (m, a0) = (rack.module, rack.pressure_angle);
                let h = 1.25 - 0.38 * (1.0 - a0.sin());
                let start = m * z as f64 / 2.0 * a0.sin() - (h - x) * m / a0.sin();
                let lowest = if wheel == "A" {
                    self.s_a
                } else {
                    self.l - self.s_b
                };
                if start < 0.0 {
                    // The cutter's corner passes the base circle's tangent point: the flank is
                    // undercut near the base circle, where this model assumes an involute.
                    self.warnings.push(format!(
                        "wheel {wheel} is undercut by a rack cutter (z = {z}, x = {x}): the model assumes an involute down to the lowest contact, {lowest} m from its base circle's tangent point"
                    ));
                } else if start > lowest + 1e-12 * self.l {
                    return Err(ModelError::new(format!(
                        "active profile below the involute: the contact reaches wheel {wheel}'s flank {lowest} m from its base \
                         circle's tangent point, below where a rack cutter's straight flank generates the involute ({start} m; \
                         lower down is the root fillet) ({shape})"
                    )));
                }
            }
        }
        Ok(())
    }

    fn paper(p: &Pair, c: &PaperCut, e_star: f64) -> Result<Geometry, ModelError> {
        let [za_nominal, zb_nominal] = c.z_nominal;
        if p.a.z as i64 * zb_nominal as i64 != p.b.z as i64 * za_nominal as i64 {
            return Err(ModelError::new(format!(
                "tooth ratio zB/zA = {}/{} differs from the nominal ratio zB_nominal/zA_nominal = {}/{}",
                p.b.z, p.a.z, zb_nominal, za_nominal
            )));
        }
        let n = zb_nominal as f64 / za_nominal as f64;
        let (r_a, r_b) = (c.r_a, n * c.r_a);
        let d = r_a + r_b;
        let alpha_inf = (2.0 * PI / (za_nominal as f64 * (1.0 + n))).atan();
        let alpha_w = c.alpha_factor * alpha_inf;
        if alpha_w >= PI / 2.0 {
            return Err(ModelError::parameter(
                "alpha_factor",
                c.alpha_factor,
                &format!("alpha_w = alpha_factor*{alpha_inf} must lie in (alpha_inf, pi/2)"),
            ));
        }
        let (r_ab, r_bb) = (r_a * alpha_w.cos(), r_b * alpha_w.cos());
        let l = d * alpha_w.sin();
        let ab = r_ab * 2.0 * PI / za_nominal as f64;
        let s_a = (l - ab) / 2.0;
        let s_b = s_a + ab;
        let p_b = r_ab * 2.0 * PI / p.a.z as f64;
        // Equal thickness on the operating pitch circles (radii r_a, r_b), backlash removed evenly.
        let s_w = (p_b - p.backlash) / (2.0 * alpha_w.cos());
        Ok(Geometry {
            alpha_w,
            r_ab,
            r_bb,
            d,
            l,
            s_a,
            s_b,
            p_b,
            t_a: s_w / r_a + 2.0 * inv(alpha_w),
            t_b: s_w / r_b + 2.0 * inv(alpha_w),
            r_tip_a: (r_ab * r_ab + s_b * s_b).sqrt(),
            r_tip_b: (r_bb * r_bb + (l - s_a) * (l - s_a)).sqrt(),
            e_star,
            ..Geometry::empty()
        })
    }

    /// Base thickness angle of an external gear from its reference thickness
    /// m (pi/2 + 2 x tan a0), minus its half of the backlash.
    fn base_thickness(p: &Pair, r: &Rack, z: f64, x: f64, r_b: f64) -> f64 {
        let (m, a0) = (r.module, r.pressure_angle);
        m * (PI / 2.0 + 2.0 * x * a0.tan()) / (m * z / 2.0) + 2.0 * inv(a0)
            - p.backlash / (2.0 * r_b)
    }

    /// Standard gear data: an external pair, or (`internal`) a pinion A inside a ring B
    /// (planetary.md §1: O_B at (-d, 0) in the paper frame, the ring's tips inwards, its tooth
    /// space on the reference circle m (pi/2 + 2 xB tan a0)). With kappa = -1 for the ring, the
    /// sums of an external pair become differences.
    fn standard(p: &Pair, rack: &Rack, e_star: f64) -> Result<Geometry, ModelError> {
        // Ranges: the variable table's or the gearbox file's checks.
        let (m, a0) = (rack.module, rack.pressure_angle);
        let (xa, xb) = (p.a.x, p.b.x);
        let (za, zb) = (p.a.z as f64, p.b.z as f64);
        let (kappa, pair) = if p.internal {
            (-1.0, "internal pair: ")
        } else {
            (1.0, "")
        };
        if p.internal && p.b.z <= p.a.z {
            return Err(ModelError::new(format!(
                "{pair}the ring needs more teeth than the pinion (zA = {}, zB = {})",
                p.a.z, p.b.z
            )));
        }
        let inv_w = inv(a0) + 2.0 * a0.tan() * (xb + kappa * xa) / (zb + kappa * za);
        let alpha_w = inv_inverse(inv_w).ok_or_else(|| {
            ModelError::new(format!(
                "{pair}profile shifts xA = {xa}, xB = {xb} give inv(alpha_w) = {inv_w}: no operating pressure angle"
            ))
        })?;
        let d = m * (zb + kappa * za) / 2.0 * a0.cos() / alpha_w.cos();
        let (r_ab, r_bb) = (m * za * a0.cos() / 2.0, m * zb * a0.cos() / 2.0);
        let l = d * alpha_w.sin();
        let r_tip_a = m * za / 2.0 + m * (rack.addendum + xa);
        // A ring's tips point inwards: its addendum counts towards its axis.
        let r_tip_b = m * zb / 2.0 + m * (kappa * rack.addendum + xb);
        if p.internal && !(r_tip_b > r_bb) {
            return Err(ModelError::new(format!(
                "{pair}the ring's tip circle (radius r_Ba = {r_tip_b} m) is not outside its base circle \
                 (rBb = {r_bb} m), where its involute flanks begin; raise xB or lower the addendum \
                 (module = {m}, zB = {}, xB = {}, addendum = {})",
                p.b.z, xb, rack.addendum
            )));
        }
        let s_b = (r_tip_a * r_tip_a - r_ab * r_ab).max(0.0).sqrt();
        let s_a = kappa * (l - (r_tip_b * r_tip_b - r_bb * r_bb).max(0.0).sqrt());
        let t_b = if p.internal {
            // The ring's tooth space on its base circle (the spec's eB, widened by half the
            // backlash); its tooth is the rest of the pitch.
            let e_b = (PI / 2.0 + 2.0 * xb * a0.tan()) * 2.0 / zb
                + 2.0 * inv(a0)
                + p.backlash / (2.0 * r_bb);
            2.0 * PI / zb - e_b
        } else {
            Self::base_thickness(p, rack, zb, xb, r_bb)
        };
        Ok(Geometry {
            alpha_w,
            r_ab,
            r_bb,
            d,
            l,
            s_a,
            s_b,
            p_b: r_ab * 2.0 * PI / za,
            t_a: Self::base_thickness(p, rack, za, xa, r_ab),
            t_b,
            r_tip_a,
            r_tip_b,
            e_star,
            ..Geometry::empty()
        })
    }

    fn empty() -> Geometry {
        Geometry {
            z_a: 0.0,
            z_b: 0.0,
            internal: false,
            kappa: 1.0,
            alpha_w: 0.0,
            r_ab: 0.0,
            r_bb: 0.0,
            d: 0.0,
            d_nominal: 0.0,
            l: 0.0,
            s_a: 0.0,
            s_b: 0.0,
            p_b: 0.0,
            d_a: 0.0,
            d_b: 0.0,
            eps: 0.0,
            m_c: 0,
            t_a: 0.0,
            t_b: 0.0,
            j_n: 0.0,
            r_tip_a: 0.0,
            r_tip_b: 0.0,
            e_star: 0.0,
            warnings: Vec::new(),
        }
    }

    /// B's contact coordinate s_B (from K_B) of a pair at s_A with penetration delta.
    #[inline(always)]
    pub fn s_b_of(&self, s_a: f64, delta: f64) -> f64 {
        self.l + self.kappa * (delta - s_a)
    }

    /// Lower end of an object's window in s_A; the upper end is s_b (spec §3).
    pub fn s_window_low(&self) -> f64 {
        self.s_b - self.m_c as f64 * self.p_b
    }

    /// Window bounds of the forward tracking angle phiA (spec §3), for reporting.
    pub fn phi_window(&self) -> (f64, f64) {
        let phi_min = self.alpha_w - self.s_b / self.r_ab;
        (phi_min, phi_min + self.m_c as f64 * self.d_a)
    }
}

#[cfg(test)]
mod tests;
