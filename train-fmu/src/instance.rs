//! SpurGearTrain as an `fmi2_slave::Slave`: parameters and inputs, initialization, stepping
//! (Co-Simulation) or the master's integration (Model Exchange, `Exchange`), outputs and FMU
//! states. The FMI state machine around it is fmi2_slave's `Instance`.

use crate::build::{self, element, var};
use crate::variables::{
    Calculated, Causality, Inputs, Locals, Outputs, Params, Var, VarType, Variability, GUID,
    LOG_CATEGORIES, MODEL_IDENTIFIER, N_EVENT_INDICATORS, STATES,
};
use fmi2_slave::fmu_state::{Reader, Writer};
use fmi2_slave::logging::LOG_EVENTS;
use fmi2_slave::{Boolean, EventUpdate, Logger, Slave, Status, ValueReference};
use gear_model::driver::exchange::{EventError, Exchange, ExchangeRig};
use gear_model::driver::train_simulation::TrainSimulation;
use gear_model::driver::{DriverError, Method, Stats, Vector};
use gear_model::model::statistics::{Statistics, Summary};
use gear_model::model::train::{self, Margins, State, Train, NY, N_MARGINS, N_MASTER_STATES};
use gear_model::variables as single;

// The table's states and event indicators are the model's, in its order.
const _: () = assert!(STATES.len() == N_MASTER_STATES);
const _: () = assert!(N_EVENT_INDICATORS == N_MARGINS);

pub use fmi2_slave::instance::{error, Failure};

const LOG_SOLVER: &str = "logSolver";

/// What an FMU state holds: everything that determines how the instance continues.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Snapshot {
    pub params: Params,
    pub inputs: Inputs,
    pub start_time: f64,
    pub stop_time: Option<f64>,
    pub tolerance: Option<f64>,
    /// Co-Simulation, and either interface in initialization mode.
    pub sim: Option<TrainSimulation>,
    /// Model Exchange after initialization (the master integrates).
    pub me: Option<Exchange<Train>>,
}

impl Snapshot {
    /// The train and the state at the current time, if there is a run (of either interface).
    fn current(&self) -> Option<(&Train, State)> {
        match (&self.me, &self.sim) {
            (Some(ex), _) => Some((&ex.rig, ex.y)),
            (None, Some(sim)) => Some((&sim.train, sim.state())),
            (None, None) => None,
        }
    }
}

/// Where an output comes from.
#[derive(Clone, Copy, Debug)]
enum Source {
    BodyTheta(usize),
    BodyW(usize),
    ShaftTau(usize),
    ShaftTwist(usize),
    /// Mesh m's output of the single mesh's name.
    Mesh(usize, single::Var),
    Whole,
}

#[derive(Clone, Debug)]
pub struct SpurGearTrain {
    pub snap: Snapshot,
    outputs: Outputs,
    fresh: bool,
    /// Each output's source, from its name (built once per instance).
    sources: Vec<(Var, Source)>,
    /// The inputs' and tunables' variables (looked up once per instance).
    load_vars: build::LoadVars,
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
                Some(("shaft", j, "tau")) => Source::ShaftTau(j - 1),
                Some(("shaft", j, "twist")) => Source::ShaftTwist(j - 1),
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

impl SpurGearTrain {
    fn from_snapshot(snap: Snapshot) -> SpurGearTrain {
        SpurGearTrain {
            snap,
            outputs: Outputs::default(),
            fresh: false,
            sources: sources(),
            load_vars: build::LoadVars::default(),
        }
    }

    /// The master's tolerance tightens rel_tol, never loosens it.
    fn tolerance(&self) -> f64 {
        let rel_tol = self.snap.params.rel_tol;
        self.snap.tolerance.map_or(rel_tol, |t| t.min(rel_tol))
    }

    /// Builds the train from the parameters (at the end of initialization, or earlier when a
    /// master reads outputs in initialization mode).
    fn build(&mut self) -> Result<&mut TrainSimulation, Failure> {
        if self.snap.sim.is_none() {
            let s = &self.snap;
            let sim = fresh_simulation(s, self.tolerance(), &self.load_vars).map_err(error)?;
            self.snap.sim = Some(sim);
            self.fresh = false;
        }
        Ok(self.snap.sim.as_mut().expect("just built"))
    }

    /// Outputs and calculated parameters at the current time; a non-finite one is an error
    /// naming it: no NaN reaches a master.
    fn outputs(&mut self) -> Result<&Outputs, Failure> {
        if !self.fresh {
            let o = match &self.snap.me {
                Some(ex) => {
                    let stats = ex.rig.stats.clone();
                    write_outputs(&ex.rig, &ex.y, stats, &ex.stats, &self.sources)
                }
                None => {
                    self.build()?;
                    let sim = self.snap.sim.as_ref().expect("just built");
                    let (y, stats) = (sim.state(), sim.statistics());
                    write_outputs(&sim.train, &y, stats, &sim.driver.stats, &self.sources)
                }
            }
            .map_err(error)?;
            if let Some((name, x)) = o.first_non_finite() {
                return Err(error(format!(
                    "output {name} = {x} is not finite at t = {}: check the parameters and start values",
                    self.time()
                )));
            }
            self.outputs = o;
            self.fresh = true;
        }
        Ok(&self.outputs)
    }

    /// The train and the state at the current time, of either interface, built if need be.
    fn point(&mut self) -> Result<(&Train, State), Failure> {
        if self.snap.me.is_none() {
            self.build()?;
        }
        Ok(self.snap.current().expect("built above"))
    }

    /// The locals (the states that are not outputs, and every state's derivative) at the
    /// current time: a right-hand-side evaluation, so only when a master reads one.
    #[cold]
    #[inline(never)]
    fn locals(&mut self) -> Result<Locals, Failure> {
        let t = self.time();
        let (train, y) = self.point()?;
        let mut dy = [0.0; NY];
        train
            .rhs(&y, &mut dy)
            .map_err(|e| error(format!("at t = {t} s: {e}")))?;
        let (mut x, mut dx) = ([0.0; N_MASTER_STATES], [0.0; N_MASTER_STATES]);
        train.to_master(&y, &mut x);
        train.to_master(&dy, &mut dx);
        let mut l = Locals::default();
        for (k, &(state, der)) in STATES.iter().enumerate() {
            l.set_real(state, x[k]);
            l.set_real(der, dx[k]);
        }
        if let Some((name, v)) = l.first_non_finite() {
            return Err(error(format!(
                "{name} = {v} is not finite at t = {t}: check the parameters and start values"
            )));
        }
        Ok(l)
    }

    /// The Model Exchange run (after initialization).
    fn exchange(&mut self) -> Result<&mut Exchange<Train>, Failure> {
        self.snap
            .me
            .as_mut()
            .ok_or_else(|| error("the instance has no Model Exchange state".into()))
    }

    fn calculated(&mut self) -> Result<Calculated, Failure> {
        let (train, _) = self.point()?;
        let mut c = Calculated::default();
        let per_mesh: Vec<single::Calculated> = train
            .meshes
            .iter()
            .map(|m| single::Calculated::of_geometry(&m.geo))
            .collect();
        for (v, s) in &self.sources {
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
        Ok(c)
    }

    fn value<T>(
        &mut self,
        v: Var,
        param: impl Fn(&Params) -> Option<T>,
        input: impl Fn(&Inputs) -> Option<T>,
        output: impl Fn(&Outputs) -> Option<T>,
        calc: impl Fn(&Calculated) -> Option<T>,
        local: impl Fn(&Locals) -> Option<T>,
    ) -> Result<T, Failure> {
        let got = match v.info().causality {
            Causality::Parameter => param(&self.snap.params),
            Causality::Input => input(&self.snap.inputs),
            Causality::Output => output(self.outputs()?),
            Causality::CalculatedParameter => calc(&self.calculated()?),
            Causality::Local => local(&self.locals()?),
        };
        got.ok_or_else(|| error(format!("{} has no value of that type", v.info().name)))
    }

    /// Sets several variables at once: all are checked before any is applied.
    fn set_many<T: Clone + std::fmt::Display>(
        &mut self,
        ty: VarType,
        vrs: &[u32],
        values: &[T],
        running: bool,
        check: impl Fn(&T) -> bool,
        apply: impl Fn(&mut Params, &mut Inputs, Var, T),
    ) -> Result<(), Failure> {
        let (mut params, mut inputs) = (self.snap.params.clone(), self.snap.inputs.clone());
        let mut any_parameter = false;
        for (&vr, x) in vrs.iter().zip(values) {
            let v = lookup(vr, ty)?;
            settable(v, x, running)?;
            if !check(x) {
                return Err(error(format!(
                    "{} = {x}: the value must be finite",
                    v.info().name
                )));
            }
            apply(&mut params, &mut inputs, v, x.clone());
            any_parameter |= v.info().causality == Causality::Parameter;
        }
        if any_parameter {
            build::validate(&params).map_err(error)?;
        }
        self.snap.params = params;
        self.snap.inputs = inputs;
        self.fresh = false;
        if running {
            let loads = build::loads(&self.snap.params, &self.snap.inputs, &self.load_vars);
            if let Some(ex) = self.snap.me.as_mut() {
                ex.set_loads(loads);
            } else if let Some(sim) = self.snap.sim.as_mut() {
                sim.set_loads(loads);
            }
        } else {
            self.snap.sim = None;
        }
        Ok(())
    }
}

/// A train simulation from the snapshot's parameters and inputs.
fn fresh_simulation(
    s: &Snapshot,
    rel_tol: f64,
    vars: &build::LoadVars,
) -> Result<TrainSimulation, String> {
    build::validate(&s.params)?;
    let spec = build::spec(&s.params)?;
    let loads = build::loads(&s.params, &s.inputs, vars);
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
    sim.set_loads(loads);
    if let Some(stop) = s.stop_time {
        sim.driver.t_stop = stop;
    }
    Ok(sim)
}

/// Every output at state y, with each mesh's statistics and the integration's counters.
fn write_outputs(
    train: &Train,
    y: &State,
    stats: Option<Vec<Statistics>>,
    st: &Stats,
    sources: &[(Var, Source)],
) -> Result<Outputs, String> {
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
    let mut o = Outputs::default();
    let (n_bodies, n_shafts) = (train.spec().bodies.len(), train.spec().shafts.len());
    for &(v, s) in sources {
        match s {
            Source::BodyTheta(i) if i < n_bodies => o.set_real(v, b.theta[i]),
            Source::BodyW(i) if i < n_bodies => o.set_real(v, b.w[i]),
            Source::ShaftTau(j) if j < n_shafts => o.set_real(v, train.shaft_torque(j, y)),
            Source::ShaftTwist(j) if j < n_shafts => o.set_real(v, train.shaft_twist(j, y)),
            Source::Mesh(m, sv) if m < per_mesh.len() => {
                if let Some(x) = per_mesh[m].get_real(sv) {
                    o.set_real(v, x)
                } else {
                    o.set_integer(v, per_mesh[m].get_integer(sv).unwrap_or(0))
                }
            }
            _ => false,
        };
    }
    let (e_kin, e_el, residual) = train.energy(y).map_err(|e| e.to_string())?;
    o.E_kin = e_kin;
    o.E_el = e_el;
    o.energy_residual = residual;
    o.W_ext = y[train::W_EXT];
    o.W_loss = y[train::W_LOSS];
    o.E_gate = train.e_gate;
    o.n_events = saturate(train.n_events);
    o.n_steps = saturate(st.steps);
    o.n_rejected_steps = saturate(st.rejected);
    o.n_rhs_evaluations = saturate(st.rhs_evals);
    o.n_jacobians = saturate(st.jac_evals);
    o.n_factorizations = saturate(st.factorizations);
    Ok(o)
}

impl Slave for SpurGearTrain {
    const MODEL_NAME: &'static str = MODEL_IDENTIFIER;
    const LOG_CATEGORIES: &'static [&'static str] = LOG_CATEGORIES;
    const STATE_MAGIC: [u8; 8] = *b"SGTSTATE";
    const STATE_FORMAT_VERSION: u32 = 1;

    fn guid() -> &'static str {
        GUID
    }

    fn fresh() -> SpurGearTrain {
        SpurGearTrain::from_snapshot(Snapshot {
            params: Params::default(),
            inputs: Inputs::default(),
            start_time: 0.0,
            stop_time: None,
            tolerance: None,
            sim: None,
            me: None,
        })
    }

    fn setup_experiment(
        &mut self,
        tol: Option<f64>,
        start: f64,
        stop: Option<f64>,
    ) -> Result<(), Failure> {
        if let Some(t) = tol {
            if !(1e-14..=0.1).contains(&t) {
                return Err(error(format!("tolerance = {t}: must lie in [1e-14, 0.1]")));
            }
        }
        fmi2_slave::check_experiment_times(start, stop)?;
        self.snap.tolerance = tol;
        self.snap.start_time = start;
        self.snap.stop_time = stop;
        self.snap.sim = None;
        self.fresh = false;
        Ok(())
    }

    fn exit_initialization(&mut self) -> Result<(), Failure> {
        self.build()?;
        self.outputs()?;
        Ok(())
    }

    fn init_warnings(&self) -> Vec<String> {
        self.snap.sim.as_ref().map_or_else(Vec::new, |s| {
            s.train
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
        })
    }

    fn get_real(&mut self, vr: ValueReference) -> Result<f64, Failure> {
        let v = lookup(vr, VarType::Real)?;
        self.value(
            v,
            |p| p.get_real(v),
            |i| i.get_real(v),
            |o| o.get_real(v),
            |c| c.get_real(v),
            |l| l.get_real(v),
        )
    }

    fn get_integer(&mut self, vr: ValueReference) -> Result<i32, Failure> {
        let v = lookup(vr, VarType::Integer)?;
        self.value(
            v,
            |p| p.get_integer(v),
            |i| i.get_integer(v),
            |o| o.get_integer(v),
            |c| c.get_integer(v),
            |_| None,
        )
    }

    fn get_boolean(&mut self, vr: ValueReference) -> Result<bool, Failure> {
        let v = lookup(vr, VarType::Boolean)?;
        self.value(
            v,
            |p| p.get_boolean(v),
            |i| i.get_boolean(v),
            |o| o.get_boolean(v),
            |c| c.get_boolean(v),
            |_| None,
        )
    }

    fn get_string(&mut self, vr: ValueReference) -> Result<String, Failure> {
        let v = lookup(vr, VarType::String)?;
        self.value(
            v,
            |p| p.get_string(v).map(str::to_owned),
            |i| i.get_string(v).map(str::to_owned),
            |o| o.get_string(v).map(str::to_owned),
            |c| c.get_string(v).map(str::to_owned),
            |_| None,
        )
    }

    fn set_real(&mut self, vrs: &[u32], values: &[f64], running: bool) -> Result<(), Failure> {
        self.set_many(
            VarType::Real,
            vrs,
            values,
            running,
            |x| x.is_finite(),
            |p, inp, v, x| {
                let _ = p.set_real(v, x) || inp.set_real(v, x);
            },
        )
    }

    fn set_integer(&mut self, vrs: &[u32], values: &[i32], running: bool) -> Result<(), Failure> {
        self.set_many(
            VarType::Integer,
            vrs,
            values,
            running,
            |_| true,
            |p, _, v, x| {
                p.set_integer(v, x);
            },
        )
    }

    fn set_boolean(
        &mut self,
        vrs: &[u32],
        values: &[Boolean],
        running: bool,
    ) -> Result<(), Failure> {
        self.set_many(
            VarType::Boolean,
            vrs,
            values,
            running,
            |_| true,
            |p, _, v, x| {
                p.set_boolean(v, x != 0);
            },
        )
    }

    fn set_string(&mut self, vrs: &[u32], values: &[String], running: bool) -> Result<(), Failure> {
        self.set_many(
            VarType::String,
            vrs,
            values,
            running,
            |_| true,
            |p, _, v, x| {
                p.set_string(v, x);
            },
        )
    }

    fn do_step(&mut self, current: f64, h: f64, log: &Logger) -> Result<(), Failure> {
        let t = self.time();
        let t_end = current + h;
        if let Some(stop) = self.snap.stop_time {
            if t_end > stop * (1.0 + 1e-12) + 1e-12 {
                return Err(error(format!(
                    "step to {t_end} goes past the stopTime {stop} of fmi2SetupExperiment"
                )));
            }
        }
        let debug_events = log.enabled(LOG_EVENTS);
        let sim = self.snap.sim.as_mut().expect("initialized in StepComplete");
        for m in &mut sim.train.meshes {
            m.describe_events = debug_events;
        }
        let before = sim.needs_work(t_end).then(|| sim.clone());
        let mut events = Vec::new();
        let result = sim.advance(t_end, &mut |te, r| {
            if debug_events {
                events.push(format!("t = {te:.12} s: {}", r.what));
            }
        });
        for e in &events {
            log.log(Status::Ok, LOG_EVENTS, e);
        }
        self.fresh = false;
        let failure = match result {
            Ok(()) => self.outputs().err().map(|f| Failure {
                message: format!("{}; state kept at t = {t}", f.message),
                ..f
            }),
            Err(e @ DriverError::Law { .. }) => Some(error(format!("{e}; state kept at t = {t}"))),
            Err(e) => Some(Failure {
                status: Status::Discard,
                message: format!("{e}; state kept at t = {t}"),
            }),
        };
        if let Some(f) = failure {
            match before {
                Some(b) => self.snap.sim = Some(b),
                None => self.snap.sim.as_mut().expect("stepped").driver.t = t,
            }
            self.fresh = false;
            return Err(f);
        }
        if log.enabled(LOG_SOLVER) {
            let s = &self.snap.sim.as_ref().expect("stepped").driver.stats;
            log.log(
                Status::Ok,
                LOG_SOLVER,
                &format!(
                    "t = {t_end}: {} steps, {} rejected, {} rhs evaluations, {} events so far",
                    s.steps, s.rejected, s.rhs_evals, s.events
                ),
            );
        }
        Ok(())
    }

    fn time(&self) -> f64 {
        match (&self.snap.me, &self.snap.sim) {
            (Some(ex), _) => ex.t,
            (None, Some(sim)) => sim.time(),
            (None, None) => self.snap.start_time,
        }
    }

    fn prepare_save(&mut self) {
        if let Some(sim) = self.snap.sim.as_mut() {
            sim.make_restart_point_if_needed();
        }
    }

    fn encode(&self, w: &mut Writer) {
        w.bytes(&postcard::to_allocvec(&self.snap).expect("a snapshot serializes"));
    }

    fn decode(r: &mut Reader) -> Result<SpurGearTrain, String> {
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
            let fresh = fresh_simulation(&bare, rel_tol, &build::LoadVars::default())
                .map_err(|e| format!("parameters in the state: {e}"))?;
            if let Some(sim) = s.sim.as_mut() {
                restore(sim, &fresh)?;
            }
            if let Some(ex) = s.me.as_mut() {
                restore_exchange(ex, &fresh)?;
            }
        }
        Ok(SpurGearTrain::from_snapshot(s))
    }

    // ---- Model Exchange: `Exchange` holds the point the master sets ---------------------------

    const MODEL_EXCHANGE: bool = true;
    const N_STATES: usize = N_MASTER_STATES;
    const N_EVENT_INDICATORS: usize = N_EVENT_INDICATORS;
    const EVENT_INDICATOR_VR0: u32 = crate::variables::EVENT_INDICATOR_VR0;

    fn state_name(k: usize) -> &'static str {
        STATES
            .get(k)
            .map_or("a continuous state", |s| s.0.info().name)
    }

    fn me_exit_initialization(&mut self) -> Result<(), Failure> {
        let sim = self.build()?;
        let (t, y) = (sim.time(), sim.state());
        let sim = self.snap.sim.take().expect("just built");
        self.snap.me = Some(Exchange::at(sim.train, t, y));
        self.fresh = false;
        self.outputs()?;
        Ok(())
    }

    fn me_set_time(&mut self, t: f64) -> Result<(), Failure> {
        let ex = self.exchange()?;
        if ex.t != t {
            ex.t = t;
            self.fresh = false;
        }
        Ok(())
    }

    fn me_set_states(&mut self, x: &[f64]) -> Result<(), Failure> {
        self.exchange()?.set_states(x);
        self.fresh = false;
        Ok(())
    }

    fn me_states(&mut self, x: &mut [f64]) -> Result<(), Failure> {
        let (train, y) = self.point()?;
        train.to_master(&y, x);
        Ok(())
    }

    fn me_derivatives(&mut self, dx: &mut [f64]) -> Result<(), Failure> {
        let t = self.time();
        let at = |e| error(format!("at t = {t} s: {e}"));
        match self.snap.me.as_mut() {
            Some(ex) => ex.derivatives(dx).map_err(at),
            None => {
                // Initialization mode: the derivatives at the start point.
                let (train, y) = self.point()?;
                let mut dy = [0.0; NY];
                train.rhs(&y, &mut dy).map_err(at)?;
                train.to_master(&dy, dx);
                Ok(())
            }
        }
    }

    fn me_event_indicators(&mut self, z: &mut [f64]) -> Result<(), Failure> {
        let (train, y) = self.point()?;
        let mut m = <Margins as Vector>::zeros();
        train.event_margins(&y, &mut m);
        z.copy_from_slice(&m.0);
        Ok(())
    }

    fn me_nominals(&mut self, n: &mut [f64]) -> Result<(), Failure> {
        let (train, _) = self.point()?;
        train.nominals(n);
        Ok(())
    }

    fn me_enter_event_mode(&mut self) -> Result<(), Failure> {
        self.exchange().map(|_| ())
    }

    fn me_new_discrete_states(&mut self, log: &Logger) -> Result<EventUpdate, Failure> {
        let debug_events = log.enabled(LOG_EVENTS);
        let ex = self.exchange()?;
        for m in &mut ex.rig.meshes {
            m.describe_events = debug_events;
        }
        let t = ex.t;
        let mut texts = Vec::new();
        let settled = ex.settle(&mut |r| {
            if debug_events {
                texts.push(format!("t = {t:.12} s: {}", r.what));
            }
        });
        for e in &texts {
            log.log(Status::Ok, LOG_EVENTS, e);
        }
        self.fresh = false;
        let s = settled.map_err(|e: EventError| error(format!("at t = {t} s: {e}")))?;
        Ok(EventUpdate {
            states_changed: s.states_changed,
            nominals_changed: s.nominals_changed,
            next_event_time: None,
        })
    }

    fn me_completed_integrator_step(&mut self) -> Result<bool, Failure> {
        let ex = self.exchange()?;
        let t = ex.t;
        let enter = ex
            .complete_step()
            .map_err(|e| error(format!("at t = {t} s: {e}")))?;
        self.fresh = false;
        Ok(enter)
    }
}

/// The configuration a state leaves out, from a simulation built afresh from its parameters,
/// and the checks a checksum cannot make.
fn restore(sim: &mut TrainSimulation, fresh: &TrainSimulation) -> Result<(), String> {
    let t = &mut sim.train;
    let mut values = restore_train(t, &fresh.train)?;
    let d = &sim.driver;
    values.extend([d.t, d.observed, d.search_from]);
    values.extend_from_slice(&d.y_start);
    // The method's own state: a state edited with a recomputed checksum must bring no NaN.
    match &d.method {
        Method::Dopri5(x) => {
            values.extend([x.t, x.t_prev, x.h]);
            values.extend_from_slice(&x.y);
            values.extend_from_slice(&x.k1);
            x.rcont.iter().for_each(|r| values.extend_from_slice(r));
        }
        Method::Dop853(x) => {
            values.extend([x.t, x.t_prev, x.h]);
            values.extend_from_slice(&x.y);
            values.extend_from_slice(&x.k1);
            x.rcont.iter().for_each(|r| values.extend_from_slice(r));
        }
        Method::Bdf(x) => {
            values.extend([x.t, x.t_prev, x.h]);
            values.extend_from_slice(&x.y);
        }
    }
    if values.iter().any(|v| !v.is_finite()) || !(d.tol.rtol >= 1e-14 && d.tol.rtol <= 0.1) {
        return Err("a value of the simulation state is not finite or out of range".into());
    }
    if d.pending
        .is_some_and(|p| p.index >= gear_model::model::train::N_MARGINS)
    {
        return Err("an event index in the state is out of range".into());
    }
    Ok(())
}

/// `restore` for a Model Exchange run.
fn restore_exchange(ex: &mut Exchange<Train>, fresh: &TrainSimulation) -> Result<(), String> {
    let values = restore_train(&mut ex.rig, &fresh.train)?;
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
    Ok(values)
}

/// A value reference of the given type, or an error naming what it is.
fn lookup(vr: u32, ty: VarType) -> Result<Var, Failure> {
    match Var::from_vr(vr) {
        Some(v) if v.info().ty == ty => Ok(v),
        None => Err(error(format!("unknown value reference {vr}"))),
        Some(v) => Err(error(format!(
            "{} (value reference {vr}) is {:?}, not {ty:?}",
            v.info().name,
            v.info().ty
        ))),
    }
}

/// Whether a variable may be set now (the value shown in the message).
fn settable(v: Var, shown: &dyn std::fmt::Display, running: bool) -> Result<(), Failure> {
    let info = v.info();
    match (info.causality, info.variability) {
        (Causality::Output | Causality::CalculatedParameter | Causality::Local, _) => {
            Err(error(format!(
                "{} = {shown}: {} is a {:?}, it cannot be set",
                info.name, info.name, info.causality
            )))
        }
        (Causality::Parameter, Variability::Fixed) if running => Err(error(format!(
            "{} = {shown}: {} is a fixed parameter, it cannot be set after initialization",
            info.name, info.name
        ))),
        _ => Ok(()),
    }
}

/// The variable of a structured name (for tests and tools).
pub fn vr_of(name: &str) -> u32 {
    var(name).info().vr
}
