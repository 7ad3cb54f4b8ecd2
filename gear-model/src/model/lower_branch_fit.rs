//! The pieces of the W_-1 table (`lower_branch.rs`). build.rs fits them at compile time, so an
//! instance neither builds nor allocates the table; this file needs only `std`, `lambert_w` and
//! `chebyshev.rs`, and build.rs includes it as it is.

use super::chebyshev::{fit_piece, piece_error};

/// Mantissa bits that index a piece inside its binade, and the terms of each piece's polynomial.
pub const BITS: u32 = 5;
pub const TERMS: usize = 6;
pub const SHIFT: u32 = 52 - BITS;
/// The table's range: x from 2^-116 (ln x = -80.4) to 2^-3 (ln x = -2.08).
pub const X_LO: f64 = 1.0 / (1u128 << 116) as f64;
pub const X_HI: f64 = 0.125;

/// Relative error of v in the table: forces to 1e-13, as the table of C (LN_C_TOLERANCE).
/// build.rs fails if the check finds more.
pub const TOLERANCE: f64 = 1e-13;

/// -1/W_{-1}(-x) from `lambert_w`; NaN from x = 1/e on.
pub fn exact(x: f64) -> f64 {
    -1.0 / lambert_w::lambert_wm1(-x)
}

/// One piece: u = x a + b runs over [-1, 1] across it; c are the coefficients of u^0..u^5.
#[cfg_attr(not(test), allow(dead_code))]
pub struct Fitted {
    pub a: f64,
    pub b: f64,
    pub c: [f64; TERMS],
}

/// The shifted bits of X_LO (piece k starts at the x whose shifted bits are base + k), every
/// piece's Chebyshev interpolant of `exact`, and the largest relative error the check found
/// (midway between the nodes and at the ends of every piece).
#[cfg_attr(not(test), allow(dead_code))]
pub fn fit() -> (u64, Vec<Fitted>, f64) {
    let base = X_LO.to_bits() >> SHIFT;
    let n = (X_HI.to_bits() >> SHIFT) - base;
    let start = |k: u64| f64::from_bits((base + k) << SHIFT);
    let mut error: f64 = 0.0;
    let pieces = (0..n)
        .map(|k| {
            let (lo, hi) = (start(k), start(k + 1));
            let c = fit_piece(&exact, lo, hi);
            error = error.max(piece_error(&c, &exact, lo, hi));
            let a = 2.0 / (hi - lo);
            Fitted {
                a,
                b: -1.0 - lo * a,
                c,
            }
        })
        .collect();
    (base, pieces, error)
}
