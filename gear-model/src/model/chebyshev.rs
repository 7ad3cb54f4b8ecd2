//! Chebyshev interpolation on one piece, in power form for Estrin's scheme: what the tables of
//! `piecewise.rs` (at initialization) and of `lower_branch.rs` (in build.rs, at compile time)
//! are made of. Only `std` here: build.rs includes this file as it is.

use std::f64::consts::PI;

/// The coefficients of u^0..u^(N-1) of f's Chebyshev interpolant on [lo, hi], u in [-1, 1]
/// across it.
pub fn fit_piece<const N: usize>(f: &dyn Fn(f64) -> f64, lo: f64, hi: f64) -> [f64; N] {
    let (mid, half) = (0.5 * (lo + hi), 0.5 * (hi - lo));
    let v: Vec<f64> = (0..N)
        .map(|j| f(mid + half * (PI * (j as f64 + 0.5) / N as f64).cos()))
        .collect();
    // Chebyshev coefficients, then power form: T_k(u) expanded by its recurrence.
    let c: Vec<f64> = (0..N)
        .map(|k| {
            2.0 / N as f64
                * (0..N)
                    .map(|j| v[j] * (PI * k as f64 * (j as f64 + 0.5) / N as f64).cos())
                    .sum::<f64>()
        })
        .collect();
    let mut power = [0.0; N];
    let (mut t0, mut t1) = ([0.0; N], [0.0; N]);
    t0[0] = 1.0;
    t1[1] = 1.0;
    for k in 0..N {
        let tk = match k {
            0 => t0,
            1 => t1,
            _ => {
                let mut t2 = [0.0; N];
                for m in 0..N {
                    t2[m] = if m > 0 { 2.0 * t1[m - 1] } else { 0.0 } - t0[m];
                }
                (t0, t1) = (t1, t2);
                t2
            }
        };
        let ck = if k == 0 { 0.5 * c[0] } else { c[k] };
        for m in 0..N {
            power[m] += ck * tk[m];
        }
    }
    power
}

/// The largest relative error of a piece against f midway between its nodes (the Chebyshev
/// extrema, where the error peaks), ends included.
pub fn piece_error<const N: usize>(c: &[f64; N], f: &dyn Fn(f64) -> f64, lo: f64, hi: f64) -> f64 {
    (0..=N)
        .map(|j| (PI * j as f64 / N as f64).cos() * (1.0 - 1e-12))
        .map(|u| {
            let exact = f(0.5 * (lo + hi) + 0.5 * (hi - lo) * u);
            ((polynomial(c, u) - exact) / exact).abs()
        })
        .fold(0.0, f64::max)
}

/// The polynomial with coefficients c of u^0..u^(N-1) at u. Estrin's scheme for the degrees
/// in use: levels of independent multiply-adds instead of Horner's chain (the baseline x86-64
/// target has no fused multiply-add, so each Horner step is a multiply and an add in series).
#[inline(always)]
pub fn polynomial<const N: usize>(c: &[f64; N], u: f64) -> f64 {
    let u2 = u * u;
    match N {
        6 => ((c[0] + c[1] * u) + u2 * (c[2] + c[3] * u)) + (u2 * u2) * (c[4] + c[5] * u),
        8 => {
            let low = (c[0] + c[1] * u) + u2 * (c[2] + c[3] * u);
            let high = (c[4] + c[5] * u) + u2 * (c[6] + c[7] * u);
            low + (u2 * u2) * high
        }
        _ => c.iter().rev().fold(0.0, |acc, &ck| acc * u + ck),
    }
}
