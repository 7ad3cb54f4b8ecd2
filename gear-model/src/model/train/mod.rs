//! The gear train (gear-train.md, planetary.md §3-§4): rotating bodies joined by torsional
//! shafts and gear meshes, the housing as body 0, carriers with planets, and loops of meshes.
//! It owns the equations of motion and reuses the mesh component for every mesh.
//!
//! State: the two quadratures (external work, dissipated energy), then each coordinate and
//! its rate (`kinematics`): the free bodies' forward angles, then the independent meshes'
//! transmission errors dte_m (their forward penetrations) and the shafts' twists. As in the
//! single mesh, the penetrations are states of their own, and a mesh that closes a loop has
//! its dte from them: every dte keeps full precision however far the bodies turn. The
//! bodies' angles and speeds follow by the inverse linear map.

pub mod bearings;
pub mod damping;
pub mod kinematics;
mod lateral;
pub mod placement;
pub mod statics;
pub mod topology;

use super::contact::{EventFn, N_EVENTS};
use super::mesh::{self, EventReport, GearMesh, Kin, LawOutOfRange};
use super::pair::MeshLaw;
use super::statistics::Statistics;
use super::ModelError;
use crate::driver::Vector;
use kinematics::{Coord, Coordinates, Source};
use nalgebra::{DMatrix, DVector};
use serde::{Deserialize, Serialize};
use std::sync::Arc;
pub use topology::{
    body_name, Body, Edge, Lateral, MeshPlace, Planet, Ripple, Shaft, Structure, TrainSpec,
    HOUSING, MAX_BODIES, MAX_COORDS, MAX_MESHES, MAX_SHAFTS,
};

/// The quadratures, then each coordinate and its rate: the rotations, then the lateral bodies'
/// translations.
pub const NY: usize = 2 + 2 * MAX_COORDS;
pub type State = crate::driver::wide::Wide<NY>;
/// The state of a train with at most one coordinate per body (every train without lateral
/// bodies, and lateral ones that fit): what the driver steps such a train on.
pub const NY_COMPACT: usize = 2 + 2 * MAX_BODIES;
pub type CompactState = crate::driver::wide::Wide<NY_COMPACT>;
pub const W_EXT: usize = 0;
pub const W_LOSS: usize = 1;
/// Model Exchange's event indicators: every mesh's event functions, mesh m's from m N_EVENTS
/// on, for the full capacity (`Train::event_indicators`). The driver's margins are packed
/// instead: each mesh's functions in use, one after the other (`Train::event_of`).
pub const N_MARGINS: usize = MAX_MESHES * N_EVENTS;

/// The states Model Exchange reads: the state itself, for the full capacity (coordinates not
/// in use read 0). SpurGearTrain declares the compact state's to masters (`NY_COMPACT`), a
/// gearbox FMU those of its train; directional derivatives read them all.
pub const N_MASTER_STATES: usize = NY;

/// y[i] and y[i + 1], with one bounds check.
#[inline(always)]
fn pair(y: &[f64], i: usize) -> [f64; 2] {
    let p = &y[i..i + 2];
    [p[0], p[1]]
}

/// Coordinate k's place in the state (its rate follows it).
pub const fn coord_index(k: usize) -> usize {
    2 + 2 * k
}

/// What a master may change between steps: the bodies' torques, the speed-driven bodies'
/// speeds and the meshes' coefficients.
#[derive(Debug, PartialEq, Serialize, Deserialize)]
pub struct TrainLoads {
    pub tau: Vec<f64>,
    /// Each body's speed input \[rad/s\], read for the speed-driven ones.
    pub w_in: Vec<f64>,
    pub coef: Vec<mesh::Coefficients>,
}

/// How mesh m reads the bodies: A's angle relative to the mesh's carrier, theta_A -
/// `rel_a` theta_c (`carrier` is the housing's slot, where angles are 0, off a carrier), and
/// its dte.
#[derive(Clone, Debug, PartialEq)]
struct MeshLink {
    a: usize,
    b: usize,
    carrier: usize,
    rel_a: f64,
    rel_b: f64,
    /// dte from the state: dte0 + sum c (y[i] - offset) over (i, c, offset); the rate from
    /// y[i + 1].
    dte: Vec<(usize, f64, f64)>,
    dte0: f64,
}

/// What the parameters fix.
#[derive(Clone, Debug, PartialEq)]
pub struct TrainConfig {
    pub spec: TrainSpec,
    pub structure: Structure,
    pub coords: Coordinates,
    /// Absolute start angles of the bodies \[rad\].
    pub psi_start: Vec<f64>,
    /// Each planet's orbit radius \[m\] (0 off a carrier).
    pub orbit_radius: Vec<f64>,
    /// Each mesh's frame, which turns its forces into the housing's (or the carrier's) frame.
    pub frames: Vec<placement::MeshFrame>,
    /// Each mesh frame's turn from its paper frame (`bearings::frame_turn`).
    frame_turns: Vec<((f64, f64), f64)>,
    /// Each planet's pin in its carrier's frame, pin errors included \[m\] (0 off a carrier).
    pub pins: Vec<[f64; 2]>,
    links: Vec<MeshLink>,
    /// Each body's carrier slot (the housing's off a carrier) and sigma_i sigma_c.
    body_carrier: Vec<(usize, f64)>,
    /// The housing's slot in `Bodies`: right after the bodies (body 0 of the spec,
    /// `HOUSING`, is renumbered so that a train's arrays are as long as its bodies).
    housing: usize,
    /// Each shaft's ends' slots (a, b).
    shaft_ends: Vec<(usize, usize)>,
    /// Each body's inertia with its planets' orbital inertia, and its reciprocal: the
    /// right-hand side multiplies where it would divide (benches/rhs_cost.rs).
    j_eff: Vec<f64>,
    inv_j: Vec<f64>,
    /// Where each mesh's event functions start in the packed margins, and their total.
    event_start: Vec<usize>,
    /// The speed-driven bodies.
    driven: Vec<usize>,
    /// The lateral bodies, if any (lateral.md).
    lateral: Option<lateral::LateralConfig>,
}

/// The slots of the full capacity's bodies: one per body and the housing's.
pub const SLOTS: usize = MAX_BODIES + 1;

/// The bodies' forward angles and speeds at a state, body i in slot i; the housing's slot
/// (`TrainConfig::housing`, right after the bodies) and those past it stay 0. N: the slots
/// held, at least the bodies' and the housing's (`by_slots!`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bodies<const N: usize = SLOTS> {
    pub theta: [f64; N],
    pub w: [f64; N],
}

impl<const N: usize> Default for Bodies<N> {
    fn default() -> Self {
        Bodies {
            theta: [0.0; N],
            w: [0.0; N],
        }
    }
}

/// Calls `$self.$f::<N>(args)` with the fewest slots N that hold the train's bodies and the
/// housing: the right-hand side and the event functions zero and copy arrays of the bodies
/// in use, not of the full capacity (what is not used costs nothing per step).
macro_rules! by_slots {
    ($self:ident . $f:ident ( $($arg:expr),* )) => {
        match $self.cfg.housing + 1 {
            0..=4 => $self.$f::<4>($($arg),*),
            5..=8 => $self.$f::<8>($($arg),*),
            _ => $self.$f::<SLOTS>($($arg),*),
        }
    };
}

mod copy;
mod events;
mod modal;
mod readout;
mod shafts;
mod tolerance;

/// The train (`copy.rs` clones it).
#[derive(Debug, PartialEq, Serialize, Deserialize)]
pub struct Train {
    #[serde(skip)]
    pub cfg: Arc<TrainConfig>,
    pub meshes: Vec<GearMesh>,
    pub loads: TrainLoads,
    pub e_gate: f64,
    pub n_events: u64,
    pub e_start: f64,
    /// Each mesh's statistics (parameter `statistics`).
    pub stats: Option<Vec<Statistics>>,
    /// The deflections a static start solved for (parameter `static_start`), kept for a saved
    /// state.
    pub static_start: Option<statics::StartDeflections>,
    /// The modes that limit an explicit method's steps, where the flanks set them (`modal`).
    pub modes: Option<modal::Modes>,
}

impl Default for TrainConfig {
    fn default() -> Self {
        TrainConfig {
            spec: TrainSpec {
                bodies: vec![],
                angle_start: 0.0,
                shafts: vec![],
                meshes: vec![],
            },
            structure: Structure {
                frame: vec![],
                sense: vec![],
                mesh_sense: vec![],
                shaft_sense: vec![],
                uses_housing: false,
                carriers: vec![],
            },
            coords: Coordinates::default(),
            psi_start: vec![],
            orbit_radius: vec![],
            frames: vec![],
            frame_turns: vec![],
            pins: vec![],
            links: vec![],
            body_carrier: vec![],
            j_eff: vec![],
            inv_j: vec![],
            event_start: vec![0],
            driven: vec![],
            lateral: None,
            housing: 0,
            shaft_ends: vec![],
        }
    }
}

/// The torques on the bodies at a state, and what they do.
struct Torques<const N: usize> {
    /// Forward torque on each body (the housing's slot is scratch).
    on: [f64; N],
    p_ext: f64,
    p_loss: f64,
    /// Counter-clockwise torque of the meshes and shafts on the housing.
    housing: f64,
}

impl Train {
    /// Builds the train and its initial state; rigid contact and a slider are refused.
    pub fn new(
        spec: TrainSpec,
        tau: Vec<f64>,
        statistics: Option<f64>,
    ) -> Result<(Train, State), ModelError> {
        let st = spec.structure()?;
        for (m, mp) in spec.meshes.iter().enumerate() {
            if mp.pair.law == MeshLaw::Rigid {
                return Err(ModelError::new(format!(
                    "parameter mesh[{}].contact_model = 2: rigid contact is not available in a gear train (its impacts and locks are the two-wheel rig's, rig-and-modes.md §2); use contact_model 1, 3 or 4",
                    m + 1
                )));
            }
        }
        let lay = placement::layout(&spec, &st)?;
        kinematics::check_jammed(&spec, &st, &lay.geo)?;
        st.check_senses(&spec)?;
        let start = placement::place(&spec, &st, &lay)?;
        let coords = Coordinates::new(&spec, &st, &lay, &start)?;
        let mut meshes = Vec::with_capacity(spec.meshes.len());
        for (m, mp) in spec.meshes.iter().enumerate() {
            let at = |e: ModelError| ModelError::new(format!("mesh[{}]: {}", m + 1, e.message));
            meshes.push(
                GearMesh::with_geometry(&mp.pair, lay.geo[m].clone(), start.meshes[m], false)
                    .map_err(at)?,
            );
        }
        let n = spec.bodies.len();
        let slot = |i: usize| if i == HOUSING { n } else { i };
        let links = (0..spec.meshes.len())
            .map(|m| {
                let mp = &spec.meshes[m];
                let (sa, sb) = st.mesh_sense[m];
                let (carrier, sc) = match st.frame[m] {
                    Some(c) => (c, st.sense[c]),
                    None => (n, 0.0),
                };
                let dte = match &coords.mesh[m] {
                    Source::Coord(k) => vec![(coord_index(*k), 1.0, start.dte0[m])],
                    Source::Combination(c) => c
                        .iter()
                        .map(|&(k, l)| (coord_index(k), l, coords.offset[k]))
                        .collect(),
                    Source::Bodies => unreachable!("a mesh's dte is a coordinate or a combination"),
                };
                MeshLink {
                    a: slot(mp.a),
                    b: slot(mp.b),
                    carrier,
                    rel_a: sa * sc,
                    rel_b: sb * sc,
                    dte,
                    dte0: start.dte0[m],
                }
            })
            .collect();
        let body_carrier: Vec<(usize, f64)> = (0..n)
            .map(|i| match spec.carrier_of(i) {
                Some(c) => (c, st.sense[i] * st.sense[c]),
                None => (n, 0.0),
            })
            .collect();
        let mut j_eff: Vec<f64> = spec.bodies.iter().map(|b| b.j).collect();
        // A lateral planet's mass moves on its own coordinates, not with its carrier.
        for (i, b) in spec.bodies.iter().enumerate() {
            if let (Some(pl), None) = (b.planet, b.lateral) {
                j_eff[pl.carrier] += pl.m * lay.orbit_radius[i] * lay.orbit_radius[i];
            }
        }
        let inv_j = j_eff.iter().map(|j| 1.0 / j).collect();
        let pins: Vec<[f64; 2]> = (0..n)
            .map(|i| match spec.bodies[i].planet {
                Some(pl) => {
                    let (r, t) = (lay.orbit_radius[i] + pl.pin_error_r, pl.pin_error_t);
                    let (sn, cs) = pl.orbit_angle.sin_cos();
                    [r * cs - t * sn, r * sn + t * cs]
                }
                None => [0.0; 2],
            })
            .collect();
        let coef = spec
            .meshes
            .iter()
            .map(|mp| mesh::Coefficients::new(&mp.pair))
            .collect();
        let n_meshes = spec.meshes.len();
        let shaft_ends = spec
            .shafts
            .iter()
            .map(|sh| (slot(sh.a), slot(sh.b)))
            .collect();
        let event_start = std::iter::once(0)
            .chain(meshes.iter().scan(0, |n, mesh: &GearMesh| {
                *n += mesh.n_event_fns();
                Some(*n)
            }))
            .collect();
        let driven = (0..n).filter(|&i| spec.bodies[i].speed_driven).collect();
        let w_in = spec.bodies.iter().map(|b| b.w_start).collect();
        let frame_turns: Vec<_> = lay
            .frames
            .iter()
            .zip(&lay.geo)
            .map(|(f, g)| bearings::frame_turn(f, g.internal))
            .collect();
        let lateral = lateral::LateralConfig::new(
            &spec,
            &st,
            &lay.frames,
            &frame_turns,
            &lay.geo,
            &pins,
            coords.coords.len(),
        )?;
        if let Some(lat) = &lateral {
            meshes = meshes
                .into_iter()
                .enumerate()
                .map(|(m, mesh)| match lat.moves(m) {
                    true => mesh.with_moving_centres(),
                    false => mesh,
                })
                .collect();
        }
        let cfg = TrainConfig {
            driven,
            lateral,
            spec,
            structure: st,
            coords,
            psi_start: start.psi,
            orbit_radius: lay.orbit_radius,
            frame_turns,
            frames: lay.frames,
            pins,
            links,
            body_carrier,
            j_eff,
            inv_j,
            event_start,
            housing: n,
            shaft_ends,
        };
        let mut train = Train {
            cfg: Arc::new(cfg),
            meshes,
            loads: TrainLoads { tau, w_in, coef },
            e_gate: 0.0,
            n_events: 0,
            e_start: 0.0,
            stats: statistics.map(|t| vec![Statistics::new(t); n_meshes]),
            static_start: None,
            modes: None,
        };
        // Every angle starts at 0: each coordinate at its offset; the rates from the bodies'
        // start speeds.
        let c = train.cfg.clone();
        let mut w = [0.0; MAX_BODIES + 1];
        for (i, b) in c.spec.bodies.iter().enumerate() {
            w[i] = b.w_start;
        }
        let mut y = State::zeros();
        for k in 0..n {
            y[coord_index(k)] = c.coords.offset[k];
            y[coord_index(k) + 1] = c.coords.rows[k].dot(&w);
        }
        for lb in c.lateral.iter().flat_map(|lat| &lat.bodies) {
            let l = c.spec.bodies[lb.body].lateral.expect("a lateral body");
            for d in 0..2 {
                y[lb.at + 2 * d] = l.q_start[d];
                y[lb.at + 2 * d + 1] = l.v_start[d];
            }
        }
        let b = train.bodies(&y);
        for m in 0..n_meshes {
            let k = train.kin(m, &y, &b);
            train.meshes[m].init_signs(&k);
        }
        train
            .check_range(&y)
            .map_err(|e| ModelError::new(format!("initial state: {e}")))?;
        train.e_start = train
            .energy_terms(&y)
            .map_err(|e| ModelError::new(e.to_string()))?
            .0;
        train.renew_modes(&y);
        Ok((train, y))
    }

    pub fn spec(&self) -> &TrainSpec {
        &self.cfg.spec
    }

    /// The bodies' angles and speeds from the coordinates.
    pub fn bodies(&self, y: &[f64]) -> Bodies {
        self.bodies_in(y)
    }

    /// The same in N slots (`by_slots!`).
    #[inline]
    fn bodies_in<const N: usize>(&self, y: &[f64]) -> Bodies<N> {
        let c = &self.cfg.coords;
        let mut b = Bodies::default();
        if let Some(order) = &c.substitution {
            for &(k, to, inv) in order {
                let [q, dq] = pair(y, coord_index(k));
                let (mut theta, mut w) = (q - c.offset[k], dq);
                for &(i, r) in &c.rows[k].0 {
                    if i != to {
                        theta -= r * b.theta[i];
                        w -= r * b.w[i];
                    }
                }
                b.theta[to] = theta * inv;
                b.w[to] = w * inv;
            }
            return b;
        }
        for (i, inverse) in c.inverse.iter().enumerate() {
            let (mut theta, mut w) = (0.0, 0.0);
            for &(k, t) in inverse {
                let [q, dq] = pair(y, coord_index(k));
                theta += t * (q - c.offset[k]);
                w += t * dq;
            }
            b.theta[i] = theta;
            b.w[i] = w;
        }
        b
    }

    /// Mesh m's dte and its rate at y.
    #[inline]
    fn dte_and_rate(&self, m: usize, y: &[f64]) -> (f64, f64) {
        let l = &self.cfg.links[m];
        if let [(i, c, _)] = l.dte[..] {
            if c == 1.0 {
                let [q, dq] = pair(y, i);
                return (q, dq);
            }
        }
        let (mut q, mut dq) = (l.dte0, 0.0);
        for &(i, c, off) in &l.dte {
            q += c * (y[i] - off);
            dq += c * y[i + 1];
        }
        (q, dq)
    }

    /// Mesh m's coordinates: A's angle and speed relative to the mesh's carrier, its dte and
    /// rate (no slider in a train), and its centres' motion if they move.
    #[inline(always)]
    fn kin<const N: usize>(&self, m: usize, y: &[f64], b: &Bodies<N>) -> Kin {
        self.kin_of::<N, true>(m, y, b)
    }

    /// `kin`, where LAT = false knows that no mesh's centres move (a train without lateral
    /// bodies: the right-hand side's common path).
    #[inline(always)]
    fn kin_of<const N: usize, const LAT: bool>(&self, m: usize, y: &[f64], b: &Bodies<N>) -> Kin {
        let l = &self.cfg.links[m];
        let (q, dq) = self.dte_and_rate(m, y);
        let mut k = [
            b.theta[l.a] - l.rel_a * b.theta[l.carrier],
            q,
            b.w[l.a] - l.rel_a * b.w[l.carrier],
            dq,
            0.0,
            0.0,
            0.0,
            0.0,
            0.0,
            0.0,
        ];
        if LAT && self.meshes[m].moving_centres {
            self.put_centres(m, y, b, &mut k);
        }
        k
    }

    /// Mesh m's centres' motion into its `Kin` (kept out of `kin`, which the base scenes
    /// inline).
    #[inline(never)]
    fn put_centres<const N: usize>(&self, m: usize, y: &[f64], b: &Bodies<N>, k: &mut Kin) {
        let [z, v, _] = self.centre_motion(m, y, b, None);
        [k[mesh::DX], k[mesh::DY], k[mesh::VX], k[mesh::VY]] = [z[0], z[1], v[0], v[1]];
    }

    /// Every torque on the bodies with the current modes (gear-train.md §5, planetary.md §3):
    /// inputs, drags (a planet's relative to its carrier, which takes the reaction), each
    /// mesh's torques on its gears and minus their sum on its carrier, the shafts'. `lat`: the
    /// lateral coordinates' generalized forces, when wanted (`lateral.rs`). `turns`: the
    /// carriers' (`carrier_turns`), which LAT needs.
    #[inline]
    fn torques<const N: usize, const LAT: bool>(
        &self,
        y: &[f64],
        b: &Bodies<N>,
        mut lat: Option<&mut [[f64; 2]; MAX_BODIES]>,
        turns: Option<&lateral::Turns<N>>,
    ) -> Result<Torques<N>, LawOutOfRange> {
        let c = &*self.cfg;
        let hs = c.housing;
        let mut t = Torques {
            on: [0.0; N],
            p_ext: 0.0,
            p_loss: 0.0,
            housing: 0.0,
        };
        // Off a carrier nothing is booked on the housing's slot (benches/rhs_cost.rs).
        for (i, body) in c.spec.bodies.iter().enumerate() {
            let tau = self.loads.tau[i] + body.ripple.torque(b.theta[i]);
            let (carrier, rel) = c.body_carrier[i];
            let w_rel = b.w[i] - rel * b.w[carrier];
            let drag = body.c * w_rel;
            t.on[i] += tau - drag;
            if carrier != hs {
                t.on[carrier] += rel * drag;
            }
            t.p_ext += tau * b.w[i] - drag * w_rel;
        }
        let st = &c.structure;
        for (m, (mesh, l)) in self.meshes.iter().zip(&c.links).enumerate() {
            let (k, turned) = match (LAT, turns) {
                (true, Some(turns)) => self.kin_turned(m, y, b, turns),
                _ => (self.kin_of::<N, false>(m, y, b), ((0.0, 1.0), [0.0; 2])),
            };
            debug_assert!(
                !LAT || turns.is_some(),
                "a lateral train's torques need its turns"
            );
            // A lateral train's lumped meshes (the HIL sets') take the lumped law inline: out of
            // line its result came back through the stack, 13 % of their right-hand side. Not
            // in `compliant_load` itself: its dispatch inlined into every caller cost the
            // Johnson scenes 1-2 % more instructions (callgrind, power-split 2.2 %).
            let load = match mesh.lumped() {
                Some(lp) if LAT && mesh.moving_centres => mesh.lumped_load::<true>(lp, &k, None),
                _ => mesh.compliant_load(&k, None)?,
            };
            t.on[l.a] += load.tq_a;
            t.on[l.b] += load.tq_b;
            if l.carrier != hs {
                t.on[l.carrier] -= l.rel_a * load.tq_a + l.rel_b * load.tq_b;
            }
            if l.a == hs || l.b == hs {
                let (sa, sb) = st.mesh_sense[m];
                t.housing += if l.a == hs {
                    sa * load.tq_a
                } else {
                    sb * load.tq_b
                };
            }
            t.p_ext += load.p_param;
            t.p_loss += load.p_loss;
            if let (true, Some(q)) = (LAT, lat.as_deref_mut()) {
                if mesh.moving_centres {
                    self.book_mesh_force(m, [load.f_bx, load.f_by], turned, &mut t.on, q);
                }
            }
        }
        for (j, sh) in c.spec.shafts.iter().enumerate() {
            let (q, dq) = self.shaft_state(j, y, Some(b));
            let tq = sh.k * q + sh.d * dq;
            let (a, e) = c.shaft_ends[j];
            t.on[a] -= tq;
            t.on[e] += tq;
            let s = st.shaft_sense[j];
            if a == hs {
                t.housing -= s * tq;
            }
            if e == hs {
                t.housing += s * tq;
            }
            t.p_loss += sh.d * dq * dq;
        }
        if let (true, Some(q)) = (LAT, lat) {
            self.book_bearings(y, &mut t.on, q, &mut t.p_loss);
        }
        Ok(t)
    }

    /// Right-hand side with the current modes: the bodies' accelerations (the inertias are
    /// diagonal in the absolute rotations), then each coordinate's.
    pub fn rhs(&self, y: &[f64], dy: &mut [f64]) -> Result<(), LawOutOfRange> {
        by_slots!(self.rhs_in(y, dy))
    }

    #[inline]
    fn rhs_in<const N: usize>(&self, y: &[f64], dy: &mut [f64]) -> Result<(), LawOutOfRange> {
        let c = &*self.cfg;
        let b = self.bodies_in::<N>(y);
        if c.lateral.is_some() {
            return self.rhs_lateral(y, &b, dy);
        }
        let t = self.torques::<N, false>(y, &b, None, None)?;
        self.rhs_from(&t, y, &b, dy);
        Ok(())
    }

    /// The same for a train with lateral bodies.
    #[inline(never)]
    fn rhs_lateral<const N: usize>(
        &self,
        y: &[f64],
        b: &Bodies<N>,
        dy: &mut [f64],
    ) -> Result<(), LawOutOfRange> {
        let mut q = [[0.0; 2]; MAX_BODIES];
        let turns = self.carrier_turns(b);
        let t = self.torques::<N, true>(y, b, Some(&mut q), Some(&turns))?;
        let acc = self.rhs_from(&t, y, b, dy);
        self.lateral_rates(y, b, (&acc, &turns), &q, dy);
        Ok(())
    }

    /// The quadratures' and the rotations' derivatives from the torques; returns the bodies'
    /// accelerations.
    #[inline(always)]
    fn rhs_from<const N: usize>(
        &self,
        t: &Torques<N>,
        y: &[f64],
        b: &Bodies<N>,
        dy: &mut [f64],
    ) -> [f64; N] {
        let c = &*self.cfg;
        let n = c.spec.bodies.len();
        let mut acc = [0.0; N];
        for (a, (tq, inv_j)) in acc.iter_mut().zip(t.on.iter().zip(&c.inv_j)).take(n) {
            *a = tq * inv_j;
        }
        // A drive holds its body's speed: its torque cancels the others' there.
        let mut p_ext = t.p_ext;
        for &i in &c.driven {
            p_ext -= t.on[i] * b.w[i];
            acc[i] = 0.0;
        }
        dy[W_EXT] = p_ext;
        dy[W_LOSS] = t.p_loss;
        // Coordinate k and its rate at coord_index(k), in pairs: no bounds check per index.
        let pairs = dy[2..].chunks_exact_mut(2).zip(y[2..].chunks_exact(2));
        for (row, (d, q)) in c.coords.rows.iter().zip(pairs) {
            d[0] = q[1];
            d[1] = row.dot(&acc);
        }
        acc
    }

    /// The number of state components in use (a prefix of `State`).
    pub fn dim(&self) -> usize {
        let lateral = self.cfg.lateral.as_ref().map_or(0, |l| 2 * l.bodies.len());
        2 + 2 * (self.cfg.coords.coords.len() + lateral)
    }

    pub fn check_state(&self, y: &[f64]) -> Result<(), LawOutOfRange> {
        let b = self.bodies(y);
        let turns = self.cfg.lateral.is_some().then(|| self.carrier_turns(&b));
        for (m, mesh) in self.meshes.iter().enumerate() {
            let k = match &turns {
                Some(turns) => self.kin_turned(m, y, &b, turns).0,
                None => self.kin(m, y, &b),
            };
            mesh.check_state(&k).map_err(|e| named(m, e))?;
        }
        Ok(())
    }

    pub fn check_range(&self, y: &[f64]) -> Result<(), LawOutOfRange> {
        let mut dy = State::zeros();
        self.rhs(y, &mut dy)?;
        self.check_state(y)
    }

    /// New torques, speeds and coefficients from a master. A speed-driven body whose input
    /// changed jumps to it, every other body keeping its speed (the drive's impulse reaches
    /// only its own body: shafts and meshes are compliant); the jump's kinetic energy is work
    /// of the drive.
    pub fn set_loads(&mut self, loads: TrainLoads, y: &mut [f64]) {
        let b = self.bodies(y);
        for m in 0..self.meshes.len() {
            let k = self.kin(m, y, &b);
            self.meshes[m].set_coefficients(loads.coef[m], &k);
        }
        // Against the input before, not the body's speed from the state, which carries a few
        // ulp of the map from the coordinates: an unchanged input moves nothing.
        let c = self.cfg.clone();
        if c.driven
            .iter()
            .any(|&i| self.loads.w_in[i] != loads.w_in[i])
        {
            let before = y.to_vec();
            let mut w = b.w;
            for &i in &c.driven {
                w[i] = loads.w_in[i];
            }
            for (k, row) in c.coords.rows.iter().enumerate() {
                y[coord_index(k) + 1] = row.dot(&w);
            }
            let after = self.bodies(y);
            y[W_EXT] += self.kinetic_energy(y, &after) - self.kinetic_energy(&before, &b);
            for m in 0..self.meshes.len() {
                let k = self.kin(m, y, &after);
                self.meshes[m].rates_jumped(&k);
            }
        }
        self.loads = loads;
    }

    /// Whether body i's speed is an input.
    pub fn is_speed_driven(&self, i: usize) -> bool {
        self.cfg.driven.contains(&i)
    }

    /// Where master state j (`N_MASTER_STATES`) is in the state; None: not in use.
    pub fn master_index(&self, j: usize) -> Option<usize> {
        (j < self.dim()).then_some(j)
    }
}

impl TrainConfig {
    /// A coordinate's reciprocal inertia: sum of row_i^2 / J_i.
    fn mobility(&self, row: &kinematics::Row) -> f64 {
        row.0.iter().map(|&(i, r)| r * r * self.inv_j[i]).sum()
    }
}

/// A mesh's error, named with the mesh.
fn named(m: usize, mut e: LawOutOfRange) -> LawOutOfRange {
    e.contact = format!("mesh[{}] {}", m + 1, e.contact);
    e
}
