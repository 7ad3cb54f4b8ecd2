//! One gear mesh as a component (spec §3-§6): its geometry, contact law and deviations, the
//! four contact objects f1, f2, b1, b2 and their modes, the forces they apply, the event
//! functions and what happens at an event, and the readout. It knows no inertia and no FMI: a
//! rig (the paper's two-wheel rig, the gear train) owns the equations of motion, hands the mesh
//! its coordinates (`Kin`) and applies the torques the mesh returns.
//!
//! Modes (which pairs are gated, which flanks touch and press) change only in `handle_event`,
//! at events the driver has located: inside an integration step the forces are smooth.

mod events;
mod forces;
mod lumped;
mod readout;

pub use events::EventReport;
pub use forces::{LawOutOfRange, MeshLoad, SlotForces, SEGMENT_LIMIT};
pub use readout::MeshReadout;

use super::contact::{self, slot_flank, EventFn, Flank, N_EVENTS, SLOTS};
use super::deviations::Deviations;
use super::geometry::Geometry;
use super::law::{JohnsonLaw, Law};
use super::pair::{Cut, Lumped, MeshLaw, Pair};
use super::tooth_structure::structure_law;
use super::ModelError;
use serde::{Deserialize, Serialize};
use std::sync::Arc;

/// What a mesh reads of its rig, in its own paper frame with forward-positive angles (the
/// single mesh's interface frame): A's angle since the start, the transmission error, A's
/// speed, the error's rate, a displacement of B's bearing along O_A O_B and its speed (the
/// paper rig's slider; 0 elsewhere), and the centres' relative displacement Dp_A - Dp_B and
/// its rate in the mesh's own frame (lateral.md §3, a mesh with `moving_centres`; 0
/// elsewhere).
pub type Kin = [f64; NK];
pub const NK: usize = 10;
pub const THETA_A: usize = 0;
pub const DTE: usize = 1;
pub const W_A: usize = 2;
pub const DDTE: usize = 3;
pub const X_S: usize = 4;
pub const V_S: usize = 5;
pub const DX: usize = 6;
pub const DY: usize = 7;
pub const VX: usize = 8;
pub const VY: usize = 9;

/// An event's description, formatted only when someone reads it (`describe_events`):
/// formatting every pair switch cost 3 % of a base scene (callgrind, high-speed).
macro_rules! describe {
    ($self:expr, $($arg:tt)*) => {
        if $self.describe_events {
            format!($($arg)*)
        } else {
            String::new()
        }
    };
}
pub(crate) use describe;

/// The contact law (`contact_model`).
#[derive(Clone, Debug, PartialEq)]
pub enum ContactModel {
    /// A compliant law with Hunt-Crossley damping: Johnson's line contact (the paper's mesh) or
    /// the tooth structure with Weber's local contact (contact model 3).
    Compliant(Law),
    /// A unilateral constraint with Newton impacts (the paper rig's; its dynamics live there).
    /// `two_sided`: zero backlash and no slider, so both flanks touch at once and N may take
    /// either sign.
    Rigid { restitution: f64, two_sided: bool },
    /// The lumped spring-damper on each flank (`contact_model = 4`, `lumped.rs`).
    Lumped(Lumped),
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

/// The mesh's coefficients a master may change between steps.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Coefficients {
    pub chi: f64,
    pub mu: f64,
    pub v_reg: f64,
}

impl Coefficients {
    pub fn new(p: &Pair) -> Coefficients {
        Coefficients {
            chi: p.chi,
            mu: p.mu,
            v_reg: p.v_reg,
        }
    }
}

/// Where the teeth are at the start, which fixes each object's pair.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Placement {
    /// The single mesh's start (spec §3): f1 touches at a, then A turned to `theta_a`.
    Paper { theta_a: f64 },
    /// Tooth 0 of A has its axis at `chi_a` in the mesh frame (gear-train.md §3) and A's
    /// angle is 0; A's tooth n meets B's tooth n + `b_fwd` on the forward flank and B's tooth
    /// n + `b_bwd` on the backward one.
    Teeth { chi_a: f64, b_fwd: i64, b_bwd: i64 },
}

/// Which teeth a slot holds, from its sigma: on the forward flank A's tooth n sits at
/// sigma = `s_fwd` + n p_b, on the backward one at `s_bwd` - n p_b; B's teeth follow with the
/// offsets.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ToothOrigin {
    pub s_fwd: f64,
    pub b_fwd: i64,
    pub s_bwd: f64,
    pub b_bwd: i64,
}

/// What the parameters fix: geometry, contact law, deviations, the objects in use.
/// An FMU state leaves it out; it is built again from the parameters, to the same bits.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MeshConfig {
    pub geo: Geometry,
    pub law: ContactModel,
    pub backlash: f64,
    pub sin_a: f64,
    pub cos_a: f64,
    pub present: [bool; SLOTS],
    /// Shape deviations (none: pairs on a flank share delta, and the flank's Pen and Rel
    /// events serve them all).
    pub dev: Option<Arc<Deviations>>,
    /// The rig moves B's bearing (the paper rig's slider): the force on B along O_A O_B is
    /// wanted, and a rigid lock on one flank no longer holds the other one open.
    pub slider: bool,
    /// The rig moves both centres in the plane (a train's lateral bodies, lateral.md §3): the
    /// penetrations and the sliding speeds gain their relative motion, and the force on B is
    /// wanted in full.
    pub moving_centres: bool,
    pub origin: ToothOrigin,
    /// 1 where a pair's gate opens a penetration after s_a (its contact point moves in by
    /// delta), 0 for the lumped mesh, whose pairs are counted at their rigid positions.
    pub gate_shift: f64,
}

/// The mesh: its configuration (`cfg`, read through Deref as `mesh.geo`, `self.law`...) and
/// the state of its contact objects and modes, which an FMU state saves.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GearMesh {
    /// Shared, never changed after construction: a simulation is copied before every step
    /// that integrates, and copying the configuration was a sixth of that copy.
    #[serde(skip)]
    pub cfg: Arc<MeshConfig>,
    pub coef: Coefficients,
    /// s_A = sigma + dir rAb theta_A for each slot.
    pub sigma: [f64; SLOTS],
    /// Recorded sign of every event function (true: positive side). Gate signs are the gating
    /// modes; Pen and Rel signs make a flank carry force. Top and Bottom are always positive
    /// between events. With rigid contact a Pen sign means "locked on that flank" and its Rel
    /// function is the constraint force.
    pub sign: [bool; N_EVENTS],
    /// The pitch deviation of the teeth each slot holds (changes when the slot jumps; derived
    /// from sigma, see `set_sigma`).
    #[serde(skip)]
    pitch_e: [f64; SLOTS],
    /// `handle_event` describes what happened; off, it leaves the text empty. The FMI layer
    /// turns it on while logEvents is.
    #[serde(skip)]
    pub describe_events: bool,
}

impl std::ops::Deref for GearMesh {
    type Target = MeshConfig;
    #[inline(always)]
    fn deref(&self) -> &MeshConfig {
        &self.cfg
    }
}

impl GearMesh {
    /// Builds the mesh from one pair's parameters and where its teeth start; `slider`: the rig
    /// moves B's bearing. The recorded signs are set by `init_signs` once the rig has a state.
    pub fn new(p: &Pair, placement: Placement, slider: bool) -> Result<GearMesh, ModelError> {
        Self::with_geometry(p, Geometry::new(p)?, placement, slider)
    }

    /// The same with the pair's geometry at hand (a planet's, at the distance its axes are).
    pub fn with_geometry(
        p: &Pair,
        mut geo: Geometry,
        placement: Placement,
        slider: bool,
    ) -> Result<GearMesh, ModelError> {
        let law = match p.law {
            MeshLaw::Rigid => ContactModel::Rigid {
                restitution: p.restitution,
                two_sided: geo.j_n == 0.0 && !slider && p.backward_contacts,
            },
            MeshLaw::ToothStructure if geo.internal => {
                return Err(ModelError::new(
                    "parameter contact_model = 3: the tooth structure is not available for an internal pair yet (the ring tooth's structure is not specified); use contact_model 1 or 2".into(),
                ))
            }
            MeshLaw::ToothStructure => {
                let Cut::Standard(rack) = &p.cut else {
                    return Err(ModelError::new(
                        "parameter contact_model = 3: the tooth structure needs the standard geometry (geometry = 2, not 1)".into(),
                    ));
                };
                let law = structure_law(p, rack, &geo)?;
                geo.warnings.extend(law.warnings(&geo));
                ContactModel::Compliant(Law::Structure(Arc::new(law)))
            }
            MeshLaw::Johnson => ContactModel::Compliant(Law::Johnson(JohnsonLaw::new(geo.l, geo.kappa, geo.e_star, p.width))),
            MeshLaw::Lumped(l) => {
                if p.mu > 0.0 {
                    geo.warnings.push(format!(
                        "parameter mu = {}: the lumped mesh (contact_model = 4) has no friction; mu is ignored",
                        p.mu
                    ));
                }
                ContactModel::Lumped(l)
            }
        };
        let dev = Deviations::new(p, &geo)?.map(Arc::new);
        if dev.is_some() && p.law == MeshLaw::Rigid {
            return Err(ModelError::new(
                "parameter contact_model = 2: shape deviations (tip relief, eccentricity, pitch errors) need a compliant contact model (1 or 3); the rigid contact has no penetration for them to add to".into(),
            ));
        }
        if dev.is_some() && matches!(p.law, MeshLaw::Lumped(_)) {
            return Err(ModelError::new(
                "parameter contact_model = 4: shape deviations (tip relief, eccentricity, pitch errors) need a model that tracks the teeth (1 or 3); the lumped mesh does not".into(),
            ));
        }
        let mut present = [false; SLOTS];
        present[0] = true;
        present[1] = geo.m_c >= 2;
        present[2] = p.backward_contacts;
        present[3] = p.backward_contacts && geo.m_c >= 2;
        let (init, theta_a, origin) = match placement {
            Placement::Paper { theta_a } => {
                let init = contact::initial_sigmas(&geo);
                // f1 at s_a holds A0/B0; b1 holds A1/B0, so A0 would sit one pitch above it.
                let origin = ToothOrigin {
                    s_fwd: geo.s_a,
                    b_fwd: 0,
                    s_bwd: init[2] + geo.p_b,
                    b_bwd: -1,
                };
                (init, theta_a, origin)
            }
            Placement::Teeth {
                chi_a,
                b_fwd,
                b_bwd,
            } => {
                // gear-train.md §3: A's forward root of tooth n at chi_a - n dA - tA/2, so
                // s_A = rAb (alpha_w - phiA) = s_fwd + n p_b; backward s_A = s_bwd - n p_b.
                let s_fwd = geo.r_ab * (geo.alpha_w - chi_a + 0.5 * geo.t_a);
                let s_bwd = geo.r_ab * (geo.alpha_w + chi_a + 0.5 * geo.t_a);
                // f1 holds A0 and f2 A1, b1 A1 and b2 its neighbour, as in the single mesh.
                let b1 = s_bwd - geo.p_b;
                let init = [s_fwd, s_fwd + geo.p_b, b1, b1 - geo.p_b];
                let origin = ToothOrigin {
                    s_fwd,
                    b_fwd,
                    s_bwd,
                    b_bwd,
                };
                (init, 0.0, origin)
            }
        };
        let mut sigma = [0.0; SLOTS];
        for k in 0..SLOTS {
            if present[k] {
                sigma[k] = contact::wrap_into_window(&geo, init[k], slot_flank(k).dir(), theta_a);
            }
        }
        let (sin_a, cos_a) = geo.alpha_w.sin_cos();
        let gate_shift = if matches!(law, ContactModel::Lumped(_)) {
            0.0
        } else {
            1.0
        };
        let mut mesh = GearMesh {
            cfg: Arc::new(MeshConfig {
                backlash: geo.j_n,
                sin_a,
                cos_a,
                law,
                geo,
                present,
                dev,
                slider,
                moving_centres: false,
                origin,
                gate_shift,
            }),
            coef: Coefficients::new(p),
            sigma,
            sign: [true; N_EVENTS],
            pitch_e: [0.0; SLOTS],
            describe_events: true,
        };
        mesh.set_sigma(sigma);
        mesh.coef = mesh.own_coefficients(mesh.coef);
        Ok(mesh)
    }

    /// Sets the slots' sigma (at t = 0, or from a saved state) and the teeth they hold.
    pub fn set_sigma(&mut self, sigma: [f64; SLOTS]) {
        self.sigma = sigma;
        for k in 0..SLOTS {
            self.update_teeth(k);
        }
    }

    pub(crate) fn update_teeth(&mut self, k: usize) {
        if let Some(d) = self.dev.as_deref() {
            let f = slot_flank(k);
            self.pitch_e[k] = d.pitch_offset(f, self.teeth(k));
        }
    }

    /// The teeth of A and B that slot k holds (deviations.rs numbers them).
    pub fn teeth(&self, k: usize) -> (i64, i64) {
        let (o, p_b) = (&self.origin, self.geo.p_b);
        match slot_flank(k) {
            Flank::Forward => {
                let n = ((self.sigma[k] - o.s_fwd) / p_b).round() as i64;
                (n, n + o.b_fwd)
            }
            Flank::Backward => {
                let n = ((o.s_bwd - self.sigma[k]) / p_b).round() as i64;
                (n, n + o.b_bwd)
            }
        }
    }

    /// The teeth slot k holds, for messages (A's, B's).
    pub(crate) fn teeth_text(&self, k: usize) -> String {
        let (a, b) = self.teeth(k);
        format!(
            "teeth A{}/B{}",
            a.rem_euclid(self.geo.z_a as i64),
            b.rem_euclid(self.geo.z_b as i64)
        )
    }

    pub fn present(&self, k: usize) -> bool {
        self.present[k]
    }

    pub(crate) fn flank_present(&self, f: Flank) -> bool {
        match f {
            Flank::Forward => true,
            Flank::Backward => self.present[2],
        }
    }

    pub(crate) fn damped(&self) -> bool {
        self.coef.chi > 0.0
    }

    pub fn rigid(&self) -> bool {
        matches!(self.law, ContactModel::Rigid { .. })
    }

    pub(crate) fn two_sided(&self) -> bool {
        matches!(
            self.law,
            ContactModel::Rigid {
                two_sided: true,
                ..
            }
        )
    }

    /// Penetration of a flank and its rate: forward delta = dte - x_S sin(alpha_w), backward
    /// delta = -backlash - dte - x_S sin(alpha_w) (moving B away opens both flanks), with the
    /// backlash at the actual centre distance; moving centres add `centre_gain`.
    #[inline(always)]
    pub fn flank_delta(&self, f: Flank, y: &Kin) -> (f64, f64) {
        if self.moving_centres {
            self.flank_delta_of::<true>(f, y)
        } else {
            self.flank_delta_of::<false>(f, y)
        }
    }

    /// `flank_delta` with `moving_centres` known (MOVING) where the caller tested it once.
    #[inline(always)]
    pub(crate) fn flank_delta_of<const MOVING: bool>(&self, f: Flank, y: &Kin) -> (f64, f64) {
        let ddte = y[DDTE];
        let (x, vx) = (y[X_S] * self.sin_a, y[V_S] * self.sin_a);
        let (delta, rate) = match f {
            Flank::Forward => (y[DTE] - x, ddte - vx),
            Flank::Backward => (-self.backlash - y[DTE] - x, -ddte - vx),
        };
        if MOVING {
            let gain = self.centre_gain(f, y[DX], y[DY]);
            return (delta + gain, rate + self.centre_gain(f, y[VX], y[VY]));
        }
        (delta, rate)
    }

    /// (Dp_A - Dp_B) . n of flank f for a relative displacement (dx, dy) in the paper frame:
    /// n_f = (sin, -cos), n_b = (sin, cos), the directions of the normal force on B.
    #[inline(always)]
    pub fn centre_gain(&self, f: Flank, dx: f64, dy: f64) -> f64 {
        match f {
            Flank::Forward => dx * self.sin_a - dy * self.cos_a,
            Flank::Backward => dx * self.sin_a + dy * self.cos_a,
        }
    }

    /// The second derivative of flank f's penetration from the rig's accelerations `dy` (the
    /// time derivative of a `Kin`): what the release events' rates need.
    #[inline(always)]
    pub(crate) fn flank_acceleration(&self, f: Flank, dy: &Kin) -> f64 {
        let a = f.dir() * dy[DDTE] - self.sin_a * dy[V_S];
        if self.moving_centres {
            return a + self.centre_gain(f, dy[VX], dy[VY]);
        }
        a
    }

    /// The centres' relative speed along flank f's tangent (forward (cos, sin), backward
    /// (-cos, sin), friction's direction on B): A's centre relative to B's, which adds to the
    /// sliding speed A's surface has relative to B's.
    #[inline(always)]
    pub(crate) fn centre_slip(&self, f: Flank, y: &Kin) -> f64 {
        if !self.moving_centres {
            return 0.0;
        }
        match f {
            Flank::Forward => y[VX] * self.cos_a + y[VY] * self.sin_a,
            Flank::Backward => -y[VX] * self.cos_a + y[VY] * self.sin_a,
        }
    }

    /// The mesh with its centres moving in the plane (`moving_centres`).
    pub fn with_moving_centres(mut self) -> GearMesh {
        Arc::make_mut(&mut self.cfg).moving_centres = true;
        self
    }

    /// Speed of wheel B, from w_A and the mesh velocity.
    #[inline(always)]
    pub fn w_b(&self, y: &Kin) -> f64 {
        (self.geo.r_ab * y[W_A] - y[DDTE]) / self.geo.r_bb
    }

    #[inline(always)]
    pub fn s_contact(&self, k: usize, y: &Kin) -> f64 {
        self.sigma[k] + slot_flank(k).dir() * self.geo.r_ab * y[THETA_A]
    }

    /// A flank carries force: compliant, touching and, when damped, pressing (Hunt-Crossley
    /// force > 0); rigid, locked on it.
    pub fn flank_on(&self, f: Flank) -> bool {
        let pen = self.sign[EventFn::Pen(f).index()];
        pen && (self.rigid() || !self.damped() || self.sign[EventFn::Rel(f).index()])
    }

    pub(crate) fn gated(&self, k: usize) -> bool {
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
        if self.pairs_untracked() {
            // A pair is always on the segment (a contact ratio above one): a flank on carries.
            let backward = self.flank_present(Flank::Backward) && self.flank_on(Flank::Backward);
            return (self.flank_on(Flank::Forward) || backward, backward);
        }
        let any = (0..SLOTS).any(|k| self.carrying(k));
        let backward = (0..SLOTS).any(|k| slot_flank(k) == Flank::Backward && self.carrying(k));
        (any, backward)
    }

    /// The rigid contact's locked flank, if any.
    pub fn locked(&self) -> Option<Flank> {
        if !self.rigid() {
            return None;
        }
        [Flank::Forward, Flank::Backward]
            .into_iter()
            .find(|&f| self.flank_present(f) && self.sign[EventFn::Pen(f).index()])
    }

    /// The objects of flank f are not tracked: a one-sided rigid lock on the other flank with
    /// no slider holds f exactly a backlash open, so its pair switches change nothing. They are
    /// brought up to date when the lock ends (the rig's `resume_tracking`).
    pub fn parked(&self, f: Flank) -> bool {
        match self.law {
            ContactModel::Rigid {
                two_sided: false, ..
            } => !self.slider && self.sign[EventFn::Pen(other(f)).index()],
            _ => false,
        }
    }

    /// The coefficients this mesh's law uses: the lumped mesh has its own damper and no
    /// friction, so Hunt-Crossley's chi and mu read 0 in it (no release events, no friction).
    fn own_coefficients(&self, coef: Coefficients) -> Coefficients {
        match self.law {
            ContactModel::Lumped(_) => Coefficients {
                chi: 0.0,
                mu: 0.0,
                ..coef
            },
            _ => coef,
        }
    }

    /// The lumped mesh's spring-damper, if it is one.
    pub fn lumped(&self) -> Option<&Lumped> {
        match &self.law {
            ContactModel::Lumped(l) => Some(l),
            _ => None,
        }
    }

    /// The compliant law (none with rigid contact).
    pub fn compliance(&self) -> Option<&Law> {
        match &self.law {
            ContactModel::Compliant(l) => Some(l),
            ContactModel::Rigid { .. } | ContactModel::Lumped(_) => None,
        }
    }

    /// New coefficients from a master: a release function comes into use when damping does.
    pub fn set_coefficients(&mut self, coef: Coefficients, y: &Kin) {
        let was_damped = self.damped();
        self.coef = self.own_coefficients(coef);
        if self.rigid() {
            return;
        }
        if !was_damped {
            self.rates_jumped(y);
        }
    }

    /// The signs of the functions that read the rates, from y after the rates jumped (a
    /// speed-driven body's new input) or damping came on.
    pub fn rates_jumped(&mut self, y: &Kin) {
        if self.rigid() || !self.damped() {
            return;
        }
        for f in [Flank::Forward, Flank::Backward] {
            self.set_sign(EventFn::Rel(f), y);
        }
        for k in 0..SLOTS {
            self.set_sign(EventFn::PairRel(k), y);
        }
    }
}

pub fn other(f: Flank) -> Flank {
    match f {
        Flank::Forward => Flank::Backward,
        Flank::Backward => Flank::Forward,
    }
}
