//! SpurGearTrain as a rig of `rig_fmu`: the gear train (`Train`) behind the generic FMI
//! instance (`rig_fmu::RigInstance`, which holds the get/set plumbing, the stepping, the Model
//! Exchange glue and the FMU state's snapshot for every rig). Here is only what is the train's
//! own: the run built from the parameters (`build`), where each output comes from, the locals
//! and calculated parameters, and the checks of a restored FMU state. The FMI state machine
//! around it is fmi2_slave's `Instance`.

use crate::build::{self, element, var};
use crate::variables::{
    Calculated, Causality, Locals, Outputs, Params, Var, GUID, LOG_CATEGORIES, MODEL_IDENTIFIER,
    N_DECLARED_STATES, N_EVENT_INDICATORS, STATES,
};
use fmi2_slave::fmu_state::{Reader, Writer};
use gear_model::driver::exchange::{Exchange, ExchangeRig};
use gear_model::driver::train_simulation::{TrainRun, TrainSimulation, TrainSystem};
use gear_model::driver::Vector;
use gear_model::driver::{Method, Stats};
use gear_model::model::mesh::LawOutOfRange;
use gear_model::model::statistics::{Statistics, Summary};
use gear_model::model::train::statics::{static_start, StartDeflections};
use gear_model::model::train::{
    self, State, Train, MAX_BODIES, NY_COMPACT, N_MARGINS, N_MASTER_STATES,
};
use gear_model::variables as single;
use rig_fmu::{Rig, Run};

// The table's states and event indicators are the model's, in its order.
const _: () = assert!(STATES.len() == N_MASTER_STATES);
const _: () = assert!(N_DECLARED_STATES == NY_COMPACT);
const _: () = assert!(N_EVENT_INDICATORS == N_MARGINS);

pub use fmi2_slave::instance::{error, Failure};

rig_fmu::rig_table!(TrainTable, crate::variables);

/// The gear train as an FMU.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrainRig;

/// The model behind an FMU instance.
pub type SpurGearTrain = rig_fmu::RigInstance<TrainRig>;
/// What an FMU state holds: everything that determines how the instance continues.
pub type Snapshot = rig_fmu::Snapshot<TrainRig>;

/// What an instance derives once from the table.
#[derive(Clone, Debug)]
pub struct Cache {
    /// Each output's source, from its name.
    sources: Vec<(Var, Source)>,
    /// The same per element (bodies, shafts, meshes), so that a step writes only the outputs
    /// of the elements in use.
    per_body: Vec<Vec<(Var, Source)>>,
    per_shaft: Vec<Vec<(Var, Source)>>,
    per_mesh: Vec<Vec<(Var, Source)>>,
    /// The lateral outputs of each body, then of each mesh: written only for a train with
    /// lateral bodies.
    lateral_body: Vec<Vec<(Var, Source)>>,
    lateral_mesh: Vec<Vec<(Var, Source)>>,
    /// The first output `write_outputs` found NaN or infinite, if any.
    non_finite: std::cell::Cell<Option<(&'static str, f64)>>,
    /// The element counts the outputs were last written for: the others read 0 and need no
    /// writing until the counts change.
    written: std::cell::Cell<Option<(usize, usize, usize)>>,
    /// The inputs' and tunables' variables.
    load_vars: build::LoadVars,
}

impl Default for Cache {
    fn default() -> Cache {
        let sources = sources();
        let group = |n: usize, of: &dyn Fn(Source) -> Option<usize>| {
            let mut g = vec![Vec::new(); n];
            for &(v, s) in &sources {
                if let Some(i) = of(s) {
                    g[i].push((v, s));
                }
            }
            g
        };
        Cache {
            per_body: group(train::MAX_BODIES, &|s| match s {
                Source::BodyTheta(i) | Source::BodyW(i) | Source::BodyDrive(i) => Some(i),
                _ => None,
            }),
            per_shaft: group(train::MAX_SHAFTS, &|s| match s {
                Source::ShaftTau(j) | Source::ShaftTwist(j) => Some(j),
                _ => None,
            }),
            lateral_body: group(train::MAX_BODIES, &|s| match s {
                Source::BodyLateral(i, _) => Some(i),
                _ => None,
            }),
            lateral_mesh: group(train::MAX_MESHES, &|s| match s {
                Source::MeshDeltaLat(m) => Some(m),
                _ => None,
            }),
            per_mesh: group(train::MAX_MESHES, &|s| match s {
                Source::Mesh(m, sv)
                    if sv.info().causality != single::Causality::CalculatedParameter =>
                {
                    Some(m)
                }
                _ => None,
            }),
            non_finite: std::cell::Cell::new(None),
            sources,
            written: std::cell::Cell::new(None),
            load_vars: build::LoadVars::default(),
        }
    }
}

impl Cache {
    /// The outputs of the elements in use, with their sources; the lateral ones with
    /// `lateral`.
    fn in_use(
        &self,
        (n_bodies, n_shafts, n_meshes): (usize, usize, usize),
        lateral: bool,
    ) -> impl Iterator<Item = &(Var, Source)> {
        let (lb, lm) = if lateral {
            (n_bodies, n_meshes)
        } else {
            (0, 0)
        };
        self.per_body[..n_bodies]
            .iter()
            .chain(&self.per_shaft[..n_shafts])
            .chain(&self.per_mesh[..n_meshes])
            .chain(&self.lateral_body[..lb])
            .chain(&self.lateral_mesh[..lm])
            .flatten()
    }
}

/// Where an output comes from.
#[derive(Clone, Copy, Debug)]
enum Source {
    BodyTheta(usize),
    BodyW(usize),
    /// The torque of a speed drive (0 for a torque-driven body).
    BodyDrive(usize),
    ShaftTau(usize),
    ShaftTwist(usize),
    /// Body i's lateral displacement or velocity (`Train::lateral_state`'s k-th).
    BodyLateral(usize, usize),
    MeshDeltaLat(usize),
    /// Mesh m's output of the single mesh's name.
    Mesh(usize, single::Var),
    Whole,
}

fn sources() -> Vec<(Var, Source)> {
    crate::variables::VARIABLES
        .iter()
        .filter(|v| {
            matches!(
                v.causality,
                Causality::Output | Causality::CalculatedParameter
            )
        })
        .map(|v| {
            let s = match element(v.name) {
                Some(("body", i, "theta")) => Source::BodyTheta(i - 1),
                Some(("body", i, "w")) => Source::BodyW(i - 1),
                Some(("body", i, "tau_drive")) => Source::BodyDrive(i - 1),
                Some(("shaft", j, "tau")) => Source::ShaftTau(j - 1),
                Some(("shaft", j, "twist")) => Source::ShaftTwist(j - 1),
                Some(("body", i, q @ ("x" | "y" | "vx" | "vy"))) => {
                    let k = ["x", "y", "vx", "vy"].iter().position(|&n| n == q);
                    Source::BodyLateral(i - 1, k.expect("one of the four"))
                }
                Some(("mesh", m, "delta_lat")) => Source::MeshDeltaLat(m - 1),
                Some(("mesh", m, name)) => Source::Mesh(
                    m - 1,
                    single::Var::from_name(name).expect("a mesh's rows are the single mesh's"),
                ),
                _ => Source::Whole,
            };
            (v.var, s)
        })
        .collect()
}

fn saturate(n: u64) -> i32 {
    n.min(i32::MAX as u64) as i32
}

/// A train simulation from the snapshot's parameters and inputs. With `static_start`, the
/// deflections are solved for the inputs now, unless a saved state brings those it started
/// with (`solved`).
fn fresh_simulation(
    s: &Snapshot,
    rel_tol: f64,
    vars: &build::LoadVars,
    solved: Option<&StartDeflections>,
) -> Result<TrainSimulation, String> {
    build::validate(&s.params)?;
    let mut spec = build::spec(&s.params, &s.inputs)?;
    let loads = build::loads(&s.params, &s.inputs, vars);
    let deflections = match (s.params.static_start, solved) {
        (false, _) => None,
        (true, Some(d)) => {
            d.apply(&mut spec).map_err(|e| e.message)?;
            Some(d.clone())
        }
        (true, None) => {
            spec = static_start(spec, &loads).map_err(|e| e.message)?;
            Some(StartDeflections::of(&spec))
        }
    };
    let p = &s.params;
    let mut sim = TrainSimulation::new(
        spec,
        loads.tau.clone(),
        p.statistics.then_some(p.stats_start),
        p.solver,
        s.start_time,
        rel_tol,
    )
    .map_err(|e| e.message)?;
    sim.train_mut().static_start = deflections;
    sim.set_loads(loads);
    if let Some(stop) = s.stop_time {
        sim.set_stop_time(stop);
    }
    Ok(sim)
}

/// Every output at state y, with each mesh's statistics and the integration's counters,
/// written in place: the elements in use, and the others' zeros once (the outputs are several
/// kilobytes at full capacity, read after every communication step).
fn write_outputs(
    train: &Train,
    y: &[f64],
    stats: Option<Vec<Statistics>>,
    st: &Stats,
    cache: &Cache,
    o: &mut Outputs,
) -> Result<(), String> {
    let b = train.bodies(y);
    let mut per_mesh = Vec::with_capacity(train.meshes.len());
    for m in 0..train.meshes.len() {
        let r = train.mesh_readout_at(m, y, &b).map_err(|e| e.to_string())?;
        let run = stats
            .as_ref()
            .map_or(Summary::default(), |s| s[m].summary());
        let mut o = single::Outputs::default();
        o.set_mesh(&r, &run);
        o.dte = train.dte(m, y);
        o.P_loss = r.p_loss;
        per_mesh.push(o);
    }
    let (n_bodies, n_shafts) = (train.spec().bodies.len(), train.spec().shafts.len());
    let lateral = train.has_lateral();
    let counts = (n_bodies, n_shafts, per_mesh.len());
    if cache.written.get() != Some(counts) {
        *o = Outputs::default();
        cache.written.set(Some(counts));
    }
    // Only the outputs written are checked for NaN or infinity (the others read 0).
    let mut non_finite = None;
    let mut put = |o: &mut Outputs, v: Var, x: f64| {
        if !x.is_finite() && non_finite.is_none() {
            non_finite = Some((v.info().name, x));
        }
        o.set_real(v, x);
    };
    for &(v, s) in cache.in_use(counts, lateral) {
        match s {
            Source::BodyTheta(i) if i < n_bodies => put(o, v, b.theta[i]),
            Source::BodyW(i) if i < n_bodies => put(o, v, b.w[i]),
            Source::BodyDrive(i) if i < n_bodies && train.is_speed_driven(i) => {
                put(o, v, train.drive_torque(i, y).map_err(|e| e.to_string())?)
            }
            Source::ShaftTau(j) if j < n_shafts => put(o, v, train.shaft_torque(j, y)),
            Source::ShaftTwist(j) if j < n_shafts => put(o, v, train.shaft_twist(j, y)),
            // Without lateral bodies they keep the zeros written with the counts.
            Source::BodyLateral(i, k) => put(o, v, train.lateral_state(i, y)[k]),
            Source::MeshDeltaLat(m) => put(o, v, train.delta_lat(m, y)),
            Source::Mesh(m, sv) if m < per_mesh.len() => {
                if let Some(x) = per_mesh[m].get_real(sv) {
                    put(o, v, x)
                } else {
                    o.set_integer(v, per_mesh[m].get_integer(sv).unwrap_or(0));
                }
            }
            _ => {}
        };
    }
    let (e_kin, e_el, residual) = train.energy(y).map_err(|e| e.to_string())?;
    let housing = train.housing_torque(y).map_err(|e| e.to_string())?;
    for (v, x) in [
        (Var::E_kin, e_kin),
        (Var::E_el, e_el),
        (Var::energy_residual, residual),
        (Var::W_ext, y[train::W_EXT]),
        (Var::W_loss, y[train::W_LOSS]),
        (Var::E_gate, train.e_gate),
        (Var::housing_tau, housing),
    ] {
        put(o, v, x);
    }
    cache.non_finite.set(non_finite);
    o.n_events = saturate(train.n_events);
    o.n_steps = saturate(st.steps);
    o.n_rejected_steps = saturate(st.rejected);
    o.n_rhs_evaluations = saturate(st.rhs_evals);
    o.n_jacobians = saturate(st.jac_evals);
    o.n_factorizations = saturate(st.factorizations);
    Ok(())
}

impl Rig for TrainRig {
    type Table = TrainTable;
    type Sim = TrainSimulation;
    type Extra = ();
    type Cache = Cache;

    const MODEL_NAME: &'static str = MODEL_IDENTIFIER;
    const LOG_CATEGORIES: &'static [&'static str] = LOG_CATEGORIES;
    const STATE_MAGIC: [u8; 8] = *b"SGTSTATE";
    /// 2 since the driver saves the margins of the event functions in use, packed; 3 since
    /// the train keeps the deflections of its static start; 4 since its loads hold the speed
    /// inputs; 5 since the run is at one of two capacities (`TrainSimulation`).
    const STATE_FORMAT_VERSION: u32 = 5;
    const N_EVENT_INDICATORS: usize = N_EVENT_INDICATORS;
    const EVENT_INDICATOR_VR0: u32 = crate::variables::EVENT_INDICATOR_VR0;
    const STATES: &'static [(Var, Var)] = STATES;
    const N_DECLARED_STATES: usize = N_DECLARED_STATES;
    const MORE_STATES_ADVICE: &'static str = " (16 coordinates, one per body): a train with \
        lateral bodies beyond that runs in Co-Simulation, or in Model Exchange as a gearbox FMU, \
        which declares its own states (docs/gearbox-file.md)";

    fn guid() -> &'static str {
        GUID
    }

    fn rel_tol(p: &Params) -> f64 {
        p.rel_tol
    }

    fn validate(p: &Params) -> Result<(), String> {
        build::validate(p)
    }

    fn validate_changed(p: &Params, changed: &[Var]) -> Result<(), String> {
        build::validate_changed(p, changed)
    }

    fn build(s: &Snapshot, rel_tol: f64, cache: &Cache) -> Result<TrainSimulation, String> {
        fresh_simulation(s, rel_tol, &cache.load_vars, None)
    }

    fn apply_loads(s: &mut Snapshot, cache: &Cache) {
        let loads = build::loads(&s.params, &s.inputs, &cache.load_vars);
        if let Some(ex) = s.me.as_mut() {
            ex.set_loads(loads);
        } else if let Some(sim) = s.sim.as_mut() {
            sim.set_loads(loads);
        }
    }

    /// What `write_outputs` found: it checks the outputs it writes (the others read 0).
    fn first_non_finite(_out: &Outputs, cache: &Cache) -> Option<(&'static str, f64)> {
        cache.non_finite.get()
    }

    fn write_outputs(
        run: Run<'_, TrainRig>,
        out: &mut Outputs,
        cache: &Cache,
    ) -> Result<(), String> {
        match run {
            Run::Exchange(ex) => {
                let stats = ex.rig.stats.clone();
                write_outputs(&ex.rig, &ex.y, stats, &ex.stats, cache, out)
            }
            Run::Sim(sim) => {
                let stats = sim.statistics();
                sim.with_state(|y| write_outputs(sim.train(), y, stats, sim.stats(), cache, out))
            }
        }
    }

    /// The bearings' forces (lateral.md §6): computed when a master reads one, as they need
    /// every mesh's force as a vector and, with planets, the carriers' accelerations.
    fn is_lazy(v: Var) -> bool {
        is_bearing_output(v)
    }

    fn write_lazy(train: &Train, y: &State, o: &mut Outputs) -> Result<(), String> {
        let f = train.bearing_forces(y).map_err(|e| e.to_string())?;
        let (x0, stride, dy) = body_force_vrs();
        for (i, fi) in f.body.iter().enumerate().take(train.spec().bodies.len()) {
            for (k, &x) in fi.iter().enumerate() {
                let vr = x0 + i as u32 * stride + k as u32 * dy;
                o.set_real(Var::from_vr(vr).expect("a body's force"), x);
            }
        }
        o.set_real(Var::housing_Fx, f.housing[0]);
        o.set_real(Var::housing_Fy, f.housing[1]);
        Ok(())
    }

    /// The locals (the states that are not outputs, and every state's derivative) at state y:
    /// a right-hand-side evaluation, so only when a master reads one.
    fn locals(train: &Train, y: &State) -> Result<Locals, LawOutOfRange> {
        let mut dy = State::zeros();
        train.rhs(y, &mut dy)?;
        let (mut x, mut dx) = ([0.0; N_MASTER_STATES], [0.0; N_MASTER_STATES]);
        train.to_master(y, &mut x);
        train.to_master(&dy, &mut dx);
        let mut l = Locals::default();
        for (k, &(state, der)) in STATES.iter().enumerate() {
            l.set_real(state, x[k]);
            l.set_real(der, dx[k]);
        }
        for m in 0..train.meshes.len() {
            l.set_real(
                var(&format!("mesh[{}].dte_rate", m + 1)),
                train.dte_rate(m, y),
            );
        }
        for j in 0..train.spec().shafts.len() {
            l.set_real(
                var(&format!("shaft[{}].twist_rate", j + 1)),
                train.shaft_twist_rate(j, y),
            );
        }
        Ok(l)
    }

    fn calculated(train: &Train, cache: &Cache) -> Calculated {
        let mut c = Calculated::default();
        let per_mesh: Vec<single::Calculated> = train
            .meshes
            .iter()
            .map(|m| single::Calculated::of_geometry(&m.geo))
            .collect();
        for (v, s) in &cache.sources {
            if let Source::Mesh(m, sv) = *s {
                if v.info().causality != Causality::CalculatedParameter || m >= per_mesh.len() {
                    continue;
                }
                if let Some(x) = per_mesh[m].get_real(sv) {
                    c.set_real(*v, x);
                } else if let Some(x) = per_mesh[m].get_integer(sv) {
                    c.set_integer(*v, x);
                }
            }
        }
        c
    }

    fn init_warnings(sim: &TrainSimulation) -> Vec<String> {
        {
            sim.train()
                .meshes
                .iter()
                .enumerate()
                .flat_map(|(m, mesh)| {
                    mesh.geo
                        .warnings
                        .iter()
                        .map(move |w| format!("mesh[{}]: {w}", m + 1))
                })
                .collect()
        }
    }

    fn solver_summary(t_end: f64, s: &Stats) -> String {
        format!(
            "t = {t_end}: {} steps, {} rejected, {} rhs evaluations, {} events so far",
            s.steps, s.rejected, s.rhs_evals, s.events
        )
    }

    fn encode(s: &Snapshot, w: &mut Writer) {
        w.bytes(&postcard::to_allocvec(s).expect("a snapshot serializes"));
    }

    fn decode(r: &mut Reader) -> Result<Snapshot, String> {
        let mut s: Snapshot = postcard::from_bytes(r.rest())
            .map_err(|e| format!("the payload does not decode: {e}"))?;
        build::validate(&s.params).map_err(|e| format!("parameters in the state: {e}"))?;
        if let Some((name, x)) = s.inputs.first_non_finite() {
            return Err(format!("input {name} = {x} in the state is not finite"));
        }
        let tol = s.tolerance;
        if tol.is_some_and(|t| !(1e-14..=0.1).contains(&t)) || !s.start_time.is_finite() {
            return Err("invalid experiment settings in the state".into());
        }
        let rel_tol = tol.map_or(s.params.rel_tol, |t| t.min(s.params.rel_tol));
        if s.sim.is_some() && s.me.is_some() {
            return Err("a state holds both a Co-Simulation and a Model Exchange run".into());
        }
        let bare = Snapshot {
            sim: None,
            me: None,
            ..s.clone()
        };
        if s.sim.is_some() || s.me.is_some() {
            let train = s.sim.as_ref().map(|x| x.train());
            let solved = train
                .or(s.me.as_ref().map(|x| &x.rig))
                .and_then(|t| t.static_start.clone());
            let fresh =
                fresh_simulation(&bare, rel_tol, &build::LoadVars::default(), solved.as_ref())
                    .map_err(|e| format!("parameters in the state: {e}"))?;
            if let Some(sim) = s.sim.as_mut() {
                restore(sim, &fresh)?;
            }
            if let Some(ex) = s.me.as_mut() {
                restore_exchange(ex, &fresh)?;
            }
        }
        Ok(s)
    }
}

/// The configuration a state leaves out, from a simulation built afresh from its parameters,
/// and the checks a checksum cannot make.
fn restore(sim: &mut TrainSimulation, fresh: &TrainSimulation) -> Result<(), String> {
    match sim {
        TrainSimulation::Compact(r) => restore_run(r, fresh.train()),
        TrainSimulation::Full(r) => restore_run(r, fresh.train()),
    }
}

/// `restore` at one capacity.
fn restore_run<S: TrainSystem>(run: &mut TrainRun<S>, fresh: &Train) -> Result<(), String> {
    let t = run.train.train_mut();
    let mut values = restore_train(t, fresh)?;
    let d = &run.driver;
    values.extend([d.t, d.observed, d.search_from]);
    values.extend_from_slice(d.y_start.as_slice());
    // The method's own state: a state edited with a recomputed checksum must bring no NaN.
    match &d.method {
        Method::Dopri5(x) => {
            values.extend([x.t, x.t_prev, x.h]);
            values.extend_from_slice(x.y.as_slice());
            values.extend_from_slice(x.k1.as_slice());
            x.rcont
                .iter()
                .for_each(|r| values.extend_from_slice(r.as_slice()));
        }
        Method::Dop853(x) => {
            values.extend([x.t, x.t_prev, x.h]);
            values.extend_from_slice(x.y.as_slice());
            values.extend_from_slice(x.k1.as_slice());
            x.rcont
                .iter()
                .for_each(|r| values.extend_from_slice(r.as_slice()));
        }
        Method::Bdf(x) => {
            values.extend([x.t, x.t_prev, x.h]);
            values.extend_from_slice(x.y.as_slice());
        }
    }
    if values.iter().any(|v| !v.is_finite()) || !(d.tol.rtol >= 1e-14 && d.tol.rtol <= 0.1) {
        return Err("a value of the simulation state is not finite or out of range".into());
    }
    // The driver's event functions are the meshes' in use, packed (`Train::event_of`).
    if d.pending
        .is_some_and(|p| p.index >= run.train.train().n_event_fns())
    {
        return Err("an event index in the state is out of range".into());
    }
    Ok(())
}

/// `restore` for a Model Exchange run.
fn restore_exchange(ex: &mut Exchange<Train>, fresh: &TrainSimulation) -> Result<(), String> {
    let values = restore_train(&mut ex.rig, fresh.train())?;
    if values.iter().any(|v| !v.is_finite()) || !ex.points_finite() {
        return Err("a value of the Model Exchange state is not finite".into());
    }
    Ok(())
}

/// The train's configuration from one built afresh; returns the train's values that must be
/// finite.
fn restore_train(t: &mut Train, f: &Train) -> Result<Vec<f64>, String> {
    if t.meshes.len() != f.meshes.len()
        || t.stats.is_some() != f.stats.is_some()
        || t.loads.tau.len() != f.loads.tau.len()
        || t.loads.w_in.len() != f.loads.w_in.len()
        || t.loads.coef.len() != f.loads.coef.len()
    {
        return Err("the state does not match its parameters".into());
    }
    t.cfg = f.cfg.clone();
    for (m, fm) in t.meshes.iter_mut().zip(&f.meshes) {
        m.cfg = fm.cfg.clone();
        m.describe_events = fm.describe_events;
        let sigma = m.sigma;
        m.set_sigma(sigma);
    }
    let mut values = vec![t.e_gate, t.e_start];
    values.extend(t.meshes.iter().flat_map(|m| m.sigma));
    values.extend_from_slice(&t.loads.tau);
    values.extend_from_slice(&t.loads.w_in);
    Ok(values)
}

/// The variable of a structured name (for tests and tools).
pub fn vr_of(name: &str) -> u32 {
    var(name).info().vr
}

/// The value reference of body 1's Fx, the stride between bodies, and Fy's offset from Fx.
fn body_force_vrs() -> (u32, u32, u32) {
    let x0 = Var::body_1_Fx.info().vr;
    (
        x0,
        Var::body_2_Fx.info().vr - x0,
        Var::body_1_Fy.info().vr - x0,
    )
}

/// Whether v is a bearing's force output: the housing's, or a body's x or y.
fn is_bearing_output(v: Var) -> bool {
    if matches!(v, Var::housing_Fx | Var::housing_Fy) {
        return true;
    }
    let (x0, stride, dy) = body_force_vrs();
    v.info()
        .vr
        .checked_sub(x0)
        .is_some_and(|off| (off / stride) < MAX_BODIES as u32 && [0, dy].contains(&(off % stride)))
}
