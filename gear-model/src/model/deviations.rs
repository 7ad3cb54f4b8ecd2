//! Shape deviations (tooth-structure.md §2): tip relief, eccentricity (runout) and per-tooth
//! pitch deviations. Each is a signed length along the line of action added to one pair's
//! penetration (positive: more penetration), so pairs on a flank no longer share delta.
//!
//! Tooth numbering, each wheel in its forward sense (tooth j+1 one pitch ahead of tooth j):
//! at theta_A = 0, f1 holds teeth A0/B0, f2 A1/B1, b1 A1/B0 (the spec's initial objects), and
//! one base pitch further along a flank's line of action (larger s_A) holds teeth one lower on
//! the forward line and one higher on the backward line.

use super::contact::Flank;
use super::geometry::Geometry;
use super::pair::{Pair, ReliefShape};
use super::ModelError;

/// Tip relief of one wheel: `amount` removed at its tip, over `length` of the line of action.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Relief {
    pub amount: f64,
    pub length: f64,
    /// Where the relief starts on the line of action (A: s_b - length; B: s_a + length).
    pub start: f64,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Deviations {
    /// Tip relief of A and of B.
    pub relief: [Option<Relief>; 2],
    pub shape: ReliefShape,
    pub ecc: [f64; 2],
    pub ecc_phase: [f64; 2],
    pub pitch: [Vec<f64>; 2],
    alpha_w: f64,
}

/// The deviation of one pair and its rate of change.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Offset {
    pub e: f64,
    pub rate: f64,
}

pub const WHEEL: [&str; 2] = ["A", "B"];

impl Deviations {
    /// The deviations the parameters ask for; None when there are none (the mesh then costs
    /// what it did without them).
    pub fn new(p: &Pair, g: &Geometry) -> Result<Option<Deviations>, ModelError> {
        for (w, gear) in [&p.a, &p.b].into_iter().enumerate() {
            let n = gear.pitch_errors.len();
            if n != 0 && n != gear.z as usize {
                return Err(ModelError::new(format!(
                    "parameter pitch_errors_{}: {n} entries, but the wheel has {} teeth (one per tooth, or none)",
                    WHEEL[w], gear.z
                )));
            }
        }
        let pitch = [p.a.pitch_errors.clone(), p.b.pitch_errors.clone()];
        let relief = |amount: f64, length: f64, start: f64| {
            (amount > 0.0 && length > 0.0).then_some(Relief {
                amount,
                length,
                start,
            })
        };
        let segment = g.s_b - g.s_a;
        for (w, length) in [(0, p.a.tip_relief_length), (1, p.b.tip_relief_length)] {
            if length > segment {
                return Err(ModelError::new(format!(
                    "parameter tip_relief_length_{} = {length} m: longer than the contact segment |ab| = {segment} m",
                    WHEEL[w]
                )));
            }
        }
        let d = Deviations {
            relief: [
                relief(
                    p.a.tip_relief,
                    p.a.tip_relief_length,
                    g.s_b - p.a.tip_relief_length,
                ),
                relief(
                    p.b.tip_relief,
                    p.b.tip_relief_length,
                    g.s_a + p.b.tip_relief_length,
                ),
            ],
            shape: p.relief_shape,
            ecc: [p.a.ecc, p.b.ecc],
            ecc_phase: [p.a.ecc_phase, p.b.ecc_phase],
            pitch,
            alpha_w: g.alpha_w,
        };
        let any = d.relief.iter().any(Option::is_some)
            || d.ecc.iter().any(|&e| e != 0.0)
            || d.pitch.iter().any(|v| !v.is_empty());
        Ok(any.then_some(d))
    }

    /// The pitch deviation of a pair holding A's tooth `teeth.0` and B's tooth `teeth.1`.
    pub fn pitch_offset(&self, f: Flank, teeth: (i64, i64)) -> f64 {
        let of = |w: usize, j: i64| {
            let v = &self.pitch[w];
            if v.is_empty() {
                0.0
            } else {
                v[j.rem_euclid(v.len() as i64) as usize]
            }
        };
        f.dir() * (of(0, teeth.0) - of(1, teeth.1))
    }

    /// Tip relief of wheel w at contact coordinate s, with `inside` the recorded mode (the
    /// relief's expression holds on its side of the start point and is extended smoothly past
    /// it until the event there is located). Returns e, de/ds and d2e/ds2.
    pub fn relief(&self, w: usize, s: f64, inside: bool) -> (f64, f64, f64) {
        let Some(r) = self.relief[w].filter(|_| inside) else {
            return (0.0, 0.0, 0.0);
        };
        // x grows towards the wheel's tip: A's at s_b, B's at s_a.
        let (x, dx) = if w == 0 {
            ((s - r.start) / r.length, 1.0 / r.length)
        } else {
            ((r.start - s) / r.length, -1.0 / r.length)
        };
        if self.shape == ReliefShape::Parabolic {
            (
                -r.amount * x * x,
                -2.0 * r.amount * x * dx,
                -2.0 * r.amount * dx * dx,
            )
        } else {
            (-r.amount * x, -r.amount * dx, 0.0)
        }
    }

    /// Both wheels' tip relief at s, each on the side of its start point that s lies on (the
    /// static mesh, which has no modes).
    pub fn tip_relief_at(&self, s: f64) -> f64 {
        let inside =
            |w: usize| self.relief[w].is_some_and(|r| (s - r.start) * [1.0, -1.0][w] > 0.0);
        self.relief(0, s, inside(0)).0 + self.relief(1, s, inside(1)).0
    }

    /// Runout of both wheels on flank f at the interface-frame angles and speeds, with its first
    /// and second time derivatives (`acc`: the wheels' angular accelerations). The centre of
    /// wheel w sits ecc_w from its axis at paper-frame angle beta (beta_A = -theta_A + phase_A,
    /// beta_B = theta_B + phase_B); its component along the flank's line of action moves the
    /// tooth into (A) or out of (B) the contact: forward e = ecc_A sin(alpha_w - beta_A) -
    /// ecc_B sin(alpha_w - beta_B), backward with alpha_w + beta.
    pub fn runout(&self, f: Flank, theta: [f64; 2], w: [f64; 2], acc: [f64; 2]) -> [f64; 3] {
        let dir = f.dir();
        // Arguments u_A = alpha_w + dir (theta_A - phase_A), u_B = alpha_w - dir (theta_B +
        // phase_B); e = ecc_A sin u_A - ecc_B sin u_B.
        let (sa, ca) = (self.alpha_w + dir * (theta[0] - self.ecc_phase[0])).sin_cos();
        let (sb, cb) = (self.alpha_w - dir * (theta[1] + self.ecc_phase[1])).sin_cos();
        let [ea, eb] = self.ecc;
        [
            ea * sa - eb * sb,
            dir * (ea * ca * w[0] + eb * cb * w[1]),
            dir * (ea * (ca * acc[0] - dir * sa * w[0] * w[0])
                + eb * (cb * acc[1] + dir * sb * w[1] * w[1])),
        ]
    }

    pub fn has_runout(&self) -> bool {
        self.ecc.iter().any(|&e| e != 0.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn with(f: impl FnOnce(&mut Pair)) -> (Deviations, Geometry) {
        let mut p = Pair::paper();
        f(&mut p);
        let g = Geometry::new(&p).unwrap();
        (Deviations::new(&p, &g).unwrap().unwrap(), g)
    }

    #[test]
    fn a_pitch_list_needs_one_entry_per_tooth() {
        let mut p = Pair::paper();
        p.b.pitch_errors = vec![1e-6, 2e-6];
        let g = Geometry::new(&p).unwrap();
        let e = Deviations::new(&p, &g).unwrap_err().message;
        assert!(e.contains("pitch_errors_B") && e.contains("2 entries") && e.contains("33 teeth"));
    }

    #[test]
    fn tip_relief_reaches_its_amount_at_each_tip() {
        for shape in [ReliefShape::Linear, ReliefShape::Parabolic] {
            let (d, g) = with(|p| {
                p.a.tip_relief = 1e-5;
                p.a.tip_relief_length = 2e-3;
                p.b.tip_relief = 2e-5;
                p.b.tip_relief_length = 1e-3;
                p.relief_shape = shape;
            });
            // x = 1 at the tip up to the rounding of (s_b - start) / length.
            assert!((d.relief(0, g.s_b, true).0 + 1e-5).abs() < 1e-19);
            assert!((d.relief(1, g.s_a, true).0 + 2e-5).abs() < 1e-19);
            assert_eq!(d.relief(0, g.s_b - 2e-3, true).0, 0.0);
            assert!(d.relief(1, g.s_a + 1e-3, true).0.abs() < 1e-20);
            assert_eq!(d.relief(0, g.s_b, false), (0.0, 0.0, 0.0));
            // The slope by central differences, inside the relief.
            for w in [0, 1] {
                let s = if w == 0 { g.s_b - 5e-4 } else { g.s_a + 3e-4 };
                let h = 1e-7;
                let fd = (d.relief(w, s + h, true).0 - d.relief(w, s - h, true).0) / (2.0 * h);
                assert!((fd - d.relief(w, s, true).1).abs() < 1e-9 * fd.abs().max(1e-3));
            }
        }
    }

    /// One revolution of A with B still: e is a sinusoid of amplitude ecc_A on both flanks; and
    /// the rates match central differences of e along a motion of both wheels.
    #[test]
    fn runout_is_a_sinusoid_with_consistent_rates() {
        let (d, _) = with(|p| {
            p.a.ecc = 3e-6;
            p.a.ecc_phase = 0.4;
            p.b.ecc = 1e-6;
            p.b.ecc_phase = -1.0;
        });
        for f in [Flank::Forward, Flank::Backward] {
            let (lo, hi) = (0..3600).fold((f64::MAX, f64::MIN), |(lo, hi), i| {
                let th = i as f64 * std::f64::consts::TAU / 3600.0;
                let e = d.runout(f, [th, 0.0], [0.0; 2], [0.0; 2])[0];
                (lo.min(e), hi.max(e))
            });
            // B still at theta_B = 0 contributes a constant.
            let b_part = -1e-6 * (d.alpha_w + f.dir()).sin();
            // Sampling every 0.1 degree misses each peak by at most ecc (1 - cos 0.05 deg).
            let miss = 3e-6 * (1.0 - (std::f64::consts::PI / 3600.0).cos()) + 1e-20;
            assert!(((hi - lo) / 2.0 - 3e-6).abs() <= miss, "{f:?}: {hi} {lo}");
            assert!(((hi + lo) / 2.0 - b_part).abs() <= miss);
            // theta(t) = theta0 + w t + a t^2 / 2 for both wheels.
            let (th0, w0, a) = ([0.3, -0.7], [80.0, 55.0], [1e3, -4e2]);
            let at = |t: f64| {
                let th = [0, 1].map(|i| th0[i] + w0[i] * t + 0.5 * a[i] * t * t);
                let w = [0, 1].map(|i| w0[i] + a[i] * t);
                d.runout(f, th, w, a)
            };
            let h = 1e-6;
            let r = at(0.0);
            let d1 = (at(h)[0] - at(-h)[0]) / (2.0 * h);
            let d2 = (at(h)[1] - at(-h)[1]) / (2.0 * h);
            assert!((d1 - r[1]).abs() < 1e-8 * r[1].abs(), "{d1} {}", r[1]);
            assert!((d2 - r[2]).abs() < 1e-6 * r[2].abs(), "{d2} {}", r[2]);
        }
    }

    #[test]
    fn pitch_offsets_follow_the_teeth_and_flank() {
        let (d, _) = with(|p| {
            p.a.pitch_errors = (0..22).map(|k| k as f64 * 1e-7).collect();
        });
        assert_eq!(d.pitch_offset(Flank::Forward, (3, 0)), 3e-7);
        assert_eq!(d.pitch_offset(Flank::Backward, (3, 5)), -3e-7);
        assert_eq!(d.pitch_offset(Flank::Forward, (-1, 0)), 21e-7);
        assert_eq!(d.pitch_offset(Flank::Forward, (23, 0)), 1e-7);
    }

    #[test]
    fn nothing_asked_is_none() {
        let mut p = Pair::paper();
        let g = Geometry::new(&p).unwrap();
        assert!(Deviations::new(&p, &g).unwrap().is_none());
        p.a.tip_relief = 1e-5;
        assert!(
            Deviations::new(&p, &g).unwrap().is_none(),
            "no length, no relief"
        );
    }
}
