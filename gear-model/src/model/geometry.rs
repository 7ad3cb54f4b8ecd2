//! Gear geometry (spec §2): from the parameters to the numbers the contact model needs.
//! Two front ends, the paper's and standard gear data, give the same `Geometry`.

use super::ModelError;
use crate::variables::Params;
use std::f64::consts::PI;

#[derive(Clone, Debug, Default, PartialEq)]
pub struct Geometry {
    pub z_a: f64,
    pub z_b: f64,
    /// Operating pressure angle alpha_w.
    pub alpha_w: f64,
    pub r_ab: f64,
    pub r_bb: f64,
    /// Centre distance.
    pub d: f64,
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
    /// Base tooth thickness angles (with backlash).
    pub t_a: f64,
    pub t_b: f64,
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
    pub fn new(p: &Params) -> Result<Geometry, ModelError> {
        let e_star = 1.0 / ((1.0 - p.nu_A * p.nu_A) / p.E_A + (1.0 - p.nu_B * p.nu_B) / p.E_B);
        let (z_a, z_b) = (p.zA as f64, p.zB as f64);
        let (d_a, d_b) = (2.0 * PI / z_a, 2.0 * PI / z_b);
        let mut g = match p.geometry {
            1 => Self::paper(p, e_star)?,
            2 => Self::standard(p, e_star)?,
            other => {
                return Err(ModelError::parameter(
                    "geometry",
                    other,
                    "must be 1 (paper) or 2 (standard gear data)",
                ))
            }
        };
        g.z_a = z_a;
        g.z_b = z_b;
        g.d_a = d_a;
        g.d_b = d_b;
        g.eps = (g.s_b - g.s_a) / g.p_b;
        if g.eps < 1.0 - 1e-9 || g.eps > 2.0 + 1e-9 {
            return Err(ModelError::new(format!(
                "contact ratio eps = (s_b - s_a)/p_b = ({} - {})/{} = {} must lie in [1, 2]",
                g.s_b, g.s_a, g.p_b, g.eps
            )));
        }
        let needed = (g.eps - 1e-9).ceil() as usize;
        g.m_c = match p.contacts_per_flank {
            0 => needed,
            m if (m as usize) < needed => {
                return Err(ModelError::parameter(
                    "contacts_per_flank",
                    m,
                    &format!(
                        "the contact ratio {} needs {needed} contact objects per flank",
                        g.eps
                    ),
                ))
            }
            m => m as usize,
        };
        g.check_teeth(p)?;
        Ok(g)
    }

    /// Teeth that cannot exist are rejected with their numbers: no thickness on the operating
    /// pitch circle (too much backlash), pointed tips, an active profile below where a rack
    /// cutter generates the involute (undercut). A tip thinner than 0.2 module is a warning.
    /// An involute tooth whose angular thickness on the base circle is t has the angular
    /// thickness t - 2 inv(alpha_r) on the circle of radius r, cos(alpha_r) = r_b/r.
    fn check_teeth(&mut self, p: &Params) -> Result<(), ModelError> {
        let thickness = |t: f64, r_b: f64, r: f64| r * (t - 2.0 * inv((r_b / r).min(1.0).acos()));
        let (shape, module) = match p.geometry {
            1 => (
                format!(
                    "alpha_factor = {}, zA = {}, zB = {}, backlash = {}",
                    p.alpha_factor, p.zA, p.zB, p.backlash
                ),
                // The operating module: the base pitch over pi cos(alpha_w).
                self.p_b / (PI * self.alpha_w.cos()),
            ),
            _ => (
                format!(
                    "module = {}, zA = {}, zB = {}, xA = {}, xB = {}, addendum = {}, backlash = {}",
                    p.module, p.zA, p.zB, p.xA, p.xB, p.addendum, p.backlash
                ),
                p.module,
            ),
        };
        for (wheel, t, r_b, r_tip, z, x) in [
            ("A", self.t_a, self.r_ab, self.r_tip_a, p.zA, p.xA),
            ("B", self.t_b, self.r_bb, self.r_tip_b, p.zB, p.xB),
        ] {
            let r_w = r_b / self.alpha_w.cos();
            let pitch = thickness(t, r_b, r_w);
            if !(pitch > 0.0) {
                return Err(ModelError::parameter(
                    "backlash",
                    p.backlash,
                    &format!(
                        "leaves wheel {wheel}'s tooth no thickness on its operating pitch circle (radius {r_w} m): {pitch} m"
                    ),
                ));
            }
            let tip = thickness(t, r_b, r_tip);
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
            if p.geometry == 2 {
                // ISO 53 profile A: the cutter's straight flank ends (1.25 - 0.38 (1 - sin a0))
                // modules above the datum line, where the generated involute begins: at the roll
                // distance r sin(a0) - (h - x) m / sin(a0) from the base circle's tangent point.
                let a0 = p.pressure_angle;
                let h = 1.25 - 0.38 * (1.0 - a0.sin());
                let start = p.module * z as f64 / 2.0 * a0.sin() - (h - x) * p.module / a0.sin();
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

    fn paper(p: &Params, e_star: f64) -> Result<Geometry, ModelError> {
        if p.zA as i64 * p.zB_nominal as i64 != p.zB as i64 * p.zA_nominal as i64 {
            return Err(ModelError::new(format!(
                "tooth ratio zB/zA = {}/{} differs from the nominal ratio zB_nominal/zA_nominal = {}/{}",
                p.zB, p.zA, p.zB_nominal, p.zA_nominal
            )));
        }
        let n = p.zB_nominal as f64 / p.zA_nominal as f64;
        let (r_a, r_b) = (p.rA, n * p.rA);
        let d = r_a + r_b;
        let alpha_inf = (2.0 * PI / (p.zA_nominal as f64 * (1.0 + n))).atan();
        let alpha_w = p.alpha_factor * alpha_inf;
        if alpha_w >= PI / 2.0 {
            return Err(ModelError::parameter(
                "alpha_factor",
                p.alpha_factor,
                &format!("alpha_w = alpha_factor*{alpha_inf} must lie in (alpha_inf, pi/2)"),
            ));
        }
        let (r_ab, r_bb) = (r_a * alpha_w.cos(), r_b * alpha_w.cos());
        let l = d * alpha_w.sin();
        let ab = r_ab * 2.0 * PI / p.zA_nominal as f64;
        let s_a = (l - ab) / 2.0;
        let s_b = s_a + ab;
        let p_b = r_ab * 2.0 * PI / p.zA as f64;
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

    fn standard(p: &Params, e_star: f64) -> Result<Geometry, ModelError> {
        // Ranges: `validate` (the variable table).
        let (m, a0) = (p.module, p.pressure_angle);
        let (za, zb) = (p.zA as f64, p.zB as f64);
        let inv_w = inv(a0) + 2.0 * a0.tan() * (p.xA + p.xB) / (za + zb);
        let alpha_w = inv_inverse(inv_w).ok_or_else(|| {
            ModelError::new(format!(
                "profile shifts xA = {}, xB = {} give inv(alpha_w) = {inv_w}: no operating pressure angle",
                p.xA, p.xB
            ))
        })?;
        let d = m * (za + zb) / 2.0 * a0.cos() / alpha_w.cos();
        let (r_ab, r_bb) = (m * za * a0.cos() / 2.0, m * zb * a0.cos() / 2.0);
        let l = d * alpha_w.sin();
        let r_tip_a = m * za / 2.0 + m * (p.addendum + p.xA);
        let r_tip_b = m * zb / 2.0 + m * (p.addendum + p.xB);
        let s_b = (r_tip_a * r_tip_a - r_ab * r_ab).max(0.0).sqrt();
        let s_a = l - (r_tip_b * r_tip_b - r_bb * r_bb).max(0.0).sqrt();
        if s_a < 0.0 || s_b > l {
            return Err(ModelError::new(format!(
                "interference: the contact segment [s_a, s_b] = [{s_a}, {s_b}] leaves the line of action [0, {l}] \
                 (tip radii {r_tip_a}, {r_tip_b}; reduce addendum or change the profile shifts)"
            )));
        }
        // Base thickness angle from the reference thickness m(pi/2 + 2 x tan a0); backlash split evenly.
        let t = |z: f64, x: f64, rb: f64| {
            m * (PI / 2.0 + 2.0 * x * a0.tan()) / (m * z / 2.0) + 2.0 * inv(a0)
                - p.backlash / (2.0 * rb)
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
            t_a: t(za, p.xA, r_ab),
            t_b: t(zb, p.xB, r_bb),
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
            alpha_w: 0.0,
            r_ab: 0.0,
            r_bb: 0.0,
            d: 0.0,
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
            r_tip_a: 0.0,
            r_tip_b: 0.0,
            e_star: 0.0,
            warnings: Vec::new(),
        }
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
mod tests {
    use super::*;

    /// test-vectors.md values are printed with 12-15 significant digits; each quantity here is a
    /// few floating-point operations from the inputs, so agreement to 1e-12 relative is expected.
    fn close(a: f64, b: f64) {
        assert!((a - b).abs() <= 1e-12 * b.abs().max(1e-300), "{a} vs {b}");
    }

    #[test]
    fn paper_geometry_matches_test_vectors() {
        let g = Geometry::new(&Params::default()).unwrap();
        close(g.alpha_w, 0.350023621796666);
        close(g.r_ab, 0.187872922544603);
        close(g.r_bb, 0.281809383816904);
        close(g.d, 0.5);
        close(g.l, 0.1714599985155);
        close(g.s_a, 0.0562189895940214);
        close(g.s_b, 0.115241008921478);
        close(g.p_b, 0.053656381206779);
        close(g.eps, 1.1);
        assert_eq!(g.m_c, 2);
        close(g.t_a, 0.172596813864531);
        close(g.t_b, 0.125085637620684);
        close(g.e_star, 115384615384.615);
        let (lo, hi) = g.phi_window();
        close(lo, -0.263375091336776);
        close(hi, 0.307823572952278);
        close(g.r_tip_a, 0.220401282125787);
        close(g.r_tip_b, 0.304461851377974);
        close(g.r_bb * g.d_b, g.p_b);
    }

    #[test]
    fn zero_backlash_thickness() {
        let p = Params {
            backlash: 0.0,
            ..Params::default()
        };
        let g = Geometry::new(&p).unwrap();
        close(g.t_a, 0.172862951205255);
        // The vector has 14 significant digits.
        assert!((g.t_b - 0.12526306251450).abs() < 1e-13);
    }

    #[test]
    fn thickness_closure_holds_for_both_front_ends() {
        for geometry in [1, 2] {
            let p = Params {
                geometry,
                xA: 0.2,
                xB: -0.1,
                ..Params::default()
            };
            let g = Geometry::new(&p).unwrap();
            let lhs = g.r_ab * g.t_a + g.r_bb * g.t_b;
            let rhs = g.p_b + 2.0 * g.d * g.alpha_w.cos() * inv(g.alpha_w) - p.backlash;
            assert!(
                (lhs - rhs).abs() < 1e-14,
                "geometry {geometry}: {lhs} vs {rhs}"
            );
        }
    }

    #[test]
    fn standard_geometry_of_unshifted_gears() {
        let p = Params {
            geometry: 2,
            module: 0.004,
            zA: 20,
            zB: 40,
            ..Params::default()
        };
        let g = Geometry::new(&p).unwrap();
        close(g.alpha_w, p.pressure_angle);
        close(g.d, 0.004 * 60.0 / 2.0);
        // Textbook contact ratio of a 20/40 pair, 20 deg, full-depth teeth: 1.6 to 1.7.
        assert!(g.eps > 1.6 && g.eps < 1.7, "{}", g.eps);
        assert_eq!(g.m_c, 2);
    }

    #[test]
    fn inconsistent_parameters_are_rejected_with_names() {
        let cases: Vec<(Params, &str)> = vec![
            (
                Params {
                    zA: 21,
                    ..Params::default()
                },
                "tooth ratio",
            ),
            (
                Params {
                    width: -1.0,
                    ..Params::default()
                },
                "width",
            ),
            (
                Params {
                    J_A: 0.0,
                    ..Params::default()
                },
                "J_A",
            ),
            (
                Params {
                    E_B: f64::NAN,
                    ..Params::default()
                },
                "E_B",
            ),
            (
                Params {
                    nu_A: 0.5,
                    ..Params::default()
                },
                "nu_A",
            ),
            (
                Params {
                    backlash: -1e-6,
                    ..Params::default()
                },
                "backlash",
            ),
            (
                Params {
                    rA: 0.0,
                    ..Params::default()
                },
                "rA",
            ),
            (
                Params {
                    zA: 44,
                    zB: 66,
                    ..Params::default()
                },
                "contact ratio",
            ),
            (
                Params {
                    zA: 18,
                    zB: 27,
                    ..Params::default()
                },
                "contact ratio",
            ),
            (
                Params {
                    contacts_per_flank: 1,
                    ..Params::default()
                },
                "contacts_per_flank",
            ),
            (
                Params {
                    geometry: 2,
                    addendum: 3.0,
                    ..Params::default()
                },
                "interference",
            ),
        ];
        // What a rig does: the parameters on their own, then how they fit together.
        for (p, word) in cases {
            let e = crate::model::params::validate(&p)
                .and_then(|_| Geometry::new(&p))
                .unwrap_err();
            assert!(e.message.contains(word), "{} should name {word}", e.message);
        }
    }

    fn standard(za: i32, zb: i32, xa: f64, xb: f64) -> Params {
        Params {
            geometry: 2,
            module: 0.004,
            zA: za,
            zB: zb,
            xA: xa,
            xB: xb,
            pressure_angle: 20f64.to_radians(),
            ..Params::default()
        }
    }

    /// Issue 9, point 5: teeth that cannot exist are rejected with their numbers, in both
    /// front ends, and each case is one that passed every earlier check. A contact below the
    /// generated involute: 20 teeth without shift are generated from 1.99 mm above the base
    /// circle's tangent point (module 4 mm), and a 1.1-module addendum on the 80-tooth mate
    /// brings the contact down to 1.91 mm.
    #[test]
    fn impossible_teeth_are_rejected() {
        let cases = [
            (
                Params {
                    alpha_factor: 3.5,
                    ..Params::default()
                },
                "pointed teeth",
                "alpha_factor = 3.5",
            ),
            (
                Params {
                    zA: 40,
                    zB: 60,
                    ..Params::default()
                },
                "pointed teeth",
                "zA = 40",
            ),
            (standard(10, 30, 0.8, 0.0), "pointed teeth", "xA = 0.8"),
            (
                Params {
                    backlash: 0.06,
                    ..Params::default()
                },
                "backlash = 0.06",
                "operating pitch circle",
            ),
            (
                Params {
                    addendum: 1.1,
                    ..standard(20, 80, 0.0, 0.0)
                },
                "active profile below the involute",
                "addendum = 1.1",
            ),
        ];
        for (p, what, names) in cases {
            let e = Geometry::new(&p).unwrap_err().message;
            assert!(e.contains(what) && e.contains(names), "{what}: {e}");
        }
    }

    /// A tip thinner than 0.2 module is accepted with a warning naming its thickness; standard
    /// unshifted pairs from 18 teeth on and the paper rig have none.
    #[test]
    fn thin_tips_are_a_warning() {
        let g = Geometry::new(&standard(12, 40, 0.8, 0.0)).unwrap();
        assert!(
            g.warnings.iter().any(|w| w.contains("wheel A's tooth tip")),
            "{:?}",
            g.warnings
        );
        for p in [
            Params::default(),
            standard(18, 40, 0.0, 0.0),
            standard(30, 30, 0.0, 0.0),
        ] {
            let g = Geometry::new(&p).unwrap();
            assert!(g.warnings.is_empty(), "{:?}", g.warnings);
        }
    }
}
