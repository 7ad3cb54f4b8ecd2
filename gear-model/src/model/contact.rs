//! Contact tracking (spec §3): the objects f1, f2 (forward flank) and b1, b2 (backward flank),
//! their windows, the gate, and the event functions whose sign changes the driver locates.
//!
//! An object tracks one tooth pair by the contact coordinate s_A on its line of action. Between
//! events `phiA = psiA + const` (paper eq. 4.2), and with `psiA = -theta_A` the spec's
//! `s_A = rAb (alpha_w - phiA)` (forward) and `s_A = rAb (alpha_w + phiA)` (backward) become
//! `s_A = sigma + dir * rAb * theta_A` with dir = +1 forward, -1 backward. A window jump by m_c
//! pairs changes sigma by -/+ m_c p_b. All pairs on one flank share the penetration (the base
//! pitches match), so an object needs no state beyond sigma; s_B = L + delta - s_A.

use super::geometry::Geometry;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Flank {
    Forward = 0,
    Backward = 1,
}

impl Flank {
    pub fn dir(self) -> f64 {
        match self {
            Flank::Forward => 1.0,
            Flank::Backward => -1.0,
        }
    }
}

/// Slots of the four objects, in the order of the outputs F_f1, F_f2, F_b1, F_b2.
pub const SLOTS: usize = 4;
pub const SLOT_NAMES: [&str; SLOTS] = ["f1", "f2", "b1", "b2"];

pub fn slot_flank(k: usize) -> Flank {
    if k < 2 {
        Flank::Forward
    } else {
        Flank::Backward
    }
}

/// The event functions, numbered for the driver: three per object slot, two per flank.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EventFn {
    /// s_b - s_A: leaving the window (and the gate) through the tip of A; jump down.
    Top(usize),
    /// s_A - s_low: leaving the window at its lower end; jump up.
    Bottom(usize),
    /// s_A - max(delta, 0) - s_a: the gate's lower edge (tip of B).
    Gate(usize),
    /// delta of the flank: contact onset and separation.
    Pen(Flank),
    /// 1 + chi d(delta)/dt of the flank: a damped contact releasing while delta > 0.
    Rel(Flank),
    /// With shape deviations, pairs have their own penetration delta_i and these replace Pen
    /// and Rel: delta_i of the gated pair k (onset and separation)...
    PairPen(usize),
    /// ... and 1 + chi d(delta_i)/dt (release).
    PairRel(usize),
    /// With tip relief: pair k's s_A past the start of A's relief (towards s_b) ...
    ReliefA(usize),
    /// ... and before the start of B's relief (towards s_a).
    ReliefB(usize),
}

/// Every event function by index.
const EVENTS: [EventFn; N_EVENTS] = {
    let mut t = [EventFn::Top(0); N_EVENTS];
    let mut i = 0;
    while i < N_EVENTS {
        t[i] = EventFn::decode(i);
        i += 1;
    }
    t
};

/// The event functions without shape deviations; the per-pair ones (four per slot) follow.
pub const BASE_EVENTS: usize = 3 * SLOTS + 4;
pub const N_EVENTS: usize = BASE_EVENTS + 4 * SLOTS;

impl EventFn {
    pub fn index(self) -> usize {
        match self {
            EventFn::Top(k) => 3 * k,
            EventFn::Bottom(k) => 3 * k + 1,
            EventFn::Gate(k) => 3 * k + 2,
            EventFn::Pen(f) => 3 * SLOTS + 2 * f as usize,
            EventFn::Rel(f) => 3 * SLOTS + 2 * f as usize + 1,
            EventFn::PairPen(k) => BASE_EVENTS + 4 * k,
            EventFn::PairRel(k) => BASE_EVENTS + 4 * k + 1,
            EventFn::ReliefA(k) => BASE_EVENTS + 4 * k + 2,
            EventFn::ReliefB(k) => BASE_EVENTS + 4 * k + 3,
        }
    }

    /// A short name: `top_f1`, `pen_forward`, `relief_A_b2`... (the FMI 3.0 event indicator
    /// of this function is `z_` and the name).
    pub fn name(self) -> String {
        let flank = |f: Flank| match f {
            Flank::Forward => "forward",
            Flank::Backward => "backward",
        };
        match self {
            EventFn::Top(k) => format!("top_{}", SLOT_NAMES[k]),
            EventFn::Bottom(k) => format!("bottom_{}", SLOT_NAMES[k]),
            EventFn::Gate(k) => format!("gate_{}", SLOT_NAMES[k]),
            EventFn::Pen(f) => format!("pen_{}", flank(f)),
            EventFn::Rel(f) => format!("rel_{}", flank(f)),
            EventFn::PairPen(k) => format!("pair_pen_{}", SLOT_NAMES[k]),
            EventFn::PairRel(k) => format!("pair_rel_{}", SLOT_NAMES[k]),
            EventFn::ReliefA(k) => format!("relief_A_{}", SLOT_NAMES[k]),
            EventFn::ReliefB(k) => format!("relief_B_{}", SLOT_NAMES[k]),
        }
    }

    /// The event function of index i, from a table built at compile time (the margin loops
    /// run through every event at every step).
    #[inline(always)]
    pub fn from_index(i: usize) -> EventFn {
        EVENTS[i]
    }

    const fn decode(i: usize) -> EventFn {
        const fn flank(j: usize) -> Flank {
            if j == 0 {
                Flank::Forward
            } else {
                Flank::Backward
            }
        }
        match i {
            i if i < 3 * SLOTS => match i % 3 {
                0 => EventFn::Top(i / 3),
                1 => EventFn::Bottom(i / 3),
                _ => EventFn::Gate(i / 3),
            },
            i if i >= BASE_EVENTS => {
                let k = (i - BASE_EVENTS) / 4;
                match (i - BASE_EVENTS) % 4 {
                    0 => EventFn::PairPen(k),
                    1 => EventFn::PairRel(k),
                    2 => EventFn::ReliefA(k),
                    _ => EventFn::ReliefB(k),
                }
            }
            i if (i - 3 * SLOTS).is_multiple_of(2) => EventFn::Pen(flank((i - 3 * SLOTS) / 2)),
            i => EventFn::Rel(flank((i - 3 * SLOTS) / 2)),
        }
    }
}

/// Initial sigma of each slot at theta_A = 0 (spec §3: f1 touches at a, f2 one pitch ahead,
/// b1 on the teeth of f2 (A) and f1 (B), b2 its neighbour inside the window).
pub fn initial_sigmas(g: &Geometry) -> [f64; SLOTS] {
    let f1 = g.s_a;
    let f2 = f1 + g.p_b;
    let b1 = b1_sigma(g);
    // b2 = phiA(b1) - dA moves s_A down one pitch; the spec takes + dA if that leaves the window.
    let b2 = if b1 - g.p_b >= g.s_window_low() {
        b1 - g.p_b
    } else {
        b1 + g.p_b
    };
    [f1, f2, b1, b2]
}

/// b1's sigma: phiA = phiA(f2) + tA with phiA(f1) = alpha_w - s_a/rAb, so
/// s_A = rAb (alpha_w + phiA) = 2 rAb alpha_w - s_a - p_b + rAb tA.
fn b1_sigma(g: &Geometry) -> f64 {
    2.0 * g.r_ab * g.alpha_w - g.s_a - g.p_b + g.r_ab * g.t_a
}

/// The teeth of A and B (deviations.rs numbers them) that a slot with this sigma holds: f1 at
/// sigma = s_a holds A0/B0 and each pitch lower on the forward line one tooth more; b1 holds
/// A1/B0 and each pitch higher on the backward line one tooth less.
pub fn teeth(g: &Geometry, f: Flank, sigma: f64) -> (i64, i64) {
    match f {
        Flank::Forward => {
            let n = ((g.s_a - sigma) / g.p_b).round() as i64;
            (-n, -n)
        }
        Flank::Backward => {
            let n = ((sigma - b1_sigma(g)) / g.p_b).round() as i64;
            (1 - n, -n)
        }
    }
}

/// Moves sigma by whole jumps of m_c pitches until s_A lies in the window [s_low, s_b].
pub fn wrap_into_window(g: &Geometry, sigma: f64, dir: f64, theta_a: f64) -> f64 {
    let span = g.m_c as f64 * g.p_b;
    let s = sigma + dir * g.r_ab * theta_a;
    let shift = if s > g.s_b {
        -((s - g.s_b) / span).ceil()
    } else if s < g.s_window_low() {
        ((g.s_window_low() - s) / span).ceil()
    } else {
        0.0
    };
    sigma + shift * span
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::pair::Pair;

    #[test]
    fn event_numbering_round_trips() {
        for i in 0..N_EVENTS {
            assert_eq!(EventFn::from_index(i).index(), i);
        }
    }

    /// The spec's phi initial values (test-vectors.md) in s_A terms, and the backward flank's
    /// penetration -backlash when the forward one is 0 (the thickness closure of spec §2).
    #[test]
    fn initial_objects_match_the_spec() {
        let g = Geometry::new(&Pair::paper()).unwrap();
        let s = initial_sigmas(&g);
        let phi_a_f1 = 0.0507841740222036;
        assert!((g.r_ab * (g.alpha_w - phi_a_f1) - s[0]).abs() < 1e-15);
        let phi_b_f1 = 3.08268379996416;
        let s_b_f1 = g.r_bb * (g.alpha_w + std::f64::consts::PI - phi_b_f1);
        assert!(
            (s[0] + s_b_f1 - g.l).abs() < 1e-14,
            "f1 touches at a with zero penetration"
        );
        // b1 from the spec's phi formulas: phiA(b1) = phiA(f2) + tA, phiB(b1) = phiB(f1) + tB.
        let phi_a_b1 = phi_a_f1 - g.d_a + g.t_a;
        let phi_b_b1 = phi_b_f1 + g.t_b;
        let sa = g.r_ab * (g.alpha_w + phi_a_b1);
        let sb = g.r_bb * (g.alpha_w - std::f64::consts::PI + phi_b_b1);
        assert!((sa - s[2]).abs() < 1e-15);
        let backlash = Pair::paper().backlash;
        assert!(
            (sa + sb - g.l + backlash).abs() < 1e-14,
            "backward penetration is -backlash"
        );
        for k in 0..SLOTS {
            assert!(
                s[k] >= g.s_window_low() && s[k] <= g.s_b,
                "{} inside its window",
                SLOT_NAMES[k]
            );
        }
    }

    #[test]
    fn wrapping_moves_by_whole_jumps() {
        let g = Geometry::new(&Pair::paper()).unwrap();
        let span = g.m_c as f64 * g.p_b;
        for theta in [-3.0, -0.1, 0.0, 0.2, 7.5] {
            for dir in [1.0, -1.0] {
                let s = wrap_into_window(&g, g.s_a, dir, theta);
                let pos = s + dir * g.r_ab * theta;
                assert!(pos >= g.s_window_low() - 1e-15 && pos <= g.s_b + 1e-15);
                let jumps = (s - g.s_a) / span;
                assert!((jumps - jumps.round()).abs() < 1e-9);
            }
        }
    }
}
