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
//! out 9 % cheaper (benches/rhs_cost.rs). build.rs fits the table (`lower_branch_fit.rs`) and
//! writes it into the library as 231 kB of constants: built at initialization it took 0.5 ms
//! per instance, and as a heap table shared by a process it was lost when a master unloaded
//! the FMU. `lambert_w` serves the rest: below X_LO (penetrations below 1e-18 of the static
//! one) and from X_HI to the limit.
//!
//! The table's relative error is proven below 2.7e-14 over every piece's whole interval
//! (`bound.rs`: the interpolation error from a bound on v's sixth derivative, the residual at the
//! nodes through the Lebesgue constant, and the rounding of the evaluation); build.rs checks
//! the fit against TOLERANCE (1e-13) at the points where its error peaks.
//!
//! Against `lambert_w` and its `ln` per evaluation, the table made Johnson's `PaperRig::rhs` on the
//! paper rig about a quarter cheaper (`cargo bench --bench rhs_cost`): the library's log and
//! its iteration are a chain of dependent operations that the polynomial's levels are not.

use super::chebyshev::polynomial;
pub use super::lower_branch_fit::{exact, TOLERANCE};
use super::lower_branch_fit::{SHIFT, TERMS};

/// One piece: u = x a + b runs over [-1, 1] across it. One cache line each.
#[repr(align(64))]
struct Piece {
    a: f64,
    b: f64,
    c: [f64; TERMS],
}

// BASE (the shifted bits of X_LO: piece k starts at the x whose shifted bits are BASE + k),
// MAX_ERROR (what build.rs's check found) and PIECES.
include!(concat!(env!("OUT_DIR"), "/lower_branch_table.rs"));

// build.rs checks the fit too; this holds the compiled table to the tolerance the laws assume.
const _: () = assert!(MAX_ERROR <= TOLERANCE);

/// v(x) for 0 < x < 1/e (the caller checks the range); NaN beyond.
#[inline]
pub fn v(x: f64) -> f64 {
    // Below X_LO the subtraction wraps to a large index, and so falls through.
    let k = (x.to_bits() >> SHIFT).wrapping_sub(BASE) as usize;
    match PIECES.get(k) {
        Some(p) => polynomial(&p.c, x * p.a + p.b),
        None => exact(x),
    }
}

#[cfg(test)]
mod bound;

#[cfg(test)]
mod tests {
    use super::*;

    /// Against lambert_w densely over the table (in ln x), at its ends and beyond them, and
    /// the identity y ln y = -x with y = x v.
    #[test]
    fn table_matches_lambert_w() {
        use crate::model::lower_branch_fit::{BITS, X_HI, X_LO};
        let mut worst: f64 = 0.0;
        for i in 0..=200_000 {
            let x = (-85.0 + 84.0 * i as f64 / 200_000.0 - 1e-9).exp();
            let (v, e) = (v(x), exact(x));
            worst = worst.max(((v - e) / e).abs());
            // ln y = ln x + ln v, so x v (ln x + ln v) = -x.
            assert!((v * (x.ln() + v.ln()) + 1.0).abs() < 1e-12, "{x}: {v}");
        }
        for x in [X_LO, X_HI, 0.3, 1e-300] {
            assert!(((v(x) - exact(x)) / exact(x)).abs() <= TOLERANCE, "{x}");
        }
        assert!(worst <= TOLERANCE, "{worst:e}");
        assert!(v(0.5).is_nan());
        assert_eq!(PIECES.len(), (116 - 3) << BITS);
    }

    /// The compiled table is the fit done here, up to rounding: build.rs runs the same code
    /// unoptimized, and the coefficients differ in their last bits, so each piece's value
    /// agrees to a few ulp (1e-15 is about 5).
    #[test]
    fn compiled_table_is_the_fit() {
        let (base, fitted, _) = crate::model::lower_branch_fit::fit();
        assert_eq!(base, BASE);
        assert_eq!(fitted.len(), PIECES.len());
        for (f, p) in fitted.iter().zip(&PIECES) {
            assert_eq!((f.a, f.b), (p.a, p.b));
            for u in [-1.0, -0.5, 0.0, 0.5, 1.0] {
                let (a, b) = (polynomial(&f.c, u), polynomial(&p.c, u));
                assert!((a - b).abs() <= 1e-15 * a.abs(), "{u}: {a} vs {b}");
            }
        }
    }
}
