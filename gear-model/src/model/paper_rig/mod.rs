//! The paper's rig (gear-mesh-model.md §5, rig-and-modes.md): two wheels A and B on one mesh,
//! the viscous load on B, B's bearing on the slider S, the housing's motion, and rigid contact
//! (`rigid_contact.rs`). It owns the equations of motion and reuses the mesh component.
//!
//! State (forward positive): theta_A, dte, w_A, v = d(dte)/dt, two quadratures (the external
//! work and the dissipated energy), and with a slider its displacement x_S and speed.
//! dte = rAb theta_A - rBb theta_B and its rate v = rAb w_A - rBb w_B are states of their own
//! rather than differences of two large numbers, so the penetration and the mesh velocity keep
//! full precision and are under error control however fast and far the wheels turn; theta_B
//! and w_B are derived from them.

mod rigid_contact;
pub mod statics;
#[cfg(test)]
mod tests;

use super::contact::{EventFn, Flank, SLOTS};
use super::mesh::{self, EventReport, GearMesh, Kin, LawOutOfRange, MeshLoad, Placement};
use super::pair::{MeshLaw, Pair};
use super::rig::Slider;
use super::statistics::Statistics;
use super::ModelError;
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

/// The mesh's coordinates in the rig's state.
#[inline(always)]
pub fn kin(y: &State) -> Kin {
    // The centres do not move in the plane (DX..VY).
    [
        y[THETA_A], y[DTE], y[W_A], y[DDTE], y[X_S], y[V_S], 0.0, 0.0, 0.0, 0.0,
    ]
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
    /// No torques and a still housing: the pair's damping and friction, and the load c_load.
    pub fn idle(pair: &Pair, c_load: f64) -> Loads {
        Loads {
            tau_a: 0.0,
            tau_b: 0.0,
            c_load,
            chi: pair.chi,
            mu: pair.mu,
            v_reg: pair.v_reg,
            alpha_housing: 0.0,
            a_housing_x: 0.0,
        }
    }

    fn coefficients(&self) -> mesh::Coefficients {
        mesh::Coefficients {
            chi: self.chi,
            mu: self.mu,
            v_reg: self.v_reg,
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

/// The rig's description: its pair, the wheels, how it starts, and B's bearing.
#[derive(Clone, Debug, PartialEq)]
pub struct RigSpec {
    pub pair: Pair,
    /// Moments of inertia of A and B \[kg m^2\].
    pub j_a: f64,
    pub j_b: f64,
    /// Start speeds \[rad/s\] and transmission error \[m\] (forward positive).
    pub w_a_start: f64,
    pub w_b_start: f64,
    pub dte_start: f64,
    pub slider: Option<Slider>,
    /// The statistics' start time \[s\], when they are kept.
    pub stats_start: Option<f64>,
}

impl RigSpec {
    /// The paper's rig (gear-mesh-model.md §5): its pair, J_A = 0.4 and J_B = 2 kg m^2, the
    /// running start at 100 rad/s with B rolling rigidly, no slider, no statistics.
    /// SpurGearMesh's defaults are these (`crate::table` checks it).
    pub fn paper() -> RigSpec {
        RigSpec {
            pair: Pair::paper(),
            j_a: 0.4,
            j_b: 2.0,
            w_a_start: 100.0,
            w_b_start: 100.0 / 1.5,
            dte_start: 0.0,
            slider: None,
            stats_start: None,
        }
    }
}

/// What the parameters fix besides the mesh's own configuration.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RigConfig {
    pub slider: Option<Slider>,
    j_a: f64,
    j_b: f64,
    /// 1/m_eff along the line of action (rig-and-modes §2), and reciprocals for the rigid
    /// constraint force (benches/rig_cost.rs: its divisions were a tenth of a rigid step).
    inv_m_eff: f64,
    inv_j_a: f64,
    inv_j_b: f64,
    inv_r_bb: f64,
}

/// The rig: its mesh, configuration and loads, and the accounts an FMU state saves.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PaperRig {
    pub mesh: GearMesh,
    #[serde(skip)]
    pub cfg: Arc<RigConfig>,
    pub loads: Loads,
    /// Energy brought in (or out) by mode changes at events, for the energy balance.
    pub e_gate: f64,
    pub n_events: u64,
    pub n_impacts: u64,
    pub e_start: f64,
    /// The run's statistics up to the driver's last observation (parameter `statistics`).
    pub stats: Option<Statistics>,
    /// Interpolated inputs, if the master gave input derivatives.
    pub ramp: Option<Ramp>,
    /// The dte_start a static start solved for (parameter `static_start`), kept for a saved
    /// state: its configuration is built again from it.
    pub static_dte: Option<f64>,
}

/// The mesh's configuration and state are read through the rig (`rig.geo`, `rig.sigma`).
impl std::ops::Deref for PaperRig {
    type Target = GearMesh;
    #[inline(always)]
    fn deref(&self) -> &GearMesh {
        &self.mesh
    }
}

/// What the rig shows at a state: the wheels, the mesh's readout, the accounts.
#[derive(Clone, Debug)]
pub struct Readout {
    pub theta_a: f64,
    pub theta_b: f64,
    pub w_a: f64,
    pub w_b: f64,
    pub dte: f64,
    pub mesh: mesh::MeshReadout,
    /// Dissipated power: the mesh's and the slider's damper.
    pub p_loss: f64,
    pub w_ext: f64,
    pub w_loss: f64,
    pub e_gate: f64,
    pub n_events: u64,
    pub n_impacts: u64,
    pub x_slider: f64,
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

impl PaperRig {
    /// Builds the rig and its initial state from the parameters (spec §3 initial values;
    /// rig-and-modes §2 for the rigid contact's initial mode).
    pub fn new(spec: &RigSpec, loads: Loads) -> Result<(PaperRig, State), ModelError> {
        let p = &spec.pair;
        // Geometry errors first, then the rig's own.
        let probe = super::geometry::Geometry::new(p)?;
        let slider = spec.slider;
        if let Some(s) = slider {
            Slider::new(s.k, s.c, s.m)?;
        }
        if p.law == MeshLaw::Rigid && !(spec.dte_start >= -probe.j_n && spec.dte_start <= 0.0) {
            return Err(ModelError::new(format!(
                "parameter dte_start = {} m: with rigid contact (contact_model = 2) it must lie in [-backlash_actual, 0] = [{}, 0]",
                spec.dte_start, 0.0 - probe.j_n
            )));
        }
        if let (true, Some(s)) = (probe.internal, slider) {
            return Err(ModelError::parameter(
                "slider_stiffness",
                s.k,
                "the slider S is not available for an internal pair (it is the paper rig's external pair's bearing, rig-and-modes.md section 1); set it to 0",
            ));
        }
        let theta_a = spec.dte_start / probe.r_ab;
        let mesh = GearMesh::new(p, Placement::Paper { theta_a }, slider.is_some())?;
        let geo = &mesh.geo;
        let (sin_a, _) = geo.alpha_w.sin_cos();
        let (j_a, j_b) = (spec.j_a, spec.j_b);
        let inv_m_eff = geo.r_ab * geo.r_ab / j_a
            + geo.r_bb * geo.r_bb / j_b
            + slider.map_or(0.0, |s| sin_a * sin_a / s.m);
        let v = geo.r_ab * spec.w_a_start - geo.r_bb * spec.w_b_start;
        let cfg = RigConfig {
            slider,
            j_a,
            j_b,
            inv_m_eff,
            inv_j_a: 1.0 / j_a,
            inv_j_b: 1.0 / j_b,
            inv_r_bb: 1.0 / geo.r_bb,
        };
        let mut rig = PaperRig {
            mesh,
            cfg: Arc::new(cfg),
            loads,
            e_gate: 0.0,
            n_events: 0,
            n_impacts: 0,
            e_start: 0.0,
            stats: spec.stats_start.map(Statistics::new),
            ramp: None,
            static_dte: None,
        };
        let mut y = [
            theta_a,
            spec.dte_start,
            spec.w_a_start,
            v,
            0.0,
            0.0,
            0.0,
            0.0,
            0.0,
        ];
        rig.mesh.init_signs(&kin(&y));
        if rig.rigid() {
            rig.init_rigid(&mut y);
        }
        rig.check_range(&y)
            .map_err(|e| ModelError::new(format!("initial state: {e}")))?;
        rig.e_start = rig
            .energy_terms(&y)
            .map_err(|e| ModelError::new(e.to_string()))?
            .0;
        Ok((rig, y))
    }

    /// The configuration an FMU state leaves out, from a rig built afresh from the same
    /// parameters; the teeth each slot holds follow from the saved sigma.
    pub fn restore_config(&mut self, fresh: &PaperRig) {
        self.cfg = fresh.cfg.clone();
        self.mesh.cfg = fresh.mesh.cfg.clone();
        self.mesh.describe_events = fresh.mesh.describe_events;
        let sigma = self.mesh.sigma;
        self.mesh.set_sigma(sigma);
    }

    pub fn slider(&self) -> Option<Slider> {
        self.cfg.slider
    }

    /// The number of state components in use (a prefix of `State`): no slider, no slider states.
    pub fn dim(&self) -> usize {
        if self.ramp.is_some() {
            NY
        } else if self.cfg.slider.is_some() {
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

    /// Speed of wheel B, from w_A and the mesh velocity.
    pub fn w_b(&self, y: &State) -> f64 {
        (self.geo.r_ab * y[W_A] - y[DDTE]) / self.geo.r_bb
    }

    pub fn flank_delta(&self, f: Flank, y: &State) -> (f64, f64) {
        self.mesh.flank_delta(f, &kin(y))
    }

    pub fn s_contact(&self, k: usize, y: &State) -> f64 {
        self.mesh.s_contact(k, &kin(y))
    }

    /// Right-hand side with the current modes. Errors only when the contact law leaves its range.
    pub fn rhs(&self, y: &State, dy: &mut State) -> Result<(), LawOutOfRange> {
        let (load, locked) = if self.rigid() {
            let (load, locked) = self.rigid_load(y);
            (load, locked.map(|(f, _)| f))
        } else {
            (self.mesh.compliant_load(&kin(y), None)?, None)
        };
        self.motion(y, &load, locked, dy);
        Ok(())
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
        let c = &*self.cfg;
        let dw_a = (external * l.tau_a + m.tq_a) / c.j_a + external * l.alpha_housing;
        // The wheels turn relative to the housing: its angular acceleration enters each with
        // the wheel's sense (B turns against A on an external pair, with it in a ring).
        let acc_b = (external * (l.tau_b - l.c_load * w_b) + m.tq_b) / c.j_b
            - self.geo.kappa * external * l.alpha_housing;
        let acc_x = match c.slider {
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
        let c = &*self.cfg;
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
            + l.alpha_housing * (c.j_a * w_a - g.kappa * c.j_b * w_b);
        if load.p_param != 0.0 {
            dy[W_EXT] += load.p_param;
        }
        dy[W_LOSS] = load.p_loss;
        dy[X_S] = 0.0;
        dy[V_S] = 0.0;
        dy[TIME] = 1.0;
        if let Some(s) = c.slider {
            dy[W_EXT] -= s.m * l.a_housing_x * y[V_S];
            dy[W_LOSS] += s.c * y[V_S] * y[V_S];
            dy[X_S] = y[V_S];
            dy[V_S] = acc_x;
        }
    }

    /// The penetration of each flank must stay below the segment length.
    pub fn check_state(&self, y: &State) -> Result<(), LawOutOfRange> {
        self.mesh.check_state(&kin(y))
    }

    /// Checks both limits at a state (the initial one).
    pub fn check_range(&self, y: &State) -> Result<(), LawOutOfRange> {
        let mut dy = [0.0; NY];
        self.rhs(y, &mut dy)?;
        self.check_state(y)
    }

    /// All event margins: the mesh's, with a rigid lock's constraint force as its release
    /// (the first `n_event_fns()` entries).
    pub fn event_margins(&self, y: &State, out: &mut [f64]) {
        self.mesh.event_margins(&kin(y), out);
        if self.rigid() {
            self.fill_rigid_release(y, out);
        }
    }

    pub fn event_margins_and_rates(
        &self,
        y: &State,
        dy: &State,
        margins: &mut [f64],
        rates: &mut [f64],
    ) {
        self.mesh
            .event_margins_and_rates(&kin(y), &kin(dy), margins, rates);
        if self.rigid() {
            self.fill_rigid_release(y, margins);
        }
    }

    pub fn margin(&self, e: EventFn, y: &State) -> f64 {
        match e {
            EventFn::Rel(f) if self.rigid() => {
                let v = self.constraint_force(f, y).map_or(-1.0, |c| c.0);
                if self.sign[e.index()] {
                    v
                } else {
                    -v
                }
            }
            _ => self.mesh.margin(e, &kin(y)),
        }
    }

    /// Applies the event whose function crossed at the state y, and returns what happened. A
    /// rigid impact changes the speeds in y.
    pub fn handle_event(&mut self, i: usize, y: &mut State) -> Result<EventReport, LawOutOfRange> {
        let before = self.elastic_energy(y)?;
        let motion_before = self.rigid_motion_modes();
        let e = EventFn::from_index(i);
        let mut report = match e {
            EventFn::Pen(f) if self.rigid() => EventReport {
                what: self.impact(f, y),
                smooth: false,
            },
            EventFn::Rel(f) if self.rigid() => EventReport {
                what: self.release(f, y),
                smooth: false,
            },
            _ => self.mesh.handle_event(i, &kin(y)),
        };
        // A pair switch moves the friction arms and the split of a rigid lock.
        if matches!(e, EventFn::Top(_) | EventFn::Bottom(_) | EventFn::Gate(_)) {
            if let Some(r) = self.recheck_lock(y) {
                report.what = mesh::describe!(self.mesh, "{}; {r}", report.what);
            }
        }
        self.n_events += 1;
        self.e_gate += self.elastic_energy(y)? - before;
        if motion_before.is_some() {
            report.smooth = motion_before == self.rigid_motion_modes();
        }
        Ok(report)
    }

    /// A master changed inputs or tunable parameters: the right-hand side changes from here on.
    pub fn set_loads(&mut self, loads: Loads, y: &mut State) {
        self.loads = loads;
        self.mesh.set_coefficients(loads.coefficients(), &kin(y));
        // A lock the new loads would make pull is released: a mode change, counted as one.
        if self.rigid() && self.recheck_lock(y).is_some() {
            self.n_events += 1;
        }
    }

    /// Bound on the highest natural frequency \[rad/s\]: the mesh stiffness times the reduced
    /// inverse inertia along the line of action, plus the slider on its spring (the trace of
    /// the coupled system bounds its largest eigenvalue); 0 without contact or slider.
    pub fn vibration_frequency(&self, y: &State) -> f64 {
        let slider = self.cfg.slider.map_or(0.0, |s| s.k / s.m);
        (self.mesh.mesh_stiffness(&kin(y)) * self.cfg.inv_m_eff + slider).sqrt()
    }

    /// Kinetic energy of the wheels and the slider.
    fn kinetic_energy(&self, y: &State) -> f64 {
        let c = &*self.cfg;
        let w_b = self.w_b(y);
        let slider = c.slider.map_or(0.0, |s| 0.5 * s.m * y[V_S] * y[V_S]);
        0.5 * (c.j_a * y[W_A] * y[W_A] + c.j_b * w_b * w_b) + slider
    }

    /// Elastic energy of the carrying pairs and of the slider's spring.
    pub fn elastic_energy(&self, y: &State) -> Result<f64, LawOutOfRange> {
        let e = self.cfg.slider.map_or(0.0, |s| 0.5 * s.k * y[X_S] * y[X_S]);
        Ok(e + self.mesh.contact_energy(&kin(y))?)
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
    fn pair_forces(&self, y: &State) -> Result<(mesh::SlotForces, MeshLoad), LawOutOfRange> {
        if !self.rigid() {
            return self.mesh.compliant_pair_forces(&kin(y));
        }
        Ok(self.rigid_pair_forces(y))
    }

    /// Total normal force of the carrying pairs at y (F_fwd + F_bwd).
    pub fn normal_force(&self, y: &State) -> Result<f64, LawOutOfRange> {
        let (pairs, _) = self.pair_forces(y)?;
        Ok((0..SLOTS)
            .filter(|&k| self.carrying(k))
            .map(|k| pairs[k].0)
            .sum())
    }

    /// What the rig shows at state y. Inlined into its callers: it runs after every
    /// communication step, and a call costs ~60 instructions.
    #[inline(always)]
    pub fn readout(&self, y: &State) -> Result<Readout, LawOutOfRange> {
        let g = &self.geo;
        let (pairs, load) = self.pair_forces(y)?;
        let m = self.mesh.readout_from(&kin(y), &pairs, &load);
        Ok(Readout {
            theta_a: y[THETA_A],
            theta_b: (g.r_ab * y[THETA_A] - y[DTE]) / g.r_bb,
            w_a: y[W_A],
            w_b: self.w_b(y),
            dte: y[DTE],
            // The right-hand side's dissipation, from the load already at hand.
            p_loss: load.p_loss + self.cfg.slider.map_or(0.0, |s| s.c * y[V_S] * y[V_S]),
            mesh: m,
            w_ext: y[W_EXT],
            w_loss: y[W_LOSS],
            e_gate: self.e_gate,
            n_events: self.n_events,
            n_impacts: self.n_impacts,
            x_slider: y[X_S],
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

    /// Takes the piece [t0, t1] of a step between events into the statistics, if kept.
    pub fn observe(
        &mut self,
        t0: f64,
        t1: f64,
        y: &dyn Fn(f64) -> State,
    ) -> Result<(), LawOutOfRange> {
        let Some(mut s) = self.stats.take() else {
            return Ok(());
        };
        let r = self.add_statistics(&mut s, t0, t1, y);
        self.stats = Some(s);
        r
    }

    /// Adds [t0, t1] to statistics `s` (the modes hold over it).
    pub fn add_statistics(
        &self,
        s: &mut Statistics,
        t0: f64,
        t1: f64,
        y: &dyn Fn(f64) -> State,
    ) -> Result<(), LawOutOfRange> {
        s.add(self.mesh.contact_modes(), t0, t1, &|t| y(t)[DTE], &|t| {
            self.normal_force(&y(t))
        })
    }

    /// Components under error control: the slider's two only when there is one.
    pub fn n_controlled(&self) -> usize {
        if self.cfg.slider.is_some() {
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
        let c = &*self.cfg;
        let force = self.loads.tau_a.abs() / g.r_ab + self.loads.tau_b.abs() / g.r_bb;
        let (delta, k) = self.mesh.static_scale(force);
        let omega = (k * (g.r_ab * g.r_ab / c.j_a + g.r_bb * g.r_bb / c.j_b)).sqrt();
        let velocity = (delta * omega).max(1e-12);
        let (x, vx) = match c.slider {
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
