//! The gear train (gear-train.md): rotating bodies joined by torsional shafts and gear meshes
//! in a tree. It owns the equations of motion and reuses the mesh component for every mesh.
//!
//! State: body 1's forward angle and speed, the two quadratures (external work, dissipated
//! energy), then for each edge in the walk from body 1 its relative coordinate and rate: a
//! mesh's transmission error dte_m = rAb theta_A - rBb theta_B + dte_start_m (its forward
//! penetration) and d(dte_m)/dt, a shaft's twist theta_a - theta_b + twist_start and its rate.
//! As in the
//! single mesh, the penetrations are states of their own and keep full precision however far
//! the bodies turn; the bodies' angles and speeds follow along the tree.

pub mod placement;
pub mod topology;

use super::contact::{EventFn, N_EVENTS};
use super::geometry::Geometry;
use super::mesh::{self, EventReport, GearMesh, Kin, LawOutOfRange};
use super::statistics::Statistics;
use super::ModelError;
use serde::{Deserialize, Serialize};
use std::sync::Arc;
pub use topology::{
    Body, Edge, MeshPlace, Ripple, Shaft, Step, TrainSpec, Tree, MAX_BODIES, MAX_MESHES, MAX_SHAFTS,
};

/// Body 1's angle and speed, the quadratures, then a coordinate and its rate per edge.
pub const NY: usize = 4 + 2 * (MAX_BODIES - 1);
pub type State = [f64; NY];
pub const THETA_1: usize = 0;
pub const W_1: usize = 1;
pub const W_EXT: usize = 2;
pub const W_LOSS: usize = 3;
/// The margins: every mesh's event functions, mesh m's from m N_EVENTS on.
pub const N_MARGINS: usize = MAX_MESHES * N_EVENTS;
pub type Margins = crate::driver::wide::Wide<N_MARGINS>;

/// The states a Model Exchange master integrates, in the FMU's order: body 1's angle and
/// speed, the quadratures, every shaft's twist and rate, every mesh's dte and rate, for the
/// full capacity (elements not in use read 0).
pub const N_MASTER_STATES: usize = 4 + 2 * (MAX_SHAFTS + MAX_MESHES);

/// Edge k's coordinate in the state (its rate follows it).
pub const fn edge_index(k: usize) -> usize {
    4 + 2 * k
}

/// What a master may change between steps: the bodies' torques and the meshes' coefficients.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TrainLoads {
    pub tau: Vec<f64>,
    pub coef: Vec<mesh::Coefficients>,
}

/// What the parameters fix.
#[derive(Clone, Debug, PartialEq)]
pub struct TrainConfig {
    pub spec: TrainSpec,
    pub tree: Tree,
    /// The walk step of each mesh and shaft (its edge's place in the state).
    mesh_step: Vec<usize>,
    shaft_step: Vec<usize>,
    /// Absolute start angles of the bodies \[rad\] (gear-train.md §4).
    pub psi_start: Vec<f64>,
    /// Each walk step as a linear map (`Link`), and the bodies' reciprocal inertias: the
    /// right-hand side multiplies where it would divide (benches/rhs_cost.rs).
    links: Vec<Link>,
    inv_j: Vec<f64>,
}

/// A walk step: theta_to = ratio theta_from + gain (q - offset), and the same for the speeds
/// with the coordinate's rate.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Link {
    from: usize,
    to: usize,
    ratio: f64,
    gain: f64,
    offset: f64,
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
            tree: Tree {
                steps: vec![],
                sense: vec![],
            },
            mesh_step: vec![],
            shaft_step: vec![],
            psi_start: vec![],
            links: vec![],
            inv_j: vec![],
        }
    }
}

/// The bodies' forward angles and speeds at a state.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Bodies {
    pub theta: [f64; MAX_BODIES],
    pub w: [f64; MAX_BODIES],
}

/// The train.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
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
}

/// One mesh's view of the train and the state's indices it reads.
struct MeshView {
    a: usize,
    q: usize,
}

impl Train {
    /// Builds the train and its initial state; rigid contact and a slider are refused.
    pub fn new(
        spec: TrainSpec,
        tau: Vec<f64>,
        statistics: Option<f64>,
    ) -> Result<(Train, State), ModelError> {
        let tree = spec.tree()?;
        let mut geo = Vec::with_capacity(spec.meshes.len());
        for (m, mp) in spec.meshes.iter().enumerate() {
            let p = &mp.params;
            let name = |v: &str| format!("mesh[{}].{v}", m + 1);
            if p.contact_model == 2 {
                return Err(ModelError::new(format!(
                    "parameter {} = 2: rigid contact is not available in a gear train (its impacts and locks are the two-wheel rig's, rig-and-modes.md §2); use contact_model 1 or 3",
                    name("contact_model")
                )));
            }
            if p.slider_stiffness != 0.0 {
                return Err(ModelError::new(format!(
                    "parameter {} = {}: the slider S is the two-wheel rig's (rig-and-modes.md §1); a train's housing holds every bearing",
                    name("slider_stiffness"),
                    p.slider_stiffness
                )));
            }
            let at = |e: ModelError| ModelError::new(format!("mesh[{}]: {}", m + 1, e.message));
            super::params::validate(p).map_err(at)?;
            geo.push(Geometry::new(p).map_err(at)?);
        }
        let start = placement::place(&spec, &tree, &geo);
        let mut meshes = Vec::with_capacity(spec.meshes.len());
        for (m, mp) in spec.meshes.iter().enumerate() {
            let at = |e: ModelError| ModelError::new(format!("mesh[{}]: {}", m + 1, e.message));
            meshes.push(GearMesh::new(&mp.params, start.meshes[m], false).map_err(at)?);
        }
        let step_of = |e: Edge| {
            tree.steps
                .iter()
                .position(|s| s.edge == e)
                .expect("a tree walks every edge")
        };
        let mesh_step = (0..spec.meshes.len())
            .map(|m| step_of(Edge::Mesh(m)))
            .collect();
        let shaft_step = (0..spec.shafts.len())
            .map(|j| step_of(Edge::Shaft(j)))
            .collect();
        let coef = spec
            .meshes
            .iter()
            .map(|mp| mesh::Coefficients::new(&mp.params))
            .collect();
        let n_meshes = spec.meshes.len();
        let mut y = [0.0; NY];
        y[W_1] = spec.bodies[0].w_start;
        let links = tree
            .steps
            .iter()
            .map(|st| {
                let (ratio, gain, offset) = match st.edge {
                    Edge::Mesh(m) => {
                        let (g, dte) = (&meshes[m].geo, spec.meshes[m].params.dte_start);
                        if st.from == spec.meshes[m].a {
                            (g.r_ab / g.r_bb, -1.0 / g.r_bb, dte)
                        } else {
                            (g.r_bb / g.r_ab, 1.0 / g.r_ab, dte)
                        }
                    }
                    Edge::Shaft(j) if st.from == spec.shafts[j].a => {
                        (1.0, -1.0, spec.shafts[j].twist_start)
                    }
                    Edge::Shaft(j) => (1.0, 1.0, spec.shafts[j].twist_start),
                };
                Link {
                    from: st.from,
                    to: st.to,
                    ratio,
                    gain,
                    offset,
                }
            })
            .collect();
        let inv_j = spec.bodies.iter().map(|b| 1.0 / b.j).collect();
        let cfg = TrainConfig {
            spec,
            tree,
            mesh_step,
            shaft_step,
            psi_start: start.psi,
            links,
            inv_j,
        };
        let mut train = Train {
            cfg: Arc::new(cfg),
            meshes,
            loads: TrainLoads { tau, coef },
            e_gate: 0.0,
            n_events: 0,
            e_start: 0.0,
            stats: statistics.map(|t| vec![Statistics::new(t); n_meshes]),
        };
        // Each edge's coordinate at the start: a mesh's dte is its dte_start, a shaft's twist
        // its twist_start (all angles 0); the rates from the bodies' start speeds.
        let c = train.cfg.clone();
        for (k, step) in c.tree.steps.iter().enumerate() {
            let i = edge_index(k);
            let w = |b: usize| c.spec.bodies[b].w_start;
            match step.edge {
                Edge::Mesh(m) => {
                    let (mp, g) = (&c.spec.meshes[m], &train.meshes[m].geo);
                    y[i] = mp.params.dte_start;
                    y[i + 1] = g.r_ab * w(mp.a) - g.r_bb * w(mp.b);
                }
                Edge::Shaft(j) => {
                    let sh = &c.spec.shafts[j];
                    y[i] = sh.twist_start;
                    y[i + 1] = w(sh.a) - w(sh.b);
                }
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
        Ok((train, y))
    }

    pub fn spec(&self) -> &TrainSpec {
        &self.cfg.spec
    }

    fn view(&self, m: usize) -> MeshView {
        let mp = &self.cfg.spec.meshes[m];
        MeshView {
            a: mp.a,
            q: edge_index(self.cfg.mesh_step[m]),
        }
    }

    /// The bodies' angles and speeds: body 1's from the state, the others along the tree.
    #[inline]
    pub fn bodies(&self, y: &State) -> Bodies {
        let mut b = Bodies::default();
        b.theta[0] = y[THETA_1];
        b.w[0] = y[W_1];
        for (k, l) in self.cfg.links.iter().enumerate() {
            let (q, dq) = (y[edge_index(k)], y[edge_index(k) + 1]);
            b.theta[l.to] = l.ratio * b.theta[l.from] + l.gain * (q - l.offset);
            b.w[l.to] = l.ratio * b.w[l.from] + l.gain * dq;
        }
        b
    }

    /// Mesh m's coordinates: A's angle and speed, its dte and rate (no slider in a train).
    #[inline]
    fn kin(&self, m: usize, y: &State, b: &Bodies) -> Kin {
        let v = self.view(m);
        [b.theta[v.a], y[v.q], b.w[v.a], y[v.q + 1], 0.0, 0.0]
    }

    /// Shaft j's transmitted torque at y (gear-train.md §1).
    pub fn shaft_torque(&self, j: usize, y: &State) -> f64 {
        let sh = &self.cfg.spec.shafts[j];
        let i = edge_index(self.cfg.shaft_step[j]);
        // The state's twist is theta_a - theta_b + twist_start whichever end the walk came from.
        sh.k * y[i] + sh.d * y[i + 1]
    }

    /// Shaft j's twist theta_a - theta_b + twist_start at y.
    pub fn shaft_twist(&self, j: usize, y: &State) -> f64 {
        y[edge_index(self.cfg.shaft_step[j])]
    }

    /// Right-hand side with the current modes (gear-train.md §5): each mesh's torques go
    /// straight onto its bodies.
    pub fn rhs(&self, y: &State, dy: &mut State) -> Result<(), LawOutOfRange> {
        let c = &*self.cfg;
        let b = self.bodies(y);
        let n = c.spec.bodies.len();
        let mut torque = [0.0; MAX_BODIES];
        let (mut p_ext, mut p_loss) = (0.0, 0.0);
        for (i, body) in c.spec.bodies.iter().enumerate() {
            let tau = self.loads.tau[i] + body.ripple.torque(b.theta[i]);
            torque[i] = tau - body.c * b.w[i];
            p_ext += tau * b.w[i] - body.c * b.w[i] * b.w[i];
        }
        for (m, (mesh, mp)) in self.meshes.iter().zip(&c.spec.meshes).enumerate() {
            let load = mesh.compliant_load(&self.kin(m, y, &b), None)?;
            torque[mp.a] += load.tq_a;
            torque[mp.b] += load.tq_b;
            p_ext += load.p_param;
            p_loss += load.p_loss;
        }
        for (j, sh) in c.spec.shafts.iter().enumerate() {
            let i = edge_index(c.shaft_step[j]);
            let t = sh.k * y[i] + sh.d * y[i + 1];
            torque[sh.a] -= t;
            torque[sh.b] += t;
            p_loss += sh.d * y[i + 1] * y[i + 1];
        }
        let mut acc = [0.0; MAX_BODIES];
        for (a, (t, inv_j)) in acc.iter_mut().zip(torque.iter().zip(&c.inv_j)).take(n) {
            *a = t * inv_j;
        }
        dy[THETA_1] = y[W_1];
        dy[W_1] = acc[0];
        dy[W_EXT] = p_ext;
        dy[W_LOSS] = p_loss;
        for (k, step) in c.tree.steps.iter().enumerate() {
            let i = edge_index(k);
            dy[i] = y[i + 1];
            dy[i + 1] = match step.edge {
                Edge::Mesh(m) => {
                    let (mp, g) = (&c.spec.meshes[m], &self.meshes[m].geo);
                    g.r_ab * acc[mp.a] - g.r_bb * acc[mp.b]
                }
                Edge::Shaft(j) => acc[c.spec.shafts[j].a] - acc[c.spec.shafts[j].b],
            };
        }
        Ok(())
    }

    /// The number of state components in use (a prefix of `State`).
    pub fn dim(&self) -> usize {
        4 + 2 * self.cfg.tree.steps.len()
    }

    /// The event functions in use: every mesh's block (a prefix of the margins).
    pub fn n_event_fns(&self) -> usize {
        match self.meshes.len() {
            0 => 0,
            n => (n - 1) * N_EVENTS + self.meshes[n - 1].n_event_fns(),
        }
    }

    pub fn check_state(&self, y: &State) -> Result<(), LawOutOfRange> {
        let b = self.bodies(y);
        for (m, mesh) in self.meshes.iter().enumerate() {
            mesh.check_state(&self.kin(m, y, &b))
                .map_err(|e| named(m, e))?;
        }
        Ok(())
    }

    pub fn check_range(&self, y: &State) -> Result<(), LawOutOfRange> {
        let mut dy = [0.0; NY];
        self.rhs(y, &mut dy)?;
        self.check_state(y)
    }

    pub fn event_margins(&self, y: &State, out: &mut Margins) {
        let b = self.bodies(y);
        out.0[self.meshes.len() * N_EVENTS..].fill(1.0);
        for (m, mesh) in self.meshes.iter().enumerate() {
            mesh.event_margins(
                &self.kin(m, y, &b),
                &mut out.0[m * N_EVENTS..(m + 1) * N_EVENTS],
            );
        }
    }

    pub fn event_margins_and_rates(
        &self,
        y: &State,
        dy: &State,
        margins: &mut Margins,
        rates: &mut Margins,
    ) {
        let b = self.bodies(y);
        let db = self.bodies(dy);
        let n = self.meshes.len() * N_EVENTS;
        margins.0[n..].fill(1.0);
        rates.0[n..].fill(0.0);
        for (m, mesh) in self.meshes.iter().enumerate() {
            let r = m * N_EVENTS..(m + 1) * N_EVENTS;
            let (k, dk) = (self.kin(m, y, &b), self.kin(m, dy, &db));
            mesh.event_margins_and_rates(&k, &dk, &mut margins.0[r.clone()], &mut rates.0[r]);
        }
    }

    pub fn margin(&self, i: usize, y: &State) -> f64 {
        let (m, e) = (i / N_EVENTS, i % N_EVENTS);
        if m >= self.meshes.len() {
            return 1.0;
        }
        let b = self.bodies(y);
        self.meshes[m].margin(EventFn::from_index(e), &self.kin(m, y, &b))
    }

    /// Applies event i (mesh i / N_EVENTS, its function i % N_EVENTS).
    pub fn handle_event(&mut self, i: usize, y: &State) -> Result<EventReport, LawOutOfRange> {
        let (m, e) = (i / N_EVENTS, i % N_EVENTS);
        let b = self.bodies(y);
        let k = self.kin(m, y, &b);
        let before = self.meshes[m].contact_energy(&k).map_err(|e| named(m, e))?;
        let mut report = self.meshes[m].handle_event(e, &k);
        if self.meshes[m].describe_events {
            report.what = format!("mesh[{}]: {}", m + 1, report.what);
        }
        self.n_events += 1;
        self.e_gate += self.meshes[m].contact_energy(&k).map_err(|e| named(m, e))? - before;
        Ok(report)
    }

    /// New torques and coefficients from a master.
    pub fn set_loads(&mut self, loads: TrainLoads, y: &State) {
        let b = self.bodies(y);
        for m in 0..self.meshes.len() {
            let k = self.kin(m, y, &b);
            self.meshes[m].set_coefficients(loads.coef[m], &k);
        }
        self.loads = loads;
    }

    /// Bound on the highest natural frequency \[rad/s\] (the trace of M^-1 K bounds its
    /// largest eigenvalue): the meshes' stiffness along their lines of action and the shafts'.
    pub fn vibration_frequency(&self, y: &State) -> f64 {
        let c = &*self.cfg;
        let b = self.bodies(y);
        let inv_j = |i: usize| 1.0 / c.spec.bodies[i].j;
        let mut sum = 0.0;
        for (m, mesh) in self.meshes.iter().enumerate() {
            let (mp, g) = (&c.spec.meshes[m], &mesh.geo);
            let k = mesh.mesh_stiffness(&self.kin(m, y, &b));
            sum += k * (g.r_ab * g.r_ab * inv_j(mp.a) + g.r_bb * g.r_bb * inv_j(mp.b));
        }
        for sh in &c.spec.shafts {
            sum += sh.k * (inv_j(sh.a) + inv_j(sh.b));
        }
        sum.sqrt()
    }

    /// At most a quarter pitch of contact travel in any mesh (its objects' events recur every
    /// pitch), and for an explicit method `stability`/omega of the fastest vibration.
    pub fn max_step(&self, y: &State, stability: Option<f64>) -> f64 {
        let b = self.bodies(y);
        let mut h = f64::INFINITY;
        for (m, mesh) in self.meshes.iter().enumerate() {
            let speed = mesh.geo.r_ab * b.w[self.cfg.spec.meshes[m].a].abs();
            if speed > 0.0 {
                h = h.min(0.25 * mesh.geo.p_b / speed);
            }
        }
        if let Some(reach) = stability {
            let omega = self.vibration_frequency(y);
            if omega > 0.0 {
                h = h.min(reach / omega);
            }
        }
        h
    }

    fn kinetic_energy(&self, b: &Bodies) -> f64 {
        let bodies = &self.cfg.spec.bodies;
        (0..bodies.len())
            .map(|i| 0.5 * bodies[i].j * b.w[i] * b.w[i])
            .sum()
    }

    /// Elastic energy of the meshes' carrying pairs and of the shafts.
    pub fn elastic_energy(&self, y: &State) -> Result<f64, LawOutOfRange> {
        let c = &*self.cfg;
        let b = self.bodies(y);
        let mut e = 0.0;
        for (j, sh) in c.spec.shafts.iter().enumerate() {
            let twist = y[edge_index(c.shaft_step[j])];
            e += 0.5 * sh.k * twist * twist;
        }
        for (m, mesh) in self.meshes.iter().enumerate() {
            e += mesh
                .contact_energy(&self.kin(m, y, &b))
                .map_err(|e| named(m, e))?;
        }
        Ok(e)
    }

    /// (E_kin + E_el + W_loss - W_ext - E_gate, E_kin, E_el).
    fn energy_terms(&self, y: &State) -> Result<(f64, f64, f64), LawOutOfRange> {
        let e_kin = self.kinetic_energy(&self.bodies(y));
        let e_el = self.elastic_energy(y)?;
        Ok((
            e_kin + e_el + y[W_LOSS] - y[W_EXT] - self.e_gate,
            e_kin,
            e_el,
        ))
    }

    /// (E_kin, E_el, the balance's residual against t = 0).
    pub fn energy(&self, y: &State) -> Result<(f64, f64, f64), LawOutOfRange> {
        let (balance, e_kin, e_el) = self.energy_terms(y)?;
        Ok((e_kin, e_el, balance - self.e_start))
    }

    /// Mesh m's readout at y.
    pub fn mesh_readout(&self, m: usize, y: &State) -> Result<mesh::MeshReadout, LawOutOfRange> {
        self.mesh_readout_at(m, y, &self.bodies(y))
    }

    /// The same with the bodies at y already at hand (every mesh's outputs after a step).
    pub fn mesh_readout_at(
        &self,
        m: usize,
        y: &State,
        b: &Bodies,
    ) -> Result<mesh::MeshReadout, LawOutOfRange> {
        let k = self.kin(m, y, b);
        let (pairs, load) = self.meshes[m]
            .compliant_pair_forces(&k)
            .map_err(|e| named(m, e))?;
        Ok(self.meshes[m].readout_from(&k, &pairs, &load))
    }

    /// Where master state j (`N_MASTER_STATES`) is in the state; None: an element not in use.
    pub fn master_index(&self, j: usize) -> Option<usize> {
        let c = &*self.cfg;
        if j < 4 {
            return Some(j);
        }
        let (k, r) = ((j - 4) / 2, j % 2);
        if k < MAX_SHAFTS {
            c.shaft_step.get(k).map(|&s| edge_index(s) + r)
        } else {
            c.mesh_step.get(k - MAX_SHAFTS).map(|&s| edge_index(s) + r)
        }
    }

    /// Mesh m's dte (its forward penetration) at y.
    pub fn dte(&self, m: usize, y: &State) -> f64 {
        y[self.view(m).q]
    }

    /// Adds the piece [t0, t1] (modes fixed) to each mesh's statistics.
    pub fn observe(
        &mut self,
        t0: f64,
        t1: f64,
        y: &dyn Fn(f64) -> State,
    ) -> Result<(), LawOutOfRange> {
        let Some(mut all) = self.stats.take() else {
            return Ok(());
        };
        let mut r = Ok(());
        for (m, s) in all.iter_mut().enumerate() {
            r = r.and(self.add_statistics(m, s, t0, t1, y));
        }
        self.stats = Some(all);
        r
    }

    pub fn add_statistics(
        &self,
        m: usize,
        s: &mut Statistics,
        t0: f64,
        t1: f64,
        y: &dyn Fn(f64) -> State,
    ) -> Result<(), LawOutOfRange> {
        let q = self.view(m).q;
        let force = |t: f64| -> Result<f64, LawOutOfRange> {
            let r = self.mesh_readout(m, &y(t))?;
            Ok(r.flank_force[0] + r.flank_force[1])
        };
        s.add(self.meshes[m].contact_modes(), t0, t1, &|t| y(t)[q], &force)
    }

    /// The torque each edge carries in a rigid train under the current torques (drag and
    /// vibration left out): the scale of its coordinate's error tolerance. The bodies turn
    /// as one, w_i = r_i w_1, with acceleration sum r_i tau_i / sum r_i^2 J_i; an edge carries
    /// what the bodies beyond it need.
    fn static_edge_torques(&self) -> [f64; MAX_BODIES - 1] {
        let c = &*self.cfg;
        let n = c.spec.bodies.len();
        let mut ratio = [0.0; MAX_BODIES];
        ratio[0] = 1.0;
        for step in &c.tree.steps {
            ratio[step.to] = match step.edge {
                Edge::Shaft(_) => ratio[step.from],
                Edge::Mesh(m) => {
                    let (mp, g) = (&c.spec.meshes[m], &self.meshes[m].geo);
                    if step.from == mp.a {
                        ratio[step.from] * g.r_ab / g.r_bb
                    } else {
                        ratio[step.from] * g.r_bb / g.r_ab
                    }
                }
            };
        }
        let (mut num, mut den) = (0.0, 0.0);
        for (i, r) in ratio.iter().enumerate().take(n) {
            num += r * self.loads.tau[i];
            den += r * r * c.spec.bodies[i].j;
        }
        let acc1 = num / den;
        // Net torque each body needs beyond its own: J_i r_i acc1 - tau_i; summed over the
        // subtree beyond each edge, walking the steps backwards.
        let mut need = [0.0; MAX_BODIES];
        for i in 0..n {
            need[i] = c.spec.bodies[i].j * ratio[i] * acc1 - self.loads.tau[i];
        }
        let mut through = [0.0; MAX_BODIES - 1];
        for (k, step) in c.tree.steps.iter().enumerate().rev() {
            through[k] = need[step.to];
            let carried = match step.edge {
                Edge::Shaft(_) => need[step.to],
                Edge::Mesh(m) => {
                    let (mp, g) = (&c.spec.meshes[m], &self.meshes[m].geo);
                    if step.from == mp.a {
                        need[step.to] * g.r_ab / g.r_bb
                    } else {
                        need[step.to] * g.r_bb / g.r_ab
                    }
                }
            };
            need[step.from] += carried;
        }
        through
    }

    /// Absolute tolerances at a relative tolerance: 1 rad and 1 rad/s for body 1 (relative
    /// control above); for a mesh, the static penetration of one pair under the force the
    /// torques imply (floor 1e-12 m) and that penetration at the mesh's natural frequency, as
    /// in the single mesh; for a shaft, its static twist (floor 1e-12 rad) and that twist at
    /// its own frequency. 0: not under error control (the quadratures).
    pub fn abs_tol(&self, rel_tol: f64) -> State {
        let c = &*self.cfg;
        let through = self.static_edge_torques();
        let mut atol = [0.0; NY];
        atol[THETA_1] = rel_tol;
        atol[W_1] = rel_tol;
        let inv_j = |i: usize| 1.0 / c.spec.bodies[i].j;
        for (k, step) in c.tree.steps.iter().enumerate() {
            let i = edge_index(k);
            let (x, omega) = match step.edge {
                Edge::Mesh(m) => {
                    let (mp, mesh) = (&c.spec.meshes[m], &self.meshes[m]);
                    let g = &mesh.geo;
                    let r_to = if step.to == mp.a { g.r_ab } else { g.r_bb };
                    let (delta, stiffness) = mesh.static_scale(through[k].abs() / r_to);
                    let omega = (stiffness
                        * (g.r_ab * g.r_ab * inv_j(mp.a) + g.r_bb * g.r_bb * inv_j(mp.b)))
                    .sqrt();
                    (delta, omega)
                }
                Edge::Shaft(j) => {
                    let sh = &c.spec.shafts[j];
                    let twist = (through[k].abs() / sh.k).max(1e-12);
                    (twist, (sh.k * (inv_j(sh.a) + inv_j(sh.b))).sqrt())
                }
            };
            atol[i] = rel_tol * x;
            atol[i + 1] = rel_tol * (x * omega).max(1e-12);
        }
        atol
    }
}

/// A mesh's error, named with the mesh.
fn named(m: usize, mut e: LawOutOfRange) -> LawOutOfRange {
    e.contact = format!("mesh[{}] {}", m + 1, e.contact);
    e
}
