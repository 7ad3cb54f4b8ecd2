//! Event location on the method's dense output (`Driver::locate`): the margins at a step's
//! ends with their rates, a cubic bound per margin, the midpoint and graze samples where it
//! may dip, and regula falsi to the crossing. Buffers are as long as the system's event
//! functions in use and are kept from step to step.

use super::{Driver, PendingEvent, System};
use serde::{Deserialize, Serialize};

/// The event margins and their rates at the end of the last accepted step, which are those at
/// the start of the next: kept so that each step evaluates them once. Recomputed when missing,
/// so it never makes two drivers unequal; an FMU state saves it, because a recomputation from
/// the dense output rounds differently. `n_events()` long: it swaps with the end's buffers
/// (`Scratch`) instead of being copied.
#[derive(Debug, Default, Serialize, Deserialize)]
pub struct MarginCache {
    /// The time the margins hold at; None: missing.
    pub(super) at: Option<f64>,
    pub(super) margins: Vec<f64>,
    pub(super) rates: Vec<f64>,
}

impl Clone for MarginCache {
    fn clone(&self) -> Self {
        match self.at {
            Some(_) => MarginCache {
                at: self.at,
                margins: self.margins.clone(),
                rates: self.rates.clone(),
            },
            None => MarginCache::default(),
        }
    }

    /// In place, keeping the buffers (`Driver::clone_from`).
    fn clone_from(&mut self, src: &Self) {
        self.at = src.at;
        if src.at.is_some() {
            self.margins.clone_from(&src.margins);
            self.rates.clone_from(&src.rates);
        }
    }
}

impl PartialEq for MarginCache {
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

impl MarginCache {
    /// Missing from now on; the buffers keep their room (a saved state holds no stale values).
    pub(super) fn clear(&mut self) {
        self.at = None;
        self.margins.clear();
        self.rates.clear();
    }
}

/// Buffers of `locate`, kept from step to step so a step allocates and zeroes nothing: the
/// margins and rates at a step's end, at its midpoint, and near a graze. Not part of a
/// driver's value (not saved, not compared, not cloned).
#[derive(Debug, Default)]
pub(super) struct Scratch {
    end: Vec<f64>,
    end_rate: Vec<f64>,
    mid: Vec<f64>,
    probe: Vec<f64>,
    probe_rate: Vec<f64>,
}

impl Clone for Scratch {
    fn clone(&self) -> Self {
        Scratch::default()
    }
}

impl PartialEq for Scratch {
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

/// A buffer of n values (its old values are overwritten by the caller).
fn sized(v: &mut Vec<f64>, n: usize) -> Vec<f64> {
    let mut v = std::mem::take(v);
    v.resize(n, 0.0);
    v
}

/// The cubic Hermite interpolant on [0, 1] through values m0, m1 with slopes d0, d1 (per unit
/// s): its interior minimum (s, value), if any.
fn hermite_minimum(m0: f64, d0: f64, m1: f64, d1: f64) -> Option<(f64, f64)> {
    // H(s) = m0 + d0 s + c2 s^2 + c3 s^3.
    let c2 = 3.0 * (m1 - m0) - 2.0 * d0 - d1;
    let c3 = 2.0 * (m0 - m1) + d0 + d1;
    let h = |s: f64| m0 + s * (d0 + s * (c2 + s * c3));
    // H'(s) = d0 + 2 c2 s + 3 c3 s^2 = 0 with H''(s) = 2 c2 + 6 c3 s > 0.
    let (a, b, c) = (3.0 * c3, 2.0 * c2, d0);
    let mut best: Option<(f64, f64)> = None;
    let mut consider = |s: f64| {
        if s > 0.0 && s < 1.0 && b + 2.0 * a * s > 0.0 {
            let v = h(s);
            if best.is_none_or(|(_, w)| v < w) {
                best = Some((s, v));
            }
        }
    };
    if a.abs() <= 1e-12 * (b.abs() + c.abs()) {
        if b != 0.0 {
            consider(-c / b);
        }
    } else {
        let disc = b * b - 4.0 * a * c;
        if disc >= 0.0 {
            let q = -0.5 * (b + b.signum() * disc.sqrt());
            if q != 0.0 {
                consider(q / a);
                consider(c / q);
            }
        }
    }
    best
}

impl<S: System + Clone + 'static> Driver<S> {
    /// The earliest event in the last step. Each margin is known at the step's ends with its
    /// rate; the cubic through those values and rates lies above a chord bound, and a margin
    /// whose bound stays positive has not crossed. For the others the midpoint is evaluated
    /// too, and where the cubic's interior minimum comes near zero (within four times the
    /// cubic's error at the midpoint), the margin itself near that minimum, after one Newton
    /// step on its rate. So a margin that dips below zero and comes back inside one step (a
    /// graze) is found. The first sample below zero brackets the root.
    pub(super) fn locate(&mut self, sys: &S) -> Option<PendingEvent> {
        let (t0, t1) = (self.search_from, self.method.t());
        let n = sys.n_events();
        let cached = self.start.at == Some(t0) && self.start.margins.len() == n;
        // The buffers are taken out for the search and put back (pointer moves).
        let sc = &mut self.scratch;
        let (mut end, mut end_rate) = (sized(&mut sc.end, n), sized(&mut sc.end_rate, n));
        let mut mid = std::mem::take(&mut sc.mid);
        let mut probe = (
            std::mem::take(&mut sc.probe),
            std::mem::take(&mut sc.probe_rate),
        );
        let (mut start, mut start_rate) = (
            sized(&mut self.start.margins, n),
            sized(&mut self.start.rates, n),
        );
        sys.event_margins_and_rates(
            self.method.y(),
            &self.method.rate_at_end(),
            &mut end,
            &mut end_rate,
        );
        // The margins at t0: the last step's end, or computed anew after a restart or event.
        if !cached {
            let y0 = self.method.interpolate(t0);
            let dy0 = self.method.derivative(t0);
            sys.event_margins_and_rates(&y0, &dy0, &mut start, &mut start_rate);
        }
        let best = self.search(
            sys,
            (&start, &start_rate),
            (&end, &end_rate),
            &mut mid,
            &mut probe,
        );
        // The end's margins start the next step, unless the step ends at an event.
        self.start = MarginCache {
            at: Some(t1),
            margins: end,
            rates: end_rate,
        };
        if best.is_some() {
            self.start.clear();
        }
        let sc = &mut self.scratch;
        (sc.end, sc.end_rate, sc.mid) = (start, start_rate, mid);
        (sc.probe, sc.probe_rate) = probe;
        best
    }

    /// `locate`'s search of the step [search_from, t] with the margins and rates at its ends
    /// (`mid` and `probe`: buffers).
    fn search(
        &self,
        sys: &S,
        (start, start_rate): (&[f64], &[f64]),
        (end, end_rate): (&[f64], &[f64]),
        mid: &mut Vec<f64>,
        probe: &mut (Vec<f64>, Vec<f64>),
    ) -> Option<PendingEvent> {
        let (t0, t1) = (self.search_from, self.method.t());
        let (h, tm) = (t1 - t0, 0.5 * (t0 + t1));
        // One length for all four, so that indexing them needs no bounds check.
        let n = end.len();
        let (start, start_rate, end_rate) = (&start[..n], &start_rate[..n], &end_rate[..n]);
        // At t0 a margin is >= 0 except when two events coincide and the other one was just
        // handled: it has then crossed at t0 itself, and the root search returns about t0.
        let m0 = |i: usize| start[i].max(0.0);
        let slopes = |i: usize| (h * start_rate[i], h * end_rate[i]);
        // The cubic through the ends is the chord plus s(1-s)[(d0 - D)(1-s) - (d1 - D)s],
        // D = m1 - m0: it stays above min(m0, m1) - max(|d0 - D|, |d1 - D|)/4. A margin whose
        // bound stays positive and whose end is positive cannot have crossed; most end here.
        let dips = |m0: f64, r0: f64, m1: f64, r1: f64| {
            let m0 = m0.max(0.0);
            let chord = m1 - m0;
            let dip = 0.25 * (h * r0 - chord).abs().max((h * r1 - chord).abs());
            !(m0.min(m1) > dip) // NaN rates: unknown, so checked
        };
        let may_dip = |i: usize| dips(start[i], start_rate[i], end[i], end_rate[i]);
        // The common case, every margin clear, by iterators (no index checks).
        let ends = end.iter().zip(end_rate);
        if !start
            .iter()
            .zip(start_rate)
            .zip(ends)
            .any(|((&m0, &r0), (&m1, &r1))| dips(m0, r0, m1, r1))
        {
            return None;
        }
        mid.resize(n, 0.0);
        sys.event_margins(&self.method.interpolate(tm), mid);
        let mut best: Option<PendingEvent> = None;
        for i in (0..n).filter(|&i| may_dip(i) || mid[i] < 0.0) {
            let (d0, d1) = slopes(i);
            let m0 = m0(i);
            let mut samples = [(tm, mid[i]), (t1, end[i]), (f64::INFINITY, 0.0)];
            let cubic = if d0.is_finite() && d1.is_finite() {
                hermite_minimum(m0, d0, end[i], d1)
            } else {
                None
            };
            if let Some((s, low)) = cubic {
                // Sample the margin near the cubic's minimum where it comes within the cubic's
                // own error at the midpoint (times 4) of zero.
                let c2 = 3.0 * (end[i] - m0) - 2.0 * d0 - d1;
                let c3 = 2.0 * (m0 - end[i]) + d0 + d1;
                let at_mid = m0 + 0.5 * (d0 + 0.5 * (c2 + 0.5 * c3));
                let slack = 4.0 * (at_mid - mid[i]).abs() + 1e-3 * (m0.abs() + end[i].abs());
                if low <= slack {
                    let curv = 2.0 * c2 + 6.0 * c3 * s;
                    samples[2] = self.graze_sample(sys, i, t0, h, s, curv, probe);
                }
            }
            if samples[2].0 < t1 {
                samples.sort_by(|a, b| a.0.total_cmp(&b.0));
            }
            let (mut a, mut fa) = (t0, m0);
            for &(t, m) in samples.iter().filter(|p| p.0.is_finite()) {
                if m < 0.0 {
                    let t = self.root(sys, i, a, fa, t, m);
                    if best.is_none_or(|e| t < e.t) {
                        best = Some(PendingEvent { t, index: i });
                    }
                    break;
                }
                (a, fa) = (t, m);
            }
        }
        best
    }

    /// The margin of event i near the cubic's interior minimum at s (curvature `curv` per s^2):
    /// one Newton step on the margin's true rate there, and the lower of the two values.
    #[allow(clippy::too_many_arguments)]
    fn graze_sample(
        &self,
        sys: &S,
        i: usize,
        t0: f64,
        h: f64,
        s: f64,
        curv: f64,
        (margins, rates): &mut (Vec<f64>, Vec<f64>),
    ) -> (f64, f64) {
        let t = t0 + s * h;
        let y = self.method.interpolate(t);
        let n = sys.n_events();
        margins.resize(n, 0.0);
        rates.resize(n, 0.0);
        sys.event_margins_and_rates(&y, &self.method.derivative(t), margins, rates);
        let m = margins[i];
        let s2 = s - h * rates[i] / curv;
        if !(s2 > 0.0 && s2 < 1.0) || s2 == s {
            return (t, m);
        }
        let t2 = t0 + s2 * h;
        let m2 = sys.margin(i, &self.method.interpolate(t2));
        if m2 < m {
            (t2, m2)
        } else {
            (t, m)
        }
    }

    /// Illinois regula falsi on the dense output: returns a time at which the function has
    /// crossed, within a few ulp of the root.
    fn root(&self, sys: &S, i: usize, mut a: f64, mut fa: f64, mut b: f64, mut fb: f64) -> f64 {
        let mut side = 0;
        for _ in 0..200 {
            if b - a <= 4.0 * f64::EPSILON * b.abs().max(1e-300) {
                break;
            }
            let mut c = (a * fb - b * fa) / (fb - fa);
            if !(c > a && c < b) {
                c = 0.5 * (a + b);
            }
            let fc = sys.margin(i, &self.method.interpolate(c));
            if fc < 0.0 {
                b = c;
                fb = fc;
                if side == -1 {
                    fa *= 0.5;
                }
                side = -1;
            } else {
                a = c;
                fa = fc;
                if side == 1 {
                    fb *= 0.5;
                }
                side = 1;
            }
        }
        b
    }
}
