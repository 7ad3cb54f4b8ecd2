//! The lower branch of Lambert W as the compliant laws use it: `v(x) = -1/W_{-1}(-x)`, so that
//! `y = x v` solves `y ln y = -x` (0 < x < 1/e). Johnson's law (contact model 1) and contact
//! model 3 both give a pair's force as `F = pi b E* delta v(x)`.
//!
//! Tabulated in pieces found from the bits of x: the exponent and the top `BITS` bits of the
//! mantissa index the piece directly (no log, no search), 2^BITS pieces per binade, each a
//! polynomial in the position inside it. v is analytic for 0 < x < 1/e; its singularities are
//! x = 0 (through ln x), 2^BITS piece widths below any piece, and the branch point 1/e, over a
//! hundred widths above the last, so every piece converges alike. Degree 5 on 32 pieces per
//! binade: against degree 7 on 8, Estrin's scheme needs the same three levels but a piece is
//! one cache line (8 reals with its scaling), and the right-hand side of contact model 3 came
//! out 9 % cheaper (benches/rhs_cost.rs). The table takes 231 kB and 0.5 ms to build, once per
//! process (`shared`). `lambert_w` serves the rest: below X_LO (penetrations below 1e-18 of
//! the static one) and from X_HI to the limit.
//!
//! Against `lambert_w` and its `ln` per evaluation, the table made Johnson's `Mesh::rhs` on the
//! paper rig about a quarter cheaper (`cargo bench --bench rhs_cost`): the library's log and
//! its iteration are a chain of dependent operations that the polynomial's levels are not.

use super::piecewise::{fit_piece, piece_error, polynomial};
use super::ModelError;
use std::sync::OnceLock;

/// Mantissa bits that index a piece inside its binade, and the terms of each piece's polynomial.
const BITS: u32 = 5;
const TERMS: usize = 6;
const SHIFT: u32 = 52 - BITS;
/// The table's range: x from 2^-116 (ln x = -80.4) to 2^-3 (ln x = -2.08).
const X_LO: f64 = 1.0 / (1u128 << 116) as f64;
const X_HI: f64 = 0.125;

/// Relative error of v in the table: forces to 1e-13, as the table of C (LN_C_TOLERANCE).
pub const TOLERANCE: f64 = 1e-13;

/// -1/W_{-1}(-x) from `lambert_w`; NaN from x = 1/e on.
pub fn exact(x: f64) -> f64 {
    -1.0 / lambert_w::lambert_wm1(-x)
}

/// One piece: u = x a + b runs over [-1, 1] across it. One cache line each.
#[derive(Clone, Debug, PartialEq)]
#[repr(align(64))]
struct Piece {
    a: f64,
    b: f64,
    c: [f64; TERMS],
}

#[derive(Clone, Debug, PartialEq)]
pub struct LowerBranch {
    /// The bits of X_LO shifted: piece k starts at the x whose shifted bits are base + k.
    base: u64,
    pieces: Vec<Piece>,
}

impl LowerBranch {
    pub fn new() -> Result<LowerBranch, ModelError> {
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
                Piece {
                    a,
                    b: -1.0 - lo * a,
                    c,
                }
            })
            .collect();
        if error > TOLERANCE {
            return Err(ModelError::new(format!(
                "contact model 3: -1/W_-1(-x) could not be tabulated to {TOLERANCE} (error {error})"
            )));
        }
        Ok(LowerBranch { base, pieces })
    }

    /// The table every instance reads. It depends on nothing, so it is built once per process,
    /// on first use, and never written again: instances stay independent, and a study of many
    /// model-3 instances pays the 0.5 ms and the 231 kB once.
    pub fn shared() -> Result<&'static LowerBranch, ModelError> {
        static TABLE: OnceLock<Result<LowerBranch, ModelError>> = OnceLock::new();
        TABLE
            .get_or_init(LowerBranch::new)
            .as_ref()
            .map_err(Clone::clone)
    }

    /// v(x) for 0 < x < 1/e (the caller checks the range); NaN beyond.
    #[inline]
    pub fn v(&self, x: f64) -> f64 {
        // Below X_LO the subtraction wraps to a large index, and so falls through.
        let k = (x.to_bits() >> SHIFT).wrapping_sub(self.base) as usize;
        match self.pieces.get(k) {
            Some(p) => polynomial(&p.c, x * p.a + p.b),
            None => exact(x),
        }
    }

    /// The number of polynomial pieces.
    pub fn pieces(&self) -> usize {
        self.pieces.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Against lambert_w densely over the table (in ln x), at its ends and beyond them, and
    /// the identity y ln y = -x with y = x v.
    #[test]
    fn table_matches_lambert_w() {
        let b = LowerBranch::new().unwrap();
        let mut worst: f64 = 0.0;
        for i in 0..=200_000 {
            let x = (-85.0 + 84.0 * i as f64 / 200_000.0 - 1e-9).exp();
            let (v, e) = (b.v(x), exact(x));
            worst = worst.max(((v - e) / e).abs());
            // ln y = ln x + ln v, so x v (ln x + ln v) = -x.
            assert!((v * (x.ln() + v.ln()) + 1.0).abs() < 1e-12, "{x}: {v}");
        }
        for x in [X_LO, X_HI, 0.3, 1e-300] {
            assert!(((b.v(x) - exact(x)) / exact(x)).abs() <= TOLERANCE, "{x}");
        }
        assert!(worst <= TOLERANCE, "{worst:e}");
        assert!(b.v(0.5).is_nan());
        assert_eq!(b.pieces(), (116 - 3) << BITS);
    }
}
