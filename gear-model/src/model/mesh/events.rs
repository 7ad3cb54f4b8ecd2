//! The mesh's event functions (spec §6): their values, signed margins and rates for the
//! driver, the recorded signs that are the modes, and what happens when one crosses.

use super::forces::{LawOutOfRange, SEGMENT_LIMIT};
use super::{describe, GearMesh, Kin, THETA_A, W_A};
use crate::model::contact::{self, slot_flank, EventFn, Flank, N_EVENTS, SLOTS, SLOT_NAMES};

/// What happened at an event, for the log.
#[derive(Clone, Debug)]
pub struct EventReport {
    pub what: String,
    /// The event left the right-hand side as it was (only bookkeeping changed): the
    /// integrator's step stays valid and continues past it without a restart.
    pub smooth: bool,
}

impl GearMesh {
    /// The penetration of each flank must stay below the segment length (see SEGMENT_LIMIT);
    /// the law's own range is checked by every force evaluation.
    pub fn check_state(&self, y: &Kin) -> Result<(), LawOutOfRange> {
        let ab = self.geo.s_b - self.geo.s_a;
        for f in [Flank::Forward, Flank::Backward] {
            let delta = self.flank_delta(f, y).0;
            if self.flank_present(f) && !(delta < ab) {
                let contact = if f == Flank::Forward {
                    "forward flank"
                } else {
                    "backward flank"
                };
                return Err(LawOutOfRange {
                    contact: contact.into(),
                    delta,
                    limit: ab,
                    limit_name: SEGMENT_LIMIT,
                });
            }
        }
        Ok(())
    }

    /// The event functions in use, a prefix of all: the per-pair ones only with shape
    /// deviations. Without, the margin loops are as short as before them (with all 32 the base
    /// scenes cost 16 % more instructions: callgrind, high-speed).
    #[inline]
    pub fn n_event_fns(&self) -> usize {
        if self.dev.is_some() {
            N_EVENTS
        } else {
            contact::BASE_EVENTS
        }
    }

    #[inline(always)]
    pub(crate) fn event_active(&self, e: EventFn) -> bool {
        if self.rigid() {
            return self.rigid_event_active(e);
        }
        match e {
            EventFn::Top(k) | EventFn::Bottom(k) | EventFn::Gate(k) => {
                self.present[k] && !self.pairs_untracked()
            }
            EventFn::Pen(f) => self.dev.is_none() && self.flank_present(f),
            // A release matters only while the flank touches; its sign is set afresh at onset.
            EventFn::Rel(f) => {
                self.dev.is_none()
                    && self.flank_present(f)
                    && self.damped()
                    && self.sign[EventFn::Pen(f).index()]
            }
            _ => self.pair_event_active(e),
        }
    }

    /// The per-pair events (shape deviations), kept out of the common path's code. A pair's
    /// own modes matter only while it is gated; they are set afresh when it enters the gate.
    #[inline(never)]
    fn pair_event_active(&self, e: EventFn) -> bool {
        match e {
            EventFn::PairPen(k) => self.dev.is_some() && self.gated(k),
            EventFn::PairRel(k) => {
                self.dev.is_some()
                    && self.damped()
                    && self.gated(k)
                    && self.sign[EventFn::PairPen(k).index()]
            }
            EventFn::ReliefA(k) => self.has_relief(0) && self.gated(k),
            EventFn::ReliefB(k) => self.has_relief(1) && self.gated(k),
            _ => unreachable!("flank and object events are not per pair"),
        }
    }

    fn has_relief(&self, wheel: usize) -> bool {
        self.dev
            .as_deref()
            .is_some_and(|d| d.relief[wheel].is_some())
    }

    /// Where wheel w's tip relief starts on the line of action (+inf without one).
    fn relief_start(&self, wheel: usize) -> f64 {
        self.dev
            .as_deref()
            .and_then(|d| d.relief[wheel])
            .map_or(f64::INFINITY, |r| r.start)
    }

    /// Rigid contact: an impact is watched for on a flank that is not locked (with two-sided
    /// contact neither is once one is), the constraint force on the locked one; a parked flank's
    /// objects are not tracked.
    fn rigid_event_active(&self, e: EventFn) -> bool {
        match e {
            EventFn::Top(k) | EventFn::Bottom(k) | EventFn::Gate(k) => {
                self.present[k] && !self.parked(slot_flank(k))
            }
            EventFn::Pen(f) => {
                self.flank_present(f)
                    && match self.locked() {
                        None => true,
                        Some(l) => l != f && !self.two_sided(),
                    }
            }
            EventFn::Rel(f) => self.locked() == Some(f),
            // Shape deviations need a compliant law (GearMesh::new).
            _ => false,
        }
    }

    /// Value of one event function. A rigid mesh's release function is the constraint force,
    /// which only its rig can compute: NaN here.
    pub fn event_value(&self, e: EventFn, y: &Kin) -> f64 {
        self.value_given(e, y, |f| self.flank_delta(f, y))
    }

    /// An event function's value, with the flanks' penetrations and rates from `delta`.
    fn value_given(&self, e: EventFn, y: &Kin, delta: impl Fn(Flank) -> (f64, f64)) -> f64 {
        match e {
            EventFn::Top(k) => self.geo.s_b - self.s_contact(k, y),
            EventFn::Bottom(k) => self.s_contact(k, y) - self.geo.s_window_low(),
            EventFn::Gate(k) => {
                self.s_contact(k, y)
                    - self.gate_shift * delta(slot_flank(k)).0.max(0.0)
                    - self.geo.s_a
            }
            EventFn::Pen(f) => delta(f).0,
            EventFn::Rel(_) if self.rigid() => f64::NAN,
            EventFn::Rel(f) => 1.0 + self.coef.chi * delta(f).1,
            EventFn::PairPen(k)
            | EventFn::PairRel(k)
            | EventFn::ReliefA(k)
            | EventFn::ReliefB(k) => self.pair_value(e, y, delta(slot_flank(k))),
        }
    }

    /// A per-pair event function's value, given its flank's penetration and rate.
    #[inline(never)]
    fn pair_value(&self, e: EventFn, y: &Kin, flank: (f64, f64)) -> f64 {
        match e {
            EventFn::PairPen(k) => self.pair_delta(k, y, flank).0,
            EventFn::PairRel(k) => 1.0 + self.coef.chi * self.pair_delta(k, y, flank).1,
            EventFn::ReliefA(k) => self.s_contact(k, y) - self.relief_start(0),
            EventFn::ReliefB(k) => self.relief_start(1) - self.s_contact(k, y),
            _ => unreachable!("flank and object events are not per pair"),
        }
    }

    /// A per-pair event function's rate at y with rate dy.
    #[inline(never)]
    fn pair_rate(&self, e: EventFn, y: &Kin, dy: &Kin, flank: (f64, f64)) -> f64 {
        let travel = self.geo.r_ab * dy[THETA_A];
        match e {
            EventFn::PairPen(k) => self.pair_delta(k, y, flank).1,
            EventFn::PairRel(k) => {
                let f = slot_flank(k);
                let e = self.deviation(self.dev.as_deref().expect("active"), k, y, Some(dy));
                self.coef.chi * (self.flank_acceleration(f, dy) + e[2])
            }
            EventFn::ReliefA(k) => slot_flank(k).dir() * travel,
            EventFn::ReliefB(k) => -slot_flank(k).dir() * travel,
            _ => unreachable!("flank and object events are not per pair"),
        }
    }

    /// All event functions, as signed distances to a crossing: positive while the recorded sign
    /// holds, negative once the function has crossed. Inactive ones read +1. The flanks'
    /// penetrations, which most of them use, are computed once. (A rigid mesh's release
    /// margin is NaN here: its rig fills it in.) Writes the first `n_event_fns()` entries.
    pub fn event_margins(&self, y: &Kin, out: &mut [f64]) {
        let d = [
            self.flank_delta(Flank::Forward, y),
            self.flank_delta(Flank::Backward, y),
        ];
        if self.dev.is_none() && !self.rigid() {
            // The common case's slot-by-slot path; the rates it also writes are not wanted.
            let mut rates = [0.0; contact::BASE_EVENTS];
            return self.base_margins_and_rates(y, &[0.0; super::NK], d, 0.0, out, &mut rates);
        }
        let n = self.n_event_fns();
        for (i, m) in out[..n].iter_mut().enumerate() {
            let e = EventFn::from_index(i);
            *m = if self.event_active(e) {
                let v = self.value_given(e, y, |f| d[f as usize]);
                if self.sign[i] {
                    v
                } else {
                    -v
                }
            } else {
                1.0
            };
        }
    }

    /// All event margins (see `event_margins`) and their time derivatives at y with rate dy,
    /// signed as the margins: 0 for inactive ones, NaN where the model gives none (the rigid
    /// constraint force). The driver fits a cubic through each margin's values and rates at a
    /// step's ends to find interior minima that may cross zero within one step (a graze).
    pub fn event_margins_and_rates(
        &self,
        y: &Kin,
        dy: &Kin,
        margins: &mut [f64],
        rates: &mut [f64],
    ) {
        let d = [
            self.flank_delta(Flank::Forward, y),
            self.flank_delta(Flank::Backward, y),
        ];
        let travel = self.geo.r_ab * dy[THETA_A];
        if self.dev.is_none() && !self.rigid() {
            return self.base_margins_and_rates(y, dy, d, travel, margins, rates);
        }
        let n = self.n_event_fns();
        for i in 0..n {
            let e = EventFn::from_index(i);
            if !self.event_active(e) {
                (margins[i], rates[i]) = (1.0, 0.0);
                continue;
            }
            let value = self.value_given(e, y, |f| d[f as usize]);
            let rate = match e {
                EventFn::Top(k) => -slot_flank(k).dir() * travel,
                EventFn::Bottom(k) => slot_flank(k).dir() * travel,
                EventFn::Gate(k) => {
                    let f = slot_flank(k);
                    let (delta, rate) = d[f as usize];
                    f.dir() * travel - self.gate_shift * if delta > 0.0 { rate } else { 0.0 }
                }
                EventFn::Pen(f) => d[f as usize].1,
                EventFn::Rel(_) if self.rigid() => f64::NAN,
                EventFn::Rel(f) => self.coef.chi * self.flank_acceleration(f, dy),
                EventFn::PairPen(k)
                | EventFn::PairRel(k)
                | EventFn::ReliefA(k)
                | EventFn::ReliefB(k) => self.pair_rate(e, y, dy, d[slot_flank(k) as usize]),
            };
            (margins[i], rates[i]) = if self.sign[i] {
                (value, rate)
            } else {
                (-value, -rate)
            };
        }
    }

    /// `event_margins_and_rates` of the compliant mesh without shape deviations, the common
    /// case, slot by slot: the same values and rates with the contact point computed once per
    /// slot and no dispatch per event (the driver evaluates these at every step).
    #[inline]
    fn base_margins_and_rates(
        &self,
        y: &Kin,
        dy: &Kin,
        d: [(f64, f64); 2],
        travel: f64,
        margins: &mut [f64],
        rates: &mut [f64],
    ) {
        let g = &self.geo;
        let low = g.s_window_low();
        // Fixed-size views: every index below is provably in range (no bounds checks).
        let margins: &mut [f64; contact::BASE_EVENTS] = (&mut margins[..contact::BASE_EVENTS])
            .try_into()
            .expect("BASE_EVENTS long");
        let rates: &mut [f64; contact::BASE_EVENTS] = (&mut rates[..contact::BASE_EVENTS])
            .try_into()
            .expect("BASE_EVENTS long");
        // An active function signed as its margin; an inactive one reads +1 with rate 0.
        let mut put = |i: usize, active: Option<(f64, f64)>| {
            (margins[i], rates[i]) = match active {
                Some((value, rate)) if self.sign[i] => (value, rate),
                Some((value, rate)) => (-value, -rate),
                None => (1.0, 0.0),
            };
        };
        let untracked = self.pairs_untracked();
        for k in 0..SLOTS {
            let i = EventFn::Top(k).index();
            if !self.present[k] || untracked {
                (i..i + 3).for_each(|j| put(j, None));
                continue;
            }
            let f = slot_flank(k);
            let (delta, rate) = d[f as usize];
            let s = self.s_contact(k, y);
            put(i, Some((g.s_b - s, -f.dir() * travel)));
            put(i + 1, Some((s - low, f.dir() * travel)));
            let shift = self.gate_shift;
            let gate_rate = f.dir() * travel - shift * if delta > 0.0 { rate } else { 0.0 };
            put(i + 2, Some((s - shift * delta.max(0.0) - g.s_a, gate_rate)));
        }
        for f in [Flank::Forward, Flank::Backward] {
            let (pen, rel) = (EventFn::Pen(f).index(), EventFn::Rel(f).index());
            let present = self.flank_present(f);
            let (delta, rate) = d[f as usize];
            put(pen, present.then_some((delta, rate)));
            let chi = self.coef.chi;
            let releasing = present && self.damped() && self.sign[pen];
            put(
                rel,
                releasing.then(|| {
                    let rel_rate = chi * self.flank_acceleration(f, dy);
                    (1.0 + chi * rate, rel_rate)
                }),
            );
        }
    }

    /// One event function's signed margin (NaN for a rigid mesh's release, see `event_value`).
    pub fn margin(&self, e: EventFn, y: &Kin) -> f64 {
        let v = self.event_value(e, y);
        if self.sign[e.index()] {
            v
        } else {
            -v
        }
    }

    /// The recorded signs at a start state (a rigid mesh starts free; its rig then decides
    /// about locks and impacts).
    pub fn init_signs(&mut self, y: &Kin) {
        for i in 0..N_EVENTS {
            let e = EventFn::from_index(i);
            match e {
                EventFn::Top(_) | EventFn::Bottom(_) => self.sign[i] = true,
                EventFn::Pen(_) | EventFn::Rel(_) if self.rigid() => {
                    self.sign[i] = !matches!(e, EventFn::Pen(_))
                }
                _ => self.set_sign(e, y),
            }
        }
        // A pair's penetration depends on its relief modes: those first.
        for k in 0..SLOTS {
            self.set_pair_modes(k, y);
        }
    }

    /// Sets a recorded sign from the value, or, when the value is within rounding of zero,
    /// from the direction the function is moving in.
    pub(crate) fn set_sign(&mut self, e: EventFn, y: &Kin) {
        let v = self.event_value(e, y);
        let scale = match e {
            EventFn::Pen(_) | EventFn::PairPen(_) => 1e-7,
            EventFn::Rel(_) | EventFn::PairRel(_) => 1.0,
            _ => self.geo.p_b,
        };
        let positive = if v.abs() > 1e-9 * scale {
            v > 0.0
        } else {
            let (delta, ddelta) = match e {
                EventFn::Pen(f) | EventFn::Rel(f) => self.flank_delta(f, y),
                EventFn::PairPen(k) => self.pair_delta(k, y, self.flank_delta(slot_flank(k), y)),
                EventFn::Top(k)
                | EventFn::Bottom(k)
                | EventFn::Gate(k)
                | EventFn::PairRel(k)
                | EventFn::ReliefA(k)
                | EventFn::ReliefB(k) => self.flank_delta(slot_flank(k), y),
            };
            let ds = |k: usize| slot_flank(k).dir() * self.geo.r_ab * y[W_A];
            let rate = match e {
                EventFn::Top(k) | EventFn::ReliefB(k) => -ds(k),
                EventFn::Bottom(k) | EventFn::ReliefA(k) => ds(k),
                EventFn::Gate(k) => {
                    ds(k) - self.gate_shift * if delta > 0.0 { ddelta } else { 0.0 }
                }
                EventFn::Pen(_) | EventFn::PairPen(_) => ddelta,
                EventFn::Rel(_) | EventFn::PairRel(_) => 0.0,
            };
            // At rest on the boundary: the spec's gate and window are closed intervals (>=).
            if rate != 0.0 {
                rate > 0.0
            } else {
                v >= 0.0
            }
        };
        self.sign[e.index()] = positive;
    }

    /// Applies an event of the contact objects (every event of a compliant mesh, and a rigid
    /// mesh's pair switches) at y and says what happened. A pair that carries no force before
    /// and after its jump (outside its contact segment or on the idle flank) leaves the forces
    /// as they were: `smooth`.
    pub fn handle_event(&mut self, i: usize, y: &Kin) -> EventReport {
        let e = EventFn::from_index(i);
        let idle_jump =
            |m: &GearMesh| matches!(e, EventFn::Top(k) | EventFn::Bottom(k) if !m.carrying(k));
        let idle_before = idle_jump(self);
        let span = self.geo.m_c as f64 * self.geo.p_b;
        let what = match e {
            EventFn::Top(k) | EventFn::Bottom(k) => {
                let down = matches!(e, EventFn::Top(_));
                self.sigma[k] += if down { -span } else { span };
                self.update_teeth(k);
                self.set_sign(EventFn::Gate(k), y);
                self.set_pair_modes(k, y);
                let teeth = match self.dev {
                    Some(_) => describe!(self, ", {}", self.teeth_text(k)),
                    None => String::new(),
                };
                describe!(
                    self,
                    "{} jumps {} pairs {} (s_A now {:.9} m{teeth})",
                    SLOT_NAMES[k],
                    self.geo.m_c,
                    if down { "back" } else { "ahead" },
                    self.s_contact(k, y)
                )
            }
            EventFn::Gate(k) => {
                self.sign[i] = !self.sign[i];
                let into = self.sign[i];
                if into {
                    self.set_pair_modes(k, y);
                }
                describe!(
                    self,
                    "{} {} the contact segment",
                    SLOT_NAMES[k],
                    if into { "enters" } else { "leaves" }
                )
            }
            EventFn::PairPen(k) => {
                self.sign[i] = !self.sign[i];
                if self.sign[i] && self.damped() {
                    self.set_sign(EventFn::PairRel(k), y);
                }
                describe!(
                    self,
                    "{} {} ({})",
                    SLOT_NAMES[k],
                    if self.sign[i] { "touches" } else { "separates" },
                    self.teeth_text(k)
                )
            }
            EventFn::PairRel(k) => {
                self.sign[i] = !self.sign[i];
                describe!(
                    self,
                    "{} {} (damped force reaches 0)",
                    SLOT_NAMES[k],
                    if self.sign[i] {
                        "presses again"
                    } else {
                        "releases"
                    }
                )
            }
            EventFn::ReliefA(k) | EventFn::ReliefB(k) => {
                self.sign[i] = !self.sign[i];
                describe!(
                    self,
                    "{} {} {}'s tip relief",
                    SLOT_NAMES[k],
                    if self.sign[i] { "enters" } else { "leaves" },
                    if matches!(e, EventFn::ReliefA(_)) {
                        "A"
                    } else {
                        "B"
                    }
                )
            }
            EventFn::Pen(f) => {
                self.sign[i] = !self.sign[i];
                if self.sign[i] && self.damped() {
                    self.set_sign(EventFn::Rel(f), y);
                }
                describe!(
                    self,
                    "{:?} flank {}",
                    f,
                    if self.sign[i] { "touches" } else { "separates" }
                )
            }
            EventFn::Rel(f) => {
                self.sign[i] = !self.sign[i];
                describe!(
                    self,
                    "{:?} flank {} (damped force reaches 0)",
                    f,
                    if self.sign[i] {
                        "presses again"
                    } else {
                        "releases"
                    }
                )
            }
        };
        let smooth = idle_before && idle_jump(self);
        EventReport { what, smooth }
    }

    /// A pair entering the gate (or jumping into it): its own modes from its state, as at t = 0.
    fn set_pair_modes(&mut self, k: usize, y: &Kin) {
        if self.dev.is_none() || !self.gated(k) {
            return;
        }
        for e in [
            EventFn::ReliefA(k),
            EventFn::ReliefB(k),
            EventFn::PairPen(k),
        ] {
            self.set_sign(e, y);
        }
        if self.damped() {
            self.set_sign(EventFn::PairRel(k), y);
        }
    }
}
