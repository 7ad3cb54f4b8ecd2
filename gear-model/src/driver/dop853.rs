//! Dormand and Prince's 8(5,3) pair (DOP853) with its 7th-order continuous extension, for tight
//! tolerances: 12 stages and the new rate per accepted step, 3 more for the dense output, the
//! error estimated from a 5th- and a 3rd-order embedded solution. The method and its
//! coefficients are those of Prince & Dormand (1981) as Hairer, Norsett & Wanner give them
//! (Solving ODEs I, sec. II.5 and II.10). The unit tests below check the coefficients'
//! quadrature conditions and the orders of the step and the dense output; `tests/driver_toys.rs`
//! runs the driver's toys with it. Like `dopri5.rs` it needs no nodes c_i: between events and
//! input changes the system is autonomous. docs/integrators.md has the measurements behind it.

use super::{min_step, Stability, Stats, StepError, System, Tolerance, Vector};

/// One row of the tableau: the stages it combines (0 is the rate at the step's start) and
/// their coefficients; the zeros are left out.
struct Row<const M: usize> {
    k: [usize; M],
    a: [f64; M],
}

impl<const M: usize> Row<M> {
    /// sum_j a_j k[j] in component i.
    #[inline(always)]
    fn dot<Y: Vector>(&self, k: &[Y], i: usize) -> f64 {
        let mut s = self.a[0] * k[self.k[0]][i];
        for j in 1..M {
            s += self.a[j] * k[self.k[j]][i];
        }
        s
    }

    /// out = y + h sum_j a_j k[j] over the first n components; the rest of `out` is left as
    /// it is (a copy of y's: components past n never change).
    #[inline(always)]
    fn step_into<Y: Vector>(&self, out: &mut Y, y: &Y, h: f64, k: &[Y], n: usize) {
        for i in 0..n {
            out[i] = y[i] + h * self.dot(k, i);
        }
    }
}

/// Stages in order: each row's argument y + h sum a k into the buffer `arg` (one buffer that
/// starts as y, `Row::step_into`), then f there into k[j].
macro_rules! stages {
    ($sys:ident, $arg:ident, $y:ident, $h:ident, $k:ident, $n:ident; $($row:ident => $j:expr),*) => {
        $(
            $row.step_into(&mut $arg, $y, $h, &$k[..], $n);
            $sys.rhs(&$arg, &mut $k[$j])?;
        )*
    };
}

/// Stage 2.
const A2: Row<1> = Row {
    k: [0],
    a: [0.05260015195876773],
};
/// Stage 3.
const A3: Row<2> = Row {
    k: [0, 1],
    a: [0.0197250569845379, 0.0591751709536137],
};
/// Stage 4.
const A4: Row<2> = Row {
    k: [0, 2],
    a: [0.02958758547680685, 0.08876275643042054],
};
/// Stage 5.
const A5: Row<3> = Row {
    k: [0, 2, 3],
    a: [0.2413651341592667, -0.8845494793282861, 0.924834003261792],
};
/// Stage 6.
const A6: Row<3> = Row {
    k: [0, 3, 4],
    a: [
        0.037037037037037035,
        0.17082860872947386,
        0.12546768756682242,
    ],
};
/// Stage 7.
const A7: Row<4> = Row {
    k: [0, 3, 4, 5],
    a: [
        0.037109375,
        0.17025221101954405,
        0.06021653898045596,
        -0.017578125,
    ],
};
/// Stage 8.
const A8: Row<5> = Row {
    k: [0, 3, 4, 5, 6],
    a: [
        0.03709200011850479,
        0.17038392571223998,
        0.10726203044637328,
        -0.015319437748624402,
        0.008273789163814023,
    ],
};
/// Stage 9.
const A9: Row<6> = Row {
    k: [0, 3, 4, 5, 6, 7],
    a: [
        0.6241109587160757,
        -3.3608926294469414,
        -0.868219346841726,
        27.59209969944671,
        20.154067550477894,
        -43.48988418106996,
    ],
};
/// Stage 10.
const A10: Row<7> = Row {
    k: [0, 3, 4, 5, 6, 7, 8],
    a: [
        0.47766253643826434,
        -2.4881146199716677,
        -0.590290826836843,
        21.230051448181193,
        15.279233632882423,
        -33.28821096898486,
        -0.020331201708508627,
    ],
};
/// Stage 11.
const A11: Row<8> = Row {
    k: [0, 3, 4, 5, 6, 7, 8, 9],
    a: [
        -0.9371424300859873,
        5.186372428844064,
        1.0914373489967295,
        -8.149787010746927,
        -18.52006565999696,
        22.739487099350505,
        2.4936055526796523,
        -3.0467644718982196,
    ],
};
/// Stage 12.
const A12: Row<9> = Row {
    k: [0, 3, 4, 5, 6, 7, 8, 9, 10],
    a: [
        2.273310147516538,
        -10.53449546673725,
        -2.0008720582248625,
        -17.9589318631188,
        27.94888452941996,
        -2.8589982771350235,
        -8.87285693353063,
        12.360567175794303,
        0.6433927460157636,
    ],
};
/// The 8th-order solution.
const B: Row<8> = Row {
    k: [0, 5, 6, 7, 8, 9, 10, 11],
    a: [
        0.054293734116568765,
        4.450312892752409,
        1.8915178993145003,
        -5.801203960010585,
        0.3111643669578199,
        -0.1521609496625161,
        0.20136540080403034,
        0.04471061572777259,
    ],
};
/// The 5th-order error estimate.
const E5: Row<8> = Row {
    k: [0, 5, 6, 7, 8, 9, 10, 11],
    a: [
        0.01312004499419488,
        -1.2251564463762044,
        -0.4957589496572502,
        1.6643771824549864,
        -0.35032884874997366,
        0.3341791187130175,
        0.08192320648511571,
        -0.022355307863886294,
    ],
};
/// The 3rd-order error estimate (B minus the 3rd-order weights).
const E3: Row<8> = Row {
    k: [0, 5, 6, 7, 8, 9, 10, 11],
    a: [
        -0.18980075407240762,
        4.450312892752409,
        1.8915178993145003,
        -5.801203960010585,
        -0.4226823213237919,
        -0.1521609496625161,
        0.20136540080403034,
        0.02265179219836082,
    ],
};
/// Stage 14, for the dense output only.
const A14: Row<8> = Row {
    k: [0, 6, 7, 8, 9, 10, 11, 12],
    a: [
        0.056167502283047954,
        0.25350021021662483,
        -0.2462390374708025,
        -0.12419142326381637,
        0.15329179827876568,
        0.00820105229563469,
        0.007567897660545699,
        -0.008298,
    ],
};
/// Stage 15, for the dense output only.
const A15: Row<8> = Row {
    k: [0, 5, 6, 7, 10, 11, 12, 13],
    a: [
        0.03183464816350214,
        0.028300909672366776,
        0.053541988307438566,
        -0.05492374857139099,
        -0.00010834732869724932,
        0.0003825710908356584,
        -0.00034046500868740456,
        0.1413124436746325,
    ],
};
/// Stage 16, for the dense output only.
const A16: Row<8> = Row {
    k: [0, 5, 6, 7, 8, 12, 13, 14],
    a: [
        -0.42889630158379194,
        -4.697621415361164,
        7.683421196062599,
        4.06898981839711,
        0.3567271874552811,
        -0.0013990241651590145,
        2.9475147891527724,
        -9.15095847217987,
    ],
};
/// Dense output coefficient 4 (of 7).
const D4: Row<12> = Row {
    k: [0, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15],
    a: [
        -8.428938276109013,
        0.5667149535193777,
        -3.0689499459498917,
        2.38466765651207,
        2.117034582445028,
        -0.871391583777973,
        2.2404374302607883,
        0.6315787787694688,
        -0.08899033645133331,
        18.148505520854727,
        -9.194632392478356,
        -4.436036387594894,
    ],
};
/// Dense output coefficient 5 (of 7).
const D5: Row<12> = Row {
    k: [0, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15],
    a: [
        10.427508642579134,
        242.28349177525817,
        165.20045171727028,
        -374.5467547226902,
        -22.113666853125306,
        7.733432668472264,
        -30.674084731089398,
        -9.332130526430229,
        15.697238121770845,
        -31.139403219565178,
        -9.35292435884448,
        35.81684148639408,
    ],
};
/// Dense output coefficient 6 (of 7).
const D6: Row<12> = Row {
    k: [0, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15],
    a: [
        19.985053242002433,
        -387.0373087493518,
        -189.17813819516758,
        527.8081592054236,
        -11.57390253995963,
        6.8812326946963,
        -1.0006050966910838,
        0.7777137798053443,
        -2.778205752353508,
        -60.19669523126412,
        84.32040550667716,
        11.99229113618279,
    ],
};
/// Dense output coefficient 7 (of 7).
const D7: Row<12> = Row {
    k: [0, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15],
    a: [
        -25.69393346270375,
        -154.18974869023643,
        -231.5293791760455,
        357.6391179106141,
        93.40532418362432,
        -37.45832313645163,
        104.0996495089623,
        29.8402934266605,
        -43.53345659001114,
        96.32455395918828,
        -39.17726167561544,
        -149.72683625798564,
    ],
};

/// The h omega that steps may reach on an undamped oscillation (`System::max_step`): the
/// stability region holds the imaginary axis up to 5.96 (|R(iy)| <= 1), and at 4 it damps an
/// oscillation by 2.3 % per step, so near an equilibrium it decays.
pub const STABILITY: Stability = Stability {
    reach: 4.0,
    region: None,
};

/// The 3rd-order error estimate's weight relative to the 5th's (Hairer's 0.01).
const E3_WEIGHT: f64 = 0.01;

#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Dop853<Y> {
    pub t: f64,
    pub t_prev: f64,
    pub h: f64,
    pub y: Y,
    /// f(t, y): the first stage of the next step.
    pub k1: Y,
    /// The continuous extension of the last step: y at its start and the 7 coefficients of
    /// y(s) = r0 + s (r1 + (1-s) (r2 + s (r3 + (1-s) (r4 + s (r5 + (1-s) (r6 + s r7)))))).
    pub rcont: [Y; 8],
    /// The last attempt was rejected: the next accepted step does not grow.
    pub rejected: bool,
    /// The error of the last accepted step (the PI controller's memory).
    pub facold: f64,
}

impl<Y: Vector> Default for Dop853<Y> {
    fn default() -> Self {
        Self::new()
    }
}

impl<Y: Vector> Dop853<Y> {
    pub fn new() -> Self {
        Dop853 {
            t: 0.0,
            t_prev: 0.0,
            h: 0.0,
            y: Y::zeros(),
            k1: Y::zeros(),
            rcont: [Y::zeros(); 8],
            rejected: false,
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
        (self.k1, self.h) = super::explicit_start(sys, y, h_hint, 8, STABILITY, tol, stats)?;
        self.rcont = [Y::zeros(); 8];
        self.rcont[0] = *y;
        self.rejected = false;
        self.facold = 1e-4;
        Ok(())
    }

    /// The stages of a step of size h into k[1..12], the 8th-order solution, and its error
    /// norm (Hairer's: |h| e5^2 / sqrt(n (e5^2 + 0.01 e3^2)), weighted RMS sums).
    fn attempt<S: System<State = Y>>(
        &self,
        sys: &S,
        h: f64,
        tol: &Tolerance<Y>,
        k: &mut [Y; 16],
    ) -> Result<(Y, f64), S::Error> {
        let (y, n) = (&self.y, sys.dim());
        let mut arg = *y;
        stages!(sys, arg, y, h, k, n; A2 => 1, A3 => 2, A4 => 3, A5 => 4, A6 => 5, A7 => 6);
        stages!(sys, arg, y, h, k, n; A8 => 7, A9 => 8, A10 => 9, A11 => 10, A12 => 11);
        let mut y1 = *y;
        B.step_into(&mut y1, y, h, &k[..], n);
        let (mut s5, mut s3, mut count) = (0.0, 0.0, 0);
        for i in (0..Y::LEN).filter(|&i| tol.atol[i] > 0.0) {
            let sk = tol.atol[i] + tol.rtol * y[i].abs().max(y1[i].abs());
            let (e5, e3) = (E5.dot(&k[..], i) / sk, E3.dot(&k[..], i) / sk);
            s5 += e5 * e5;
            s3 += e3 * e3;
            count += 1;
        }
        let denominator = s5 + E3_WEIGHT * s3;
        let err = if denominator > 0.0 {
            h.abs() * s5 / (count as f64 * denominator).sqrt()
        } else {
            0.0
        };
        Ok((y1, err))
    }

    /// After an accepted step: the rate at its end into k[12], the three extra stages, and the
    /// continuous extension into `rcont` (only once every stage succeeded).
    fn dense<S: System<State = Y>>(
        &mut self,
        sys: &S,
        h: f64,
        y1: &Y,
        k: &mut [Y; 16],
    ) -> Result<(), S::Error> {
        let (y, n) = (&self.y, sys.dim());
        sys.rhs(y1, &mut k[12])?;
        let mut arg = *y;
        stages!(sys, arg, y, h, k, n; A14 => 13, A15 => 14, A16 => 15);
        // In place: past n, rcont[0] holds y's constant components and the others 0
        // (`restart`).
        let r = &mut self.rcont;
        for i in 0..n {
            r[0][i] = y[i];
            let dy = y1[i] - y[i];
            r[1][i] = dy;
            r[2][i] = h * k[0][i] - dy;
            r[3][i] = 2.0 * dy - h * (k[12][i] + k[0][i]);
            r[4][i] = h * D4.dot(&k[..], i);
            r[5][i] = h * D5.dot(&k[..], i);
            r[6][i] = h * D6.dot(&k[..], i);
            r[7][i] = h * D7.dot(&k[..], i);
        }
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
        let mut h = self.h.min(h_max);
        let mut k = [Y::zeros(); 16];
        k[0] = self.k1;
        let mut last_err = None;
        loop {
            if !(h > min_step(self.t)) {
                return Err(last_err.unwrap_or(StepError::StepTooSmall { t: self.t, h }));
            }
            let attempt = self.attempt(sys, h, tol, &mut k);
            stats.rhs_evals += 11;
            let accepted = match attempt {
                Ok((y1, err)) if err <= 1.0 => {
                    let dense = self.dense(sys, h, &y1, &mut k);
                    stats.rhs_evals += 4;
                    dense.map(|()| (y1, err))
                }
                Ok((_, err)) => {
                    stats.rejected += 1;
                    // Shrink by err^(1/5), at most 20x, as dopri5.rs: after a contact onset
                    // the error of the carried step is far outside the asymptotic O(h^8)
                    // (it fell as h^2 to h^3 there), and err^(1/8) took up to six tries
                    // where this takes two. NaN errors: shrink hard.
                    let shrink = if err.is_finite() {
                        ((0.2 * err.ln()).exp() / 0.9).min(20.0)
                    } else {
                        4.0
                    };
                    h /= shrink;
                    self.rejected = true;
                    last_err = None;
                    continue;
                }
                Err(e) => Err(e),
            };
            match accepted {
                Ok((y1, err)) => {
                    // PI control as Hairer's DOP853 with beta = 0.04 (as dopri5.rs):
                    // err^(1/8 - 0.2 beta) / facold^beta, the step within [h/3, 6h], and no
                    // growth right after a rejection. Without the memory (beta = 0) every
                    // other step was rejected on the undamped paper rig.
                    let fac = ((0.117 * err.ln() - 0.04 * self.facold.ln()).exp() / 0.9)
                        .clamp(1.0 / 6.0, 3.0);
                    self.facold = err.max(1e-4);
                    let h_new = h / fac;
                    self.h = if self.rejected { h_new.min(h) } else { h_new };
                    self.rejected = false;
                    self.t_prev = self.t;
                    self.t += h;
                    self.y = y1;
                    self.k1 = k[12];
                    stats.steps += 1;
                    return Ok(());
                }
                Err(e) => {
                    // Outside the contact law's range: try a smaller step; report it if none works.
                    last_err = Some(StepError::Law(e));
                    stats.rejected += 1;
                    self.rejected = true;
                    h *= 0.25;
                }
            }
        }
    }

    /// The continuous extension at t inside the last step.
    pub fn interpolate(&self, t: f64) -> Y {
        let h = self.t - self.t_prev;
        if h == 0.0 {
            return self.y;
        }
        let s = (t - self.t_prev) / h;
        let s1 = 1.0 - s;
        let r = &self.rcont;
        Y::from_fn(|i| {
            r[0][i]
                + s * (r[1][i]
                    + s1 * (r[2][i]
                        + s * (r[3][i]
                            + s1 * (r[4][i] + s * (r[5][i] + s1 * (r[6][i] + s * r[7][i]))))))
        })
    }

    /// The rate of the continuous extension at t: the nested products differentiated from the
    /// inside out (the factors alternate s and 1 - s, with derivatives +1 and -1).
    pub fn derivative(&self, t: f64) -> Y {
        let h = self.t - self.t_prev;
        if h == 0.0 {
            return self.k1;
        }
        let s = (t - self.t_prev) / h;
        let r = &self.rcont;
        Y::from_fn(|i| {
            let (mut v, mut dv) = (r[7][i], 0.0);
            for level in (1..7).rev() {
                // r_level + m v, m = s for even levels and 1 - s for odd ones.
                let (m, dm) = if level % 2 == 0 {
                    (s, 1.0)
                } else {
                    (1.0 - s, -1.0)
                };
                dv = m * dv + dm * v;
                v = r[level][i] + m * v;
            }
            (s * dv + v) / h
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::driver::EventOutcome;

    /// The nodes: each stage's row sum (stage 1 at 0, the rate at the step's end at 1).
    fn nodes() -> [f64; 16] {
        fn sum<const M: usize>(r: &Row<M>) -> f64 {
            r.a.iter().sum()
        }
        [
            0.0,
            sum(&A2),
            sum(&A3),
            sum(&A4),
            sum(&A5),
            sum(&A6),
            sum(&A7),
            sum(&A8),
            sum(&A9),
            sum(&A10),
            sum(&A11),
            sum(&A12),
            1.0,
            sum(&A14),
            sum(&A15),
            sum(&A16),
        ]
    }

    /// A row's weights spread over the 16 stages.
    fn weights<const M: usize>(r: &Row<M>) -> [f64; 16] {
        let mut w = [0.0; 16];
        for (&k, &a) in r.k.iter().zip(&r.a) {
            w[k] = a;
        }
        w
    }

    /// sum_i w_i c_i^(q-1).
    fn moment(w: &[f64; 16], q: i32) -> f64 {
        w.iter().zip(nodes()).map(|(w, c)| w * c.powi(q - 1)).sum()
    }

    /// What rounding allows a sum of 16 weighted terms with |c| <= 1: the weights and nodes
    /// (row sums) carry an error of a few ulp of sum |w|, and so does the summation.
    fn rounding(w: &[f64; 16]) -> f64 {
        64.0 * f64::EPSILON * w.iter().map(|x| x.abs()).sum::<f64>()
    }

    /// The quadrature conditions (the order conditions of the bushy trees): the solution's
    /// weights integrate c^(q-1) exactly to order 8, the 5th- and 3rd-order estimates vanish
    /// to their orders, and the dense output's weights at s integrate to s^q / q to order 7.
    /// They catch a mistyped coefficient; the order test below covers the other trees.
    #[test]
    fn coefficients_meet_the_quadrature_conditions() {
        let a12 = weights(&A12);
        assert!(
            (nodes()[11] - 1.0).abs() < rounding(&a12),
            "stage 12 is at c = 1"
        );
        let b = weights(&B);
        for q in 1..=8 {
            assert!(
                (moment(&b, q) - 1.0 / q as f64).abs() < rounding(&b),
                "B, q = {q}"
            );
        }
        for (e, order) in [(weights(&E5), 5), (weights(&E3), 3)] {
            for q in 1..=order {
                assert!(moment(&e, q).abs() < rounding(&e), "order {order}, q = {q}");
            }
        }
        let d = [weights(&D4), weights(&D5), weights(&D6), weights(&D7)];
        for s in [0.3, 0.7] {
            // y(s) - y0 = h sum_i b_i(s) k_i, from the nested form with r1 = B, r2 = e1 - B,
            // r3 = 2 B - e1 - e13 and r4..r7 = D.
            let mut e = [[0.0; 16]; 2];
            e[0][0] = 1.0;
            e[1][12] = 1.0;
            let r: Vec<[f64; 16]> = [
                b,
                std::array::from_fn(|i| e[0][i] - b[i]),
                std::array::from_fn(|i| 2.0 * b[i] - e[0][i] - e[1][i]),
            ]
            .into_iter()
            .chain(d)
            .collect();
            let mut v = r[6];
            for level in (1..7).rev() {
                let m = if level % 2 == 0 { s } else { 1.0 - s };
                v = std::array::from_fn(|i| r[level - 1][i] + m * v[i]);
            }
            let bs: [f64; 16] = std::array::from_fn(|i| s * v[i]);
            for q in 1..=7 {
                let exact = s.powi(q) / q as f64;
                let bound = rounding(&bs) + d.iter().map(rounding).sum::<f64>();
                assert!(
                    (moment(&bs, q) - exact).abs() < bound,
                    "dense, s = {s}, q = {q}"
                );
            }
        }
    }

    /// Lotka-Volterra, u' = u (1 - v), v' = v (u - 1): nonlinear in both components.
    #[derive(Clone)]
    struct Predator;

    #[derive(Clone, Debug, PartialEq, thiserror::Error)]
    #[error("never")]
    struct Never;

    struct NoEvent;

    impl EventOutcome for NoEvent {
        fn smooth(&self) -> bool {
            true
        }
    }

    impl System for Predator {
        type State = [f64; 2];
        type Error = Never;
        type Report = NoEvent;
        fn rhs(&self, y: &[f64; 2], dy: &mut [f64; 2]) -> Result<(), Never> {
            dy[0] = y[0] * (1.0 - y[1]);
            dy[1] = y[1] * (y[0] - 1.0);
            Ok(())
        }
        fn n_events(&self) -> usize {
            0
        }
        fn event_margins(&self, _y: &[f64; 2], _out: &mut [f64]) {}
        fn event_margins_and_rates(
            &self,
            _y: &[f64; 2],
            _dy: &[f64; 2],
            _m: &mut [f64],
            _r: &mut [f64],
        ) {
        }
        fn margin(&self, _i: usize, _y: &[f64; 2]) -> f64 {
            1.0
        }
        fn handle_event(&mut self, _i: usize, _y: &mut [f64; 2]) -> Result<NoEvent, Never> {
            Ok(NoEvent)
        }
        fn check_state(&self, _y: &[f64; 2]) -> Result<(), Never> {
            Ok(())
        }
        fn max_step(&self, _y: &[f64; 2], _stability: Option<super::Stability>) -> f64 {
            f64::INFINITY
        }
        fn dim(&self) -> usize {
            2
        }
    }

    /// One step of size h from (2, 1), accepted at any error (a loose tolerance).
    fn one_step(h: f64) -> Dop853<[f64; 2]> {
        let tol = Tolerance {
            rtol: 1e3,
            atol: [1e3; 2],
        };
        let mut m = Dop853::new();
        let mut stats = Stats::default();
        m.restart(&Predator, 0.0, &[2.0, 1.0], Some(h), &tol, &mut stats)
            .unwrap();
        m.step(&Predator, h, &tol, &mut stats).unwrap();
        assert_eq!((m.t, stats.rejected), (h, 0));
        m
    }

    /// The solution at t after n equal steps.
    fn solve(t: f64, n: usize) -> [f64; 2] {
        let h = t / n as f64;
        let mut m = one_step(h);
        let tol = Tolerance {
            rtol: 1e3,
            atol: [1e3; 2],
        };
        let mut stats = Stats::default();
        for _ in 1..n {
            m.step(&Predator, h, &tol, &mut stats).unwrap();
        }
        m.y
    }

    fn distance(a: &[f64; 2], b: &[f64; 2]) -> f64 {
        (a[0] - b[0]).hypot(a[1] - b[1])
    }

    /// An order-p method's global error over a fixed interval is C h^p (1 + O(h)), so halving h
    /// divides it by 2^p: 256 for order 8 (2 time units, 8 and 16 steps). The 7th-order dense
    /// output's error inside one step is O(h^8): 256 again (at the midpoint of one step of 0.4
    /// and of 0.2). The bounds allow a factor 2^(1/2) either way for the O(h) terms; the errors
    /// (1e-7 to 1e-12) stay far above rounding, and the references' errors (2048 steps, and 256
    /// over half a step) are about 2^-56 and 2^-72 of the compared ones.
    #[test]
    fn step_and_dense_output_converge_at_their_orders() {
        let exact = solve(2.0, 2048);
        let (e1, e2) = (
            distance(&solve(2.0, 8), &exact),
            distance(&solve(2.0, 16), &exact),
        );
        let dense = |h: f64| distance(&one_step(h).interpolate(0.5 * h), &solve(0.5 * h, 256));
        let (d1, d2) = (dense(0.4), dense(0.2));
        let orders = 2f64.powf(7.5)..=2f64.powf(8.5);
        assert!(
            orders.contains(&(e1 / e2)),
            "steps: errors {e1:.2e}, {e2:.2e}, ratio {:.0}",
            e1 / e2
        );
        assert!(
            orders.contains(&(d1 / d2)),
            "dense output: errors {d1:.2e}, {d2:.2e}, ratio {:.0}",
            d1 / d2
        );
    }

    /// The dense output's rate is the derivative of its value (central differences, error
    /// ~1e-9 of the rate), and at the step's ends the method's own rates.
    #[test]
    fn derivative_matches_the_interpolant() {
        let m = one_step(0.2);
        let mut f = [0.0; 2];
        let (mut f0, mut f1) = ([0.0; 2], [0.0; 2]);
        Predator.rhs(&[2.0, 1.0], &mut f0).unwrap();
        Predator.rhs(&m.y, &mut f1).unwrap();
        assert!(distance(&m.derivative(0.0), &f0) < 1e-13);
        assert!(distance(&m.derivative(0.2), &f1) < 1e-13);
        for s in [0.1, 0.45, 0.8] {
            let (t, d) = (0.2 * s, 1e-5);
            let (a, b) = (m.interpolate(t - d), m.interpolate(t + d));
            for i in 0..2 {
                f[i] = (b[i] - a[i]) / (2.0 * d);
            }
            assert!(distance(&m.derivative(t), &f) < 1e-8, "s = {s}");
        }
    }
}
