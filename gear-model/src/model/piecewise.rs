//! A smooth function of one variable fitted at initialization for cheap evaluation in the
//! right-hand side: piecewise polynomials of degree `DEGREE` (Chebyshev interpolation on each
//! piece, kept in power form for Estrin's scheme; one Chebyshev series over a whole contact
//! segment needed 32-64 terms, a serial chain of 4x the latency). Each span between kinks is
//! fitted on its own (a polynomial piece across a kink would converge only linearly), and its
//! pieces are halved until the relative error found midway between the nodes (the Chebyshev
//! extrema, where it peaks) on every piece is below the tolerance.

use super::chebyshev::{fit_piece, piece_error, polynomial};
use super::ModelError;

#[derive(Clone, Debug, PartialEq)]
pub struct PiecewiseFit {
    /// Spans between the kinks (for ln C, where Sainsot's u_f reaches 0 and is held there).
    spans: Vec<Span>,
    /// The largest relative error found by the check.
    pub error: f64,
}

#[derive(Clone, Debug, PartialEq)]
struct Span {
    lo: f64,
    hi: f64,
    /// Pieces per unit of the variable.
    scale: f64,
    /// Per piece, the coefficients of u^0..u^DEGREE, u in [-1, 1] across the piece.
    coef: Vec<Coefficients>,
    /// Just below the number of pieces: the largest x that still falls in the last piece.
    end: f64,
    /// The largest relative error found by the check.
    error: f64,
}

pub const DEGREE: usize = 7;

/// A piece's coefficients on one cache line of their own.
#[derive(Clone, Debug, PartialEq)]
#[repr(align(64))]
struct Coefficients([f64; DEGREE + 1]);

impl PiecewiseFit {
    /// Fits f on [lo, hi] to within the relative `tolerance` with breaks at `kinks` (those
    /// inside are used); `what` names f in the error if the pieces would get too many.
    pub fn new(
        f: &dyn Fn(f64) -> f64,
        lo: f64,
        hi: f64,
        kinks: &[f64],
        tolerance: f64,
        what: &str,
    ) -> Result<PiecewiseFit, ModelError> {
        let mut cuts: Vec<f64> = kinks
            .iter()
            .cloned()
            .filter(|&k| k > lo && k < hi)
            .collect();
        cuts.sort_by(f64::total_cmp);
        let ends: Vec<f64> = std::iter::once(lo)
            .chain(cuts)
            .chain(std::iter::once(hi))
            .collect();
        let spans = ends
            .windows(2)
            // About 32 pieces over the whole interval to start with (enough for the ln C of
            // the default pair).
            .map(|w| {
                let start = ((32.0 * (w[1] - w[0]) / (hi - lo)).ceil() as usize).max(4);
                Span::new(f, w[0], w[1], start, tolerance, what)
            })
            .collect::<Result<Vec<Span>, ModelError>>()?;
        let error = spans.iter().map(|s| s.error).fold(0.0, f64::max);
        Ok(PiecewiseFit { spans, error })
    }

    #[inline(always)]
    fn span(&self, s: f64) -> &Span {
        self.spans
            .iter()
            .find(|sp| s < sp.hi)
            .unwrap_or(self.spans.last().expect("a span"))
    }

    #[inline]
    pub fn value(&self, s: f64) -> f64 {
        self.span(s).value(s)
    }

    pub fn derivative(&self, s: f64) -> f64 {
        self.span(s).derivative(s)
    }

    /// Both at once, from one lookup of the piece. Inlined: a call clobbers every xmm register
    /// of the caller's per-pair loop (benches/rhs_cost.rs).
    #[inline(always)]
    pub fn value_and_derivative(&self, s: f64) -> (f64, f64) {
        self.span(s).value_and_derivative(s)
    }
}

impl Span {
    fn new(
        f: &dyn Fn(f64) -> f64,
        lo: f64,
        hi: f64,
        start: usize,
        tolerance: f64,
        what: &str,
    ) -> Result<Span, ModelError> {
        let mut pieces = start;
        loop {
            let t = Self::fit(f, lo, hi, pieces);
            if t.error <= tolerance {
                return Ok(t);
            }
            if pieces >= 1024 {
                return Err(ModelError::new(format!(
                    "{what} could not be tabulated to {tolerance} on [{lo}, {hi}] (error {})",
                    t.error
                )));
            }
            pieces *= 2;
        }
    }

    fn fit(f: &dyn Fn(f64) -> f64, lo: f64, hi: f64, pieces: usize) -> Span {
        let width = (hi - lo) / pieces as f64;
        let ends = |i: usize| (lo + i as f64 * width, lo + (i + 1) as f64 * width);
        let coef: Vec<_> = (0..pieces)
            .map(|i| {
                let (a, b) = ends(i);
                Coefficients(fit_piece(f, a, b))
            })
            .collect();
        let error = coef
            .iter()
            .enumerate()
            .map(|(i, c)| {
                let (a, b) = ends(i);
                piece_error(&c.0, f, a, b)
            })
            .fold(0.0, f64::max);
        Span {
            lo,
            hi,
            scale: 1.0 / width,
            end: pieces as f64 * (1.0 - f64::EPSILON),
            coef,
            error,
        }
    }

    /// The piece of s and u in it; beyond the table's ends the end values hold (a polynomial
    /// piece extrapolated far could run away, and stages of a step that carries a pair past
    /// s_b, before its event is located, reach there).
    #[inline(always)]
    fn locate(&self, s: f64) -> (&[f64; DEGREE + 1], f64) {
        // x in [0, pieces): truncation is then the floor, without a call to libm's floor,
        // which the baseline x86-64 target does not inline; through i64, because x86-64
        // converts signed integers in one instruction and unsigned ones in a dozen.
        let x = ((s - self.lo) * self.scale).clamp(0.0, self.end);
        let i = x as i64;
        (&self.coef[i as usize].0, (x + x) - (2 * i + 1) as f64)
    }

    fn value(&self, s: f64) -> f64 {
        let (c, u) = self.locate(s);
        polynomial(c, u)
    }

    fn derivative(&self, s: f64) -> f64 {
        self.value_and_derivative(s).1
    }

    #[inline(always)]
    fn value_and_derivative(&self, s: f64) -> (f64, f64) {
        let (c, u) = self.locate(s);
        (polynomial(c, u), 2.0 * self.scale * slope(c, u))
    }
}

/// The derivative in u of the polynomial c (Estrin's scheme as in `polynomial`).
#[inline(always)]
fn slope<const N: usize>(c: &[f64; N], u: f64) -> f64 {
    let u2 = u * u;
    match N {
        8 => {
            let low = (c[1] + 2.0 * c[2] * u) + u2 * (3.0 * c[3] + 4.0 * c[4] * u);
            let high = (5.0 * c[5] + 6.0 * c[6] * u) + u2 * (7.0 * c[7]);
            low + (u2 * u2) * high
        }
        _ => (1..N).rev().fold(0.0, |acc, k| acc * u + k as f64 * c[k]),
    }
}
