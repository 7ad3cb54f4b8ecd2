//! The compliant contact laws behind one interface: a pair's elastic force, stiffness and
//! energy at a penetration, and, for a law whose stiffness depends on where the pair sits on
//! the line of action, that dependence. A new law is a new type implementing `ContactLaw` and
//! one more variant of `Law`.

pub use super::contact_law::ContactLaw;
use super::johnson::{self, OutOfRange};
use super::lower_branch;
use super::tooth_structure::StructureLaw;
use std::sync::Arc;

pub const JOHNSON_LIMIT: &str = "the Johnson law's limit 4(rho_A+rho_B)/e^2";

/// Johnson's line contact (paper eq. 5.1) with R = rho_A + kappa rho_B = L + kappa delta:
/// independent of the position (kappa = -1 for a convex flank in a ring's concave one,
/// planetary.md §1). `F = pi b E* delta v(x)`, `x = e delta/(4R)`, with v from the table of
/// W_-1 (`lower_branch::v`).
#[derive(Clone, Debug, PartialEq)]
pub struct JohnsonLaw {
    l: f64,
    kappa: f64,
    e_star: f64,
    width: f64,
    /// pi E* b, derived from the three above: they are private so that it cannot go stale.
    p: f64,
}

impl JohnsonLaw {
    /// The law of an external pair (kappa = 1) or an internal one (kappa = -1).
    pub fn new(l: f64, kappa: f64, e_star: f64, width: f64) -> JohnsonLaw {
        JohnsonLaw {
            l,
            kappa,
            e_star,
            width,
            p: std::f64::consts::PI * e_star * width,
        }
    }
}

impl ContactLaw for JohnsonLaw {
    /// The odd continuation below 0, as `johnson::force`, which stays the exact oracle.
    #[inline(always)]
    fn force(&self, delta: f64, _s_a: f64) -> Result<f64, OutOfRange> {
        let d = delta.abs();
        let r = self.l + self.kappa * delta;
        let x = std::f64::consts::E * d / (4.0 * r);
        if x == 0.0 {
            return Ok(0.0);
        }
        // NaN x fails the comparison too.
        let v = if x < 1.0 / std::f64::consts::E {
            lower_branch::v(x)
        } else {
            f64::NAN
        };
        if v.is_finite() {
            Ok(delta.signum() * self.p * d * v)
        } else {
            Err(OutOfRange {
                delta: d,
                limit: johnson::delta_limit(r),
            })
        }
    }
    fn stiffness(&self, delta: f64, _s_a: f64) -> Result<f64, OutOfRange> {
        let f = self.force(delta, 0.0)?;
        Ok(self.stiffness_at_force(f.abs(), delta, 0.0))
    }
    /// pi E* b / (-1 - ln y), y = e N/(4 pi E* R) (`johnson::stiffness`).
    fn stiffness_at_force(&self, force: f64, delta: f64, _s_a: f64) -> f64 {
        use std::f64::consts::{E, PI};
        let y = E * (force / self.width) / (4.0 * PI * self.e_star * (self.l + self.kappa * delta));
        if y > 0.0 {
            self.width * PI * self.e_star / (-1.0 - y.ln())
        } else {
            0.0
        }
    }
    fn energy(&self, delta: f64, _s_a: f64) -> Result<f64, OutOfRange> {
        Ok(self.width * johnson::energy_along(delta, self.l, self.kappa, self.e_star)?)
    }
    fn energy_slope(&self, _force: f64, _s_a: f64) -> f64 {
        0.0
    }
    fn depends_on_position(&self) -> bool {
        false
    }
    fn static_delta(&self, force: f64) -> f64 {
        // Eq. 5.1 at R = L: delta(N), monotone, no iteration needed for a scale.
        use std::f64::consts::PI;
        let n = force / self.width;
        n / (PI * self.e_star) * ((4.0 * PI * self.e_star * self.l / n).ln() - 1.0)
    }
    fn limit_name(&self) -> &'static str {
        JOHNSON_LIMIT
    }
}

/// The compliant laws (`contact_model` 1 and 3).
#[derive(Clone, Debug, PartialEq)]
pub enum Law {
    Johnson(JohnsonLaw),
    /// Shared, not copied: a simulation is copied before every integrating fmi2DoStep, and
    /// the law's table never changes after initialization.
    Structure(Arc<StructureLaw>),
}

/// Static dispatch: the right-hand side calls the law for every pair, and a match lets the
/// compiler inline Johnson's law there as before this interface existed (a call through
/// `dyn` cost 9 % more instructions on the base scenes).
macro_rules! dispatch {
    ($self:ident, $l:ident => $e:expr) => {
        match $self {
            Law::Johnson($l) => $e,
            Law::Structure($l) => $e,
        }
    };
}

impl ContactLaw for Law {
    #[inline(always)]
    fn force(&self, delta: f64, s_a: f64) -> Result<f64, OutOfRange> {
        dispatch!(self, l => l.force(delta, s_a))
    }
    #[inline]
    fn stiffness(&self, delta: f64, s_a: f64) -> Result<f64, OutOfRange> {
        dispatch!(self, l => l.stiffness(delta, s_a))
    }
    #[inline]
    fn stiffness_at_force(&self, force: f64, delta: f64, s_a: f64) -> f64 {
        dispatch!(self, l => l.stiffness_at_force(force, delta, s_a))
    }
    #[inline]
    fn energy(&self, delta: f64, s_a: f64) -> Result<f64, OutOfRange> {
        dispatch!(self, l => l.energy(delta, s_a))
    }
    #[inline]
    fn energy_slope(&self, force: f64, s_a: f64) -> f64 {
        dispatch!(self, l => l.energy_slope(force, s_a))
    }
    #[inline]
    fn force_and_slope(&self, delta: f64, s_a: f64) -> Result<(f64, f64), OutOfRange> {
        dispatch!(self, l => l.force_and_slope(delta, s_a))
    }
    #[inline]
    fn flank_forces_and_slopes(
        &self,
        delta: f64,
        s_a: &[f64],
        out: &mut [(f64, f64)],
    ) -> Result<(), OutOfRange> {
        dispatch!(self, l => l.flank_forces_and_slopes(delta, s_a, out))
    }
    #[inline]
    fn depends_on_position(&self) -> bool {
        dispatch!(self, l => l.depends_on_position())
    }
    fn static_delta(&self, force: f64) -> f64 {
        dispatch!(self, l => l.static_delta(force))
    }
    fn limit_name(&self) -> &'static str {
        dispatch!(self, l => l.limit_name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Through the table Johnson's force stays within the table's tolerance (1e-13 of v) and
    /// the rounding of a different formula (a few ulp: 2e-13 in all) of the closed form with
    /// `lambert_w` (`johnson::force`), over the penetrations from below the table's range to
    /// the law's limit, for both signs, with the same range errors. The stiffness divides y's
    /// error by -1 - ln y, at least 2.2 over the table's range (x <= 1/8), so 1e-13 holds.
    #[test]
    fn johnson_through_the_table_matches_the_closed_form() {
        let (l, e_star, width) = (0.1714599985155, 115384615384.615, 0.02);
        let law = JohnsonLaw::new(l, 1.0, e_star, width);
        // With R = L + delta the range ends where delta = 4(L + delta)/e^2.
        let e2 = std::f64::consts::E * std::f64::consts::E;
        let limit = 4.0 * l / (e2 - 4.0);
        let mut k = 0;
        let mut delta = 1e-40;
        while delta < limit {
            for d in [delta, -delta] {
                // R = L + delta: below 0 the limit is a little lower.
                let Ok(exact) = johnson::force(d, l + d, e_star) else {
                    let e = johnson::force(d, l + d, e_star).unwrap_err();
                    assert_eq!(law.force(d, 0.0), Err(e), "{d}");
                    continue;
                };
                let exact = width * exact;
                let got = law.force(d, 0.0).unwrap();
                assert!(
                    (got - exact).abs() <= 2e-13 * exact.abs(),
                    "{d}: {got} vs {exact}"
                );
                let k_exact = width * johnson::stiffness(d, l + d, e_star).unwrap();
                let k_got = law.stiffness(d, 0.0).unwrap();
                assert!(
                    (k_got - k_exact).abs() <= 1e-13 * k_exact,
                    "{d}: {k_got} vs {k_exact}"
                );
            }
            delta *= 1.0137;
            k += 1;
        }
        assert!(k > 5000, "{k} samples");
        assert_eq!(law.force(0.0, 0.0), Ok(0.0));
        assert!(law.force(limit * (1.0 - 1e-9), 0.0).is_ok());
        for bad in [limit * (1.0 + 1e-9), 2.0 * limit, f64::NAN, f64::INFINITY] {
            let e = law.force(bad, 0.0).unwrap_err();
            let exact = johnson::force(bad, l + bad, e_star).unwrap_err();
            // Debug text: NaN fields compare unequal.
            assert_eq!(format!("{e:?}"), format!("{exact:?}"));
        }
    }
}
