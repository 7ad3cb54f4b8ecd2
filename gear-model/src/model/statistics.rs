//! Statistics of a run along the integrator's dense output (issue 11): the mean, RMS and
//! extremes of dte, the peak normal force, and the time separated and on the backward flanks,
//! from `stats_start` on. The driver hands each piece of a step between events to `add`, so
//! they do not depend on the communication step.
//!
//! Integrals: 5-point Gauss-Legendre on each piece, exact to degree 9 in time. Dormand-Prince's
//! dense output is of degree 4, so the integrals of dte and dte^2 are exact for that method
//! (DOP853's, of degree 7, and BDF's interpolant, of degree up to 5, leave an error of order
//! h^10 on dte^2).
//! Extremes: the piece's ends and its Gauss nodes are sampled; where the best sample is
//! interior, a golden-section search on the dense output between its neighbours finds the
//! extremum to 1e-6 of the piece (the value's error is quadratic in that: ~1e-12 relative).
//! Modes are constant inside a piece, so the times separated and backward are exact.

use super::mesh::LawOutOfRange;

/// 5-point Gauss-Legendre nodes and weights on [0, 1].
const NODES: [f64; 5] = [
    0.046_910_077_030_668,
    0.230_765_344_947_158_5,
    0.5,
    0.769_234_655_052_841_5,
    0.953_089_922_969_332,
];
const WEIGHTS: [f64; 5] = [
    0.118_463_442_528_094_5,
    0.239_314_335_249_683_2,
    0.284_444_444_444_444_4,
    0.239_314_335_249_683_2,
    0.118_463_442_528_094_5,
];

#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Statistics {
    /// stats_start \[s\].
    pub start: f64,
    /// Time covered since stats_start.
    pub duration: f64,
    pub int_dte: f64,
    pub int_dte2: f64,
    /// +inf / -inf / 0 until the first piece.
    pub dte_min: f64,
    pub dte_max: f64,
    pub f_max: f64,
    pub t_separated: f64,
    pub t_backward: f64,
}

/// What the FMU reports (all 0 before stats_start).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Summary {
    pub dte_mean: f64,
    pub dte_rms: f64,
    pub dte_min: f64,
    pub dte_max: f64,
    pub f_max: f64,
    pub t_separated: f64,
    pub t_backward: f64,
}

impl Statistics {
    pub fn new(start: f64) -> Statistics {
        Statistics {
            start,
            duration: 0.0,
            int_dte: 0.0,
            int_dte2: 0.0,
            dte_min: f64::INFINITY,
            dte_max: f64::NEG_INFINITY,
            f_max: 0.0,
            t_separated: 0.0,
            t_backward: 0.0,
        }
    }

    /// Adds the piece [t0, t1] of a step, on which `y` is the dense output and the mesh's
    /// modes hold.
    /// Adds the piece [t0, t1] of a step between events, on which the contact modes
    /// `(carrying, backward)` hold, `dte(t)` is the dense output's dte and `force(t)` the total
    /// normal force.
    pub fn add(
        &mut self,
        (carrying, backward): (bool, bool),
        t0: f64,
        t1: f64,
        dte: &dyn Fn(f64) -> f64,
        force: &dyn Fn(f64) -> Result<f64, LawOutOfRange>,
    ) -> Result<(), LawOutOfRange> {
        let a = t0.max(self.start);
        if !(t1 > a) {
            return Ok(());
        }
        let h = t1 - a;
        self.duration += h;
        if !carrying {
            self.t_separated += h;
        }
        if backward {
            self.t_backward += h;
        }
        // Samples: the ends and the Gauss nodes, in time order.
        let mut ts = [0.0; 7];
        ts[0] = a;
        ts[6] = t1;
        for (k, x) in NODES.iter().enumerate() {
            ts[k + 1] = a + x * h;
        }
        let dte_values: Vec<f64> = ts.iter().map(|&t| dte(t)).collect();
        for k in 0..5 {
            let d = dte_values[k + 1];
            self.int_dte += h * WEIGHTS[k] * d;
            self.int_dte2 += h * WEIGHTS[k] * d * d;
        }
        let dte_ok = |t: f64| Ok(dte(t));
        self.dte_max = self.dte_max.max(peak(&ts, &dte_values, &dte_ok)?);
        let neg = |t: f64| Ok(-dte(t));
        let neg_values: Vec<f64> = dte_values.iter().map(|d| -d).collect();
        self.dte_min = self.dte_min.min(-peak(&ts, &neg_values, &neg)?);
        if carrying {
            let values = ts
                .iter()
                .map(|&t| force(t))
                .collect::<Result<Vec<f64>, _>>()?;
            self.f_max = self.f_max.max(peak(&ts, &values, force)?);
        }
        Ok(())
    }

    /// Marks the statistics as lost: the contact law left its range on the dense output between
    /// two accepted states (a corner case). The outputs' finiteness check then reports F_max.
    pub fn poison(&mut self) {
        self.f_max = f64::NAN;
    }

    pub fn summary(&self) -> Summary {
        if self.duration <= 0.0 {
            return Summary::default();
        }
        Summary {
            dte_mean: self.int_dte / self.duration,
            dte_rms: (self.int_dte2 / self.duration).max(0.0).sqrt(),
            dte_min: self.dte_min,
            dte_max: self.dte_max,
            f_max: self.f_max,
            t_separated: self.t_separated,
            t_backward: self.t_backward,
        }
    }
}

/// The largest value of f on [ts[0], ts[last]] given its samples: the best sample, refined by
/// golden-section search between its neighbours when it is interior.
fn peak(
    ts: &[f64],
    values: &[f64],
    f: &dyn Fn(f64) -> Result<f64, LawOutOfRange>,
) -> Result<f64, LawOutOfRange> {
    let (i, &best) = values
        .iter()
        .enumerate()
        .max_by(|a, b| a.1.total_cmp(b.1))
        .expect("samples");
    if i == 0 || i == values.len() - 1 {
        return Ok(best);
    }
    let (mut lo, mut hi) = (ts[i - 1], ts[i + 1]);
    // 1e-6 of the piece, but no finer than the times' own spacing: a piece of a few ulp
    // (events close together) would otherwise never narrow below its tolerance.
    let tol = (1e-6 * (ts[ts.len() - 1] - ts[0])).max(8.0 * f64::EPSILON * hi.abs().max(lo.abs()));
    const R: f64 = 0.618_033_988_749_894_9;
    let (mut x1, mut x2) = (hi - R * (hi - lo), lo + R * (hi - lo));
    let (mut f1, mut f2) = (f(x1)?, f(x2)?);
    let mut top = best.max(f1).max(f2);
    while hi - lo > tol {
        if f1 >= f2 {
            hi = x2;
            (x2, f2) = (x1, f1);
            x1 = hi - R * (hi - lo);
            f1 = f(x1)?;
            top = top.max(f1);
        } else {
            lo = x1;
            (x1, f1) = (x2, f2);
            x2 = lo + R * (hi - lo);
            f2 = f(x2)?;
            top = top.max(f2);
        }
    }
    Ok(top)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gauss_rule_is_exact_to_degree_nine() {
        for n in 0..=9 {
            let q: f64 = NODES.iter().zip(WEIGHTS).map(|(x, w)| w * x.powi(n)).sum();
            let exact = 1.0 / (n as f64 + 1.0);
            assert!((q - exact).abs() < 1e-15, "degree {n}: {q} vs {exact}");
        }
    }

    #[test]
    fn golden_section_finds_an_interior_peak() {
        // A peak between two samples at 0.3 with curvature 1: found to within the search's
        // tolerance (1e-6 of the piece), so the value to within its square.
        let f = |t: f64| Ok(1.0 - (t - 0.3) * (t - 0.3));
        let ts = [0.0, 0.25, 0.5, 1.0];
        let v: Vec<f64> = ts.iter().map(|&t| f(t).unwrap()).collect();
        let p = peak(&ts, &v, &f).unwrap();
        assert!(p <= 1.0 && 1.0 - p <= 1e-12, "{p}");
    }

    /// A piece a few ulp long (two events a hair apart at t = 0.01 s): the search ends, where
    /// a tolerance of 1e-6 of the piece lies below the times' spacing and never would.
    #[test]
    fn golden_section_ends_on_a_piece_of_a_few_ulp() {
        let t0 = 0.01;
        let h = 16.0 * f64::EPSILON * t0;
        let f = |t: f64| Ok(-(t - t0 - 0.4 * h).abs());
        let ts: Vec<f64> = (0..7).map(|k| t0 + h * k as f64 / 6.0).collect();
        let v: Vec<f64> = ts.iter().map(|&t| f(t).unwrap()).collect();
        let p = peak(&ts, &v, &f).unwrap();
        assert!(p <= 0.0 && p >= -h, "{p}");
    }
}
