//! TR-BDF2 (Bank et al. 1985; Hosea & Shampine 1996): a trapezoidal stage to t + gamma h, a
//! BDF2 stage to t + h, gamma = 2 - sqrt(2), both with the same iteration matrix I - d h J.
//! L-stable and stiffly accurate, with a third-order embedded solution for the error estimate,
//! the estimate filtered through (I - d h J)^-1 so stiff components do not force tiny steps, and
//! cubic Hermite dense output. The Jacobian is by finite differences (4 controlled components).

use super::{error_norm, Stats, StepError, System};
use crate::model::mesh::N_CONTROLLED;
use crate::model::{State, NY};
use nalgebra::{SMatrix, SVector};

type Mat = SMatrix<f64, NY, NY>;
type Vector = SVector<f64, NY>;

const SQRT2: f64 = std::f64::consts::SQRT_2;
const GAMMA: f64 = 2.0 - SQRT2;
const D: f64 = GAMMA / 2.0;
const W: f64 = SQRT2 / 4.0;
/// b - b_hat of the embedded pair: ((4w - 1)/3, -1/3, 2d/3).
const EB1: f64 = (4.0 * W - 1.0) / 3.0;
const EB2: f64 = -1.0 / 3.0;
const EB3: f64 = 2.0 * D / 3.0;

#[derive(Clone, Debug, PartialEq)]
pub struct TrBdf2 {
    pub t: f64,
    pub t_prev: f64,
    pub h: f64,
    pub y: State,
    pub f: State,
    pub y_prev: State,
    pub f_prev: State,
    pub jac: Mat,
    pub jac_fresh: bool,
}

fn to_vec(a: &State) -> Vector {
    Vector::from_column_slice(a)
}

fn from_vec(v: &Vector) -> State {
    let mut a = [0.0; NY];
    a.copy_from_slice(v.as_slice());
    a
}

impl TrBdf2 {
    pub fn new() -> Self {
        TrBdf2 {
            t: 0.0,
            t_prev: 0.0,
            h: 0.0,
            y: [0.0; NY],
            f: [0.0; NY],
            y_prev: [0.0; NY],
            f_prev: [0.0; NY],
            jac: Mat::zeros(),
            jac_fresh: false,
        }
    }

    pub fn restart<S: System>(
        &mut self,
        sys: &S,
        t: f64,
        y: &State,
        h_hint: Option<f64>,
        tol: &super::Tolerance,
        stats: &mut Stats,
    ) -> Result<(), StepError> {
        self.t = t;
        self.t_prev = t;
        self.y = *y;
        self.y_prev = *y;
        sys.rhs(y, &mut self.f).map_err(StepError::Law)?;
        stats.rhs_evals += 1;
        self.f_prev = self.f;
        // The modes changed: the old Jacobian is stale.
        self.jacobian(sys, tol, stats)?;
        self.h = match h_hint {
            Some(h) => h,
            None => super::initial_step(sys, y, &self.f, 2, tol, stats)?,
        };
        Ok(())
    }

    fn jacobian<S: System>(
        &mut self,
        sys: &S,
        tol: &super::Tolerance,
        stats: &mut Stats,
    ) -> Result<(), StepError> {
        let mut jac = Mat::zeros();
        for j in 0..N_CONTROLLED {
            let dy = f64::EPSILON.sqrt() * self.y[j].abs().max(tol.atol[j] / tol.rtol);
            let mut yp = self.y;
            yp[j] += dy;
            let mut fp = [0.0; NY];
            sys.rhs(&yp, &mut fp).map_err(StepError::Law)?;
            for i in 0..NY {
                jac[(i, j)] = (fp[i] - self.f[i]) / dy;
            }
        }
        stats.rhs_evals += N_CONTROLLED as u64;
        stats.jac_evals += 1;
        self.jac = jac;
        self.jac_fresh = true;
        Ok(())
    }

    /// Solves z = base + d h f(z) by simplified Newton; None if it does not converge.
    fn solve_stage<S: System>(
        sys: &S,
        lu: &nalgebra::LU<f64, nalgebra::Const<NY>, nalgebra::Const<NY>>,
        base: &State,
        guess: State,
        dh: f64,
        tol: &super::Tolerance,
        stats: &mut Stats,
    ) -> Result<Option<(State, State)>, StepError> {
        let mut z = guess;
        let mut fz = [0.0; NY];
        let mut prev_norm = f64::INFINITY;
        for _ in 0..8 {
            if sys.rhs(&z, &mut fz).is_err() {
                stats.rhs_evals += 1;
                return Ok(None);
            }
            stats.rhs_evals += 1;
            let mut g = [0.0; NY];
            for i in 0..NY {
                g[i] = -(z[i] - base[i] - dh * fz[i]);
            }
            let delta = match lu.solve(&to_vec(&g)) {
                Some(d) => from_vec(&d),
                None => return Ok(None),
            };
            let norm = error_norm(&delta, &z, &z, tol);
            for i in 0..NY {
                z[i] += delta[i];
            }
            if !norm.is_finite() || norm > 0.9 * prev_norm && norm > 1e-3 {
                return Ok(None);
            }
            // Converged when the Newton correction is a small fraction of the error tolerance.
            if norm <= 1e-3 {
                sys.rhs(&z, &mut fz).map_err(StepError::Law)?;
                stats.rhs_evals += 1;
                return Ok(Some((z, fz)));
            }
            prev_norm = norm;
        }
        Ok(None)
    }

    pub fn step<S: System>(
        &mut self,
        sys: &S,
        h_max: f64,
        tol: &super::Tolerance,
        stats: &mut Stats,
    ) -> Result<(), StepError> {
        let mut h = self.h.min(h_max);
        loop {
            if !(h > super::min_step(self.t)) {
                return Err(StepError::StepTooSmall { t: self.t, h });
            }
            let m = Mat::identity() - self.jac * (D * h);
            let lu = m.lu();
            stats.factorizations += 1;
            let y = self.y;
            let f1 = self.f;
            let base2: State = std::array::from_fn(|i| y[i] + D * h * f1[i]);
            let guess2: State = std::array::from_fn(|i| y[i] + GAMMA * h * f1[i]);
            let stage2 = Self::solve_stage(sys, &lu, &base2, guess2, D * h, tol, stats)?;
            let stage3 = match stage2 {
                Some((_, f2)) => {
                    let base3: State = std::array::from_fn(|i| y[i] + W * h * (f1[i] + f2[i]));
                    let guess3: State = std::array::from_fn(|i| base3[i] + D * h * f2[i]);
                    Self::solve_stage(sys, &lu, &base3, guess3, D * h, tol, stats)?.map(|s| (f2, s))
                }
                None => None,
            };
            let Some((f2, (y1, f3))) = stage3 else {
                stats.rejected += 1;
                if !self.jac_fresh {
                    self.jacobian(sys, tol, stats)?;
                } else {
                    h *= 0.25;
                }
                continue;
            };
            let raw: State = std::array::from_fn(|i| h * (EB1 * f1[i] + EB2 * f2[i] + EB3 * f3[i]));
            let est = lu.solve(&to_vec(&raw)).map(|v| from_vec(&v)).unwrap_or(raw);
            let err = error_norm(&est, &y, &y1, tol);
            let fac = if err > 0.0 {
                (0.9 * err.powf(-1.0 / 3.0)).clamp(0.2, 5.0)
            } else {
                5.0
            };
            if err <= 1.0 {
                self.t_prev = self.t;
                self.y_prev = y;
                self.f_prev = f1;
                self.t += h;
                self.y = y1;
                self.f = f3;
                self.h = h * fac;
                self.jac_fresh = false;
                stats.steps += 1;
                return Ok(());
            }
            stats.rejected += 1;
            h *= if err.is_finite() { fac.min(0.9) } else { 0.25 };
        }
    }

    /// Cubic Hermite interpolation between the last two accepted points.
    pub fn interpolate(&self, t: f64) -> State {
        let h = self.t - self.t_prev;
        if h == 0.0 {
            return self.y;
        }
        let s = (t - self.t_prev) / h;
        let h00 = (1.0 + 2.0 * s) * (1.0 - s) * (1.0 - s);
        let h10 = s * (1.0 - s) * (1.0 - s);
        let h01 = s * s * (3.0 - 2.0 * s);
        let h11 = s * s * (s - 1.0);
        std::array::from_fn(|i| {
            h00 * self.y_prev[i] + h * h10 * self.f_prev[i] + h01 * self.y[i] + h * h11 * self.f[i]
        })
    }
}
