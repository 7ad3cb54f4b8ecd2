//! The gear mesh as an ODE with modes (spec §4-§6): state, right-hand side, event functions,
//! event handling, outputs and the energy balance.
//!
//! State (interface frame, forward positive): theta_A, dte, w_A, v = d(dte)/dt, and two
//! quadratures, the external work and the dissipated energy. dte = rAb theta_A - rBb theta_B and
//! its rate v = rAb w_A - rBb w_B are states of their own rather than differences of two large
//! numbers, so the penetration and the mesh velocity keep full precision and are under error
//! control however fast and far the wheels turn; theta_B and w_B are derived from them.
//!
//! Modes (which pairs are gated, which flanks touch and press) change only in `handle_event`, at
//! events the driver has located: inside an integration step the right-hand side is smooth.

use super::contact::{self, slot_flank, EventFn, Flank, N_EVENTS, SLOTS, SLOT_NAMES};
use super::geometry::Geometry;
use super::johnson::{self, OutOfRange};
use super::ModelError;
use crate::variables::{Calculated, Inputs, Outputs, Params};

pub const NY: usize = 6;
pub type State = [f64; NY];
pub const THETA_A: usize = 0;
pub const DTE: usize = 1;
pub const W_A: usize = 2;
/// The mesh's relative velocity d(dte)/dt = rAb w_A - rBb w_B.
pub const DDTE: usize = 3;
pub const W_EXT: usize = 4;
pub const W_LOSS: usize = 5;
/// Components under error control; the two quadratures do not feed back into the dynamics.
pub const N_CONTROLLED: usize = 4;

/// A contact left the model's range: reported with the contact, the penetration and the limit.
#[derive(Clone, Debug, PartialEq)]
pub struct LawOutOfRange {
    pub contact: String,
    pub delta: f64,
    pub limit: f64,
    pub limit_name: &'static str,
}

/// The Johnson law's own range (spec §4).
pub const JOHNSON_LIMIT: &str = "the Johnson law's limit 4(rho_A+rho_B)/e^2";
/// Beyond the segment length no pair can be gated (s_A - delta >= s_a and s_A <= s_b): the teeth
/// would pass through each other and the mesh would carry nothing.
pub const SEGMENT_LIMIT: &str =
    "the contact segment length |ab|, beyond which the teeth would pass through each other";

impl std::fmt::Display for LawOutOfRange {
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        write!(
            f,
            "contact {} out of the model's range: penetration {} m reaches {} = {} m",
            self.contact, self.delta, self.limit_name, self.limit
        )
    }
}

/// The tunable parameters and the inputs: what a master may change between steps.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Loads {
    pub tau_a: f64,
    pub tau_b: f64,
    pub c_load: f64,
    pub chi: f64,
    pub mu: f64,
    pub v_reg: f64,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Mesh {
    pub geo: Geometry,
    pub loads: Loads,
    width: f64,
    j_a: f64,
    j_b: f64,
    backlash: f64,
    present: [bool; SLOTS],
    /// s_A = sigma + dir rAb theta_A for each slot.
    pub sigma: [f64; SLOTS],
    /// Recorded sign of every event function (true: positive side). Gate signs are the gating
    /// modes; Pen and Rel signs make a flank carry force. Top and Bottom are always positive
    /// between events.
    pub sign: [bool; N_EVENTS],
    /// Energy brought in (or out) by mode changes at events, for the energy balance.
    pub e_gate: f64,
    pub n_events: u64,
    pub(crate) e_start: f64,
}

/// What happened at an event, for the log.
#[derive(Clone, Debug)]
pub struct EventReport {
    pub what: String,
}

impl Mesh {
    /// Builds the mesh and its initial state from the parameters (spec §3 initial values).
    pub fn new(p: &Params, inputs: &Inputs) -> Result<(Mesh, State), ModelError> {
        let geo = Geometry::new(p)?;
        let theta_a = p.dte_start / geo.r_ab;
        let (geo_r_ab, geo_r_bb) = (geo.r_ab, geo.r_bb);
        let mut present = [false; SLOTS];
        present[0] = true;
        present[1] = geo.m_c >= 2;
        present[2] = p.backward_contacts;
        present[3] = p.backward_contacts && geo.m_c >= 2;
        let init = contact::initial_sigmas(&geo);
        let mut sigma = [0.0; SLOTS];
        for k in 0..SLOTS {
            if present[k] {
                sigma[k] = contact::wrap_into_window(&geo, init[k], slot_flank(k).dir(), theta_a);
            }
        }
        let mut mesh = Mesh {
            width: p.width,
            j_a: p.J_A,
            j_b: p.J_B,
            backlash: p.backlash,
            loads: Loads {
                tau_a: inputs.tau_A,
                tau_b: inputs.tau_B,
                c_load: p.c_load,
                chi: p.chi,
                mu: p.mu,
                v_reg: p.v_reg,
            },
            geo,
            present,
            sigma,
            sign: [true; N_EVENTS],
            e_gate: 0.0,
            n_events: 0,
            e_start: 0.0,
        };
        let v = geo_r_ab * p.w_A_start - geo_r_bb * p.w_B_start;
        let y = [theta_a, p.dte_start, p.w_A_start, v, 0.0, 0.0];
        mesh.init_signs(&y);
        mesh.check_range(&y)
            .map_err(|e| ModelError::new(format!("initial state: {e}")))?;
        mesh.e_start = mesh
            .energy_terms(&y)
            .map_err(|e| ModelError::new(e.to_string()))?
            .0;
        Ok((mesh, y))
    }

    pub fn present(&self, k: usize) -> bool {
        self.present[k]
    }

    fn flank_present(&self, f: Flank) -> bool {
        match f {
            Flank::Forward => true,
            Flank::Backward => self.present[2],
        }
    }

    fn damped(&self) -> bool {
        self.loads.chi > 0.0
    }

    /// Penetration of a flank and its rate: forward delta = dte, backward delta = -backlash - dte.
    pub fn flank_delta(&self, f: Flank, y: &State) -> (f64, f64) {
        let ddte = y[DDTE];
        match f {
            Flank::Forward => (y[DTE], ddte),
            Flank::Backward => (-self.backlash - y[DTE], -ddte),
        }
    }

    /// Speed of wheel B, from w_A and the mesh velocity.
    pub fn w_b(&self, y: &State) -> f64 {
        (self.geo.r_ab * y[W_A] - y[DDTE]) / self.geo.r_bb
    }

    pub fn s_contact(&self, k: usize, y: &State) -> f64 {
        self.sigma[k] + slot_flank(k).dir() * self.geo.r_ab * y[THETA_A]
    }

    /// A flank carries force: touching and, when damped, pressing (Hunt-Crossley force > 0).
    pub fn flank_on(&self, f: Flank) -> bool {
        self.sign[EventFn::Pen(f).index()] && (!self.damped() || self.sign[EventFn::Rel(f).index()])
    }

    pub fn carrying(&self, k: usize) -> bool {
        self.present[k] && self.sign[EventFn::Gate(k).index()] && self.flank_on(slot_flank(k))
    }

    /// Normal force of one pair on a carrying flank: width N(delta)(1 + chi d(delta)/dt).
    fn pair_force(&self, delta: f64, ddelta: f64) -> Result<(f64, f64), OutOfRange> {
        let n = johnson::force(delta, self.geo.l + delta, self.geo.e_star)?;
        Ok((n, self.width * n * (1.0 + self.loads.chi * ddelta)))
    }

    /// Right-hand side with the current modes. Errors only when the Johnson law leaves its range.
    pub fn rhs(&self, y: &State, dy: &mut State) -> Result<(), LawOutOfRange> {
        let g = &self.geo;
        let (w_a, w_b) = (y[W_A], self.w_b(y));
        let (mut tq_a, mut tq_b, mut p_loss) = (0.0, 0.0, 0.0);
        for f in [Flank::Forward, Flank::Backward] {
            if !self.flank_present(f) || !self.flank_on(f) {
                continue;
            }
            let slots = if f == Flank::Forward { 0..2 } else { 2..4 };
            let gated = slots.filter(|&k| self.present[k] && self.sign[EventFn::Gate(k).index()]);
            let mut pairs = gated.peekable();
            if pairs.peek().is_none() {
                continue;
            }
            let (delta, ddelta) = self.flank_delta(f, y);
            let (n, fn_) = self
                .pair_force(delta, ddelta)
                .map_err(|e| self.out_of_range(f, e))?;
            let dir = f.dir();
            for k in pairs {
                // Normal force: the spec's paper-frame torques, turned into the interface frame.
                tq_a -= dir * fn_ * g.r_ab;
                tq_b += dir * fn_ * g.r_bb;
                if self.loads.chi > 0.0 {
                    p_loss += self.width * n * self.loads.chi * ddelta * ddelta;
                }
                if self.loads.mu > 0.0 {
                    let s_a = self.s_contact(k, y);
                    let s_b = g.l + delta - s_a;
                    let v_s = -w_a * s_a + w_b * s_b;
                    let ft = self.loads.mu * (v_s / self.loads.v_reg).tanh() * fn_;
                    tq_a += ft * s_a;
                    tq_b -= ft * s_b;
                    p_loss += ft * v_s;
                }
            }
        }
        let l = &self.loads;
        dy[THETA_A] = w_a;
        dy[DTE] = g.r_ab * w_a - g.r_bb * w_b;
        dy[W_A] = (l.tau_a + tq_a) / self.j_a;
        let acc_b = (l.tau_b - l.c_load * w_b + tq_b) / self.j_b;
        dy[DDTE] = g.r_ab * dy[W_A] - g.r_bb * acc_b;
        dy[W_EXT] = l.tau_a * w_a + l.tau_b * w_b - l.c_load * w_b * w_b;
        dy[W_LOSS] = p_loss;
        Ok(())
    }

    fn out_of_range(&self, f: Flank, e: OutOfRange) -> LawOutOfRange {
        let names: Vec<&str> = (0..SLOTS)
            .filter(|&k| slot_flank(k) == f && self.carrying(k))
            .map(|k| SLOT_NAMES[k])
            .collect();
        LawOutOfRange {
            contact: names.join("+"),
            delta: e.delta,
            limit: e.limit,
            limit_name: JOHNSON_LIMIT,
        }
    }

    /// The penetration of each flank must stay below the segment length (see SEGMENT_LIMIT);
    /// the Johnson range itself is checked by every right-hand-side evaluation.
    pub fn check_state(&self, y: &State) -> Result<(), LawOutOfRange> {
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

    /// Checks both limits at a state (the initial one).
    pub fn check_range(&self, y: &State) -> Result<(), LawOutOfRange> {
        let mut dy = [0.0; NY];
        self.rhs(y, &mut dy)?;
        self.check_state(y)
    }

    fn event_active(&self, e: EventFn) -> bool {
        match e {
            EventFn::Top(k) | EventFn::Bottom(k) | EventFn::Gate(k) => self.present[k],
            EventFn::Pen(f) => self.flank_present(f),
            // A release matters only while the flank touches; its sign is set afresh at onset.
            EventFn::Rel(f) => {
                self.flank_present(f) && self.damped() && self.sign[EventFn::Pen(f).index()]
            }
        }
    }

    /// Value of one event function.
    pub fn event_value(&self, e: EventFn, y: &State) -> f64 {
        match e {
            EventFn::Top(k) => self.geo.s_b - self.s_contact(k, y),
            EventFn::Bottom(k) => self.s_contact(k, y) - self.geo.s_window_low(),
            EventFn::Gate(k) => {
                let (delta, _) = self.flank_delta(slot_flank(k), y);
                self.s_contact(k, y) - delta.max(0.0) - self.geo.s_a
            }
            EventFn::Pen(f) => self.flank_delta(f, y).0,
            EventFn::Rel(f) => 1.0 + self.loads.chi * self.flank_delta(f, y).1,
        }
    }

    /// All event functions, as signed distances to a crossing: positive while the recorded sign
    /// holds, negative once the function has crossed. Inactive ones read +1.
    pub fn event_margins(&self, y: &State, out: &mut [f64; N_EVENTS]) {
        for (i, m) in out.iter_mut().enumerate() {
            let e = EventFn::from_index(i);
            *m = if self.event_active(e) {
                self.margin(e, y)
            } else {
                1.0
            };
        }
    }

    pub fn margin(&self, e: EventFn, y: &State) -> f64 {
        let v = self.event_value(e, y);
        if self.sign[e.index()] {
            v
        } else {
            -v
        }
    }

    /// Sets a recorded sign from the value, or, when the value is within rounding of zero,
    /// from the direction the function is moving in.
    fn set_sign(&mut self, e: EventFn, y: &State) {
        let v = self.event_value(e, y);
        let scale = match e {
            EventFn::Pen(_) => 1e-7,
            EventFn::Rel(_) => 1.0,
            _ => self.geo.p_b,
        };
        let positive = if v.abs() > 1e-9 * scale {
            v > 0.0
        } else {
            let (delta, ddelta) = match e {
                EventFn::Top(k) | EventFn::Bottom(k) | EventFn::Gate(k) => {
                    self.flank_delta(slot_flank(k), y)
                }
                EventFn::Pen(f) | EventFn::Rel(f) => self.flank_delta(f, y),
            };
            let ds = |k: usize| slot_flank(k).dir() * self.geo.r_ab * y[W_A];
            let rate = match e {
                EventFn::Top(k) => -ds(k),
                EventFn::Bottom(k) => ds(k),
                EventFn::Gate(k) => ds(k) - if delta > 0.0 { ddelta } else { 0.0 },
                EventFn::Pen(_) => ddelta,
                EventFn::Rel(_) => 0.0,
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

    fn init_signs(&mut self, y: &State) {
        for i in 0..N_EVENTS {
            let e = EventFn::from_index(i);
            match e {
                EventFn::Top(_) | EventFn::Bottom(_) => self.sign[i] = true,
                _ => self.set_sign(e, y),
            }
        }
    }

    /// Applies the event whose function crossed at the state y, and returns what happened.
    pub fn handle_event(&mut self, i: usize, y: &State) -> Result<EventReport, LawOutOfRange> {
        let before = self.elastic_energy(y)?;
        let e = EventFn::from_index(i);
        let span = self.geo.m_c as f64 * self.geo.p_b;
        let what = match e {
            EventFn::Top(k) | EventFn::Bottom(k) => {
                let down = matches!(e, EventFn::Top(_));
                self.sigma[k] += if down { -span } else { span };
                self.set_sign(EventFn::Gate(k), y);
                format!(
                    "{} jumps {} pairs {} (s_A now {:.9} m)",
                    SLOT_NAMES[k],
                    self.geo.m_c,
                    if down { "back" } else { "ahead" },
                    self.s_contact(k, y)
                )
            }
            EventFn::Gate(k) => {
                self.sign[i] = !self.sign[i];
                let into = self.sign[i];
                format!(
                    "{} {} the contact segment",
                    SLOT_NAMES[k],
                    if into { "enters" } else { "leaves" }
                )
            }
            EventFn::Pen(f) => {
                self.sign[i] = !self.sign[i];
                if self.sign[i] && self.damped() {
                    self.set_sign(EventFn::Rel(f), y);
                }
                format!(
                    "{:?} flank {}",
                    f,
                    if self.sign[i] { "touches" } else { "separates" }
                )
            }
            EventFn::Rel(f) => {
                self.sign[i] = !self.sign[i];
                format!(
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
        self.n_events += 1;
        self.e_gate += self.elastic_energy(y)? - before;
        Ok(EventReport { what })
    }

    /// A master changed inputs or tunable parameters: the right-hand side changes from here on.
    pub fn set_loads(&mut self, loads: Loads, y: &State) {
        let was_damped = self.damped();
        self.loads = loads;
        if self.damped() && !was_damped {
            for f in [Flank::Forward, Flank::Backward] {
                self.set_sign(EventFn::Rel(f), y);
            }
        }
    }

    /// Highest natural frequency of the wheels on the carrying contacts [rad/s]: tangent mesh
    /// stiffness times the reduced inverse inertia (rAb^2/J_A + rBb^2/J_B); 0 without contact.
    pub fn vibration_frequency(&self, y: &State) -> f64 {
        let mut k = 0.0;
        for f in [Flank::Forward, Flank::Backward] {
            let pairs = (0..SLOTS)
                .filter(|&k| slot_flank(k) == f && self.carrying(k))
                .count();
            if pairs > 0 {
                let (delta, _) = self.flank_delta(f, y);
                let stiffness =
                    johnson::stiffness(delta, self.geo.l + delta, self.geo.e_star).unwrap_or(0.0);
                k += pairs as f64 * self.width * stiffness;
            }
        }
        let g = &self.geo;
        (k * (g.r_ab * g.r_ab / self.j_a + g.r_bb * g.r_bb / self.j_b)).sqrt()
    }

    /// Elastic energy of the carrying pairs.
    pub fn elastic_energy(&self, y: &State) -> Result<f64, LawOutOfRange> {
        let mut e = 0.0;
        for f in [Flank::Forward, Flank::Backward] {
            let pairs = (0..SLOTS)
                .filter(|&k| slot_flank(k) == f && self.carrying(k))
                .count();
            if pairs > 0 {
                let (delta, _) = self.flank_delta(f, y);
                let u = johnson::energy(delta, self.geo.l + delta, self.geo.e_star)
                    .map_err(|err| self.out_of_range(f, err))?;
                e += pairs as f64 * self.width * u;
            }
        }
        Ok(e)
    }

    /// (E_kin + E_el + W_loss - W_ext - E_gate, E_kin, E_el).
    fn energy_terms(&self, y: &State) -> Result<(f64, f64, f64), LawOutOfRange> {
        let w_b = self.w_b(y);
        let e_kin = 0.5 * (self.j_a * y[W_A] * y[W_A] + self.j_b * w_b * w_b);
        let e_el = self.elastic_energy(y)?;
        Ok((
            e_kin + e_el + y[W_LOSS] - y[W_EXT] - self.e_gate,
            e_kin,
            e_el,
        ))
    }

    pub fn outputs(&self, y: &State) -> Result<Outputs, LawOutOfRange> {
        let g = &self.geo;
        let mut force = [0.0; SLOTS];
        let mut s = [0.0; SLOTS];
        let (mut f_flank, mut n_flank) = ([0.0; 2], [0; 2]);
        for k in 0..SLOTS {
            if !self.present[k] {
                continue;
            }
            s[k] = self.s_contact(k, y);
            if self.carrying(k) {
                let f = slot_flank(k);
                let (delta, ddelta) = self.flank_delta(f, y);
                force[k] = self
                    .pair_force(delta, ddelta)
                    .map_err(|e| self.out_of_range(f, e))?
                    .1;
                f_flank[f as usize] += force[k];
                n_flank[f as usize] += 1;
            }
        }
        let mut dy = [0.0; NY];
        self.rhs(y, &mut dy)?;
        let l = &self.loads;
        let tau_mesh_a = dy[W_A] * self.j_a - l.tau_a;
        let acc_b = (g.r_ab * dy[W_A] - dy[DDTE]) / g.r_bb;
        let tau_mesh_b = acc_b * self.j_b - l.tau_b + l.c_load * self.w_b(y);
        let (balance, e_kin, e_el) = self.energy_terms(y)?;
        Ok(Outputs {
            theta_A: y[THETA_A],
            theta_B: (g.r_ab * y[THETA_A] - y[DTE]) / g.r_bb,
            w_A: y[W_A],
            w_B: self.w_b(y),
            dte: y[DTE],
            F_f1: force[0],
            F_f2: force[1],
            F_b1: force[2],
            F_b2: force[3],
            F_fwd: f_flank[0],
            F_bwd: f_flank[1],
            n_fwd: n_flank[0],
            n_bwd: n_flank[1],
            tau_mesh_A: tau_mesh_a,
            tau_mesh_B: tau_mesh_b,
            P_loss: dy[W_LOSS],
            s_f1: s[0],
            s_f2: s[1],
            s_b1: s[2],
            s_b2: s[3],
            E_kin: e_kin,
            E_el: e_el,
            W_ext: y[W_EXT],
            W_loss: y[W_LOSS],
            E_gate: self.e_gate,
            energy_residual: balance - self.e_start,
            n_events: saturate(self.n_events),
            // The driver's counters; the simulation fills them in.
            n_steps: 0,
            n_rejected_steps: 0,
            n_rhs_evaluations: 0,
            n_jacobians: 0,
            n_factorizations: 0,
        })
    }

    pub fn calculated(&self) -> Calculated {
        let g = &self.geo;
        Calculated {
            alpha_w: g.alpha_w,
            rAb: g.r_ab,
            rBb: g.r_bb,
            line_of_action: g.l,
            s_a: g.s_a,
            s_b: g.s_b,
            contact_ratio: g.eps,
            r_tipA: g.r_tip_a,
            r_tipB: g.r_tip_b,
            base_pitch: g.p_b,
            contact_objects_per_flank: g.m_c as i32,
        }
    }

    /// Absolute error tolerances of the controlled components at a relative tolerance: 1 rad
    /// for the angle and 1 rad/s for w_A (relative control takes over above). The penetration's
    /// scale is the static penetration of one pair under the contact force that the current
    /// torques imply (floor 1e-12 m), so dte stays under control from milli-newton to mega-newton
    /// loads; the mesh velocity's scale is that penetration times the mesh's natural frequency
    /// there, the velocity of a vibration of that amplitude.
    pub fn abs_tol(&self, rel_tol: f64) -> [f64; N_CONTROLLED] {
        let g = &self.geo;
        let force = self.loads.tau_a.abs() / g.r_ab + self.loads.tau_b.abs() / g.r_bb;
        let n = force / self.width;
        let delta = if n > 0.0 {
            // Eq. 5.1 at R = L: delta(N), monotone, no iteration needed for a scale.
            n / (std::f64::consts::PI * g.e_star)
                * ((4.0 * std::f64::consts::PI * g.e_star * g.l / n).ln() - 1.0)
        } else {
            0.0
        };
        let delta = if delta.is_finite() {
            delta.max(1e-12)
        } else {
            1e-12
        };
        let k = self.width * johnson::stiffness(delta, g.l + delta, g.e_star).unwrap_or(0.0);
        let omega = (k * (g.r_ab * g.r_ab / self.j_a + g.r_bb * g.r_bb / self.j_b)).sqrt();
        let velocity = (delta * omega).max(1e-12);
        [rel_tol, rel_tol * delta, rel_tol, rel_tol * velocity]
    }
}

/// A counter as an FMI Integer, saturating at 2^31 - 1.
pub fn saturate(n: u64) -> i32 {
    n.min(i32::MAX as u64) as i32
}

#[cfg(test)]
mod tests {
    use super::*;

    fn paper() -> (Params, Inputs) {
        let p = Params {
            c_load: 2.0,
            w_A_start: 100.0,
            w_B_start: 100.0 / 1.5,
            ..Params::default()
        };
        (
            p,
            Inputs {
                tau_A: 100.0,
                tau_B: 0.0,
            },
        )
    }

    #[test]
    fn initial_modes_of_the_paper_rig() {
        let (p, i) = paper();
        let (m, y) = Mesh::new(&p, &i).unwrap();
        // f1 at a (moving onto the segment) and f2 one pitch ahead are both gated. At dte = 0
        // with no relative speed the forward flank touches (the spec's closed interval) with
        // zero force; the backward flank is a backlash away.
        assert!(m.sign[EventFn::Gate(0).index()] && m.sign[EventFn::Gate(1).index()]);
        assert!(!m.sign[EventFn::Gate(2).index()] && m.sign[EventFn::Gate(3).index()]);
        assert!(m.flank_on(Flank::Forward) && !m.flank_on(Flank::Backward));
        let o = m.outputs(&y).unwrap();
        assert_eq!((o.F_fwd, o.n_fwd), (0.0, 2));
    }

    /// Spec §4: the power of the contact torques equals -F_n d(delta)/dt - F_t v_s, i.e. the
    /// mesh power equals -dE_el/dt - P_loss, on both flanks, with friction and damping.
    #[test]
    fn mesh_power_balances_elastic_energy_and_losses() {
        for (dte, flank) in [(4e-7, Flank::Forward), (-1e-4 - 3e-7, Flank::Backward)] {
            let p = Params {
                chi: 5.0,
                mu: 0.3,
                dte_start: dte,
                w_A_start: 50.0,
                w_B_start: 33.0,
                ..Params::default()
            };
            let (m, y) = Mesh::new(&p, &Inputs::default()).unwrap();
            assert!(m.flank_on(flank));
            let mut dy = [0.0; NY];
            m.rhs(&y, &mut dy).unwrap();
            let acc_b = (m.geo.r_ab * dy[W_A] - dy[DDTE]) / m.geo.r_bb;
            let p_mesh = (dy[W_A] * p.J_A) * y[W_A] + (acc_b * p.J_B) * m.w_b(&y);
            let h = 1e-9;
            let mut y2 = y;
            for c in 0..NY {
                y2[c] += h * dy[c];
            }
            let de_el = (m.elastic_energy(&y2).unwrap() - m.elastic_energy(&y).unwrap()) / h;
            let residual = p_mesh + de_el + dy[W_LOSS];
            // Forward difference of E_el over h: relative error ~ h * d2E/dt2 / dE/dt ~ 1e-5.
            assert!(
                residual.abs() <= 1e-4 * p_mesh.abs(),
                "{flank:?}: {residual} vs {p_mesh}"
            );
        }
    }

    #[test]
    fn friction_off_costs_nothing_and_changes_nothing_when_mu_is_zero() {
        let p = Params {
            dte_start: 3e-7,
            w_A_start: 80.0,
            w_B_start: 50.0,
            ..Params::default()
        };
        let (m, y) = Mesh::new(&p, &Inputs::default()).unwrap();
        let o = m.outputs(&y).unwrap();
        assert_eq!(o.P_loss, 0.0);
        // Without friction the torques are the normal force times the base radii exactly.
        assert!((o.tau_mesh_A + o.F_fwd * m.geo.r_ab).abs() <= 1e-12 * o.F_fwd);
        assert!((o.tau_mesh_B - o.F_fwd * m.geo.r_bb).abs() <= 1e-12 * o.F_fwd);
    }

    #[test]
    fn backward_contacts_can_be_left_out() {
        let p = Params {
            backward_contacts: false,
            ..Params::default()
        };
        let (m, _) = Mesh::new(&p, &Inputs::default()).unwrap();
        assert!(m.present(0) && m.present(1) && !m.present(2) && !m.present(3));
        let p = Params {
            zA: 20,
            zB: 30,
            ..Params::default()
        };
        let (m, _) = Mesh::new(&p, &Inputs::default()).unwrap();
        assert_eq!(m.geo.m_c, 1);
        assert!(m.present(0) && !m.present(1) && m.present(2) && !m.present(3));
    }
}
