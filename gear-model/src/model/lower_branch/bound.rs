//! A proof that every piece of the W_-1 table (`lower_branch.rs`) stays within `TOLERANCE` of
//! v(x) = -1/W_{-1}(-x) over its whole interval, not only at the points build.rs checks.
//!
//! On a piece of half-width r, with p the stored polynomial and p* the exact interpolant of v at
//! the six Chebyshev roots t_i (the nodes `fit_piece` uses):
//! - |p* - v| <= 2^-5 r^6 / 6! max|v^(6)| (the node polynomial of six Chebyshev roots is at most
//!   2^-5 on [-1, 1]);
//! - p - p* interpolates p - v at the nodes, so |p - p*| <= Lambda max_i |p(t_i) - v(t_i)|, with
//!   Lambda <= 1 + (2/pi) ln 6 (Rivlin's bound on the Lebesgue constant of Chebyshev roots);
//! - evaluating p in floating point (Estrin's scheme, and u = x a + b before it) adds at most a
//!   few units of rounding times sum |c_k| and sum k |c_k|.
//!
//! v^(n)(x) = N_n(w) / (x^n w (1 + w)^(2n)) with w = W_{-1}(-x) < -1 and N_n a polynomial with
//! integer coefficients (`derivative_numerators`), so the sixth derivative is bounded on a piece
//! from an enclosure of w there. Each W used is enclosed: psi(w) = -w e^w / x increases with w
//! below -1 and is 1 at the root, and both ends are checked on their side by more than psi's
//! rounding. The other quantities are sums and products of positive terms, each rounded by half
//! an ulp; the final bound is raised by 1e-9 of itself for them.

use super::{polynomial, BASE, PIECES};
use crate::model::lower_branch_fit::{SHIFT, TERMS, TOLERANCE};
use std::f64::consts::PI;

const EPS: f64 = f64::EPSILON;

fn add(a: &[f64], b: &[f64], sign: f64) -> Vec<f64> {
    (0..a.len().max(b.len()))
        .map(|i| a.get(i).unwrap_or(&0.0) + sign * b.get(i).unwrap_or(&0.0))
        .collect()
}

fn mul(a: &[f64], b: &[f64]) -> Vec<f64> {
    let mut out = vec![0.0; a.len() + b.len() - 1];
    for (i, x) in a.iter().enumerate() {
        for (j, y) in b.iter().enumerate() {
            out[i + j] += x * y;
        }
    }
    out
}

fn derivative(a: &[f64]) -> Vec<f64> {
    let d: Vec<f64> = a
        .iter()
        .enumerate()
        .skip(1)
        .map(|(i, c)| i as f64 * c)
        .collect();
    if d.is_empty() {
        vec![0.0]
    } else {
        d
    }
}

fn eval(a: &[f64], w: f64) -> f64 {
    a.iter().rev().fold(0.0, |acc, c| acc * w + c)
}

/// sum |a_j| |w|^j: bounds |a(z)| for |z| <= |w|, and the rounding of `eval` (times a few eps).
fn eval_abs(a: &[f64], w: f64) -> f64 {
    a.iter().rev().fold(0.0, |acc, c| acc * w.abs() + c.abs())
}

/// max |a(w)| over |w - w0| <= h, from a's Taylor polynomial at w0 term by term (its terms
/// cancel far less there than its coefficients do at w), each term with its rounding.
fn taylor_bound(a: &[f64], w0: f64, h: f64) -> f64 {
    let (mut d, mut sum, mut scale) = (a.to_vec(), 0.0, 1.0);
    for m in 0..a.len() {
        sum += (eval(&d, w0).abs() + 8.0 * EPS * eval_abs(&d, w0)) * scale;
        d = derivative(&d);
        scale *= h / (m + 1) as f64;
    }
    sum
}

/// N_0..N_n with x^k v^(k)(x) = N_k(w) / (w (1 + w)^(2k)). From dw/dx = w / (x (1 + w)), G_k =
/// x^k v^(k) obeys G_{k+1} = -k G_k + w/(1 + w) dG_k/dw, which for G_k = N_k / (w (1+w)^(2k))
/// gives N_{k+1} = w (1+w) N_k' - (1 + (2k+1) w) N_k - k (1+w)^2 N_k. Integer coefficients,
/// exact in f64 while below 2^53 (checked).
fn derivative_numerators(n: usize) -> Vec<Vec<f64>> {
    let mut out = vec![vec![-1.0]];
    for k in 0..n {
        let nk = &out[k];
        let kf = k as f64;
        let a = mul(&derivative(nk), &[0.0, 1.0, 1.0]);
        let b = mul(nk, &[1.0, 2.0 * kf + 1.0]);
        let c = mul(nk, &[kf, 2.0 * kf, kf]);
        let next = add(&add(&a, &b, -1.0), &c, -1.0);
        assert!(next
            .iter()
            .all(|x| x.fract() == 0.0 && x.abs() < 2f64.powi(52)));
        out.push(next);
    }
    out
}

/// x^n v^(n)(x) at w = W_{-1}(-x).
fn scaled_derivative(numerators: &[Vec<f64>], n: usize, w: f64) -> f64 {
    eval(&numerators[n], w) / (w * (1.0 + w).powi(2 * n as i32))
}

/// W_{-1}(-x) enclosed: (lo, hi) with lo <= W <= hi, about 4e-15 apart relatively.
fn enclose(x: f64) -> (f64, f64) {
    let w = lambert_w::lambert_wm1(-x);
    let (lo, hi) = (w * (1.0 + 4e-15), w * (1.0 - 4e-15));
    // exp within an ulp, a product and a quotient: well inside 8 eps.
    let psi = |w: f64| -w * w.exp() / x;
    assert!(
        psi(lo) < 1.0 - 8.0 * EPS && psi(hi) > 1.0 + 8.0 * EPS,
        "W_-1(-{x}) not enclosed"
    );
    (lo, hi)
}

/// The derivatives are right: their Taylor sum to order 6 misses v(x + h) by O(h^7), so halving
/// h divides the miss by 2^7 (1 + O(h)). The bounds 100-170 leave room for the O(h) term and
/// shut out the 2^6 that a sixth derivative wrong by more than about 1 % would leave (its term
/// would outweigh the seventh order's at h = 0.08 x); the misses, 1e-12 and more, stand far
/// above the rounding of the sum.
#[test]
fn derivative_numerators_give_the_taylor_series() {
    let numerators = derivative_numerators(6);
    for x in [1e-30, 1e-8, 1e-3, 0.05, 0.1] {
        let w = lambert_w::lambert_wm1(-x);
        let miss = |q: f64| {
            let (sum, _) = (0..=6).fold((0.0, 1.0), |(s, f), n| {
                let f = if n == 0 { 1.0 } else { f * q / n as f64 };
                (s + f * scaled_derivative(&numerators, n, w), f)
            });
            let exact = -1.0 / lambert_w::lambert_wm1(-x * (1.0 + q));
            (sum - exact).abs() / exact
        };
        let (coarse, fine) = (miss(0.08), miss(0.04));
        let ratio = coarse / fine;
        println!(
            "x = {x:e}: miss {coarse:.2e} at h = 0.08 x, {fine:.2e} at 0.04 x, ratio {ratio:.1}"
        );
        assert!(
            ratio > 100.0 && ratio < 170.0,
            "x = {x}: {coarse:e} / {fine:e} = {ratio}"
        );
    }
}

/// Every piece of the table within TOLERANCE of v over its whole interval (see the module's
/// documentation); prints the largest bound found.
#[test]
fn table_error_is_proven_below_the_tolerance() {
    let numerators = derivative_numerators(6);
    let n6 = &numerators[6];
    let lebesgue = 1.0 + 2.0 / PI * 6f64.ln();
    let nodes: Vec<f64> = (0..TERMS)
        .map(|j| (PI * (j as f64 + 0.5) / TERMS as f64).cos())
        .collect();
    let mut worst: f64 = 0.0;
    for (k, p) in PIECES.iter().enumerate() {
        let start = |i: u64| f64::from_bits((BASE + i) << SHIFT);
        let (lo, hi) = (start(k as u64), start(k as u64 + 1));
        let (r, mid) = (0.5 * (hi - lo), 0.5 * (lo + hi));
        // W rises with x: over the piece it lies between the enclosures at its ends.
        let (w_lo, w_hi) = (enclose(lo).0, enclose(hi).1);
        let (w_mid, w_half) = (0.5 * (w_lo + w_hi), 0.5 * (w_hi - w_lo));
        let n_max = taylor_bound(n6, w_mid, w_half);
        // |w| and |1 + w| are smallest at w_hi.
        let d6 = n_max / (w_hi.abs() * (1.0 + w_hi).abs().powi(12) * lo.powi(6));
        let interpolation = 2f64.powi(-5) * r.powi(6) / 720.0 * d6;
        // Rounding of Estrin's scheme, and of u = x a + b (|x a| <= |b| + 1) through the slope.
        let (sum_c, sum_kc) = p.c.iter().enumerate().fold((0.0, 0.0), |(s, sk), (i, c)| {
            (s + c.abs(), sk + i as f64 * c.abs())
        });
        let rounding = 8.0 * EPS * sum_c + 4.0 * EPS * (p.b.abs() + 2.0) * sum_kc;
        // The nodes as computed lie within a few eps (|b| + 2) of the Chebyshev roots in u; the
        // error p - v moves there by at most that times its slope, below |p'| + r |v'| with
        // |v'| = 1 / (x |w| |1 + w|).
        let slope_v = r / (lo * w_hi.abs() * (1.0 + w_hi).abs());
        let node_shift = 4.0 * EPS * (p.b.abs() + 2.0) * (sum_kc + slope_v);
        let residual = nodes
            .iter()
            .map(|t| {
                let x = mid + r * t;
                let (wl, wh) = enclose(x);
                let got = polynomial(&p.c, x * p.a + p.b);
                // 1/w and the difference rounded by an ulp each.
                (got + 1.0 / wl).abs().max((got + 1.0 / wh).abs()) + 4.0 * EPS * got.abs()
            })
            .fold(0.0, f64::max);
        let bound = lebesgue * (residual + rounding + node_shift) + interpolation + rounding;
        // v = -1/w is smallest at the lower end.
        let relative = bound * (-w_lo) * (1.0 + 1e-9);
        worst = worst.max(relative);
        assert!(
            relative <= TOLERANCE,
            "piece {k} [{lo:e}, {hi:e}]: {relative:e}"
        );
    }
    println!(
        "W_-1 table: relative error proven below {worst:.2e} on all {} pieces",
        PIECES.len()
    );
}
