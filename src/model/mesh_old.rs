//! The gear mesh as an ODE with modes (spec §4-§6, rig-and-modes.md): state, right-hand side,
//! event functions, event handling, outputs and the energy balance.
//!
//! State (interface frame, forward positive): theta_A, dte, w_A, v = d(dte)/dt, two quadratures
//! (the external work and the dissipated energy), and with a slider its displacement x_S and
//! speed. dte = rAb theta_A - rBb theta_B and its rate v = rAb w_A - rBb w_B are states of their
//! own rather than differences of two large numbers, so the penetration and the mesh velocity
//! keep full precision and are under error control however fast and far the wheels turn;
//! theta_B and w_B are derived from them.
//!
//! Modes (which pairs are gated, which flanks touch and press, rigid locks) change only in
//! `handle_event`, at events the driver has located: inside an integration step the right-hand
//! side is smooth.

use super::contact::{self, slot_flank, EventFn, Flank, N_EVENTS, SLOTS, SLOT_NAMES};
use super::deviations::Deviations;
use super::geometry::Geometry;
use super::johnson::OutOfRange;
use super::law::{ContactLaw, JohnsonLaw, Law};
use super::rig::{self, Slider};
use super::rigid::{self, Impact};
use super::statistics::Statistics;
use super::tooth_structure::structure_law;
use super::ModelError;
use crate::variables::{Inputs, Params};
use serde::{Deserialize, Serialize};
use std::sync::Arc;

pub const NY: usize = 9;
pub type State = [f64; NY];
pub const THETA_A: usize = 0;
pub const DTE: usize = 1;
pub const W_A: usize = 2;
/// The mesh's relative velocity d(dte)/dt = rAb w_A - rBb w_B.
pub const DDTE: usize = 3;
pub const W_EXT: usize = 4;
pub const W_LOSS: usize = 5;
/// The slider's displacement and speed (zero and constant without a slider).
pub const X_S: usize = 6;
pub const V_S: usize = 7;
/// Time, integrated (dt/dt = 1) only while inputs are interpolated (`Ramp`): the right-hand
/// side then reads the inputs at the state's own time.
pub const TIME: usize = 8;
/// Components under error control, at most; the quadratures do not feed back into the dynamics.
pub const N_CONTROLLED: usize = 6;
/// Their indices: the first four always, the slider's two when there is one.
pub const CONTROLLED: [usize; N_CONTROLLED] = [THETA_A, DTE, W_A, DDTE, X_S, V_S];

/// A contact left the model's range: reported with the contact, the penetration and the limit.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("contact {contact} out of the model's range: penetration {delta} m reaches {limit_name} = {limit} m")]
pub struct LawOutOfRange {
    pub contact: String,
    pub delta: f64,
    pub limit: f64,
    pub limit_name: &'static str,
}

/// Beyond the segment length no pair can be gated (s_A - delta >= s_a and s_A <= s_b): the teeth
/// would pass through each other and the mesh would carry nothing.
pub const SEGMENT_LIMIT: &str =
    "the contact segment length |ab|, beyond which the teeth would pass through each other";

/// An event's description, formatted only when someone reads it (`Mesh::describe_events`):
/// formatting every pair switch cost 3 % of a base scene (callgrind, high-speed).
macro_rules! describe {
    ($self:ident, $($arg:tt)*) => {
        if $self.describe_events {
            format!($($arg)*)
        } else {
            String::new()
        }
    };
}

/// The tunable parameters and the inputs: what a master may change between steps.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Loads {
    pub tau_a: f64,
    pub tau_b: f64,
    pub c_load: f64,
    pub chi: f64,
    pub mu: f64,
    pub v_reg: f64,
    /// Angular acceleration of the housing [rad/s^2] (rig-and-modes §4).
    pub alpha_housing: f64,
    /// Acceleration of the slider's guide along O_A O_B [m/s^2].
    pub a_housing_x: f64,
}

impl Loads {
    pub fn new(p: &Params, i: &Inputs) -> Loads {
        Loads {
            tau_a: i.tau_A,
            tau_b: i.tau_B,
            c_load: p.c_load,
            chi: p.chi,
            mu: p.mu,
            v_reg: p.v_reg,
            alpha_housing: i.alpha_housing,
            a_housing_x: i.a_housing_x,
        }
    }
}

/// Inputs interpolated over communication steps (fmi2SetRealInputDerivatives): input k is
/// u_k + r_k (t - t0_k) + c_k (t - t0_k)^2 / 2 from the communication point t0_k at which
/// u_k holds, for tau_A, tau_B, alpha_housing and a_housing_x in that order.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Ramp {
    pub t0: [f64; 4],
    pub rate: [f64; 4],
    pub curvature: [f64; 4],
}

impl Ramp {
    /// Whether any input changes between communication points.
    pub fn is_active(&self) -> bool {
        self.rate.iter().chain(&self.curvature).any(|&x| x != 0.0)
    }

    /// Input k's value, rate and curvature at t, from u at t0_k.
    pub fn extrapolate(&self, k: usize, u: f64, t: f64) -> (f64, f64) {
        let dt = t - self.t0[k];
        (
            u + dt * (self.rate[k] + 0.5 * dt * self.curvature[k]),
            self.rate[k] + dt * self.curvature[k],
        )
    }

    /// The loads at time t.
    #[inline]
    pub fn apply(&self, l: &Loads, t: f64) -> Loads {
        let at = |k: usize, u: f64| self.extrapolate(k, u, t).0;
        Loads {
            tau_a: at(0, l.tau_a),
            tau_b: at(1, l.tau_b),
            alpha_housing: at(2, l.alpha_housing),
            a_housing_x: at(3, l.a_housing_x),
            ..*l
        }
    }
}

/// The contact law (`contact_model`).
#[derive(Clone, Debug, PartialEq)]
pub enum ContactModel {
    /// A compliant law with Hunt-Crossley damping: Johnson's line contact (the paper's mesh) or
    /// the tooth structure with Weber's local contact (contact model 3).
    Compliant(Law),
    /// A unilateral constraint with Newton impacts. `two_sided`: zero backlash and no slider,
    /// so both flanks touch at once and N may take either sign.
    Rigid { restitution: f64, two_sided: bool },
}

/// Normal, friction and elastic force of the pair each slot holds.
type SlotForces = [(f64, f64, f64); SLOTS];

/// What the mesh applies to the wheels and to B's bearing, interface-frame torques.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct MeshLoad {
    pub tq_a: f64,
    pub tq_b: f64,
    /// x component (paper frame) of the force on B; computed only where a slider needs it.
    pub f_bx: f64,
    pub p_loss: f64,
    /// Power of a position-dependent stiffness on the pairs' elastic energy (`ContactLaw::
    /// energy_slope`), booked with the external work.
    pub p_param: f64,
}

impl MeshLoad {
    fn scaled(&self, n: f64) -> MeshLoad {
        MeshLoad {
            tq_a: n * self.tq_a,
            tq_b: n * self.tq_b,
            f_bx: n * self.f_bx,
            p_loss: n * self.p_loss,
            p_param: n * self.p_param,
        }
    }
}

/// What the parameters fix: the geometry, the contact law, the rig, the derived constants.
/// An FMU state leaves it out; it is built again from the parameters, to the same bits.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MeshConfig {
    pub geo: Geometry,
    pub law: ContactModel,
    pub slider: Option<Slider>,
    width: f64,
    j_a: f64,
    j_b: f64,
    backlash: f64,
    sin_a: f64,
    cos_a: f64,
    /// 1/m_eff along the line of action (rig-and-modes §2), and reciprocals for the rigid
    /// constraint force (benches/rig_cost.rs: its divisions were a tenth of a rigid step).
    inv_m_eff: f64,
    inv_j_a: f64,
    inv_j_b: f64,
    inv_r_bb: f64,
    present: [bool; SLOTS],
    /// Shape deviations (none: pairs on a flank share delta, and the flank's Pen and Rel
    /// events serve them all).
    pub dev: Option<Arc<Deviations>>,
}

/// The mesh: its configuration (`cfg`, read through Deref as `mesh.geo`, `self.law`...) and
/// the state of its contact objects, modes and accounts, which an FMU state saves.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Mesh {
    /// Shared, never changed after construction: fmi2DoStep copies the simulation before every
    /// step that integrates, and copying the configuration was a sixth of that copy.
    #[serde(skip)]
    pub cfg: Arc<MeshConfig>,
    pub loads: Loads,
    /// s_A = sigma + dir rAb theta_A for each slot.
    pub sigma: [f64; SLOTS],
    /// Recorded sign of every event function (true: positive side). Gate signs are the gating
    /// modes; Pen and Rel signs make a flank carry force. Top and Bottom are always positive
    /// between events. With rigid contact a Pen sign means "locked on that flank" and its Rel
    /// function is the constraint force.
    pub sign: [bool; N_EVENTS],
    /// Energy brought in (or out) by mode changes at events, for the energy balance.
    pub e_gate: f64,
    pub n_events: u64,
    pub n_impacts: u64,
    pub(crate) e_start: f64,
    /// The run's statistics up to the driver's last observation (parameter `statistics`).
    pub stats: Option<Statistics>,
    /// Interpolated inputs, if the master gave input derivatives.
    pub ramp: Option<Ramp>,
    /// The pitch deviation of the teeth each slot holds (changes when the slot jumps; derived
    /// from sigma, see `set_sigma`).
    #[serde(skip)]
    pitch_e: [f64; SLOTS],
    /// `handle_event` describes what happened (`EventReport::what`); off, it leaves the text
    /// empty. The FMI layer turns it on while logEvents is.
    #[serde(skip)]
    pub describe_events: bool,
}

impl std::ops::Deref for Mesh {
    type Target = MeshConfig;
    #[inline(always)]
    fn deref(&self) -> &MeshConfig {
        &self.cfg
    }
}

impl Default for ContactModel {
    /// A placeholder until the configuration is built from the parameters.
    fn default() -> Self {
        ContactModel::Rigid {
            restitution: 0.0,
            two_sided: false,
        }
    }
}

/// What the mesh shows at a state: the wheels, each contact object's force and contact point,
/// the loads on the wheels and on B's bearing, and the energy account.
#[derive(Clone, Debug)]
pub struct Readout {
    pub theta_a: f64,
    pub theta_b: f64,
    pub w_a: f64,
    pub w_b: f64,
    pub dte: f64,
    /// Normal force of each contact object (slots f1, f2, b1, b2).
    pub pair_force: [f64; SLOTS],
    /// Each object's contact point on the line of action, from K_A.
    pub contact_point: [f64; SLOTS],
    /// Total normal force and number of carrying pairs, forward and backward flank.
    pub flank_force: [f64; 2],
    pub flank_pairs: [u32; 2],
    /// Mesh torques on A and B.
    pub tq_a: f64,
    pub tq_b: f64,
    pub p_loss: f64,
    pub w_ext: f64,
    pub w_loss: f64,
    pub e_gate: f64,
    pub n_events: u64,
    pub n_impacts: u64,
    pub x_slider: f64,
    /// The mesh force on B (x, y).
    pub force_on_b: [f64; 2],
    /// Tangent stiffness of the carrying pairs [N/m].
    pub k_mesh: f64,
}

/// The energy account at a state: kinetic and elastic energy, and the balance's residual
/// E_kin + E_el + W_loss - W_ext - E_gate - E(0). Apart from the readout: the elastic energy
/// costs a law evaluation per flank, and only a master reading these outputs needs it.
#[derive(Clone, Copy, Debug)]
pub struct Energy {
    pub e_kin: f64,
    pub e_el: f64,
    pub residual: f64,
}

/// What happened at an event, for the log.
#[derive(Clone, Debug)]
pub struct EventReport {
    pub what: String,
    /// The event left the right-hand side as it was (only bookkeeping changed): the
    /// integrator's step stays valid and continues past it without a restart.
    pub smooth: bool,
}

impl Mesh {
    /// Builds the mesh and its initial state from the parameters (spec §3 initial values;
    /// rig-and-modes §2 for the rigid contact's initial mode).
    pub fn new(p: &Params, inputs: &Inputs) -> Result<(Mesh, State), ModelError> {
        let mut geo = Geometry::new(p)?;
        let slider = Slider::from_params(p)?;
        let law = if p.contact_model == 2 {
            if !(p.dte_start >= -p.backlash && p.dte_start <= 0.0) {
                return Err(ModelError::new(format!(
                    "parameter dte_start = {} m: with rigid contact (contact_model = 2) it must lie in [-backlash, 0] = [{}, 0]",
                    p.dte_start, 0.0 - p.backlash
                )));
            }
            ContactModel::Rigid {
                restitution: p.restitution,
                two_sided: p.backlash == 0.0 && slider.is_none() && p.backward_contacts,
            }
        } else if p.contact_model == 3 {
            if p.geometry != 2 {
                return Err(ModelError::new(format!(
                    "parameter contact_model = 3: the tooth structure needs the standard geometry (geometry = 2, not {})",
                    p.geometry
                )));
            }
            let law = structure_law(p, &geo)?;
            geo.warnings.extend(law.warnings(&geo));
            ContactModel::Compliant(Law::Structure(Arc::new(law)))
        } else {
            ContactModel::Compliant(Law::Johnson(JohnsonLaw::new(geo.l, geo.e_star, p.width)))
        };
        let dev = Deviations::from_params(p, &geo)?.map(Arc::new);
        if dev.is_some() && p.contact_model == 2 {
            return Err(ModelError::new(
                "parameter contact_model = 2: shape deviations (tip relief, eccentricity, pitch errors) need a compliant contact model (1 or 3); the rigid contact has no penetration for them to add to".into(),
            ));
        }
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
        let (sin_a, cos_a) = geo.alpha_w.sin_cos();
        let inv_m_eff = geo.r_ab * geo.r_ab / p.J_A
            + geo.r_bb * geo.r_bb / p.J_B
            + slider.map_or(0.0, |s| sin_a * sin_a / s.m);
        let mut mesh = Mesh {
            cfg: Arc::new(MeshConfig {
                width: p.width,
                j_a: p.J_A,
                j_b: p.J_B,
                backlash: p.backlash,
                sin_a,
                cos_a,
                inv_m_eff,
                inv_j_a: 1.0 / p.J_A,
                inv_j_b: 1.0 / p.J_B,
                inv_r_bb: 1.0 / geo.r_bb,
                law,
                slider,
                geo,
                present,
                dev,
            }),
            loads: Loads::new(p, inputs),
            sigma,
            sign: [true; N_EVENTS],
            e_gate: 0.0,
            n_events: 0,
            n_impacts: 0,
            e_start: 0.0,
            stats: p.statistics.then(|| Statistics::new(p.stats_start)),
            pitch_e: [0.0; SLOTS],
            ramp: None,
            describe_events: true,
        };
        mesh.set_sigma(sigma);
        let v = geo_r_ab * p.w_A_start - geo_r_bb * p.w_B_start;
        let mut y = [
            theta_a,
            p.dte_start,
            p.w_A_start,
            v,
            0.0,
            0.0,
            0.0,
            0.0,
            0.0,
        ];
        mesh.init_signs(&mut y);
        mesh.check_range(&y)
            .map_err(|e| ModelError::new(format!("initial state: {e}")))?;
        mesh.e_start = mesh
            .energy_terms(&y)
            .map_err(|e| ModelError::new(e.to_string()))?
            .0;
        Ok((mesh, y))
    }

    /// Sets the slots' sigma (at t = 0, or from a saved state) and the teeth they hold.
    pub fn set_sigma(&mut self, sigma: [f64; SLOTS]) {
        self.sigma = sigma;
        for k in 0..SLOTS {
            self.update_teeth(k);
        }
    }

    fn update_teeth(&mut self, k: usize) {
        if let Some(d) = self.dev.as_deref() {
            let f = slot_flank(k);
            self.pitch_e[k] = d.pitch_offset(f, contact::teeth(&self.geo, f, self.sigma[k]));
        }
    }

    /// The teeth slot k holds, for messages (A's, B's).
    fn teeth_text(&self, k: usize) -> String {
        let (a, b) = contact::teeth(&self.geo, slot_flank(k), self.sigma[k]);
        format!(
            "teeth A{}/B{}",
            a.rem_euclid(self.geo.z_a as i64),
            b.rem_euclid(self.geo.z_b as i64)
        )
    }

    /// Pair k's shape deviation [e, de/dt, d2e/dt2] at y (with `dy`, the accelerations for the
    /// last; else it reads 0). The tip relief follows the recorded ReliefA/B modes.
    fn deviation(&self, d: &Deviations, k: usize, y: &State, dy: Option<&State>) -> [f64; 3] {
        let g = &self.geo;
        let f = slot_flank(k);
        let mut e = [self.pitch_e[k], 0.0, 0.0];
        let (acc_a, acc_b) = dy.map_or((0.0, 0.0), |dy| {
            (dy[W_A], (g.r_ab * dy[W_A] - dy[DDTE]) / g.r_bb)
        });
        if d.has_runout() {
            let theta_b = (g.r_ab * y[THETA_A] - y[DTE]) / g.r_bb;
            let r = d.runout(
                f,
                [y[THETA_A], theta_b],
                [y[W_A], self.w_b(y)],
                [acc_a, acc_b],
            );
            (0..3).for_each(|i| e[i] += r[i]);
        }
        if d.relief[0].is_some() || d.relief[1].is_some() {
            let s = self.s_contact(k, y);
            let (ds, dds) = (f.dir() * g.r_ab * y[W_A], f.dir() * g.r_ab * acc_a);
            for (w, mode) in [(0, EventFn::ReliefA(k)), (1, EventFn::ReliefB(k))] {
                let (r, dr, ddr) = d.relief(w, s, self.sign[mode.index()]);
                e[0] += r;
                e[1] += dr * ds;
                e[2] += ddr * ds * ds + dr * dds;
            }
        }
        e
    }

    /// Penetration of pair k and its rate, given its flank's: with shape deviations its own.
    #[inline]
    fn pair_delta(&self, k: usize, y: &State, flank: (f64, f64)) -> (f64, f64) {
        match self.dev.as_deref() {
            None => flank,
            Some(d) => {
                let e = self.deviation(d, k, y, None);
                (flank.0 + e[0], flank.1 + e[1])
            }
        }
    }

    pub fn present(&self, k: usize) -> bool {
        self.present[k]
    }

    /// The number of state components in use (a prefix of `State`): no slider, no slider states.
    pub fn dim(&self) -> usize {
        if self.ramp.is_some() {
            NY
        } else if self.slider.is_some() {
            V_S + 1
        } else {
            X_S
        }
    }

    /// The loads at state y: the interpolated inputs at its time, if any.
    #[inline]
    fn loads_at(&self, y: &State) -> Loads {
        match &self.ramp {
            None => self.loads,
            Some(r) => r.apply(&self.loads, y[TIME]),
        }
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

    fn rigid(&self) -> bool {
        matches!(self.law, ContactModel::Rigid { .. })
    }

    fn two_sided(&self) -> bool {
        matches!(
            self.law,
            ContactModel::Rigid {
                two_sided: true,
                ..
            }
        )
    }

    /// Penetration of a flank and its rate: forward delta = dte - x_S sin(alpha_w), backward
    /// delta = -backlash - dte - x_S sin(alpha_w) (moving B away opens both flanks).
    pub fn flank_delta(&self, f: Flank, y: &State) -> (f64, f64) {
        let ddte = y[DDTE];
        let (x, vx) = (y[X_S] * self.sin_a, y[V_S] * self.sin_a);
        match f {
            Flank::Forward => (y[DTE] - x, ddte - vx),
            Flank::Backward => (-self.backlash - y[DTE] - x, -ddte - vx),
        }
    }

    /// Speed of wheel B, from w_A and the mesh velocity.
    pub fn w_b(&self, y: &State) -> f64 {
        (self.geo.r_ab * y[W_A] - y[DDTE]) / self.geo.r_bb
    }

    pub fn s_contact(&self, k: usize, y: &State) -> f64 {
        self.sigma[k] + slot_flank(k).dir() * self.geo.r_ab * y[THETA_A]
    }

    /// A flank carries force: compliant, touching and, when damped, pressing (Hunt-Crossley
    /// force > 0); rigid, locked on it.
    pub fn flank_on(&self, f: Flank) -> bool {
        let pen = self.sign[EventFn::Pen(f).index()];
        pen && (self.rigid() || !self.damped() || self.sign[EventFn::Rel(f).index()])
    }

    fn gated(&self, k: usize) -> bool {
        self.present[k] && self.sign[EventFn::Gate(k).index()]
    }

    pub fn carrying(&self, k: usize) -> bool {
        self.gated(k)
            && if self.dev.is_some() {
                self.sign[EventFn::PairPen(k).index()]
                    && (!self.damped() || self.sign[EventFn::PairRel(k).index()])
            } else {
                self.flank_on(slot_flank(k))
            }
    }

    /// Whether any pair carries force, and whether a backward one does (fixed between events).
    pub fn contact_modes(&self) -> (bool, bool) {
        let any = (0..SLOTS).any(|k| self.carrying(k));
        let backward = (0..SLOTS).any(|k| slot_flank(k) == Flank::Backward && self.carrying(k));
        (any, backward)
    }

    /// Total normal force of the carrying pairs at y (F_fwd + F_bwd).
    pub fn normal_force(&self, y: &State) -> Result<f64, LawOutOfRange> {
        let (pairs, _) = self.pair_forces(y)?;
        Ok((0..SLOTS)
            .filter(|&k| self.carrying(k))
            .map(|k| pairs[k].0)
            .sum())
    }

    /// The rigid contact's locked flank, if any.
    fn locked(&self) -> Option<Flank> {
        if !self.rigid() {
            return None;
        }
        [Flank::Forward, Flank::Backward]
            .into_iter()
            .find(|&f| self.flank_present(f) && self.sign[EventFn::Pen(f).index()])
    }

    /// The compliant law (none with rigid contact).
    fn compliance(&self) -> Option<&Law> {
        match &self.law {
            ContactModel::Compliant(l) => Some(l),
            ContactModel::Rigid { .. } => None,
        }
    }

    /// Elastic force of one pair on a carrying flank, and with damping N(delta)(1 + chi
    /// d(delta)/dt).
    #[inline]
    fn pair_force(
        &self,
        law: &Law,
        delta: f64,
        ddelta: f64,
        s_a: f64,
    ) -> Result<(f64, f64), OutOfRange> {
        let n = law.force(delta, s_a)?;
        Ok((n, n * (1.0 + self.loads.chi * ddelta)))
    }

    /// Friction force per unit normal force of a pair, and its sliding velocity (spec §4).
    fn friction(&self, s_a: f64, s_b: f64, w_a: f64, w_b: f64) -> (f64, f64) {
        let v_s = -w_a * s_a + w_b * s_b;
        (self.loads.mu * (v_s / self.loads.v_reg).tanh(), v_s)
    }

    /// Right-hand side with the current modes. Errors only when the Johnson law leaves its range.
    pub fn rhs(&self, y: &State, dy: &mut State) -> Result<(), LawOutOfRange> {
        let (load, locked) = if self.rigid() {
            let (load, locked) = self.rigid_load(y);
            (load, locked.map(|(f, _)| f))
        } else {
            (self.compliant_load(y, None)?, None)
        };
        self.motion(y, &load, locked, dy);
        Ok(())
    }

    /// The compliant mesh's load; `pairs` also receives each slot's normal, friction and
    /// elastic force.
    fn compliant_load(
        &self,
        y: &State,
        mut pairs: Option<&mut SlotForces>,
    ) -> Result<MeshLoad, LawOutOfRange> {
        let law = self.compliance().expect("compliant");
        let w_b = self.w_b(y);
        let mut m = MeshLoad::default();
        if let Some(d) = self.dev.as_deref() {
            self.deviated_pairs(law, d, y, w_b, &mut m, &mut pairs)?;
            return Ok(m);
        }
        for f in [Flank::Forward, Flank::Backward] {
            if !self.flank_present(f) || !self.flank_on(f) {
                continue;
            }
            let slots = if f == Flank::Forward { 0..2 } else { 2..4 };
            let mut gated = slots.filter(|&k| self.gated(k)).peekable();
            if gated.peek().is_none() {
                continue;
            }
            let (delta, ddelta) = self.flank_delta(f, y);
            if law.depends_on_position() {
                self.position_dependent_pairs(law, f, gated, y, w_b, &mut m, &mut pairs)?;
                continue;
            }
            // One evaluation serves every pair of the flank. Johnson's is called directly: through
            // `pair_force` it cost the base scenes 3 % more instructions (callgrind).
            let forces = match law {
                Law::Johnson(j) => {
                    let n = j.force(delta, 0.0).map_err(|e| self.out_of_range(f, e))?;
                    (n, n * (1.0 + self.loads.chi * ddelta))
                }
                _ => self
                    .pair_force(law, delta, ddelta, 0.0)
                    .map_err(|e| self.out_of_range(f, e))?,
            };
            for k in gated {
                self.apply_pair(k, forces, (delta, ddelta), y, w_b, &mut m, &mut pairs);
            }
        }
        Ok(m)
    }

    /// The pairs of flank f under a law that depends on where each sits: a force each, and the
    /// work of the changing stiffness (kept out of the common path's loop).
    // What the caller holds is passed on, not looked up again in the right-hand side.
    #[allow(clippy::too_many_arguments)]
    #[inline(never)]
    fn position_dependent_pairs(
        &self,
        law: &Law,
        f: Flank,
        gated: impl Iterator<Item = usize>,
        y: &State,
        w_b: f64,
        m: &mut MeshLoad,
        pairs: &mut Option<&mut SlotForces>,
    ) -> Result<(), LawOutOfRange> {
        let (delta, ddelta) = self.flank_delta(f, y);
        let (mut slots, mut s_a, mut count) = ([0; 2], [0.0; 2], 0);
        for k in gated {
            slots[count] = k;
            s_a[count] = self.s_contact(k, y);
            count += 1;
        }
        // Every pair's force in one call before any pair's load, so that the law's latency
        // chains of the pairs overlap (1.33x -> 1.18x contact model 1's right-hand side,
        // benches/rhs_cost.rs; forces then loads with a call per pair stayed at 1.33x).
        let mut out = [(0.0, 0.0); 2];
        law.flank_forces_and_slopes(delta, &s_a[..count], &mut out[..count])
            .map_err(|e| self.out_of_range(f, e))?;
        for (&k, &(n, slope)) in slots.iter().zip(&out).take(count) {
            m.p_param += slope * f.dir() * self.geo.r_ab * y[W_A];
            let forces = (n, n * (1.0 + self.loads.chi * ddelta));
            self.apply_pair(k, forces, (delta, ddelta), y, w_b, m, pairs);
        }
        Ok(())
    }

    /// Each carrying pair at its own penetration (shape deviations): a force each, and the work
    /// that the deviations and a position-dependent stiffness do on the pair (booked with the
    /// external work: the force acts along the line of action only).
    #[inline(never)]
    fn deviated_pairs(
        &self,
        law: &Law,
        d: &Deviations,
        y: &State,
        w_b: f64,
        m: &mut MeshLoad,
        pairs: &mut Option<&mut SlotForces>,
    ) -> Result<(), LawOutOfRange> {
        for k in (0..SLOTS).filter(|&k| self.carrying(k)) {
            let f = slot_flank(k);
            let flank = self.flank_delta(f, y);
            let e = self.deviation(d, k, y, None);
            let (delta, ddelta) = (flank.0 + e[0], flank.1 + e[1]);
            let s_a = self.s_contact(k, y);
            let forces = self
                .pair_force(law, delta, ddelta, s_a)
                .map_err(|err| self.out_of_range(f, err))?;
            m.p_param += forces.1 * e[1];
            if law.depends_on_position() {
                m.p_param += law.energy_slope(forces.0, s_a) * f.dir() * self.geo.r_ab * y[W_A];
            }
            self.apply_pair(k, forces, (delta, ddelta), y, w_b, m, pairs);
        }
        Ok(())
    }

    /// Adds pair k's elastic and damped normal force `forces` and its friction to the load.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn apply_pair(
        &self,
        k: usize,
        (n, fn_): (f64, f64),
        (delta, ddelta): (f64, f64),
        y: &State,
        w_b: f64,
        m: &mut MeshLoad,
        pairs: &mut Option<&mut SlotForces>,
    ) {
        let g = &self.geo;
        let f = slot_flank(k);
        let dir = f.dir();
        // Normal force: the spec's paper-frame torques, turned into the interface frame.
        m.tq_a -= dir * fn_ * g.r_ab;
        m.tq_b += dir * fn_ * g.r_bb;
        if self.loads.chi > 0.0 {
            m.p_loss += n * self.loads.chi * ddelta * ddelta;
        }
        let mut ft = 0.0;
        if self.loads.mu > 0.0 {
            let s_a = self.s_contact(k, y);
            let s_b = g.l + delta - s_a;
            let (mu_eff, v_s) = self.friction(s_a, s_b, y[W_A], w_b);
            ft = mu_eff * fn_;
            m.tq_a += ft * s_a;
            m.tq_b -= ft * s_b;
            m.p_loss += ft * v_s;
        }
        if self.slider.is_some() {
            m.f_bx += rig::force_on_b(f, fn_, ft, self.sin_a, self.cos_a).0;
        }
        if let Some(p) = pairs.as_deref_mut() {
            p[k] = (fn_, ft, n);
        }
    }

    /// The load of a locked flank per newton of total constraint force, with the equal split
    /// between its gated pairs; `None` when no pair is gated there.
    fn unit_load(&self, f: Flank, y: &State) -> Option<MeshLoad> {
        let g = &self.geo;
        let slots = if f == Flank::Forward { 0..2 } else { 2..4 };
        let n = slots.clone().filter(|&k| self.gated(k)).count();
        if n == 0 {
            return None;
        }
        let dir = f.dir();
        let share = 1.0 / n as f64;
        // Without friction the normal forces of the pairs add up to N along the line of action.
        let mut m = MeshLoad {
            tq_a: -dir * g.r_ab,
            tq_b: dir * g.r_bb,
            f_bx: self.sin_a,
            ..MeshLoad::default()
        };
        if self.loads.mu > 0.0 {
            let (w_a, w_b) = (y[W_A], self.w_b(y));
            for k in slots.filter(|&k| self.gated(k)) {
                let s_a = self.s_contact(k, y);
                let s_b = g.l - s_a;
                let (mu_eff, v_s) = self.friction(s_a, s_b, w_a, w_b);
                let ft = mu_eff * share;
                m.tq_a += ft * s_a;
                m.tq_b -= ft * s_b;
                m.p_loss += ft * v_s;
                m.f_bx += rig::force_on_b(f, 0.0, ft, self.sin_a, self.cos_a).0;
            }
        }
        Some(m)
    }

    /// Total constraint force that keeps flank f locked, with the current gates and speeds.
    fn constraint_force(&self, f: Flank, y: &State) -> Option<(f64, MeshLoad)> {
        let unit = self.unit_load(f, y)?;
        let g = &self.geo;
        // d^2 delta/dt^2 = a0 + a1 N: the free acceleration and the effect of a unit N.
        // The free accelerations as in `accelerations_given`, by reciprocals: this runs at every
        // communication point of a locked rigid mesh, where the chain of three divisions was
        // a tenth of the wall time. (The compliant right-hand side keeps its divisions, and so
        // its trajectories bit for bit.)
        let l = &self.loads_at(y);
        let w_b = (g.r_ab * y[W_A] - y[DDTE]) * self.inv_r_bb;
        let dw_a = l.tau_a * self.inv_j_a + l.alpha_housing;
        let acc_b = (l.tau_b - l.c_load * w_b) * self.inv_j_b - l.alpha_housing;
        let inv_m = self.slider.map_or(0.0, |s| 1.0 / s.m);
        let acc_x = self.slider.map_or(0.0, |s| {
            -(s.k * y[X_S] + s.c * y[V_S]) * inv_m - l.a_housing_x
        });
        let a0 = f.dir() * (g.r_ab * dw_a - g.r_bb * acc_b) - self.sin_a * acc_x;
        // Without friction a1 = -1/m_eff.
        let a1 = f.dir() * (g.r_ab * unit.tq_a * self.inv_j_a - g.r_bb * unit.tq_b * self.inv_j_b)
            - self.sin_a * unit.f_bx * inv_m;
        let n = rigid::lock_force(a0, a1)?;
        Some((n, unit))
    }

    /// The rigid mesh's load, its locked flank and constraint force (none when free).
    fn rigid_load(&self, y: &State) -> (MeshLoad, Option<(Flank, f64)>) {
        match self.locked() {
            Some(f) => match self.constraint_force(f, y) {
                Some((n, unit)) => (unit.scaled(n), Some((f, n))),
                None => (MeshLoad::default(), None),
            },
            None => (MeshLoad::default(), None),
        }
    }

    /// Accelerations of A, B and the slider under a mesh load, given the loads and w_B;
    /// `external` scales the torques, housing and slider forces (1 for the real motion, 0 for a
    /// unit constraint force alone).
    #[inline(always)]
    fn accelerations_given(
        &self,
        y: &State,
        l: &Loads,
        w_b: f64,
        m: &MeshLoad,
        external: f64,
    ) -> (f64, f64, f64) {
        let dw_a = (external * l.tau_a + m.tq_a) / self.j_a + external * l.alpha_housing;
        let acc_b = (external * (l.tau_b - l.c_load * w_b) + m.tq_b) / self.j_b
            - external * l.alpha_housing;
        let acc_x = match self.slider {
            Some(s) => {
                (m.f_bx - external * (s.k * y[X_S] + s.c * y[V_S])) / s.m - external * l.a_housing_x
            }
            None => 0.0,
        };
        (dw_a, acc_b, acc_x)
    }

    /// The equations of motion under a mesh load (spec §5, rig-and-modes §3-§4). A locked
    /// rigid flank holds its penetration exactly: no drift away from the constraint.
    #[inline]
    fn motion(&self, y: &State, load: &MeshLoad, locked: Option<Flank>, dy: &mut State) {
        let g = &self.geo;
        let l = &self.loads_at(y);
        let (w_a, w_b) = (y[W_A], self.w_b(y));
        let (dw_a, acc_b, acc_x) = self.accelerations_given(y, l, w_b, load, 1.0);
        dy[THETA_A] = w_a;
        dy[DTE] = g.r_ab * w_a - g.r_bb * w_b;
        dy[W_A] = dw_a;
        dy[DDTE] = g.r_ab * dw_a - g.r_bb * acc_b;
        if let Some(f) = locked {
            dy[DTE] = y[DDTE];
            dy[DDTE] = f.dir() * self.sin_a * acc_x;
        }
        dy[W_EXT] = l.tau_a * w_a + l.tau_b * w_b - l.c_load * w_b * w_b
            + l.alpha_housing * (self.j_a * w_a - self.j_b * w_b);
        if load.p_param != 0.0 {
            dy[W_EXT] += load.p_param;
        }
        dy[W_LOSS] = load.p_loss;
        dy[X_S] = 0.0;
        dy[V_S] = 0.0;
        dy[TIME] = 1.0;
        if let Some(s) = self.slider {
            dy[W_EXT] -= s.m * l.a_housing_x * y[V_S];
            dy[W_LOSS] += s.c * y[V_S] * y[V_S];
            dy[X_S] = y[V_S];
            dy[V_S] = acc_x;
        }
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
            limit_name: self.compliance().map_or("", |l| l.limit_name()),
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
    fn event_active(&self, e: EventFn) -> bool {
        if self.rigid() {
            return self.rigid_event_active(e);
        }
        match e {
            EventFn::Top(k) | EventFn::Bottom(k) | EventFn::Gate(k) => self.present[k],
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
            // Shape deviations need a compliant law (Mesh::new).
            _ => false,
        }
    }

    /// Value of one event function.
    pub fn event_value(&self, e: EventFn, y: &State) -> f64 {
        self.value_given(e, y, |f| self.flank_delta(f, y))
    }

    /// An event function's value, with the flanks' penetrations and rates from `delta`.
    fn value_given(&self, e: EventFn, y: &State, delta: impl Fn(Flank) -> (f64, f64)) -> f64 {
        match e {
            EventFn::Top(k) => self.geo.s_b - self.s_contact(k, y),
            EventFn::Bottom(k) => self.s_contact(k, y) - self.geo.s_window_low(),
            EventFn::Gate(k) => {
                self.s_contact(k, y) - delta(slot_flank(k)).0.max(0.0) - self.geo.s_a
            }
            EventFn::Pen(f) => delta(f).0,
            EventFn::Rel(f) if self.rigid() => self.constraint_force(f, y).map_or(-1.0, |c| c.0),
            EventFn::Rel(f) => 1.0 + self.loads.chi * delta(f).1,
            EventFn::PairPen(k)
            | EventFn::PairRel(k)
            | EventFn::ReliefA(k)
            | EventFn::ReliefB(k) => self.pair_value(e, y, delta(slot_flank(k))),
        }
    }

    /// A per-pair event function's value, given its flank's penetration and rate.
    #[inline(never)]
    fn pair_value(&self, e: EventFn, y: &State, flank: (f64, f64)) -> f64 {
        match e {
            EventFn::PairPen(k) => self.pair_delta(k, y, flank).0,
            EventFn::PairRel(k) => 1.0 + self.loads.chi * self.pair_delta(k, y, flank).1,
            EventFn::ReliefA(k) => self.s_contact(k, y) - self.relief_start(0),
            EventFn::ReliefB(k) => self.relief_start(1) - self.s_contact(k, y),
            _ => unreachable!("flank and object events are not per pair"),
        }
    }

    /// A per-pair event function's rate at y with state rate dy.
    #[inline(never)]
    fn pair_rate(&self, e: EventFn, y: &State, dy: &State, flank: (f64, f64)) -> f64 {
        let travel = self.geo.r_ab * dy[THETA_A];
        match e {
            EventFn::PairPen(k) => self.pair_delta(k, y, flank).1,
            EventFn::PairRel(k) => {
                let f = slot_flank(k);
                let e = self.deviation(self.dev.as_deref().expect("active"), k, y, Some(dy));
                self.loads.chi * (f.dir() * dy[DDTE] - self.sin_a * dy[V_S] + e[2])
            }
            EventFn::ReliefA(k) => slot_flank(k).dir() * travel,
            EventFn::ReliefB(k) => -slot_flank(k).dir() * travel,
            _ => unreachable!("flank and object events are not per pair"),
        }
    }

    /// All event functions, as signed distances to a crossing: positive while the recorded sign
    /// holds, negative once the function has crossed. Inactive ones read +1. The flanks'
    /// penetrations, which most of them use, are computed once.
    pub fn event_margins(&self, y: &State, out: &mut [f64; N_EVENTS]) {
        let d = [
            self.flank_delta(Flank::Forward, y),
            self.flank_delta(Flank::Backward, y),
        ];
        if self.dev.is_none() && !self.rigid() {
            // The common case's slot-by-slot path; the rates it also writes are not wanted.
            let mut rates = [0.0; N_EVENTS];
            return self.base_margins_and_rates(y, &[0.0; NY], d, 0.0, out, &mut rates);
        }
        let n = self.n_event_fns();
        out[n..].fill(1.0);
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

    /// All event margins (see `event_margins`) and their time derivatives at state y with state
    /// rate dy, signed as the margins: 0 for inactive ones, NaN where the model gives none (the
    /// rigid constraint force). The driver fits a cubic through each margin's values and rates
    /// at a step's ends to find interior minima that may cross zero within one step (a graze).
    pub fn event_margins_and_rates(
        &self,
        y: &State,
        dy: &State,
        margins: &mut [f64; N_EVENTS],
        rates: &mut [f64; N_EVENTS],
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
        margins[n..].fill(1.0);
        rates[n..].fill(0.0);
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
                    f.dir() * travel - if delta > 0.0 { rate } else { 0.0 }
                }
                EventFn::Pen(f) => d[f as usize].1,
                EventFn::Rel(_) if self.rigid() => f64::NAN,
                EventFn::Rel(f) => self.loads.chi * (f.dir() * dy[DDTE] - self.sin_a * dy[V_S]),
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
        y: &State,
        dy: &State,
        d: [(f64, f64); 2],
        travel: f64,
        margins: &mut [f64; N_EVENTS],
        rates: &mut [f64; N_EVENTS],
    ) {
        let g = &self.geo;
        let low = g.s_window_low();
        margins[contact::BASE_EVENTS..].fill(1.0);
        rates[contact::BASE_EVENTS..].fill(0.0);
        // An active function signed as its margin; an inactive one reads +1 with rate 0.
        let mut put = |i: usize, active: Option<(f64, f64)>| {
            (margins[i], rates[i]) = match active {
                Some((value, rate)) if self.sign[i] => (value, rate),
                Some((value, rate)) => (-value, -rate),
                None => (1.0, 0.0),
            };
        };
        for k in 0..SLOTS {
            let i = EventFn::Top(k).index();
            if !self.present[k] {
                (i..i + 3).for_each(|j| put(j, None));
                continue;
            }
            let f = slot_flank(k);
            let (delta, rate) = d[f as usize];
            let s = self.s_contact(k, y);
            put(i, Some((g.s_b - s, -f.dir() * travel)));
            put(i + 1, Some((s - low, f.dir() * travel)));
            let gate_rate = f.dir() * travel - if delta > 0.0 { rate } else { 0.0 };
            put(i + 2, Some((s - delta.max(0.0) - g.s_a, gate_rate)));
        }
        for f in [Flank::Forward, Flank::Backward] {
            let (pen, rel) = (EventFn::Pen(f).index(), EventFn::Rel(f).index());
            let present = self.flank_present(f);
            let (delta, rate) = d[f as usize];
            put(pen, present.then_some((delta, rate)));
            let chi = self.loads.chi;
            let releasing = present && self.damped() && self.sign[pen];
            put(
                rel,
                releasing.then(|| {
                    let rel_rate = chi * (f.dir() * dy[DDTE] - self.sin_a * dy[V_S]);
                    (1.0 + chi * rate, rel_rate)
                }),
            );
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

    fn init_signs(&mut self, y: &mut State) {
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
        if self.rigid() {
            self.init_rigid(y);
        }
    }

    /// The rigid contact at t = 0 (rig-and-modes §2): a flank touching with delta = 0 is an
    /// impact if it approaches faster than double precision resolves, free if it separates,
    /// else locked when the constraint force is >= 0.
    fn init_rigid(&mut self, y: &mut State) {
        let g = &self.geo;
        let res = rigid::speed_resolution(g.r_ab, g.r_bb, y[W_A], self.w_b(y));
        for f in [Flank::Forward, Flank::Backward] {
            let (delta, rate) = self.flank_delta(f, y);
            if !self.flank_present(f) || delta != 0.0 || self.locked().is_some() {
                continue;
            }
            if rate > res {
                self.impact(f, y);
            } else if rate >= -res {
                self.try_lock(f, y);
            }
        }
    }

    /// Sets a recorded sign from the value, or, when the value is within rounding of zero,
    /// from the direction the function is moving in.
    fn set_sign(&mut self, e: EventFn, y: &State) {
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
                EventFn::Gate(k) => ds(k) - if delta > 0.0 { ddelta } else { 0.0 },
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

    /// Kinetic energy of the wheels and the slider.
    fn kinetic_energy(&self, y: &State) -> f64 {
        let w_b = self.w_b(y);
        let slider = self.slider.map_or(0.0, |s| 0.5 * s.m * y[V_S] * y[V_S]);
        0.5 * (self.j_a * y[W_A] * y[W_A] + self.j_b * w_b * w_b) + slider
    }

    /// A rigid tooth impact on flank f (Newton's law), then a lock if the rebound is too short
    /// to resolve (see `rigid::Impact::ends_in_lock`). Returns what happened.
    fn impact(&mut self, f: Flank, y: &mut State) -> String {
        let ContactModel::Rigid {
            restitution,
            two_sided,
        } = self.law
        else {
            unreachable!("impacts are rigid-contact events")
        };
        let e_kin = self.kinetic_energy(y);
        // The event was located just past delta = 0: put the teeth exactly on the flank, so the
        // rebound starts from delta = 0 and the event cannot fire again at its own restart.
        self.touch(f, y);
        let (_, rate) = self.flank_delta(f, y);
        let g = &self.geo;
        if rate < -rigid::speed_resolution(g.r_ab, g.r_bb, y[W_A], self.w_b(y)) {
            return describe!(self, "{f:?} flank grazed while separating: no impact");
        }
        let v_minus = rate.max(0.0);
        // No room to rebound into with two-sided contact: the impact is plastic.
        let e = if two_sided { 0.0 } else { restitution };
        let imp = Impact::new(v_minus, e, self.inv_m_eff);
        self.apply_impulse(f, imp.impulse, y);
        let g = &self.geo;
        let mut dy = [0.0; NY];
        self.motion(y, &MeshLoad::default(), None, &mut dy);
        let approach = f.dir() * dy[DDTE] - self.sin_a * dy[V_S];
        let res = rigid::speed_resolution(g.r_ab, g.r_bb, y[W_A], self.w_b(y));
        let locked = (e == 0.0 || imp.ends_in_lock(approach, res)) && self.try_lock(f, y);
        self.n_impacts += 1;
        y[W_LOSS] += e_kin - self.kinetic_energy(y);
        describe!(
            self,
            "{f:?} flank impact at {v_minus:.6e} m/s, rebound {:.6e} m/s: {}",
            imp.rebound_speed,
            if locked { "locks" } else { "free" }
        )
    }

    /// Sets dte so that flank f's penetration is exactly 0.
    fn touch(&self, f: Flank, y: &mut State) {
        let x = y[X_S] * self.sin_a;
        y[DTE] = match f {
            Flank::Forward => x,
            Flank::Backward => -self.backlash - x,
        };
    }

    /// An impulse p along flank f's line of action, pushing the teeth apart (rig-and-modes §2:
    /// forward, J_A dw_A = -P rAb and J_B dw_B = +P rBb; backward the opposite; the slider
    /// takes P sin(alpha_w) either way).
    fn apply_impulse(&self, f: Flank, p: f64, y: &mut State) {
        let g = &self.geo;
        let dir = f.dir();
        y[W_A] -= dir * p * g.r_ab / self.j_a;
        y[DDTE] -= dir * p * (g.r_ab * g.r_ab / self.j_a + g.r_bb * g.r_bb / self.j_b);
        if let Some(s) = self.slider {
            y[V_S] += p * self.sin_a / s.m;
        }
    }

    /// Locks flank f if its constraint force is >= 0 (two-sided: either flank, by the sign of
    /// N). A lock is a plastic impact: the impulse along the line of action that stops the
    /// relative normal motion; the penetration and its rate are then exactly 0.
    fn try_lock(&mut self, f: Flank, y: &mut State) -> bool {
        let mut candidates = vec![f];
        if self.two_sided() {
            candidates.push(other(f));
        }
        for c in candidates {
            let mut yl = *y;
            let rate = self.flank_delta(c, &yl).1;
            self.apply_impulse(c, rate / self.inv_m_eff, &mut yl);
            self.touch(c, &mut yl);
            let vx = yl[V_S] * self.sin_a;
            yl[DDTE] = match c {
                Flank::Forward => vx,
                Flank::Backward => -vx,
            };
            if matches!(self.constraint_force(c, &yl), Some((n, _)) if n >= 0.0) {
                self.sign[EventFn::Pen(c).index()] = true;
                self.sign[EventFn::Rel(c).index()] = true;
                *y = yl;
                return true;
            }
        }
        false
    }

    /// After a change of gates or loads a locked flank must still press (N >= 0); else it is
    /// released (two-sided: the other flank takes over).
    fn recheck_lock(&mut self, y: &mut State) -> Option<String> {
        let f = self.locked()?;
        if matches!(self.constraint_force(f, y), Some((n, _)) if n >= 0.0) {
            return None;
        }
        Some(self.release(f, y))
    }

    /// The objects of flank f are not tracked: a one-sided rigid lock on the other flank with
    /// no slider holds f exactly a backlash open, so its pair switches change nothing. They are
    /// brought up to date when the lock ends (`resume_tracking`).
    fn parked(&self, f: Flank) -> bool {
        match self.law {
            ContactModel::Rigid {
                two_sided: false, ..
            } => self.slider.is_none() && self.sign[EventFn::Pen(other(f)).index()],
            _ => false,
        }
    }

    /// Wraps the objects of flank f into their windows at the current angle and re-derives their
    /// gates, as at t = 0.
    fn resume_tracking(&mut self, f: Flank, y: &State) {
        let present = self.present;
        for k in (0..SLOTS).filter(|&k| slot_flank(k) == f && present[k]) {
            self.sigma[k] =
                contact::wrap_into_window(&self.geo, self.sigma[k], f.dir(), y[THETA_A]);
            self.update_teeth(k);
            self.set_sign(EventFn::Gate(k), y);
        }
    }

    fn release(&mut self, f: Flank, y: &mut State) -> String {
        let parked = self.parked(other(f));
        self.sign[EventFn::Pen(f).index()] = false;
        if parked {
            self.resume_tracking(other(f), y);
        }
        if self.two_sided() && self.try_lock(other(f), y) {
            return describe!(
                self,
                "constraint force changes sign: the {:?} flank carries",
                other(f)
            );
        }
        describe!(self, "{f:?} flank releases (constraint force reaches 0)")
    }

    /// Applies the event whose function crossed at the state y, and returns what happened. A
    /// rigid impact changes the speeds in y.
    pub fn handle_event(&mut self, i: usize, y: &mut State) -> Result<EventReport, LawOutOfRange> {
        let before = self.elastic_energy(y)?;
        let motion_before = self.rigid_motion_modes();
        let e = EventFn::from_index(i);
        // A compliant pair that carries no force before and after its jump (outside its
        // contact segment or on the idle flank) leaves the right-hand side alone.
        let idle_jump =
            |m: &Mesh| matches!(e, EventFn::Top(k) | EventFn::Bottom(k) if !m.carrying(k));
        let idle_before = idle_jump(self);
        let span = self.geo.m_c as f64 * self.geo.p_b;
        let mut what = match e {
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
            EventFn::Pen(f) if self.rigid() => self.impact(f, y),
            EventFn::Rel(f) if self.rigid() => self.release(f, y),
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
        // A pair switch moves the friction arms and the split of a rigid lock.
        if matches!(e, EventFn::Top(_) | EventFn::Bottom(_) | EventFn::Gate(_)) {
            if let Some(r) = self.recheck_lock(y) {
                what = describe!(self, "{what}; {r}");
            }
        }
        self.n_events += 1;
        self.e_gate += self.elastic_energy(y)? - before;
        let smooth = match motion_before {
            Some(_) => motion_before == self.rigid_motion_modes(),
            None => idle_before && idle_jump(self),
        };
        Ok(EventReport { what, smooth })
    }

    /// A pair entering the gate (or jumping into it): its own modes from its state, as at t = 0.
    fn set_pair_modes(&mut self, k: usize, y: &State) {
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

    /// What a rigid mesh's right-hand side depends on besides the state: the locked flank, and
    /// on it which pairs are gated (their friction arms; without friction only that one is, as
    /// the equal split does not enter the motion). A pair switch that keeps them is only
    /// bookkeeping. (The compliant mesh's free-flight switches are such too; they still restart
    /// so that today's compliant scenes keep their step sequences.)
    fn rigid_motion_modes(&self) -> Option<(Option<Flank>, [bool; SLOTS])> {
        if !self.rigid() {
            return None;
        }
        let locked = self.locked();
        let gated: [bool; SLOTS] = std::array::from_fn(|k| {
            locked == Some(slot_flank(k)) && self.gated(k) && self.loads.mu > 0.0
        });
        let any = locked.is_some_and(|f| (0..SLOTS).any(|k| slot_flank(k) == f && self.gated(k)));
        Some((locked.filter(|_| any), gated))
    }

    /// A master changed inputs or tunable parameters: the right-hand side changes from here on.
    pub fn set_loads(&mut self, loads: Loads, y: &mut State) {
        let was_damped = self.damped();
        self.loads = loads;
        if self.rigid() {
            // A lock the new loads would make pull is released: a mode change, counted as one.
            if self.recheck_lock(y).is_some() {
                self.n_events += 1;
            }
            return;
        }
        if self.damped() && !was_damped {
            for f in [Flank::Forward, Flank::Backward] {
                self.set_sign(EventFn::Rel(f), y);
            }
            for k in 0..SLOTS {
                self.set_sign(EventFn::PairRel(k), y);
            }
        }
    }

    /// Tangent stiffness [N/m] of the carrying compliant contacts, summed.
    fn mesh_stiffness(&self, y: &State) -> f64 {
        let Some(law) = self.compliance() else {
            return 0.0;
        };
        let mut k = 0.0;
        for f in [Flank::Forward, Flank::Backward] {
            k += self
                .per_carrying_pair(f, y, |delta, s| law.stiffness(delta, s))
                .unwrap_or(0.0);
        }
        k
    }

    /// Bound on the highest natural frequency [rad/s]: the mesh stiffness times the reduced
    /// inverse inertia along the line of action, plus the slider on its spring (the trace of
    /// the coupled system bounds its largest eigenvalue); 0 without contact or slider.
    pub fn vibration_frequency(&self, y: &State) -> f64 {
        let slider = self.slider.map_or(0.0, |s| s.k / s.m);
        (self.mesh_stiffness(y) * self.inv_m_eff + slider).sqrt()
    }

    /// Elastic energy of the carrying pairs and of the slider's spring.
    pub fn elastic_energy(&self, y: &State) -> Result<f64, LawOutOfRange> {
        let mut e = self.slider.map_or(0.0, |s| 0.5 * s.k * y[X_S] * y[X_S]);
        let Some(law) = self.compliance() else {
            return Ok(e);
        };
        for f in [Flank::Forward, Flank::Backward] {
            e += self
                .per_carrying_pair(f, y, |delta, s| law.energy(delta, s))
                .map_err(|err| self.out_of_range(f, err))?;
        }
        Ok(e)
    }

    /// The sum of `value(delta_i, s_A)` over the carrying pairs of flank f: one evaluation for
    /// all of them when they share delta and the law does not depend on the position.
    fn per_carrying_pair(
        &self,
        f: Flank,
        y: &State,
        value: impl Fn(f64, f64) -> Result<f64, OutOfRange>,
    ) -> Result<f64, OutOfRange> {
        let slots = (0..SLOTS).filter(|&k| slot_flank(k) == f && self.carrying(k));
        let flank = self.flank_delta(f, y);
        if self.dev.is_some() || self.compliance().is_some_and(|l| l.depends_on_position()) {
            slots
                .map(|k| value(self.pair_delta(k, y, flank).0, self.s_contact(k, y)))
                .sum()
        } else {
            let count = slots.count();
            Ok(if count > 0 {
                count as f64 * value(flank.0, 0.0)?
            } else {
                0.0
            })
        }
    }

    /// (E_kin + E_el + W_loss - W_ext - E_gate, E_kin, E_el).
    fn energy_terms(&self, y: &State) -> Result<(f64, f64, f64), LawOutOfRange> {
        let e_kin = self.kinetic_energy(y);
        let e_el = self.elastic_energy(y)?;
        Ok((
            e_kin + e_el + y[W_LOSS] - y[W_EXT] - self.e_gate,
            e_kin,
            e_el,
        ))
    }

    /// Normal, friction and elastic force of every slot, and the load they make.
    fn pair_forces(&self, y: &State) -> Result<(SlotForces, MeshLoad), LawOutOfRange> {
        let mut pairs = [(0.0, 0.0, 0.0); SLOTS];
        if !self.rigid() {
            let load = self.compliant_load(y, Some(&mut pairs))?;
            return Ok((pairs, load));
        }
        let (load, locked) = self.rigid_load(y);
        if let Some((f, n)) = locked {
            let gated = || (0..SLOTS).filter(move |&k| slot_flank(k) == f && self.gated(k));
            // 1 or 2 pairs: the product by the exact reciprocal is the quotient, without a
            // second division after the constraint force's.
            let share = [1.0, 0.5][gated().count() - 1];
            let (w_a, w_b) = (y[W_A], self.w_b(y));
            for k in gated() {
                let fn_ = n * share;
                let mut ft = 0.0;
                if self.loads.mu > 0.0 {
                    let s_a = self.s_contact(k, y);
                    ft = self.friction(s_a, self.geo.l - s_a, w_a, w_b).0 * fn_;
                }
                pairs[k] = (fn_, ft, fn_);
            }
        }
        Ok((pairs, load))
    }

    /// What the mesh shows at state y (the FMI layer maps it onto its outputs). Inlined into
    /// its callers: it runs after every communication step, and a call costs ~60 instructions.
    #[inline(always)]
    pub fn readout(&self, y: &State) -> Result<Readout, LawOutOfRange> {
        let g = &self.geo;
        let mut s = [0.0; SLOTS];
        let (mut flank_force, mut flank_pairs) = ([0.0; 2], [0; 2]);
        let (pairs, load) = self.pair_forces(y)?;
        let parked = [self.parked(Flank::Forward), self.parked(Flank::Backward)];
        let mut force_on_b = [0.0; 2];
        let (mut k_mesh, mut flank_stiffness) = (0.0, [None; 2]);
        let law = self.compliance();
        for k in 0..SLOTS {
            if !self.present[k] {
                continue;
            }
            s[k] = if parked[slot_flank(k) as usize] {
                let dir = slot_flank(k).dir();
                contact::wrap_into_window(g, self.sigma[k], dir, y[THETA_A])
                    + dir * g.r_ab * y[THETA_A]
            } else {
                self.s_contact(k, y)
            };
            if self.carrying(k) {
                let f = slot_flank(k);
                flank_force[f as usize] += pairs[k].0;
                flank_pairs[f as usize] += 1;
                let (fx, fy) = rig::force_on_b(f, pairs[k].0, pairs[k].1, self.sin_a, self.cos_a);
                force_on_b[0] += fx;
                force_on_b[1] += fy;
                if let Some(law) = law {
                    let fi = f as usize;
                    let own = law.depends_on_position() || self.dev.is_some();
                    if own || flank_stiffness[fi].is_none() {
                        let delta = self.pair_delta(k, y, self.flank_delta(f, y)).0;
                        flank_stiffness[fi] = Some(law.stiffness_at_force(pairs[k].2, delta, s[k]));
                    }
                    k_mesh += flank_stiffness[fi].expect("just set");
                }
            }
        }
        Ok(Readout {
            theta_a: y[THETA_A],
            theta_b: (g.r_ab * y[THETA_A] - y[DTE]) / g.r_bb,
            w_a: y[W_A],
            w_b: self.w_b(y),
            dte: y[DTE],
            pair_force: pairs.map(|p| p.0),
            contact_point: s,
            flank_force,
            flank_pairs,
            tq_a: load.tq_a,
            tq_b: load.tq_b,
            // The right-hand side's dissipation, from the load already at hand.
            p_loss: load.p_loss + self.slider.map_or(0.0, |s| s.c * y[V_S] * y[V_S]),
            w_ext: y[W_EXT],
            w_loss: y[W_LOSS],
            e_gate: self.e_gate,
            n_events: self.n_events,
            n_impacts: self.n_impacts,
            x_slider: y[X_S],
            force_on_b,
            k_mesh,
        })
    }

    /// The energy account at state y.
    pub fn energy(&self, y: &State) -> Result<Energy, LawOutOfRange> {
        let (balance, e_kin, e_el) = self.energy_terms(y)?;
        Ok(Energy {
            e_kin,
            e_el,
            residual: balance - self.e_start,
        })
    }

    /// Components under error control: the slider's two only when there is one.
    pub fn n_controlled(&self) -> usize {
        if self.slider.is_some() {
            N_CONTROLLED
        } else {
            4
        }
    }

    /// Absolute error tolerances of the controlled components at a relative tolerance: 1 rad
    /// for the angle and 1 rad/s for w_A (relative control takes over above). The penetration's
    /// scale is the static penetration of one pair under the contact force that the current
    /// torques imply (floor 1e-12 m), so dte stays under control from milli-newton to mega-newton
    /// loads; the mesh velocity's scale is that penetration times the mesh's natural frequency
    /// there, the velocity of a vibration of that amplitude. The slider's scales are its static
    /// deflection under that force and the same deflection at its own frequency.
    pub fn abs_tol(&self, rel_tol: f64) -> [f64; N_CONTROLLED] {
        let g = &self.geo;
        let force = self.loads.tau_a.abs() / g.r_ab + self.loads.tau_b.abs() / g.r_bb;
        let law = self.compliance();
        let delta = match law {
            Some(l) if force > 0.0 => l.static_delta(force),
            _ => 0.0,
        };
        let delta = if delta.is_finite() {
            delta.max(1e-12)
        } else {
            1e-12
        };
        let mid = 0.5 * (g.s_a + g.s_b);
        let k = law.map_or(0.0, |l| l.stiffness(delta, mid).unwrap_or(0.0));
        let omega = (k * (g.r_ab * g.r_ab / self.j_a + g.r_bb * g.r_bb / self.j_b)).sqrt();
        let velocity = (delta * omega).max(1e-12);
        let (x, vx) = match self.slider {
            Some(s) => {
                let x = (force * self.sin_a / s.k).max(1e-12);
                (x, (x * s.frequency()).max(1e-12))
            }
            None => (1.0, 1.0),
        };
        [
            rel_tol,
            rel_tol * delta,
            rel_tol,
            rel_tol * velocity,
            rel_tol * x,
            rel_tol * vx,
        ]
    }
}

fn other(f: Flank) -> Flank {
    match f {
        Flank::Forward => Flank::Backward,
        Flank::Backward => Flank::Forward,
    }
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
                ..Inputs::default()
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
        let o = m.readout(&y).unwrap();
        assert_eq!((o.flank_force[0], o.flank_pairs[0]), (0.0, 2));
    }

    /// A jump of a pair on the idle flank leaves the right-hand side as it was, and says so (the
    /// driver then continues its step); a jump of a carrying pair does not.
    #[test]
    fn only_a_jump_that_carries_no_force_is_smooth() {
        let (p, i) = paper();
        let (m, y) = Mesh::new(&p, &i).unwrap();
        let mut dy = [0.0; NY];
        m.rhs(&y, &mut dy).unwrap();
        for e in [EventFn::Top(2), EventFn::Bottom(2), EventFn::Bottom(3)] {
            let (mut m2, mut y2) = (m.clone(), y);
            assert!(m2.handle_event(e.index(), &mut y2).unwrap().smooth, "{e:?}");
            let mut dy2 = [0.0; NY];
            m2.rhs(&y2, &mut dy2).unwrap();
            assert_eq!((y2, dy2), (y, dy), "{e:?}");
        }
        let mut m2 = m.clone();
        assert!(m2.carrying(0));
        assert!(
            !m2.handle_event(EventFn::Top(0).index(), &mut y.clone())
                .unwrap()
                .smooth
        );
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
                c_load: 0.0,
                ..Params::default()
            };
            // No external torque: the wheels' power is the mesh's.
            let no_drive = Inputs {
                tau_A: 0.0,
                ..Inputs::default()
            };
            let (m, y) = Mesh::new(&p, &no_drive).unwrap();
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
            chi: 0.0,
            mu: 0.0,
            ..Params::default()
        };
        let (m, y) = Mesh::new(&p, &Inputs::default()).unwrap();
        let o = m.readout(&y).unwrap();
        let f = o.flank_force[0];
        assert_eq!(o.p_loss, 0.0);
        // Without friction the torques are the normal force times the base radii exactly.
        assert!((o.tq_a + f * m.geo.r_ab).abs() <= 1e-12 * f);
        assert!((o.tq_b - f * m.geo.r_bb).abs() <= 1e-12 * f);
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

    /// rig-and-modes §1 end to end: the vector force of every carrying pair (F_B_x, F_B_y of
    /// the outputs, pair by pair), taken at B's contact point built from the spec's vectors
    /// (forward K_B - s_B u, backward K_B' - s_B u_b), has the moment about O_B that the
    /// right-hand side applies to B, and its opposite at A's contact point (K_A + s_A u) the
    /// moment it applies to A (interface frame: theta_A = -psi_A, theta_B = psi_B). Both flanks,
    /// with friction and damping, compliant and rigid, with double and single contact. Only
    /// rounding separates them: sums of products of lengths below 0.5 m and forces, 1e-12.
    #[test]
    fn vector_forces_at_the_contact_points_give_the_torques() {
        for (contact_model, dte) in [(1, 4e-7), (1, -1e-4 - 3e-7), (2, 0.0), (2, -1e-4)] {
            for theta in [0.0, 0.004, 0.011] {
                let p = Params {
                    contact_model,
                    chi: 5.0,
                    mu: 0.3,
                    dte_start: dte,
                    w_A_start: 50.0,
                    // The flank that carries is approaching (a rigid one then locks at t = 0).
                    w_B_start: if dte < 0.0 { 34.0 } else { 33.0 },
                    ..Params::default()
                };
                let tau = if dte < 0.0 { -100.0 } else { 100.0 };
                let i = Inputs {
                    tau_A: tau,
                    ..Inputs::default()
                };
                let (mut m, mut y) = Mesh::new(&p, &i).unwrap();
                // Move A on by theta at the same penetration and re-derive the gates there.
                y[THETA_A] += theta;
                m.init_signs(&mut y);
                let (pairs, load) = m.pair_forces(&y).unwrap();
                let g = m.geo.clone();
                let (a, d) = (g.alpha_w, g.d);
                let (mut m_a, mut m_b, mut n) = (0.0, 0.0, 0);
                for k in (0..SLOTS).filter(|&k| m.carrying(k)) {
                    let f = slot_flank(k);
                    let (delta, _) = m.flank_delta(f, &y);
                    let s_a = m.s_contact(k, &y);
                    let s_b = g.l + delta - s_a;
                    let (k_b, u) = match f {
                        Flank::Forward => (
                            (d - g.r_bb * a.cos(), -g.r_bb * a.sin()),
                            (a.sin(), -a.cos()),
                        ),
                        Flank::Backward => {
                            ((d - g.r_bb * a.cos(), g.r_bb * a.sin()), (a.sin(), a.cos()))
                        }
                    };
                    // Each tooth's own contact point: they differ by the penetration along u.
                    let k_a = (g.r_ab * a.cos(), k_b.1 * -g.r_ab / g.r_bb);
                    let pt_b = (k_b.0 - s_b * u.0, k_b.1 - s_b * u.1);
                    let pt_a = (k_a.0 + s_a * u.0, k_a.1 + s_a * u.1);
                    let (fx, fy) = rig::force_on_b(f, pairs[k].0, pairs[k].1, a.sin(), a.cos());
                    m_b += (pt_b.0 - d) * fy - pt_b.1 * fx;
                    m_a += pt_a.0 * -fy - pt_a.1 * -fx;
                    n += 1;
                }
                assert!(
                    n >= 1,
                    "model {contact_model}, dte {dte}, theta {theta}: a flank carries"
                );
                let scale = 1e-9 * (load.tq_a.abs() + load.tq_b.abs());
                assert!(
                    (m_b - load.tq_b).abs() <= scale,
                    "B: {m_b} vs {}",
                    load.tq_b
                );
                assert!(
                    (-m_a - load.tq_a).abs() <= scale,
                    "A: {} vs {}",
                    -m_a,
                    load.tq_a
                );
            }
        }
    }
}
