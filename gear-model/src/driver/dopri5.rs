//! Dormand-Prince 5(4) with FSAL, PI step-size control and the 4th-order continuous extension
//! (coefficients from Hairer, Norsett & Wanner, Solving ODEs I, sec. II.5 and II.6). The nodes c_i
//! are not needed: between events and input changes the system is autonomous.

use super::{error_norm, Stability, Stats, StepError, System, Tolerance, Vector};

const A21: f64 = 1.0 / 5.0;
const A31: f64 = 3.0 / 40.0;
const A32: f64 = 9.0 / 40.0;
const A41: f64 = 44.0 / 45.0;
const A42: f64 = -56.0 / 15.0;
const A43: f64 = 32.0 / 9.0;
const A51: f64 = 19372.0 / 6561.0;
const A52: f64 = -25360.0 / 2187.0;
const A53: f64 = 64448.0 / 6561.0;
const A54: f64 = -212.0 / 729.0;
const A61: f64 = 9017.0 / 3168.0;
const A62: f64 = -355.0 / 33.0;
const A63: f64 = 46732.0 / 5247.0;
const A64: f64 = 49.0 / 176.0;
const A65: f64 = -5103.0 / 18656.0;
const A71: f64 = 35.0 / 384.0;
const A73: f64 = 500.0 / 1113.0;
const A74: f64 = 125.0 / 192.0;
const A75: f64 = -2187.0 / 6784.0;
const A76: f64 = 11.0 / 84.0;
const E1: f64 = 71.0 / 57600.0;
const E3: f64 = -71.0 / 16695.0;
const E4: f64 = 71.0 / 1920.0;
const E5: f64 = -17253.0 / 339200.0;
const E6: f64 = 22.0 / 525.0;
const E7: f64 = -1.0 / 40.0;
const D1: f64 = -12715105075.0 / 11282082432.0;
const D3: f64 = 87487479700.0 / 32700410799.0;
const D4: f64 = -10690763975.0 / 1880347072.0;
const D5: f64 = 701980252875.0 / 199316789632.0;
const D6: f64 = -1453857185.0 / 822651844.0;
const D7: f64 = 69997945.0 / 29380423.0;

/// The h omega that steps may reach on an oscillation (`System::max_step`). The stability
/// function grows slowly along the imaginary axis, |R(iy)| - 1 = 1.4e-6 at y = 1 and 0.03 at
/// y = 2, so near an equilibrium, where the error estimate sees nothing, an undamped
/// oscillation grows by at most a few per cent per step. Along a damped mode's ray the region
/// reaches further: from 0.99 undamped to 2.4 at 5 % damping and 3.27 overdamped
/// (R(z) = 1 + z + ... + z^5/120 + z^6/600).
pub const STABILITY: Stability = Stability {
    reach: 2.0,
    region: Some(&[
        (0.0, 0.99),
        (0.002, 1.5),
        (0.005, 1.69),
        (0.01, 1.87),
        (0.02, 2.07),
        (0.05, 2.4),
        (0.1, 2.68),
        (0.2, 3.0),
        (0.3, 3.21),
        (0.5, 3.27),
        (1.0, 3.27),
    ]),
};

#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Dopri5<Y> {
    pub t: f64,
    pub t_prev: f64,
    pub h: f64,
    pub y: Y,
    /// f(t, y): first stage of the next step (FSAL).
    pub k1: Y,
    /// Continuous-extension coefficients of the last step.
    pub rcont: [Y; 5],
    pub facold: f64,
}

/// out = y + h sum(a k) over the first n components; the rest of `out` is left as it is (a
/// copy of y's: components past n never change). The term count is a constant so that the
/// loop over terms unrolls; inlined, so each stage's sum is straight code.
#[inline(always)]
fn axpy<Y: Vector, const M: usize>(out: &mut Y, y: &Y, h: f64, a: [f64; M], k: [&Y; M], n: usize) {
    for i in 0..n {
        let mut s = a[0] * k[0][i];
        for j in 1..M {
            s += a[j] * k[j][i];
        }
        out[i] = y[i] + h * s;
    }
}

impl<Y: Vector> Default for Dopri5<Y> {
    fn default() -> Self {
        Self::new()
    }
}

impl<Y: Vector> Dopri5<Y> {
    pub fn new() -> Self {
        Dopri5 {
            t: 0.0,
            t_prev: 0.0,
            h: 0.0,
            y: Y::zeros(),
            k1: Y::zeros(),
            rcont: [Y::zeros(); 5],
            facold: 1e-4,
        }
    }

    /// Starts at (t, y). With no hint the initial step follows Hairer's estimate from f and f'.
    pub fn restart<S: System<State = Y>>(
        &mut self,
        sys: &S,
        t: f64,
        y: &Y,
        h_hint: Option<f64>,
        tol: &Tolerance<Y>,
        stats: &mut Stats,
    ) -> Result<(), StepError<S::Error>> {
        self.t = t;
        self.t_prev = t;
        self.y = *y;
        (self.k1, self.h) = super::explicit_start(sys, y, h_hint, 5, STABILITY, tol, stats)?;
        self.rcont = [*y, Y::zeros(), Y::zeros(), Y::zeros(), Y::zeros()];
        self.facold = 1e-4;
        Ok(())
    }

    /// One accepted step of at most h_max.
    pub fn step<S: System<State = Y>>(
        &mut self,
        sys: &S,
        h_max: f64,
        tol: &Tolerance<Y>,
        stats: &mut Stats,
    ) -> Result<(), StepError<S::Error>> {
        let (y, k1) = (&self.y, &self.k1);
        // Only the components in use: the others have zero derivatives and stay as they are,
        // so the stages' arguments share one buffer that starts as y.
        let n = sys.dim();
        let mut arg = *y;
        let mut h = self.h.min(h_max);
        let mut last_err = None;
        loop {
            if !(h > super::min_step(self.t)) {
                return Err(last_err.unwrap_or(StepError::StepTooSmall { t: self.t, h }));
            }
            let mut k = [Y::zeros(); 6];
            let stages = (|| {
                axpy(&mut arg, y, h, [A21], [k1], n);
                sys.rhs(&arg, &mut k[0])?;
                axpy(&mut arg, y, h, [A31, A32], [k1, &k[0]], n);
                sys.rhs(&arg, &mut k[1])?;
                axpy(&mut arg, y, h, [A41, A42, A43], [k1, &k[0], &k[1]], n);
                sys.rhs(&arg, &mut k[2])?;
                let a = [A51, A52, A53, A54];
                axpy(&mut arg, y, h, a, [k1, &k[0], &k[1], &k[2]], n);
                sys.rhs(&arg, &mut k[3])?;
                let a = [A61, A62, A63, A64, A65];
                axpy(&mut arg, y, h, a, [k1, &k[0], &k[1], &k[2], &k[3]], n);
                sys.rhs(&arg, &mut k[4])
            })();
            let mut y1 = *y;
            let a = [A71, A73, A74, A75, A76];
            axpy(&mut y1, y, h, a, [k1, &k[1], &k[2], &k[3], &k[4]], n);
            let result = stages.and_then(|_| sys.rhs(&y1, &mut k[5]));
            stats.rhs_evals += 6;
            if let Err(e) = result {
                // Outside the contact law's range: try a smaller step; report it if none works.
                last_err = Some(StepError::Law(e));
                stats.rejected += 1;
                h *= 0.25;
                continue;
            }
            let (k3, k4, k5, k6, k7) = (&k[1], &k[2], &k[3], &k[4], &k[5]);
            let mut e = Y::zeros();
            for i in 0..n {
                e[i] = h
                    * (E1 * k1[i] + E3 * k3[i] + E4 * k4[i] + E5 * k5[i] + E6 * k6[i] + E7 * k7[i]);
            }
            let err = error_norm(&e, y, &y1, tol);
            if err <= 1.0 {
                // In place: past n, rcont[0] holds y's constant components and the others 0
                // (`restart`).
                let r = &mut self.rcont;
                for i in 0..n {
                    let ydiff = y1[i] - y[i];
                    let bspl = h * k1[i] - ydiff;
                    r[0][i] = y[i];
                    r[1][i] = ydiff;
                    r[2][i] = bspl;
                    r[3][i] = ydiff - h * k7[i] - bspl;
                    r[4][i] = h
                        * (D1 * k1[i]
                            + D3 * k3[i]
                            + D4 * k4[i]
                            + D5 * k5[i]
                            + D6 * k6[i]
                            + D7 * k7[i]);
                }
                // PI controller (beta = 0.04) as in Hairer's DOPRI5.
                // err^0.17 / facold^0.04 by one exp: two pow calls were 3 % of a run.
                let fac = ((0.17 * err.ln() - 0.04 * self.facold.ln()).exp() / 0.9).clamp(0.1, 5.0);
                self.facold = err.max(1e-4);
                self.t_prev = self.t;
                self.t += h;
                self.y = y1;
                self.k1 = *k7;
                self.h = h / fac;
                stats.steps += 1;
                return Ok(());
            }
            stats.rejected += 1;
            // The error is O(h^5): shrink by err^(1/5), at most 20x. After a contact onset the
            // first step is often 10x too long (err ~ 1e5), and Hairer's cap of 5 cost one more
            // rejection there; an error far outside the asymptotic range (a stage near the
            // law's limit) still backs off over several tries. NaN errors: shrink hard.
            let shrink = if err.is_finite() {
                ((0.2 * err.ln()).exp() / 0.9).min(20.0)
            } else {
                4.0
            };
            h /= shrink;
            last_err = None;
        }
    }

    /// The rate of the continuous extension at t: f(t_prev) and f(t) at the step's ends.
    pub fn derivative(&self, t: f64) -> Y {
        let h = self.t - self.t_prev;
        if h == 0.0 {
            return self.k1;
        }
        let s = (t - self.t_prev) / h;
        let r = &self.rcont;
        Y::from_fn(|i| {
            (r[1][i]
                + (1.0 - 2.0 * s) * r[2][i]
                + s * (2.0 - 3.0 * s) * r[3][i]
                + 2.0 * s * (1.0 - s) * (1.0 - 2.0 * s) * r[4][i])
                / h
        })
    }

    pub fn interpolate(&self, t: f64) -> Y {
        let h = self.t - self.t_prev;
        if h == 0.0 {
            return self.y;
        }
        let s = (t - self.t_prev) / h;
        let s1 = 1.0 - s;
        let r = &self.rcont;
        let mut out = Y::zeros();
        for i in 0..Y::LEN {
            out[i] = r[0][i] + s * (r[1][i] + s1 * (r[2][i] + s * (r[3][i] + s1 * r[4][i])));
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `STABILITY.region` lies inside the method's region (its weights are A7*: FSAL).
    #[test]
    fn region_table_is_inside_the_stability_region() {
        let a: [&[f64]; 6] = [
            &[],
            &[A21],
            &[A31, A32],
            &[A41, A42, A43],
            &[A51, A52, A53, A54],
            &[A61, A62, A63, A64, A65],
        ];
        let b = [A71, 0.0, A73, A74, A75, A76];
        super::super::stability::check_region(&a, &b, STABILITY);
        // And the table is close under the boundary: a step 5 % past it leaves the region.
        for &(zeta, r) in STABILITY.region.unwrap() {
            let d = (-zeta, (1.0 - zeta * zeta).sqrt());
            let past = 1.05 * r;
            let g = crate::driver::stability::amplification(&a, &b, (past * d.0, past * d.1));
            assert!(
                g > 1.0,
                "zeta {zeta}: the table is more than 5 % inside ({g})"
            );
        }
    }
}
